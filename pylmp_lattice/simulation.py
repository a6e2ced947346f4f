"""From a case to its results: write the run folder, run LAMMPS, read, measure.

`execute` runs a case and leaves its files; `simulate` also returns the trajectory;
`run_case` is the whole job of `pylmp-lattice run` (run, front measures, summary.json and the
run's figure), for one run or a sweep member. `load_trajectory` reads whichever output a run
folder has; `measure_run` takes the front measures from the engine's record when there is one;
`read_run` opens a run folder again.

Before anything is written, `preflight.check` refuses a run too large for this machine (and,
without `yes`, one estimated to take over an hour). A folder that holds a run is never
replaced without `overwrite`. SIGINT/SIGTERM stop the engine cleanly (`errors.Interrupted`).
"""

from __future__ import annotations

import json
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from . import measures, preflight
from .case import Case, load_case
from .deck import DUMP, FINE_BIN, LOG, TRAJ_BIN
from .dump import read_dump, read_log, trajectory_from_dump
from .errors import ConfigError, LatticeError
from .front_record import case_front, has_front_record, read_front_record
from .h5md import FILE as H5MD_FILE
from .h5md import convert_run, read_group
from .progress import progress_bar
from .runner import CASE_FILE, run_embedded, run_executable, write_run_folder
from .trajectory import Trajectory
from .units import from_engine

RUNNERS = ("embedded", "lmp")
SUMMARY = "summary.json"
FIGURE = "shock.png"


def execute(case: Case, folder: str | Path, runner: str = "embedded", nprocs: int = 1, echo: bool = False,
            overwrite: bool = False, progress: bool = False, yes: bool = False) -> Path:
    """Write `case` into `folder` and run it there; return the folder.

    runner = "embedded" uses the LAMMPS Python module in this process; "lmp" the executable
    (with mpiexec for nprocs > 1). `progress` draws a bar on stderr (terminals only); `echo`
    shows LAMMPS's screen output on stderr. The trajectory becomes traj.h5md also when the run
    fails, stops early or is interrupted, so the folder keeps every frame written before the stop.
    """
    if runner not in RUNNERS:
        raise ValueError(f"runner: got {runner!r}; choose one of {', '.join(RUNNERS)}")
    preflight.check(case, folder, nprocs, yes=yes)
    if nprocs > 1 and runner != "lmp":
        raise ConfigError("--np", f"got {nprocs}; several ranks need --runner lmp")
    folder = write_run_folder(case, folder, overwrite=overwrite)
    try:
        with progress_bar(case, progress) as on_step:
            if runner == "embedded":
                run_embedded(folder, echo=echo, on_step=on_step)
            else:
                run_executable(folder, nprocs=nprocs, echo=echo, on_step=on_step)
    finally:
        if case.output.format == "h5md":
            convert_run(case, folder)
    return folder


def simulate(case: Case, folder: str | Path, runner: str = "embedded", nprocs: int = 1, echo: bool = False,
             overwrite: bool = False, progress: bool = False, yes: bool = False) -> Trajectory:
    """Run `case` in `folder` (see `execute`) and return its whole trajectory in user units."""
    return load_trajectory(case, execute(case, folder, runner, nprocs, echo, overwrite, progress, yes))


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
    front = case_front(case, traj.t, traj.v, traj.a, arrival_method(case)) if vi > 0 else None
    return front, np.max(np.abs(traj.v), axis=0)


def arrival_method(case: Case) -> str:
    """A pulse's arrival is its first velocity peak (far from the impactor it may never reach
    V_I/2); any other drive's is the crossing of V_I/2."""
    return measures.default_arrival_method(pulse=case.impactor.profile == "sine")


def friction_work(folder: str | Path) -> float:
    """Energy the friction has dissipated by the end of the run, mJ (the fix's scalar in the log)."""
    return float(from_engine(read_log(Path(folder) / LOG).runs[-1]["f_friction"][-1], "energy"))


