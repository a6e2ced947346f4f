"""One call from a case to its trajectory: write the run folder, run LAMMPS, read the dump."""

from __future__ import annotations

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
