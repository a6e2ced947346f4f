"""A case's measures: the bridge between a case and the array measures (`measures`).

- the front measures' levels (m/s): the case's noise velocity sigma and the levels set against
  it and V_I (`measures.levels`), one home for the deck, which passes them to fix lattice/front,
  and for the readers, which apply the same levels to arrays;
- the engine's front record (front.bin, read by `formats.front_record`) as a `measures.Front`:
  each chain's rows with its levels, magnet 1's measures from the impactor's profile (its motion is
  prescribed, not integrated, so the record has none), and the chain's slowest linear speed,
  below which a gap's V_P is flagged;
- `case_front`: the same definitions applied to a trajectory's arrays;
- `linear_constants`, `linear_constants_at`: the linear chain's wave speed V0 and frequency f0;
- `set_impactor_acceleration`: magnet 1's row of a trajectory's accelerations from its profile.
"""

from __future__ import annotations

from dataclasses import dataclass, fields
from functools import cached_property
from operator import attrgetter
from pathlib import Path

import numpy as np

from . import measures
from .case import Case, Chain, thermal_velocities
from .case.chain import thermal_normals
from .errors import ConfigError
from .formats.front_record import FrontRows, read_front_rows


def linear_constants(case: Case) -> tuple[float, float]:
    """(V0 in m/s, f0 in Hz): the linear wave speed and frequency of the case's nearest-neighbour
    law at its mean gap and mean mass, as drawn (`linear_constants_at`)."""
    return linear_constants_at(case.force, float(np.mean(case.chain.gaps())), float(np.mean(case.chain.masses())))


def linear_constants_at(force, r0: float, mass: float) -> tuple[float, float]:
    """(V0 in m/s, f0 in Hz) of the nearest-neighbour law `force` linearised at gap r0 (mm) for
    magnets of mass `mass` (g) (`measures.linear_wave_speed`, `measures.linear_frequency`)."""
    k0 = float(force.stiffness(r0))
    return float(measures.linear_wave_speed(k0, mass, r0)), float(measures.linear_frequency(k0, mass))


def set_impactor_acceleration(case: Case, traj, columns) -> None:
    """Magnet 1's accelerations in `traj` (its `columns`: a list of indices or a mask, maybe
    empty) from the impactor's profile, m/s^2: its motion is prescribed, so the force on it in a
    dump is the chain's push, not m a."""
    traj.a[:, columns] = case.impactor.acceleration_at(traj.t)[:, None]


@dataclass(frozen=True)
class ChainDraws:
    """The initial chains of R cases of one batch (equal N), each row the case's own draws bit
    for bit (`Chain.masses`, `gaps`, `velocities`): masses (R, N) g, gaps (R, N-1) mm,
    velocities (R, N) m/s. Drawn once per batch (`chain_draws`), for every measure and engine
    that takes the batch's chains as arrays."""

    masses: np.ndarray
    gaps: np.ndarray
    velocities: np.ndarray
    case: Case  # the first: the batch's held ends and force law

    @cached_property
    def noise(self) -> np.ndarray:
        """The noise velocity of each chain, m/s, shape (R,) (`chain_noises`): once per batch, read
        by the engine's levels, the deck's and the record's."""
        free = np.ones(self.case.chain.particles, bool)
        free[[0, *self.case.held()]] = False
        return measures.noise_velocity(self.masses, self.velocities, self.gaps, self.case.force.energy, free)

    @cached_property
    def positions(self) -> np.ndarray:
        """Initial positions (R, N), mm, x_1 = 0 (`Chain.positions` of each row); read by the
        kernel's arrays and the summaries, made once."""
        return np.concatenate([np.zeros((len(self.gaps), 1)), np.cumsum(self.gaps, axis=1)], axis=1)


def chain_draws(cases) -> ChainDraws:
    """The chains of R cases (equal N) as arrays, each drawn once. Thermal chains that differ
    only in their seed (a sweep's replicas without disorder) share their masses and gaps, drawn
    once; thermal chains get their velocities together (`thermal_velocities`, each chain with its
    own masses), each row its chain's bits."""
    chains = [case.chain for case in cases]
    first, r = chains[0], len(chains)
    if r > 1 and all(map(_thermal_only, chains)) and all(map(_NOMINAL(first).__eq__, map(_NOMINAL, chains))):
        masses, gaps = (np.repeat(draw(first)[None], r, axis=0) for draw in (Chain.masses, Chain.gaps))
    else:
        masses, gaps = (np.stack([draw(chain) for chain in chains]) for draw in (Chain.masses, Chain.gaps))
    if r > 1 and all(c.thermal_velocity and c.velocity is None for c in chains):
        v = np.zeros_like(masses)
        v[:, 1:-1] = thermal_velocities(masses[:, 1:-1], [c.thermal_velocity for c in chains], thermal_normals(chains))
    else:
        v = np.stack([chain.velocities() for chain in chains])
    return ChainDraws(masses, gaps, v, cases[0])


def _thermal_only(chain: Chain) -> bool:
    """Whether the seed draws only the chain's thermal velocities (no disorder, no given velocity)."""
    return bool(chain.thermal_velocity) and chain.velocity is None and not (chain.mass_disorder or chain.r0_disorder)


# What sets a chain's masses and gaps without disorder, as one tuple (chains with equal tuples have
# the same; a tuple's == tries `is` first: a sweep's replicas share these objects)
_NOMINAL = attrgetter("particles", "mass", "r0", "defect_index", "defect_mass", "defect_r0")


def chain_noise(case: Case) -> float:
    """The case's noise velocity sigma, m/s: `measures.noise_velocity` of its initial state."""
    return float(chain_noises([case])[0])


