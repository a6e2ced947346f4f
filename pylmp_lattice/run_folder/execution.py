"""Executing a case into a run folder: the one way a case becomes a run.

`execute` checks the case against this machine (`preflight`), writes the folder
(`RunFolder.create`), runs LAMMPS in it (`runner`) and records how the run ended; `run_case`
adds the summary (`RunFolder.summarize`); `simulate` returns the trajectory. Nothing of the
folder is lost when a run fails, stops on a contact or is interrupted: its files stay, run.json
says how it stopped, and an interrupted run's binary dumps wait for the next read to become
H5MD, so that Ctrl-C returns at once.
"""

from __future__ import annotations

import time
from pathlib import Path

import tomli_w

from .. import preflight
from ..case import Case, case_to_dict
from ..deck import render_replicas
from ..dump import read_dump, trajectory_from_dump
from ..errors import ConfigError, ContactError, Interrupted, RunError
from ..progress import progress_bar
from ..runner import deck_dir, run_deck
from ..trajectory import Trajectory
from ..units import to_engine
from . import layout
from .folder import CONTACT, FAILED, FINISHED, INTERRUPTED, RunFolder

RUNNERS = ("embedded", "lmp")


def execute(case: Case, folder: str | Path, runner: str = "embedded", nprocs: int = 1, echo: bool = False,
            overwrite: bool = False, progress: bool = False, yes: bool = False) -> RunFolder:
    """Write `case` into `folder` and run it there; return the RunFolder.

    runner = "embedded" uses the LAMMPS Python module in this process; "lmp" the executable
    (with mpiexec for nprocs > 1). `progress` draws a bar on stderr (terminals only); `echo`
    shows LAMMPS's screen output on stderr.
    """
    if runner not in RUNNERS:
        raise ConfigError("runner", f"got {runner!r}; choose one of {', '.join(RUNNERS)}")
    if nprocs > 1 and runner != "lmp":
        raise ConfigError("--np", f"got {nprocs}; several ranks need --runner lmp")
    preflight.check(case, folder, nprocs, yes=yes)
    if runner == "embedded":
        deck_dir(Path(folder))  # a folder the deck cannot name is refused before anything is written
    run = RunFolder.create(case, folder, overwrite=overwrite)
    try:
        with run.running(), progress_bar(case, progress) as on_step:
            run_deck(run.path, runner, nprocs=nprocs, echo=echo, on_step=on_step)
    except Interrupted as err:  # the dumps wait for the next read: Ctrl-C returns at once
        run.record(INTERRUPTED, time_ms=err.time_ms)
        raise
    except ContactError as err:
        run.record(CONTACT, time_ms=err.time_ms)
        run.convert()
        raise
    except RunError as err:
        run.record(FAILED, error=err.message)
        run.convert()
        raise
    except BaseException:
        run.record(INTERRUPTED)
        raise
    run.record(FINISHED)
    run.convert()
    return run


def run_case(case: Case, folder: str | Path, runner: str = "embedded", nprocs: int = 1, echo: bool = False,
             figure: bool = True, overwrite: bool = False, progress: bool = False, yes: bool = False) -> dict:
    """Run `case` in `folder`, measure its front, write summary.json (then shock.png); return the summary.

    summary.json is written after the run ended: a folder with it holds a finished run (or one
    that stopped, as its "stopped" entry says)."""
    start = time.perf_counter()
    run = execute(case, folder, runner=runner, nprocs=nprocs, echo=echo, overwrite=overwrite,
                  progress=progress, yes=yes)
    return run.summarize(figure=figure, wall_time=time.perf_counter() - start)


def simulate(case: Case, folder: str | Path, runner: str = "embedded", nprocs: int = 1, echo: bool = False,
             overwrite: bool = False, progress: bool = False, yes: bool = False) -> Trajectory:
    """Run `case` in `folder` (see `execute`) and return its whole trajectory in user units."""
    return execute(case, folder, runner, nprocs, echo, overwrite, progress, yes).trajectory()


def simulate_replicas(cases, folder: str | Path, runner: str = "embedded", nprocs: int = 1,
                      echo: bool = False) -> list[Trajectory]:
    """Run equal-length chains batched in one LAMMPS instance (see deck.render_replicas);
    return one trajectory per case, each the same as its own `simulate` run's."""
    folder = run_deck(write_replicas_folder(cases, folder), runner, nprocs=nprocs, echo=echo)
    dt = to_engine(cases[0].run.dt, "time")
    return split_replicas(cases, trajectory_from_dump(read_dump(folder / layout.DUMP, dt=dt)))


def write_replicas_folder(cases, folder: str | Path) -> Path:
    """Write the batched deck of `cases` (deck.render_replicas) and the cases (replicas.toml)."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    for name, text in render_replicas(cases).items():
        (folder / name).write_text(text)
    (folder / layout.REPLICAS).write_bytes(tomli_w.dumps({"replica": [case_to_dict(c) for c in cases]}).encode())
    return folder


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
