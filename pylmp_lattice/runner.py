"""The one layer that talks to LAMMPS: run a run folder's deck, report failures.

Two runners produce the same files in the folder (see `formats.layout`): `run_embedded` (the
LAMMPS Python module, in this process; the default) and `run_executable` (the `lmp` program,
optionally under `mpiexec`). Writing the folder is `run_folder.write`'s job, reading it back `RunFolder`'s.

Both stop cleanly on SIGINT or SIGTERM and raise `Interrupted`, keeping the files written so
far. The embedded run calls LAMMPS from a worker thread: a C call holds the thread, and Python
runs signal handlers only in the main thread, between bytecodes. The handler asks LAMMPS for a
"soft stop" (`force_timeout`, checked every step), so the run ends as a normal run does and
LAMMPS closes its dump and log itself. `lmp` runs in its own process group, to which the
signal is forwarded once, and dies with its parent (a parent-death signal). An embedded run
that is one of several MPI ranks (`mpiexec -n 2 pylmp-lattice lmp -in in.lattice`, each rank a
process like this one) must stop every rank at the same step: fix lattice/chain does so
(`_Engine.stop`); a deck without it ends by the signal at once, as a killed lmp does.

A run leaves the calling process as it found it: no change of working directory (the deck
finds its files through the `dir` variable, see `formats.layout`) and no redirection of the
process's streams (LAMMPS's screen output goes to its own handle on stderr, or nowhere).
"""

from __future__ import annotations

import contextlib
import ctypes
import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Callable
from pathlib import Path

from .formats.dump import error_line, find_contact
from .engine import ONE_INSTANCE, new_lammps
from .errors import ContactError, DumpFormatError, Interrupted, RunError
from .formats.layout import DECK, DIR_VARIABLE, LOG, TRAJ_BIN, deck_dir
from .ranks import launched
from .units import from_engine

STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM)
# Seconds between looks at a running engine (progress, and the end of an interrupted lmp).
POLL = 0.2


def run_deck(folder: str | Path, runner: str = "embedded", nprocs: int = 1, echo: bool = False,
             on_step: Callable[[int], None] | None = None) -> Path:
    """Run the folder's deck with `runner`: "embedded" (`run_embedded`) or "lmp" (`run_executable`)."""
    if runner == "embedded":
        return run_embedded(folder, echo=echo, on_step=on_step)
    return run_executable(folder, nprocs=nprocs, echo=echo, on_step=on_step)


def run_embedded(folder: str | Path, echo: bool = False, on_step: Callable[[int], None] | None = None,
                 cmdargs: list[str] | None = None) -> Path:
    """Run the folder's deck with the LAMMPS Python module.

    `echo` shows LAMMPS's screen output (on stderr: stdout stays free for results);
    `on_step(step)` is called about every POLL seconds with the current time step. cmdargs:
    LAMMPS's command line instead of the log, screen and folder chosen here (a hand run, run
    in the folder as `lmp -in` with these arguments would be).
    """
    folder = Path(folder).resolve()
    args = cmdargs if cmdargs is not None else ["-log", str(folder / LOG), "-screen", "/dev/stderr" if echo else "none",
                                                "-var", DIR_VARIABLE, deck_dir(folder)]
    engine = _Engine(args, str(folder / DECK))
    worker = threading.Thread(target=engine.run, name="lammps", daemon=True)
    try:
        with _stop_signals(engine.stop) as stopped:
            worker.start()
            while worker.is_alive():
                worker.join(POLL)
                if on_step:
                    on_step(engine.step())
    finally:
        if worker.is_alive():  # an error in this thread: stop LAMMPS and let it close its files
            engine.stop()
            worker.join()
    if engine.failure:
        text = str(engine.failure)
        raise RunError(error_line(text) or text.strip() or "LAMMPS failed", folder) from engine.failure
    if stopped:
        raise Interrupted(stopped[0], from_engine(engine.time, "time"), folder)
    _check_contact(folder)
    return folder