def chain_noises(cases, draws: ChainDraws | None = None) -> np.ndarray:
    """The noise velocity of each of R cases, m/s, shape (R,): the cases of a batch (equal N,
    held ends and force law; `deck.render_replicas` checks), computed together with the bits of
    each alone (`chain_noise` is a batch of one); draws: their `chain_draws`, if drawn, which
    keep the result (the draws are of these cases)."""
    return (draws or chain_draws(cases)).noise


def front_levels(case: Case) -> measures.FrontLevels:
    """The front measures' levels for this case (m/s): the fix's arguments, and the array measures'."""
    return measures.front_levels(case.impactor.peak_velocity(), chain_noise(case))


def chain_front_levels(cases, draws: ChainDraws | None = None) -> measures.FrontLevels:
    """The front levels of each of R cases of one drive, m/s: arrays of shape (R,), entry r the
    levels of `front_levels(cases[r])` (draws: their `chain_draws`, if drawn)."""
    return measures.front_levels(cases[0].impactor.peak_velocity(), chain_noises(cases, draws))

@dataclass(frozen=True)
class FrontRecord:
    """front: the run's `measures.Front`; max_speed (N,): largest |v| of each magnet, m/s;
    end_time: when the record was written (the end of the run, or where it stopped), ms.
    Of R chains (`read_front_batch`): the Front of R chains, max_speed (R, N)."""

    front: measures.Front
    max_speed: np.ndarray
    end_time: float


def read_front_record(case: Case, path: str | Path, arrival_method: str = "level") -> FrontRecord:
    """The record in `path` (a run's front.bin); arrival by `arrival_method`, "level" or
    "velocity_peak" (see measures.arrival)."""
    return read_front_records([case], path, arrival_method)[0]


def read_front_records(cases, path: str | Path, arrival_method: str = "level") -> list[FrontRecord]:
    """The record in `path` of a batch of equal chains (deck.render_replicas with `front`): one
    per case, chain r from rows r N .. r N + N - 1. The cases share their drive and time step."""
    batch = read_front_batch(cases, path, arrival_method)
    return [FrontRecord(batch.front.row(r), batch.max_speed[r], batch.end_time) for r in range(len(cases))]


def read_front_batch(cases, path: str | Path, arrival_method: str = "level",
                     draws: ChainDraws | None = None, rows: FrontRows | None = None) -> FrontRecord:
    """`read_front_records` as one FrontRecord of R chains: its front a `measures.Front` of R
    chains (`stack_fronts`), max_speed (R, N); each chain's levels from its noise velocity
    (`chain_noises`); draws: the cases' `chain_draws`, if drawn; rows: the record in `path` as
    its engine holds it in memory (`formats.front_record.front_rows`, its columns this call's
    own), which is then not read back.

    One pass for the batch: the drive's measures once, against each distinct noise velocity
    (the drive is the same, its levels are not), and each chain's rows as a row of (R, N) arrays."""
    if arrival_method not in ("level", "velocity_peak"):
        raise ValueError(f"arrival_method: got {arrival_method!r}; the record has 'level' and 'velocity_peak'")
    case = cases[0]
    record = rows if rows is not None else read_front_rows(path, len(cases), case.chain.particles)
    rows, end = record.columns, record.end_time
    draws = draws or chain_draws(cases)
    noise = chain_noises(cases, draws)
    sigma, level_of = np.unique(noise, return_inverse=True)
    imp, vi = case.impactor, case.impactor.peak_velocity()
    t = np.arange(round(end / case.run.dt) + 1) * case.run.dt
    if t.size < 2:
        raise ConfigError(str(path), f"the record ends at t = {end:g} ms, before the run's first step "
                                     f"({case.run.dt:g} ms); nothing to measure")
    v, a = imp.velocity_at(t)[:, None], imp.acceleration_at(t)[:, None]  # one signal, its measures per sigma
    drive = measures.first_peaks(t, v, a, vi, noise=sigma)
    column = "arrival" if arrival_method == "level" else "pulse_arrival"
    arrival = rows[column]  # (the record's columns are this call's own arrays: filled in place)
    arrival[:, 0] = measures.arrival_times(t, v, vi, method=arrival_method, noise=sigma)[level_of]
    peaks = []
    for f in fields(measures.FirstPeaks):  # magnet 1's are the drive's
        peaks.append(rows[f.name])
        peaks[-1][:, 0] = getattr(drive, f.name)[level_of]
    gaps = draws.gaps
    front = measures.Front(arrival, measures.propagation_velocity(arrival, gaps), measures.FirstPeaks(*peaks),
                           arrival_method, noise, slowest_linear_speeds(cases, gaps, draws.masses))
    return FrontRecord(front, rows["max_speed"], end)


def case_front(case: Case, t, v, a, arrival_method: str = "level") -> measures.Front:
    """`measures.front` of a trajectory of `case` (t ms, v m/s, a m/s^2), with the case's noise
    velocity and slowest linear speed: the same definitions as the record."""
    return measures.front(t, v, a, case.impactor.peak_velocity(), case.chain.gaps(), arrival_method,
                          chain_noise(case), slowest_linear_speed(case))


def slowest_linear_speed(case: Case) -> float:
    """The chain's slowest local linear wave speed, m/s (`measures.slowest_linear_speed`)."""
    return float(slowest_linear_speeds([case], case.chain.gaps()[None])[0])


def slowest_linear_speeds(cases, gaps: np.ndarray, masses: np.ndarray | None = None) -> np.ndarray:
    """`slowest_linear_speed` of each of R cases of one law, gaps (R, N-1) mm (masses (R, N) g,
    if drawn): shape (R,)."""
    masses = np.stack([c.chain.masses() for c in cases]) if masses is None else masses
    return measures.slowest_linear_speed(cases[0].force.stiffness(gaps), masses, gaps)
