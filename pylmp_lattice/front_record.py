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
from .case_levels import chain_noise
from .run_folder.layout import FRONT_FIELDS
from .units import from_engine


@dataclass(frozen=True)
class FrontRecord:
    """front: the run's `measures.Front`; max_speed (N,): largest |v| of each magnet, m/s;
    end_time: when the record was written (the end of the run, or where it stopped), ms."""

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
    if arrival_method not in ("level", "velocity_peak"):
        raise ValueError(f"arrival_method: got {arrival_method!r}; the record has 'level' and 'velocity_peak'")
    frame = open_dump(path).read()
    columns = {name: from_engine(frame.data[-1, :, k + 1], quantity) for k, (name, quantity) in enumerate(FRONT_FIELDS)}
    end = float(from_engine(frame.time[-1], "time"))
    case = cases[0]
    imp, vi = case.impactor, case.impactor.peak_velocity()
    t = np.arange(round(end / case.run.dt) + 1) * case.run.dt
    v, a = imp.velocity_at(t)[:, None], imp.acceleration_at(t)[:, None]
    column = "arrival" if arrival_method == "level" else "pulse_arrival"
    n, out = case.chain.particles, []
    for r, case in enumerate(cases):  # the drive's measures use each chain's own noise level
        record = {name: values[r * n:(r + 1) * n] for name, values in columns.items()}
        noise = chain_noise(case)
        drive = measures.first_peaks(t, v, a, vi, noise=noise)
        peaks = measures.FirstPeaks(*(np.concatenate([getattr(drive, f.name), record[f.name][1:]])
                                      for f in fields(measures.FirstPeaks)))
        arrival = np.concatenate([measures.arrival_times(t, v, vi, method=arrival_method, noise=noise),
                                  record[column][1:]])
        front = measures.Front(arrival, measures.propagation_velocity(arrival, case.chain.gaps()), peaks,
                               arrival_method, noise, slowest_linear_speed(case))
        out.append(FrontRecord(front, record["max_speed"].copy(), end))
    return out


def case_front(case: Case, t, v, a, arrival_method: str = "level") -> measures.Front:
    """`measures.front` of a trajectory of `case` (t ms, v m/s, a m/s^2), with the case's noise
    velocity and slowest linear speed: the same definitions as the record."""
    return measures.front(t, v, a, case.impactor.peak_velocity(), case.chain.gaps(), arrival_method,
                          chain_noise(case), slowest_linear_speed(case))


def slowest_linear_speed(case: Case) -> float:
    """The chain's slowest local linear wave speed, m/s (`measures.slowest_linear_speed`)."""
    gaps = case.chain.gaps()
    return measures.slowest_linear_speed(case.force.stiffness(gaps), case.chain.masses(), gaps)
