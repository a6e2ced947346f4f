"""One call from a case to its results: write the run folder, run LAMMPS, read, measure.

`simulate` returns the trajectory; `run_case` is the whole job of `pylmp-lattice run`
(simulate, front measures, summary.json and the run's figure), for one run or a sweep member;
`read_run` opens a run folder again.

Before anything is written, `preflight.check` refuses a run too large for this machine (and,
without `yes`, one estimated to take over an hour). A folder that holds a run is never
replaced without `overwrite`. SIGINT/SIGTERM stop the engine cleanly (`errors.Interrupted`).
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path

from . import preflight
from .case import Case, load_case
from .deck import DUMP, LOG
from .dump import read_dump, read_log, trajectory_from_dump
from .errors import ConfigError
from .progress import progress_bar
from .runner import CASE_FILE, run_embedded, run_executable, write_run_folder
from .trajectory import Trajectory
from .units import from_engine

RUNNERS = ("embedded", "lmp")


def simulate(case: Case, folder: str | Path, runner: str = "embedded", nprocs: int = 1, echo: bool = False,
             overwrite: bool = False, progress: bool = False, yes: bool = False) -> Trajectory:
    """Run `case` in `folder` and return its trajectory in user units.

    runner = "embedded" uses the LAMMPS Python module in this process; "lmp" the executable
    (with mpiexec for nprocs > 1). `progress` draws a bar on stderr (terminals only); `echo`
    shows LAMMPS's screen output on stderr. On failure or interrupt the folder keeps everything
    written so far.
    """
    if runner not in RUNNERS:
        raise ValueError(f"runner: got {runner!r}; choose one of {', '.join(RUNNERS)}")
    preflight.check(case, folder, nprocs, yes=yes)
    if nprocs > 1 and runner != "lmp":
        raise ConfigError("--np", f"got {nprocs}; several ranks need --runner lmp")
    folder = write_run_folder(case, folder, overwrite=overwrite)
    with progress_bar(case, progress) as on_step:
        if runner == "embedded":
            run_embedded(folder, echo=echo, on_step=on_step)
        else:
            run_executable(folder, nprocs=nprocs, echo=echo, on_step=on_step)
    return load_trajectory(case, folder)


def load_trajectory(case: Case, folder: str | Path) -> Trajectory:
    """The trajectory in a run folder, with the impactor's prescribed acceleration.

    The dump's force on the impactor is the chain's push against the piston, not m a: the
    piston imposes the motion, so its acceleration comes from the profile.
    """
    traj = trajectory_from_dump(read_dump(Path(folder) / DUMP))
    traj.a[:, 0] = case.impactor.acceleration_at(traj.t)
    return traj


def friction_work(folder: str | Path) -> float:
    """Energy the friction has dissipated by the end of the run, mJ (the fix's scalar in the log)."""
    return float(from_engine(read_log(Path(folder) / LOG).runs[-1]["f_friction"][-1], "energy"))


def run_figure(case: Case, traj: Trajectory, measured):
    """The run's Fig. 3-style figure (matplotlib Figure) with its front measures `measured`."""
    from .plots import shock_figure
    from .summary import linear_chain

    vi = case.impactor.peak_velocity()
    title = f"{case.name}: $V_I$ = {vi:g} m/s, N = {case.chain.particles}"
    return shock_figure(traj, vi, measured, linear_chain(case)[0], title=title)


SUMMARY = "summary.json"
FIGURE = "shock.png"


def run_case(case: Case, folder: str | Path, runner: str = "embedded", nprocs: int = 1, echo: bool = False,
             figure: bool = True, overwrite: bool = False, progress: bool = False, yes: bool = False) -> dict:
    """Run `case` in `folder`, measure its front, write summary.json (and shock.png); return the summary.

    summary.json is written last: a folder with it holds a finished run.
    """
    from .serialize import dumps
    from .summary import front_measures, summarize

    folder = Path(folder)
    start = time.perf_counter()
    traj = simulate(case, folder, runner=runner, nprocs=nprocs, echo=echo, overwrite=overwrite,
                    progress=progress, yes=yes)
    measured = front_measures(case, traj) if case.impactor.peak_velocity() > 0 else None
    summary = summarize(case, traj, measured)
    if case.friction is not None:
        summary["friction_dissipated_energy_mJ"] = round(friction_work(folder), 6)
    summary["files"] = {"folder": str(folder), "dump": str(folder / DUMP), "log": str(folder / LOG)}
    if figure and measured is not None:
        from .plots import pyplot

        fig = run_figure(case, traj, measured)
        fig.savefig(folder / FIGURE, dpi=120)
        pyplot().close(fig)  # a long session (API, sweeps) must not keep every figure
        summary["files"]["figure"] = str(folder / FIGURE)
    summary["wall_time_s"] = round(time.perf_counter() - start, 2)
    (folder / SUMMARY).write_text(dumps(summary) + "\n")
    return summary


@dataclass(frozen=True)
class Run:
    """A run folder read back: its case, trajectory (user units) and summary (None if unfinished)."""

    folder: Path
    case: Case
    trajectory: Trajectory
    summary: dict | None

    def front(self):
        """The front measures of this run (`summary.front_measures`: arrival, V_P per gap, first peaks)."""
        from .summary import front_measures

        return front_measures(self.case, self.trajectory)

    def figure(self):
        """The run's Fig. 3-style figure (`run_figure`)."""
        return run_figure(self.case, self.trajectory, self.front())


def read_run(folder: str | Path) -> Run:
    """Open a run folder written by `run_case` or `simulate` (also an interrupted one)."""
    import json

    folder = Path(folder)
    case = load_case(folder / CASE_FILE)
    summary = json.loads((folder / SUMMARY).read_text()) if (folder / SUMMARY).exists() else None
    return Run(folder, case, load_trajectory(case, folder), summary)
