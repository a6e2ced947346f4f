"""The one layer that talks to LAMMPS: write a run folder, run its deck, report failures.

Two runners produce the same files in the folder (deck, data, table, case.toml, log.lammps,
traj.bin or traj.dump): `run_embedded` (the LAMMPS Python module, in this process; the default) and
`run_executable` (the `lmp` program, optionally under `mpiexec`).

Both stop cleanly on SIGINT or SIGTERM and raise `Interrupted`, keeping the files written so
far. The embedded run calls LAMMPS from a worker thread: a C call holds the thread, and Python
runs signal handlers only in the main thread, between bytecodes. The handler asks LAMMPS for a
"soft stop" (`force_timeout`, checked every step), so the run ends as a normal run does and
LAMMPS closes its dump and log itself. `lmp` runs in its own process group, to which the
signal is forwarded once.
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

import tomli_w

from . import deck
from .case import Case, case_to_dict
from .engine import new_lammps
from .errors import ConfigError, ContactError, DumpFormatError, Interrupted, RunError
from .units import from_engine

STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM)
# Seconds between looks at a running engine (progress, and the end of an interrupted lmp).
POLL = 0.2
CASE_FILE = "case.toml"


def write_run_folder(case: Case, folder: str | Path, overwrite: bool = False) -> Path:
    """Write the deck, its input files and the case (case.toml) into `folder`.

    A folder that already holds a run is refused unless `overwrite`; then the whole earlier run
    folder is removed first, so no stale summary or figure stays beside the new run's files.
    """
    folder = Path(folder)
    if check_folder(folder, overwrite):
        shutil.rmtree(folder)
    folder.mkdir(parents=True, exist_ok=True)
    for name, text in deck.render(case).items():
        (folder / name).write_text(text)
    (folder / CASE_FILE).write_bytes(tomli_w.dumps(case_to_dict(case)).encode())
    return folder


def write_replicas_folder(cases, folder: str | Path) -> Path:
    """Write the batched deck of `cases` (deck.render_replicas) and the cases (replicas.toml)."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    for name, text in deck.render_replicas(cases).items():
        (folder / name).write_text(text)
    (folder / "replicas.toml").write_bytes(tomli_w.dumps({"replica": [case_to_dict(c) for c in cases]}).encode())
    return folder


def check_folder(folder: str | Path, overwrite: bool = False) -> bool:
    """Whether `folder` holds an earlier run (it has case.toml) to remove before this one;
    ConfigError if it does and `overwrite` is not set. Other files are not a run's: they stay."""
    if not (Path(folder) / CASE_FILE).exists():
        return False
    if not overwrite:
        raise ConfigError("output", f"{folder} already holds a run; pass --overwrite (overwrite=True) to "
                                    "replace it, or choose another --name or -o")
    return True


def run_embedded(folder: str | Path, echo: bool = False, on_step: Callable[[int], None] | None = None) -> Path:
    """Run the folder's deck with the LAMMPS Python module.

    `echo` shows LAMMPS's screen output (on stderr: stdout stays free for results);
    `on_step(step)` is called about every POLL seconds with the current time step.
    """
    folder = Path(folder).resolve()
    args = ["-log", deck.LOG] + ([] if echo else ["-screen", "none"])
    engine = _Engine(args)
    with _working_dir(folder), _stdout_to_stderr():
        worker = threading.Thread(target=engine.run, name="lammps", daemon=True)
        try:
            with _stop_signals(lambda signum: engine.stop()) as stopped:
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
        raise RunError(_error_line(text) or text.strip() or "LAMMPS failed", folder) from engine.failure
    if stopped:
        raise Interrupted(stopped[0], from_engine(engine.time, "time"), folder)
    _check_contact(folder)
    return folder


class _Engine:
    """One LAMMPS instance living in the worker thread that runs the deck.

    The instance is created, run and closed in that thread: created in the main thread and run
    in another, the same run took 15-20 times longer (benchmarked, 1000 steps of the main case).
    The main thread only asks for the step and for a soft stop, under a lock, so it never
    touches a closed instance.
    """

    def __init__(self, args: list[str]):
        self.args = args
        self.lock = threading.RLock()  # re-entrant: a signal handler may run while the main thread holds it
        self.lmp = None
        self.stopped = False
        self.failure: Exception | None = None
        self.time = 0.0  # s, simulated time reached

    def run(self) -> None:
        try:
            with self.lock:
                self.lmp = new_lammps(self.args)
                if self.stopped:  # a signal came before the instance existed
                    self.lmp.force_timeout()
            self.lmp.file(deck.DECK)
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

    def stop(self) -> None:
        """LAMMPS's soft stop: the run ends at its next step as if it had finished."""
        with self.lock:
            self.stopped = True
            if self.lmp is not None:
                self.lmp.force_timeout()


