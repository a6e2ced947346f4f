"""Executing cases into a run folder: the one road from a case, or a batch of chains, to a run.

Each step is a module entered once, and each after the first takes the claimed folder, never a
path to check again:

    preflight  a single case against this machine: disk, memory, time (`preflight.check`)
    claim      every check of the folder, and its lock (`claim.claim`)
    write      the deck, its inputs, the cases and run.json "running" (`write.write`)
    run        the engine in the folder, then run.json says how it ended (`_run`)
    convert    binary dumps into H5MD (`convert.convert_claimed`)
    summarize  (`run_case`) summary.json and the figure (`folder.summarize_folder`)

`execute` and `run_case` take one case, `execute_batch` equal-length chains in one instance
(`deck.render_replicas`: a sweep's members). The engine is a step the road takes: LAMMPS
(`Lammps`: embedded, or the `lmp` executable), or any object with the same `nprocs`, `check`
and call (issue 28's kernels). Nothing of the folder is lost when a run fails, stops on a
contact or is interrupted: its files stay, run.json says how it stopped; a contact is
measured up to where it stopped (`run_case`), and an interrupted run's binary dumps wait for
the next read to become H5MD, so that Ctrl-C returns at once.
"""

from __future__ import annotations

import numbers
import re
import time
from collections.abc import Callable, Sequence
from contextlib import ExitStack, contextmanager, suppress
from dataclasses import dataclass
from pathlib import Path
from typing import Protocol

from .. import deck, preflight
from .. import runner as lammps_runner
from ..case import Case, as_case
from ..engine import RUNNERS
from ..errors import ContactError, Interrupted, RunError, UsageError, require_bool
from ..ranks import refuse_launched
from ..formats import layout
from ..formats.files import DiskFull, disk_full
from ..progress import progress_bar
from ..trajectory import Trajectory
from . import marker
from .claim import Claimed, claim
from .convert import convert_claimed
from .folder import RunFolder, summarize_folder
from .write import write


class Engine(Protocol):
    """What runs a written folder: `nprocs` (for the estimate), `check(path)` (refuse a folder
    it cannot run, before anything is written) and `engine(path, on_step)`, which raises
    ContactError, RunError or Interrupted as `runner.run_deck` does. An engine with
    `reads_chain_files` False (one that takes a batch's chains as arrays) gets no data file and
    no levels file in a batch's folder (`deck.render_folder`); one with a `start()` is started
    before the folder is written (the GPU engine: its first launch runs meanwhile)."""

    nprocs: int

    def check(self, path: Path) -> None:
        """Refuse a folder this engine cannot run, before anything is written."""

    def __call__(self, path: Path, on_step: Callable[[int], None] | None = None) -> None: ...


@dataclass(frozen=True)
class Lammps:
    """LAMMPS as the engine: runner = "embedded" (its Python module, in this process) or "lmp"
    (the executable, under mpiexec for nprocs > 1); `echo` shows its screen output on stderr."""

    runner: str = "embedded"
    nprocs: int = 1
    echo: bool = False

    def __post_init__(self):
        require_bool(echo=self.echo)
        if self.runner not in RUNNERS:
            raise UsageError("runner", f"got {self.runner!r}; choose one of {', '.join(RUNNERS)}")
        if isinstance(self.nprocs, bool) or not isinstance(self.nprocs, numbers.Integral):
            raise UsageError("--np", f"got {self.nprocs!r}; expected an integer >= 1 (nprocs, the MPI ranks)")
        object.__setattr__(self, "nprocs", int(self.nprocs))  # numpy's integers too (np.int64(2): 2)
        if self.nprocs > 1 and self.runner != "lmp":
            raise UsageError("--np", f"got {self.nprocs}; several ranks need --runner lmp")

    def check(self, path: Path) -> None:
        """The embedded runner refuses a folder its deck cannot name (`layout.deck_dir`)."""
        if self.runner == "embedded":
            layout.deck_dir(path)  # a folder the deck cannot name

    def __call__(self, path: Path, on_step: Callable[[int], None] | None = None) -> None:
        lammps_runner.run_deck(path, self.runner, nprocs=self.nprocs, echo=self.echo, on_step=on_step)


def execute(case: Case | str | Path, folder: str | Path, runner: str | Engine = "embedded", nprocs: int = 1, echo: bool = False,
            overwrite: bool = False, progress: bool = False, yes: bool = False) -> RunFolder:
    """Write `case` (a Case, or the path of its TOML file) into `folder` and run it there;
    return the RunFolder.

    runner = "embedded" uses the LAMMPS Python module in this process; "lmp" the executable
    (with mpiexec for nprocs > 1); or an `Engine`. `progress` draws a bar on stderr (terminals
    only); `echo` shows LAMMPS's screen output on stderr; `yes` starts a run estimated to take
    over an hour.
    """
    with _road([as_case(case)], folder, _engine(runner, nprocs, echo), overwrite, progress, yes) as claimed:
        return RunFolder(claimed.path)


def execute_batch(cases: Sequence[Case], folder: str | Path, runner: str | Engine = "embedded", nprocs: int = 1,
                  echo: bool = False, overwrite: bool = False, draws=None) -> RunFolder:
    """Run equal-length chains, equal outside [chain], in one instance (`deck.render_replicas`),
    on the road of `execute`; return the batch's RunFolder (`RunFolder.cases`, and
    `RunFolder.replicas` for its chains' trajectories).

    Cases with output.format = "none" record only each chain's front (front.bin, chain r's
    rows its atoms; with friction, each chain's friction work); others write one text dump of
    all chains. The machine check of a single run (`preflight`) is its sweep's here: a batch
    is a sweep's members. draws: the cases' `case_measures.chain_draws`, if drawn (the deck's
    data file and levels are made from them)."""
    with _road(list(cases), folder, _engine(runner, nprocs, echo), overwrite, draws=draws) as claimed:
        return RunFolder(claimed.path)


