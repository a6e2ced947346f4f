"""From a case to its results: write the run folder, run LAMMPS, read, measure.

`execute` runs a case and leaves its files; `simulate` also returns the trajectory;
`run_case` is the whole job of `pylmp-lattice run` (run, front measures, summary.json and the
run's figure), for one run or a sweep member. `load_trajectory` reads whichever output a run
folder has; `measure_run` takes the front measures from the engine's record when there is one.
"""

from __future__ import annotations

import json
import time
from pathlib import Path

import numpy as np

from . import measures
from .case import Case
from .deck import DUMP, FINE_BIN, TRAJ_BIN
from .dump import read_dump, trajectory_from_dump
from .errors import LatticeError
from .front_record import has_front_record, read_front_record
from .h5md import FILE as H5MD_FILE
from .h5md import convert_run, read_group
from .runner import run_embedded, run_executable, write_run_folder
from .trajectory import Trajectory

RUNNERS = ("embedded", "lmp")
SUMMARY = "summary.json"
FIGURE = "shock.png"


def execute(case: Case, folder: str | Path, runner: str = "embedded", nprocs: int = 1, echo: bool = False) -> Path:
    """Write `case` into `folder` and run it there; return the folder.

    runner = "embedded" uses the LAMMPS Python module in this process; "lmp" the executable
    (with mpiexec for nprocs > 1). The trajectory becomes traj.h5md also when the run fails or
    stops early, so the folder keeps every frame written before the stop.
    """
    if runner not in RUNNERS:
        raise ValueError(f"runner: got {runner!r}; choose one of {', '.join(RUNNERS)}")
    folder = write_run_folder(case, folder)
    try:
        if runner == "embedded":
            run_embedded(folder, echo=echo)
        else:
            run_executable(folder, nprocs=nprocs, echo=echo)
    finally:
        if case.output.format == "h5md":
            convert_run(case, folder)
    return folder


def simulate(case: Case, folder: str | Path, runner: str = "embedded", nprocs: int = 1, echo: bool = False) -> Trajectory:
    """Run `case` in `folder` (see `execute`) and return its whole trajectory in user units."""
    return load_trajectory(case, execute(case, folder, runner, nprocs, echo))


def load_trajectory(case: Case, folder: str | Path, group: str = "chain", particles=None) -> Trajectory:
    """The trajectory in a run folder: traj.h5md (binary dumps of a deck run by hand are converted
    first) or the text dump.

    group: "chain" (every magnet) or "fine" (the output.fine magnets at output.fine_interval).
    particles: 0-based indices into the group, increasing, to read only those columns.
    The impactor's acceleration comes from its profile: the piston imposes its motion, and the
    force on it in the file is the chain's push, not m a.
    """
    folder = Path(folder)
    if not (folder / H5MD_FILE).exists() and ((folder / TRAJ_BIN).exists() or (folder / FINE_BIN).exists()):
        convert_run(case, folder)
    if (folder / H5MD_FILE).exists():
        traj = read_group(folder / H5MD_FILE, group, particles)
    elif (folder / DUMP).exists() or (folder / DUMP.replace("traj", "fine")).exists():
        name = DUMP if group == "chain" else DUMP.replace("traj", "fine")
        traj = _select(trajectory_from_dump(read_dump(folder / name)), particles)
    else:
        raise LatticeError(f"{folder}: no trajectory (output.format = {case.output.format!r})")
    # the group's columns are in id order
    numbers = np.arange(case.chain.particles) if group == "chain" else np.sort(case.output.fine) - 1
    numbers = numbers if particles is None else numbers[list(particles)]
    traj.a[:, numbers == 0] = case.impactor.acceleration_at(traj.t)[:, None]
    return traj


def measure_run(case: Case, folder: str | Path) -> tuple[measures.Front | None, np.ndarray | None]:
    """The run's front measures and each magnet's largest |v| (m/s): from the engine's record
    when the run has one, else from the whole trajectory. (None, None) without a drive."""
    if has_front_record(folder):
        record = read_front_record(case, folder, arrival_method(case))
        return record.front, record.max_speed
    traj = load_trajectory(case, folder)
    vi = case.impactor.peak_velocity()
    front = measures.front(traj.t, traj.v, traj.a, vi, case.chain.gaps(), arrival_method(case)) if vi > 0 else None
    return front, np.max(np.abs(traj.v), axis=0)


def arrival_method(case: Case) -> str:
    """A pulse's arrival is its first velocity peak (far from the impactor it may never reach
    V_I/2); any other drive's is the crossing of V_I/2."""
    return measures.default_arrival_method(pulse=case.impactor.profile == "sine")


def run_case(case: Case, folder: str | Path, runner: str = "embedded", nprocs: int = 1, echo: bool = False,
             figure: bool = True) -> dict:
    """Run `case` in `folder`, measure its front, write summary.json (and shock.png); return the summary."""
    from .summary import summarize

    start = time.perf_counter()
    folder = execute(case, folder, runner=runner, nprocs=nprocs, echo=echo)
    front, max_speed = measure_run(case, folder)
    summary = summarize(case, front, max_speed)
    summary["files"] = {"folder": str(folder), "log": str(folder / "log.lammps")}
    for name in (H5MD_FILE, DUMP):
        if (folder / name).exists():
            summary["files"]["trajectory"] = str(folder / name)
    if figure and front is not None:
        _figure(case, folder, front, summary["linear_wave_speed_V0_m_per_s"]).savefig(folder / FIGURE, dpi=120)
        summary["files"]["figure"] = str(folder / FIGURE)
    summary["wall_time_s"] = round(time.perf_counter() - start, 2)
    (folder / SUMMARY).write_text(json.dumps(summary, indent=2) + "\n")
    return summary


def _figure(case: Case, folder: Path, front: measures.Front, v0: float):
    """Fig. 3(a-d) of the run: profiles from the fine output if any, else a few magnets the
    front reached, read alone from the trajectory; panels (a, d) empty without a trajectory."""
    from .plots import shock_figure

    if case.output.format == "none":
        return shock_figure(None, [], case.impactor.peak_velocity(), front, v0)
    if case.output.fine:
        chosen = sorted(n - 1 for n in case.output.fine)
        profiles = load_trajectory(case, folder, "fine")
    else:
        reached = np.flatnonzero(np.isfinite(front.arrival))
        last = int(reached[-1]) if reached.size else 0
        chosen = sorted({1, max(1, last // 4), max(1, last // 2), max(1, last - 1)})
        profiles = load_trajectory(case, folder, "chain", chosen)
    return shock_figure(profiles, chosen, case.impactor.peak_velocity(), front, v0)


def _select(traj: Trajectory, particles) -> Trajectory:
    if particles is None:
        return traj
    cols = list(particles)
    return Trajectory(traj.t, traj.x0[cols], traj.u[:, cols], traj.v[:, cols], traj.a[:, cols])