def run_case(case: Case, folder: str | Path, runner: str = "embedded", nprocs: int = 1, echo: bool = False,
             figure: bool = True, overwrite: bool = False, progress: bool = False, yes: bool = False) -> dict:
    """Run `case` in `folder`, measure its front, write summary.json (and shock.png); return the summary.

    summary.json (strict JSON: an undefined measure is null) is written last: a folder with it
    holds a finished run.
    """
    from .serialize import dumps
    from .summary import summarize

    start = time.perf_counter()
    folder = execute(case, folder, runner=runner, nprocs=nprocs, echo=echo, overwrite=overwrite,
                     progress=progress, yes=yes)
    front, max_speed = measure_run(case, folder)
    summary = summarize(case, front, max_speed)
    if case.friction is not None:
        summary["friction_dissipated_energy_mJ"] = round(friction_work(folder), 6)
    summary["files"] = {"folder": str(folder), "log": str(folder / LOG)}
    for name in (H5MD_FILE, DUMP):
        if (folder / name).exists():
            summary["files"]["trajectory"] = str(folder / name)
    if figure and front is not None:
        run_figure(case, folder, front).savefig(folder / FIGURE, dpi=120)
        summary["files"]["figure"] = str(folder / FIGURE)
    summary["wall_time_s"] = round(time.perf_counter() - start, 2)
    (folder / SUMMARY).write_text(dumps(summary) + "\n")
    return summary


def simulate_replicas(cases, folder: str | Path, runner: str = "embedded", nprocs: int = 1,
                      echo: bool = False) -> list[Trajectory]:
    """Run equal-length chains batched in one LAMMPS instance (see deck.render_replicas);
    return one trajectory per case, each the same as its own `simulate` run's."""
    from .runner import write_replicas_folder

    folder = write_replicas_folder(cases, folder)
    if runner == "embedded":
        run_embedded(folder, echo=echo)
    else:
        run_executable(folder, nprocs=nprocs, echo=echo)
    return split_replicas(cases, trajectory_from_dump(read_dump(folder / DUMP)))


def split_replicas(cases, batched: Trajectory) -> list[Trajectory]:
    """The trajectories of the replicas in a batched run (replica r: particles r N .. r N + N - 1)."""
    n = cases[0].chain.particles
    out = []
    for r, case in enumerate(cases):
        part = slice(r * n, (r + 1) * n)
        a = batched.a[:, part].copy()
        a[:, 0] = case.impactor.acceleration_at(batched.t)
        out.append(Trajectory(batched.t, batched.x0[part], batched.u[:, part], batched.v[:, part], a))
    return out


def run_figure(case: Case, folder: str | Path, front: measures.Front):
    """Fig. 3(a-d) of a run, titled with the case, V_I and N: profiles from the fine output if
    any, else a few magnets the front reached, read alone from the trajectory; panels (a, d)
    empty without a trajectory."""
    from .plots import shock_figure
    from .summary import linear_chain

    vi, v0 = case.impactor.peak_velocity(), linear_chain(case)[0]
    title = f"{case.name}: $V_I$ = {vi:g} m/s, N = {case.chain.particles}"
    if case.output.format == "none":
        return shock_figure(None, [], vi, front, v0, title=title)
    if case.output.fine:
        chosen = sorted(n - 1 for n in case.output.fine)
        profiles = load_trajectory(case, folder, "fine")
    else:
        reached = np.flatnonzero(np.isfinite(front.arrival))
        last = int(reached[-1]) if reached.size else 0
        chosen = sorted({1, max(1, last // 4), max(1, last // 2), max(1, last - 1)})
        profiles = load_trajectory(case, folder, "chain", chosen)
    return shock_figure(profiles, chosen, vi, front, v0, title=title)


@dataclass(frozen=True)
class Run:
    """A run folder read back: its case, summary (None if unfinished) and, on request, its
    trajectory and front measures."""

    folder: Path
    case: Case
    summary: dict | None

    @property
    def trajectory(self) -> Trajectory:
        """The whole trajectory, user units (read from the folder on each access)."""
        return load_trajectory(self.case, self.folder)

    def front(self) -> measures.Front | None:
        """The front measures (`measure_run`: arrival times, V_P per gap, first peaks)."""
        return measure_run(self.case, self.folder)[0]

    def figure(self):
        """The run's Fig. 3-style figure (`run_figure`)."""
        return run_figure(self.case, self.folder, self.front())


def read_run(folder: str | Path) -> Run:
    """Open a run folder written by `run_case` or `simulate` (also an interrupted one)."""
    folder = Path(folder)
    case = load_case(folder / CASE_FILE)
    summary = json.loads((folder / SUMMARY).read_text()) if (folder / SUMMARY).exists() else None
    return Run(folder, case, summary)


def _select(traj: Trajectory, particles) -> Trajectory:
    if particles is None:
        return traj
    cols = list(particles)
    return Trajectory(traj.t, traj.x0[cols], traj.u[:, cols], traj.v[:, cols], traj.a[:, cols])
