"""The engine's on-the-fly front record (fix lattice/front, file front.bin) as measures results.

The fix applies the definitions of `measures.arrival_times` and `measures.first_peaks` to every
time step of every magnet, so a run has its front measures without any per-frame output. The
impactor's motion is prescribed, not integrated (its force is the chain's push on the piston),
so its measures come from its profile sampled at the same steps, as `RunFolder.trajectory` takes its
acceleration from the profile.

Both the record and the array measures of a trajectory (`case_front`) are interpreted here
with the case's levels (`case_levels.front_levels`: against V_I and the chain's noise velocity) and
its slowest linear speed, below which a gap's V_P is flagged (`measures.Front`).
"""

from __future__ import annotations

from dataclasses import dataclass, fields
from pathlib import Path

import numpy as np

from . import measures
from .bindump import open_dump
from .case import Case
from .case_levels import chain_noise, chain_noises
from .run_folder.layout import FRONT_FIELDS
from .units import from_engine


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


def read_front_batch(cases, path: str | Path, arrival_method: str = "level") -> FrontRecord:
    """`read_front_records` as one FrontRecord of R chains: its front a `measures.Front` of R
    chains (`stack_fronts`), max_speed (R, N); each chain's levels from its noise velocity
    (`case_levels.chain_noises`).

    One pass for the batch: the drive's measures once, against each distinct noise velocity
    (the drive is the same, its levels are not), and each chain's rows as a row of (R, N) arrays."""
    if arrival_method not in ("level", "velocity_peak"):
        raise ValueError(f"arrival_method: got {arrival_method!r}; the record has 'level' and 'velocity_peak'")
    frame = open_dump(path).read()
    end = float(from_engine(frame.time[-1], "time"))
    case, n, chains = cases[0], cases[0].chain.particles, len(cases)
    # (R, N): chain r's magnets in row r
    rows = {name: from_engine(frame.data[-1, :, k + 1], quantity).reshape(chains, n)
            for k, (name, quantity) in enumerate(FRONT_FIELDS)}
    noise = chain_noises(cases)
    sigma, level_of = np.unique(noise, return_inverse=True)
    imp, vi = case.impactor, case.impactor.peak_velocity()
    t = np.arange(round(end / case.run.dt) + 1) * case.run.dt
    v, a = imp.velocity_at(t)[:, None], imp.acceleration_at(t)[:, None]  # one signal, its measures per sigma
    drive = measures.first_peaks(t, v, a, vi, noise=sigma)
    column = "arrival" if arrival_method == "level" else "pulse_arrival"
    arrival = rows[column].copy()
    arrival[:, 0] = measures.arrival_times(t, v, vi, method=arrival_method, noise=sigma)[level_of]
    peaks = []
    for f in fields(measures.FirstPeaks):  # magnet 1's are the drive's
        peaks.append(rows[f.name].copy())
        peaks[-1][:, 0] = getattr(drive, f.name)[level_of]
    gaps = np.stack([c.chain.gaps() for c in cases])
    front = measures.Front(arrival, measures.propagation_velocity(arrival, gaps), measures.FirstPeaks(*peaks),
                           arrival_method, noise, slowest_linear_speeds(cases, gaps))
    return FrontRecord(front, rows["max_speed"].copy(), end)


def case_front(case: Case, t, v, a, arrival_method: str = "level") -> measures.Front:
    """`measures.front` of a trajectory of `case` (t ms, v m/s, a m/s^2), with the case's noise
    velocity and slowest linear speed: the same definitions as the record."""
    return measures.front(t, v, a, case.impactor.peak_velocity(), case.chain.gaps(), arrival_method,
                          chain_noise(case), slowest_linear_speed(case))


def slowest_linear_speed(case: Case) -> float:
    """The chain's slowest local linear wave speed, m/s (`measures.slowest_linear_speed`)."""
    return float(slowest_linear_speeds([case], case.chain.gaps()[None])[0])


def slowest_linear_speeds(cases, gaps: np.ndarray) -> np.ndarray:
    """`slowest_linear_speed` of each of R cases of one law, gaps (R, N-1) mm: shape (R,)."""
    masses = np.stack([c.chain.masses() for c in cases])
    return measures.slowest_linear_speed(cases[0].force.stiffness(gaps), masses, gaps)