def run_executable(folder: str | Path, nprocs: int = 1, echo: bool = False,
                   on_step: Callable[[int], None] | None = None) -> Path:
    """Run the folder's deck with the `lmp` executable (under mpiexec when nprocs > 1).

    `echo` passes LAMMPS's screen output to stderr; `on_step(step)` follows the log's thermo rows.
    """
    folder = Path(folder).resolve()
    cmd = [_tool("lmp"), "-in", deck.DECK, "-log", deck.LOG] + ([] if echo else ["-screen", "none"])
    if nprocs > 1:
        cmd = [_tool("mpiexec"), "-n", str(nprocs)] + cmd
    with tempfile.TemporaryFile("w+") as out:
        # Its own process group: a terminal's Ctrl-C reaches only us, and we stop the whole group once.
        proc = subprocess.Popen(cmd, cwd=folder, stdout=sys.stderr if echo else out, stderr=subprocess.STDOUT,
                                text=True, start_new_session=True)
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
        log = folder / deck.LOG
        message = _error_line((log.read_text() if log.exists() else "") + output)
        if message is None:
            message = (f"lmp was killed by signal {signal.Signals(-proc.returncode).name}" if proc.returncode < 0
                       else f"lmp exited with code {proc.returncode} without a LAMMPS error message")
        raise RunError(message, folder, proc.returncode)
    _check_contact(folder)
    return folder


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
        text = (folder / deck.LOG).read_text(errors="replace")
    except FileNotFoundError:
        return 0, None
    rows = re.findall(r"^\s*(\d+)\s+([-+.\deE]+)\s+[-+.\deE]+\s", text, re.MULTILINE)
    return (int(rows[-1][0]), float(rows[-1][1])) if rows else (0, None)


def _last_frame_time(folder: Path) -> float | None:
    """Time (s) of the last complete frame of the binary trajectory, if there is one: a killed
    `lmp` prints thermo rows only every 1/20 of the run, but writes frames to the end."""
    from .bindump import open_dump

    path = folder / deck.TRAJ_BIN
    with contextlib.suppress(FileNotFoundError, DumpFormatError):  # the signal's report comes first
        dump = open_dump(path)
        if dump.frames:
            return float(dump.read(dump.frames - 1).time[-1])
    return None


def _check_contact(folder: Path) -> None:
    """Raise ContactError if the deck's guard stopped the run (it prints CONTACT_MARK)."""
    text = (folder / deck.LOG).read_text()
    pattern = re.escape(deck.CONTACT_MARK) + r" magnets (\d+) and (\d+) gap (\S+) m at t = (\S+) s"
    m = re.search(r"^" + pattern, text, re.MULTILINE)
    if m:
        i, j, gap, t = m.groups()
        raise ContactError((int(i), int(j)), from_engine(float(t), "time"), from_engine(float(gap), "length"), folder)


def _error_line(text: str) -> str | None:
    """LAMMPS's first ERROR line in `text` in user units, without its source location; None if none."""
    for line in text.splitlines():
        if "ERROR" in line:
            # LAMMPS's "(src/...)" and a plugin's "(/path/to/fix.cpp:123)"
            line = re.sub(r"\s*\((?:src/[^)]*|[^()]*\.(?:cpp|h):\d+)\)", "", line.strip())
            # engine lengths (m) -> mm, e.g. "Bond length > table outer cutoff: type 1 length 0.0130"
            return re.sub(r"\blength (-?[\d.]+(?:[eE][-+]?\d+)?)",
                          lambda m: f"length {from_engine(float(m.group(1)), 'length'):.6g} mm", line)
    return None


def _tool(name: str) -> str:
    """An executable of this Python environment (the wheels' lmp, mpiexec), else from PATH."""
    local = Path(sys.executable).parent / name
    found = str(local) if local.exists() else shutil.which(name)
    if not found:
        raise RunError(f"`{name}` not found; install the `lammps[mpi]` package")
    return found


@contextlib.contextmanager
def _working_dir(path: Path):
    # The deck names its files relative to the run folder, as for `lmp -in` run there.
    old = Path.cwd()
    os.chdir(path)
    try:
        yield
    finally:
        os.chdir(old)


@contextlib.contextmanager
def _stdout_to_stderr():
    """Send the process's C-level stdout (LAMMPS's screen) to stderr: stdout carries only results."""
    sys.stdout.flush()
    saved = os.dup(1)
    os.dup2(2, 1)
    try:
        yield
    finally:
        ctypes.CDLL(None).fflush(None)
        os.dup2(saved, 1)
        os.close(saved)
