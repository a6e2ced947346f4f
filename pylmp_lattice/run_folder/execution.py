"""Executing a case into a run folder: the one way a case becomes a run.

`execute` checks the case against this machine (`preflight`), writes the folder
(`write.write_folder`), runs LAMMPS in it (`runner`), records how the run ended (`marker`)
and turns its binary dumps into H5MD (`convert`); `run_case` then hands the folder to the
reader for its summary (`folder.summarize`); `simulate` returns the trajectory. Each of these
modules is entered once on the way. Nothing of the folder is lost when a run fails, stops on a
contact or is interrupted: its files stay, run.json says how it stopped, and an interrupted
run's binary dumps wait for the next read to become H5MD, so that Ctrl-C returns at once.
"""

from __future__ import annotations

import time
from contextlib import contextmanager
from pathlib import Path

import tomli_w

from .. import preflight
from ..case import Case, case_to_dict
from ..deck import render, render_replicas
from ..formats.dump import read_dump, trajectory_from_dump
from ..errors import ConfigError, ContactError, Interrupted, RunError
from ..progress import progress_bar
from ..runner import run_deck
from ..trajectory import Trajectory
from ..units import to_engine
from ..formats import layout
from ..formats.files import atomic_write, refuse_links
from . import marker
from .convert import convert_dumps
from .folder import RunFolder, summarize
from .write import write_claimed

RUNNERS = ("embedded", "lmp")


def execute(case: Case, folder: str | Path, runner: str = "embedded", nprocs: int = 1, echo: bool = False,
            overwrite: bool = False, progress: bool = False, yes: bool = False) -> RunFolder:
    """Write `case` into `folder` and run it there; return the RunFolder.

    runner = "embedded" uses the LAMMPS Python module in this process; "lmp" the executable
    (with mpiexec for nprocs > 1). `progress` draws a bar on stderr (terminals only); `echo`
    shows LAMMPS's screen output on stderr.
    """
    with _ran(case, folder, runner, nprocs, echo, overwrite, progress, yes) as path:
        return RunFolder(path)


def run_case(case: Case, folder: str | Path, runner: str = "embedded", nprocs: int = 1, echo: bool = False,
             figure: bool = True, overwrite: bool = False, progress: bool = False, yes: bool = False) -> dict:
    """Run `case` in `folder`, measure its front, write summary.json (then shock.png); return the summary.

    summary.json is written after the run ended: a folder with it holds a finished run (or one
    that stopped, as its "stopped" entry says)."""
    start = time.perf_counter()
    with _ran(case, folder, runner, nprocs, echo, overwrite, progress, yes) as path:
        return summarize(path, figure=figure, wall_time=time.perf_counter() - start)


@contextmanager
def _ran(case: Case, folder: str | Path, runner: str, nprocs: int, echo: bool, overwrite: bool, progress: bool,
         yes: bool):
    """The writer's side: the folder written, run and its dumps converted; its path is yielded
    with the folder's lock still held (from the check of the folder until the caller has read
    it: no other process overwrites or converts it meanwhile)."""
    if runner not in RUNNERS:
        raise ConfigError("runner", f"got {runner!r}; choose one of {', '.join(RUNNERS)}")
    if nprocs > 1 and runner != "lmp":
        raise ConfigError("--np", f"got {nprocs}; several ranks need --runner lmp")
    preflight.check(case, folder, nprocs, yes=yes)
    if runner == "embedded":
        layout.deck_dir(Path(folder))  # a folder the deck cannot name is refused before anything is written
    path = Path(folder)
    files = render(case)  # first: a case the deck refuses leaves the folder as it was
    with marker.claimed(layout.make_place(path)):
        write_claimed(case, path, overwrite, files)
        try:
            _run(case, path, runner, nprocs, echo, progress)
        except (ContactError, RunError):  # what the run wrote up to there becomes H5MD
            convert_dumps(path, case)
            raise
        convert_dumps(path, case)
        yield path


def _run(case: Case, path: Path, runner: str, nprocs: int, echo: bool, progress: bool) -> None:
    """Run the written folder; run.json says how it ended."""
    marker.record(path, marker.RUNNING)
    try:
        with progress_bar(case, progress) as on_step:
            run_deck(path, runner, nprocs=nprocs, echo=echo, on_step=on_step)
    except Interrupted as err:  # the dumps wait for the next read: Ctrl-C returns at once
        marker.record(path, marker.INTERRUPTED, time_ms=err.time_ms)
        raise
    except ContactError as err:
        marker.record(path, marker.CONTACT, time_ms=err.time_ms)
        raise
    except RunError as err:
        marker.record(path, marker.FAILED, error=err.message)
        raise
    except BaseException:
        marker.record(path, marker.INTERRUPTED)
        raise
    marker.record(path, marker.FINISHED)


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
    refuse_links(folder, layout.RUN_FILES)  # LAMMPS writes its files by name
    for name, text in render_replicas(cases).items():
        atomic_write(folder / name, text)
    atomic_write(folder / layout.REPLICAS, tomli_w.dumps({"replica": [case_to_dict(c) for c in cases]}))
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
