"""One call from a case to its results: write the run folder, run LAMMPS, read, measure.

`simulate` returns the trajectory; `run_case` is the whole job of `pylmp-lattice run`
(simulate, front measures, summary.json and the run's figure), for one run or a sweep member.
"""

from __future__ import annotations

import json
import time
from pathlib import Path

from .case import Case
from .deck import DUMP
from .dump import read_dump, trajectory_from_dump
from .runner import run_embedded, run_executable, write_run_folder
from .trajectory import Trajectory

RUNNERS = ("embedded", "lmp")


def simulate(case: Case, folder: str | Path, runner: str = "embedded", nprocs: int = 1, echo: bool = False) -> Trajectory:
    """Run `case` in `folder` and return its trajectory in user units.

    runner = "embedded" uses the LAMMPS Python module in this process; "lmp" the executable
    (with mpiexec for nprocs > 1). On failure the folder keeps everything written so far.
    """
    if runner not in RUNNERS:
        raise ValueError(f"runner: got {runner!r}; choose one of {', '.join(RUNNERS)}")
    folder = write_run_folder(case, folder)
    if runner == "embedded":
        run_embedded(folder, echo=echo)
    else:
        run_executable(folder, nprocs=nprocs, echo=echo)
    return load_trajectory(case, folder)


def load_trajectory(case: Case, folder: str | Path) -> Trajectory:
    """The trajectory in a run folder, with the impactor's prescribed acceleration.

    The dump's force on the impactor is the chain's push against the piston, not m a: the
    piston imposes the motion, so its acceleration comes from the profile.
    """
    traj = trajectory_from_dump(read_dump(Path(folder) / DUMP))
    traj.a[:, 0] = case.impactor.acceleration_at(traj.t)
    return traj


SUMMARY = "summary.json"
FIGURE = "shock.png"


def run_case(case: Case, folder: str | Path, runner: str = "embedded", nprocs: int = 1, echo: bool = False,
             figure: bool = True) -> dict:
    """Run `case` in `folder`, measure its front, write summary.json (and shock.png); return the summary."""
    from .summary import front_measures, summarize

    folder = Path(folder)
    start = time.perf_counter()
    traj = simulate(case, folder, runner=runner, nprocs=nprocs, echo=echo)
    vi = case.impactor.peak_velocity()
    measured = front_measures(case, traj) if vi > 0 else None
    summary = summarize(case, traj, measured)
    summary["files"] = {"folder": str(folder), "dump": str(folder / DUMP), "log": str(folder / "log.lammps")}
    if figure and measured is not None:
        from .plots import shock_figure

        shock_figure(traj, vi, measured, summary["linear_wave_speed_V0_m_per_s"]).savefig(folder / FIGURE, dpi=120)
        summary["files"]["figure"] = str(folder / FIGURE)
    summary["wall_time_s"] = round(time.perf_counter() - start, 2)
    (folder / SUMMARY).write_text(json.dumps(summary, indent=2) + "\n")
    return summary