class _Engine:
    """One LAMMPS instance living in the worker thread that runs the deck.

    The instance is created, run and closed in that thread: created in the main thread and run
    in another, the same run took 15-20 times longer (benchmarked, 1000 steps of the main case).
    The main thread only asks for the step and for a soft stop, under a lock, so it never
    touches a closed instance (one of several MPI ranks whose instance is still being made
    ends at a stop instead: `stop`).
    """

    def __init__(self, args: list[str], deck: str):
        self.args = args
        self.deck = deck
        self.lock = threading.RLock()  # re-entrant: a signal handler may run while the main thread holds it
        self.lmp = None
        self.stopped = 0  # the signal that asked for a stop (SIGTERM for an error in the caller)
        self.failure: Exception | None = None
        self.time = 0.0  # s, simulated time reached

    def run(self) -> None:
        with ONE_INSTANCE:  # runs in other threads of this process wait (see engine.ONE_INSTANCE)
            try:
                with self.lock:
                    self.lmp = new_lammps(self.args)
                    if self.stopped:  # a signal came before the instance existed
                        self._stop_now()
                self.lmp.file(self.deck)
            except Exception as err:  # the module raises a bare Exception carrying LAMMPS's message
                self.failure = err
            finally:
                with self.lock:
                    if self.lmp is not None:
                        self.time = self.lmp.extract_global("ntimestep") * self.lmp.extract_global("dt")
                        self.lmp.close()  # flushes and closes the log and the dump
                        self.lmp = None

    def step(self) -> int:
        with self.lock:
            return self.lmp.extract_global("ntimestep") if self.lmp is not None else 0

    def stop(self, signum: int = signal.SIGTERM) -> None:
        """LAMMPS's soft stop: the run ends at its next step as if it had finished. On several MPI
        ranks, LAMMPS's own (force_timeout) would end each rank at the step its signal reached it,
        and leave the others waiting for it in an exchange for ever: fix lattice/chain ends them
        all at one step (`_request_stop`). Without that fix (or before the deck has made it), such
        a rank ends at once by `signum`, its files as a killed lmp leaves them."""
        self.stopped = signum
        several = launched()[1] > 1
        # One of several MPI ranks may be making its instance, waiting in MPI for a rank that is
        # gone: it ends at once (nothing of it to keep). Any other waits for the instance, then stops it.
        if not self.lock.acquire(blocking=not several):
            _die(signum)
        try:
            if self.lmp is not None:
                self._stop_now()
        finally:
            self.lock.release()

    def _stop_now(self) -> None:
        """`stop` of the instance (under the lock)."""
        if self.lmp.extract_setting("world_size") == 1:
            self.lmp.force_timeout()
        elif not _request_stop():  # (before the deck made its fix, too)
            _die(self.stopped)


def _request_stop() -> int:
    """Ask fix lattice/chain (the plugin's `pylmp_lattice_request_stop`) to stop its runs in this
    process at their next step, on every MPI rank at once; the number of such fixes here (0: no
    run will take it; an older plugin without the function counts none)."""
    try:
        return ctypes.CDLL(None).pylmp_lattice_request_stop()  # LAMMPS loads its plugins into the global scope
    except AttributeError:
        return 0


def _die(signum: int) -> None:
    """End this process by `signum` now, as if it had never been handled (from any thread: the C
    library's `signal`, as `_engine_child` sets it; Python's only from the main thread)."""
    ctypes.CDLL(None, use_errno=True).signal(int(signum), ctypes.c_void_p(0))  # SIG_DFL
    os.kill(os.getpid(), signum)


def run_executable(folder: str | Path, nprocs: int = 1, echo: bool = False,
                   on_step: Callable[[int], None] | None = None) -> Path:
    """Run the folder's deck with the `lmp` executable (under mpiexec when nprocs > 1).

    `echo` passes LAMMPS's screen output to stderr; `on_step(step)` follows the log's thermo rows.
    """
    folder = Path(folder).resolve()
    cmd = [_tool("lmp"), "-in", DECK, "-log", LOG] + ([] if echo else ["-screen", "none"])
    if nprocs > 1:
        cmd = [_tool("mpiexec"), "-n", str(nprocs)] + cmd
    with tempfile.TemporaryFile("w+") as out:
        # Its own process group: a terminal's Ctrl-C reaches only us, and we stop the whole group once.
        proc = subprocess.Popen(cmd, cwd=folder, stdout=sys.stderr if echo else out, stderr=subprocess.STDOUT,
                                text=True, start_new_session=True, preexec_fn=_engine_child)
        with _stop_signals(lambda signum: _signal_group(proc, signum)) as stopped:
            while proc.poll() is None:
                time.sleep(POLL)
                if on_step:
                    on_step(_last_thermo(folder)[0])
        if proc.returncode != 0:  # what is left of a killed or failed lmp (the wrapper's child, ranks)
            _signal_group(proc, signal.SIGKILL)
        out.seek(0)
        output = out.read()
    if stopped:
        written = [t for t in (_last_thermo(folder)[1], _last_frame_time(folder)) if t is not None]
        raise Interrupted(stopped[0], from_engine(max(written), "time") if written else None, folder)
    if proc.returncode != 0:
        log = folder / LOG
        message = error_line((log.read_text() if log.exists() else "") + output)
        if message is None:
            killer = _killed_by(proc.returncode)
            message = (f"lmp was killed by signal {signal.Signals(killer).name}" if killer
                       else f"lmp exited with code {proc.returncode} without a LAMMPS error message")
        raise RunError(message, folder, proc.returncode)
    _check_contact(folder)
    return folder