def run_case(case: Case | str | Path, folder: str | Path, runner: str | Engine = "embedded", nprocs: int = 1, echo: bool = False,
             figure: bool = True, overwrite: bool = False, progress: bool = False, yes: bool = False) -> dict:
    """Run `case` in `folder` (see `execute`), measure its front, write summary.json (then
    shock.png); return the summary.

    summary.json is written after the run ended: a folder with it holds a finished run, or one
    stopped by a contact (measured up to the contact, as its "stopped" entry says; the
    ContactError is raised after it is written)."""
    require_bool(figure=figure)  # before the run, not after it
    start = time.perf_counter()
    with _road([as_case(case)], folder, _engine(runner, nprocs, echo), overwrite, progress, yes,
               contact_ends=True) as claimed:
        return summarize_folder(claimed.path, figure=figure, wall_time=time.perf_counter() - start)


def simulate(case: Case | str | Path, folder: str | Path, runner: str | Engine = "embedded", nprocs: int = 1, echo: bool = False,
             overwrite: bool = False, progress: bool = False, yes: bool = False) -> Trajectory:
    """Run `case` in `folder` (see `execute`) and return its whole trajectory in user units."""
    return execute(case, folder, runner, nprocs, echo, overwrite, progress, yes).trajectory()


def _engine(runner: str | Engine, nprocs: int, echo: bool) -> Engine:
    if isinstance(runner, str):  # LAMMPS, which under an MPI launcher would join its job (a Python script
        refuse_launched("a run of pylmp_lattice")  # under mpiexec; the command refuses it first); a kernel engine would not
        return Lammps(runner, nprocs, echo)
    if not callable(getattr(runner, "check", None)):
        raise UsageError("runner", f"got {type(runner).__name__}; choose one of {', '.join(RUNNERS)}, or an Engine")
    require_bool(echo=echo)  # (an Engine shows no LAMMPS screen; `Lammps` checks its own)
    return runner


@contextmanager
def _road(cases: list[Case], folder: str | Path, engine: Engine, overwrite: bool, progress: bool = False,
          yes: bool = False, contact_ends: bool = False, draws=None):
    """The road: a single case checked against the machine, the deck rendered (a case the deck
    refuses leaves the folder as it was), the folder claimed, written, run and its dumps
    converted; the claimed folder is yielded with its lock still held (no other process
    overwrites or converts it until the caller has read it). With `contact_ends`, a run
    stopped by a contact is yielded too (to be measured), and its ContactError raised after."""
    require_bool(overwrite=overwrite, progress=progress, yes=yes)
    folder = layout.as_path(folder)
    engine.check(folder)
    if len(cases) == 1:
        preflight.check(cases[0], folder, engine.nprocs, yes=yes)
    getattr(engine, "start", lambda: None)()
    files = deck.render_folder(cases, draws, chain_files=getattr(engine, "reads_chain_files", True))
    with ExitStack() as held:
        claimed = claim(folder, overwrite, held)
        write(claimed, cases, files, marker.RUNNING)
        try:
            _run(claimed, engine, progress)
        except ContactError as err:
            convert_claimed(claimed)  # what the run wrote up to the contact becomes H5MD
            if not contact_ends:
                raise
            yield claimed
            raise ContactError(err.pair, err.time_ms, err.gap_mm, err.folder, summarized=True) from None
        except RunError:
            with suppress(DiskFull):  # on a full disk the dumps stay binary: the run's error says more
                convert_claimed(claimed)
            raise
        convert_claimed(claimed)
        yield claimed


def _run(claimed: Claimed, engine: Engine, progress: bool) -> None:
    """Run the written folder (run.json "running"); run.json says how it ended."""
    path, kept = claimed.path, claimed.record
    try:
        with progress_bar(claimed.cases[0], progress) as on_step:
            engine(path, on_step=on_step)
    except Interrupted as err:  # the dumps wait for the next read: Ctrl-C returns at once
        marker.record(path, marker.INTERRUPTED, **kept, time_ms=err.time_ms)
        raise
    except ContactError as err:
        marker.record(path, marker.CONTACT, **kept, time_ms=err.time_ms)
        raise
    except RunError as err:
        if disk_full(err):  # LAMMPS names the dump ("Error writing dump traj"): the message names its file
            full = DiskFull(_full_file(claimed.cases[0], path, err.message),
                            f"LAMMPS stopped ({err.message}); the files are kept")
            marker.record(path, marker.FAILED, **kept, error=f"{full.path}: no space left on the device ({err.message})")
            raise full from err
        marker.record(path, marker.FAILED, **kept, error=err.message)
        raise
    except Exception as err:  # an engine's own error (a full disk writing its record, a bug): failed, not redone
        marker.record(path, marker.FAILED, **kept, error=f"{type(err).__name__}: {err}".splitlines()[0])
        raise
    except BaseException:  # a signal on its way out (KeyboardInterrupt, SystemExit)
        marker.record(path, marker.INTERRUPTED, **kept)
        raise
    marker.record(path, marker.DONE, **kept)


def _full_file(case: Case, path: Path, message: str) -> Path:
    """The file LAMMPS could not write on a full disk, from its ERROR line: a dump's by its ID,
    else the log."""
    groups = layout.TEXT_GROUPS if case.output.format == "text" else layout.BINARY_GROUPS
    dump = re.search(r"dump (\w+)", message)
    return path / groups.get({"traj": "chain"}.get(dump[1], dump[1]) if dump else "", layout.LOG)