def _killed_by(code: int) -> int | None:
    """The signal that killed the engine, from the exit code of `lmp` or `mpiexec`: -n from the
    program itself, 256 - n from the wheel's `lmp` wrapper (a Python script that exits with its
    child's -n), 128 + n from a shell or mpiexec; None for an ordinary exit code."""
    for signum in (-code, 256 - code if code < 255 else 0, code - 128):  # 255: exit(-1), no signal
        if 0 < signum < signal.NSIG:
            with contextlib.suppress(ValueError):
                return int(signal.Signals(signum))
    return None


def die_with_parent() -> None:
    """In the child before exec: SIGTERM when the parent dies, so that mpiexec stops its ranks
    and lmp stops even if the parent is killed outright (Linux's PR_SET_PDEATHSIG)."""
    with contextlib.suppress(OSError, AttributeError):
        ctypes.CDLL(None, use_errno=True).prctl(1, signal.SIGTERM)  # 1 = PR_SET_PDEATHSIG


def _engine_child() -> None:
    """In lmp's child before exec: die with the parent, and take SIGINT and SIGTERM by default.
    A signal ignored here would stay ignored after exec, and the parent, which stops on both
    even when its caller ignored them (`cmd &` in a script), forwards them to the child."""
    die_with_parent()
    libc = ctypes.CDLL(None, use_errno=True)
    for signum in STOP_SIGNALS:
        libc.signal(int(signum), ctypes.c_void_p(0))  # SIG_DFL


def _signal_group(proc: subprocess.Popen, signum: int) -> None:
    with contextlib.suppress(ProcessLookupError):
        os.killpg(proc.pid, signum)


@contextlib.contextmanager
def _stop_signals(stop: Callable[[int], None]):
    """While inside, SIGINT and SIGTERM call `stop(signum)` once and are recorded in the yielded list.

    Handlers can only be set from the main thread; elsewhere (a thread pool of a sweep) the
    process's own handling stays in place.
    """
    received: list[int] = []
    if threading.current_thread() is not threading.main_thread():
        yield received
        return

    def handler(signum, frame):
        if not received:
            stop(signum)
        received.append(signum)

    previous = {s: signal.signal(s, handler) for s in STOP_SIGNALS}
    try:
        yield received
    finally:
        for s, h in previous.items():
            signal.signal(s, h)


def _last_thermo(folder: Path) -> tuple[int, float | None]:
    """Step and time (s) of the last thermo row in the folder's log so far; (0, None) before one."""
    try:
        text = (folder / LOG).read_text(errors="replace")
    except FileNotFoundError:
        return 0, None
    rows = re.findall(r"^\s*(\d+)\s+([-+.\deE]+)\s+[-+.\deE]+\s", text, re.MULTILINE)
    return (int(rows[-1][0]), float(rows[-1][1])) if rows else (0, None)


def _last_frame_time(folder: Path) -> float | None:
    """Time (s) of the last complete frame of the binary trajectory, if there is one: a killed
    `lmp` prints thermo rows only every 1/20 of the run, but writes frames to the end."""
    from .formats.bindump import open_dump

    path = folder / TRAJ_BIN
    with contextlib.suppress(FileNotFoundError, DumpFormatError):  # the signal's report comes first
        dump = open_dump(path)
        if dump.frames:
            return float(dump.read(dump.frames - 1).time[-1])
    return None


def _check_contact(folder: Path) -> None:
    """Raise ContactError if the run stopped because two magnets touched (the deck's CONTACT line)."""
    contact = find_contact((folder / LOG).read_text(errors="replace"))
    if contact:
        raise ContactError(contact.magnets, contact.time_ms, contact.gap_mm, folder)


def _tool(name: str) -> str:
    """An executable of this Python environment (the wheels' lmp, mpiexec), else from PATH."""
    local = Path(sys.executable).parent / name
    found = str(local) if local.exists() else shutil.which(name)
    if not found:
        raise RunError(f"`{name}` not found; install the `lammps[mpi]` package")
    return found
