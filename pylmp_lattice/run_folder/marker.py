"""A run folder's state: the package's record of it (run.json), the lock a writer or runner holds
while it writes the folder (run.lock, see `claimed`), and how the run stands, read from both and
from the log.

The format of two small files, as `bindump` is that of the binary dumps: the writer
(`run_folder.write`, `run_folder.execution`) and the reader (`run_folder.folder`) share it.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import math
import os
import socket
import time
from contextlib import contextmanager, suppress
from pathlib import Path

from ..errors import Interrupted, UsageError
from ..file_lock import Held, exclusive, is_held
from ..formats import files, layout

PACKAGE = "pylmp_lattice"
# Seconds a writer waits for the folder's lock: a reader's look at it (`locked`) holds it for an
# instant; a writer or runner holds it for the whole run.
CLAIM_WAIT = 0.5
# How a run stands, as run.json records it; "written" until a runner of this package ran it.
# One vocabulary for run folders and a sweep's members (`sweep.store`): "done" ended normally.
WRITTEN, RUNNING, DONE, INTERRUPTED, CONTACT, FAILED = (
    "written", "running", "done", "interrupted", "contact", "failed")
OLD_DONE = "finished"  # "done" in run.json of version 0.1.0 and before
# Read, never recorded: a deck that ran (its outputs are there) with no log.lammps in its folder and
# no runner of this package (`lmp -in` from another folder without -log logs there): its end is not known.
UNLOGGED = "unlogged"
# run.json's hash of the deck as written (`deck_hash`), and a batch's number of chains: kept by
# every later record of the folder.
DECK_HASH = "deck_sha256"
CHAINS = "chains"
HAND_RUNNER = "pylmp-lattice lmp"  # run.json's runner of a hand run (`hand_run`)
# Seconds a hand-run log that has not ended, and the dumps beside it, must stay unchanged to count
# as no longer written (`being_written`): /proc can show a writer, never that none exists (one of
# another user, or on another machine writing a shared folder).
QUIET = 30.0
# Seconds they must stay unchanged before anything destroys files of such an "interrupted" run, or
# an "unlogged" one (converting its dumps, --overwrite, a hand run: `settled`): a writer /proc
# cannot see may write a frame only every few minutes.
SETTLED = 600.0


def deck_hash(text: str) -> str:
    """The hash run.json keeps of the deck (in.lattice) as written: a deck edited since differs."""
    return hashlib.sha256(text.encode()).hexdigest()


def record(folder: Path, state: str, **details) -> None:
    """Write run.json (atomically): the package, its version, the state and its details (the
    deck's hash and a batch's chains of the earlier record are kept, unless the details give
    the hash: a runner that wrote the folder knows them, and saves a read). A "running" record
    names its writer (host and pid): once that process is gone, the run is known to have ended
    (`writer_gone`).

    On a full disk (no room for the new file beside the old one) the record is rewritten in
    place, in the block the old one frees: a run stopped by a full disk is not left "running"."""
    from ..version import __version__

    if DECK_HASH not in details:
        earlier = read(folder) or {}
        details = {k: earlier[k] for k in (DECK_HASH, CHAINS) if earlier.get(k) is not None} | details
    writer = {"host": socket.gethostname(), "pid": os.getpid()} if state == RUNNING else {}
    data = {"package": PACKAGE, "version": __version__, "state": state, **writer, **details}
    text = json.dumps(data, indent=2) + "\n"
    try:
        files.atomic_write(folder / layout.MARKER, text)
    except files.DiskFull:  # no room for a second copy: the record in place (never through a link)
        try:
            fd = os.open(folder / layout.MARKER, os.O_WRONLY | os.O_TRUNC | os.O_NOFOLLOW)
        except OSError:
            raise files.DiskFull(folder / layout.MARKER) from None
        with os.fdopen(fd, "wb") as f:
            f.write(text.encode())


def writer_gone(data: dict | None) -> bool:
    """Whether the writer a "running" record names (`record`) is a process of this machine that
    no longer runs: then no runner of this package writes the folder (LAMMPS dies with it: the
    `lmp` runner's parent-death signal, `pylmp-lattice lmp`'s too). A writer of another machine,
    or a record without one, may still be writing: False."""
    if not data or data.get("state") != RUNNING or data.get("host") != socket.gethostname():
        return False
    pid = data.get("pid")
    if not isinstance(pid, int) or isinstance(pid, bool) or pid <= 0:
        return False
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except FileNotFoundError:
        return Path("/proc/self/stat").exists()  # no such process (on a system with /proc)
    except OSError:
        return False
    return stat.rsplit(")", 1)[-1].split()[0] in ("Z", "X")  # a zombie: killed, not yet reaped


def read(folder: Path) -> dict | None:
    """run.json, if the folder has one written by this package."""
    try:
        data = json.loads((folder / layout.MARKER).read_text())
    except (OSError, ValueError):
        return None
    return data if isinstance(data, dict) and data.get("package") == PACKAGE else None


def is_run(folder: Path) -> bool:
    """Whether the folder holds a run of this package (its cases, case.toml or a batch's
    replicas.toml, and run.json)."""
    return ((folder / layout.CASE).is_file() or (folder / layout.REPLICAS).is_file()) and read(folder) is not None


@contextmanager
def claimed(folder: Path):
    """Hold the folder's lock (run.lock): a writer from before it looks at the folder until it
    wrote it, a runner until its run is converted and summarised, a reader while it converts
    the dumps. Two cannot write one folder, and others leave its files alone meanwhile; in the
    thread that holds it (`file_lock`) it is simply held on. UsageError if another holds it."""
    files.refuse_link(folder / layout.LOCK)
    with contextlib.ExitStack() as stack:
        try:
            stack.enter_context(exclusive(folder / layout.LOCK, timeout=CLAIM_WAIT))
        except Held as err:
            raise _still_written(folder, "output") from err
        yield


def locked(folder: Path) -> bool:
    """Whether another runner or writer of this package (a process, or another thread) holds the folder's lock."""
    return is_held(folder / layout.LOCK)


def _still_written(folder: Path, field: str) -> UsageError:
    return UsageError(field, f"{folder} holds a run that is still being written; wait for it or stop it")


def log_text(folder: Path) -> str | None:
    """The folder's log.lammps as text, None without one."""
    try:
        return (folder / layout.LOG).read_text(errors="replace")
    except FileNotFoundError:
        return None


def status(folder: Path) -> str:
    """"running" while a runner of this package holds the folder's lock or a process writes its
    log, or without one its outputs (`being_written`); else how the run ended: "done", "contact", "failed" (the log has
    an ERROR line), "interrupted" (its log has no end and no process writes it: killed, Ctrl-C,
    a time limit), "unlogged" (outputs but no log, and no process writes them), or "written"
    for a deck never run. A lock this thread holds is no other runner's (`file_lock`)."""
    if locked(folder):
        return RUNNING
    data = read(folder) or {}
    state = data.get("state", WRITTEN)
    if state not in (WRITTEN, RUNNING):
        return DONE if state == OLD_DONE else state
    text = log_text(folder)
    if text is None:
        if state == RUNNING:
            return INTERRUPTED  # a runner that died before LAMMPS wrote
        if not any((folder / name).exists() for name in layout.OUTPUTS):
            return WRITTEN
        return RUNNING if being_written(folder) else UNLOGGED  # run by hand, its log elsewhere or none
    if log_state(text) is None:
        if being_written(folder, quiet=0.0 if writer_gone(data) else QUIET):  # its runner's end is known at once
            return RUNNING
        text = log_text(folder) or text  # it may have ended while we looked
    return log_state(text) or INTERRUPTED


def log_state(text: str) -> str | None:
    """How a log says its run ended: "contact", "failed" (an ERROR line) or "done"; None
    while it has not ended."""
    from ..formats.dump import error_line, find_contact, log_ended  # (not needed before a sweep's first task)

    error = error_line(text)
    if not log_ended(text) and error is None:
        return None
    return CONTACT if find_contact(text) else FAILED if error else DONE


@contextmanager
def hand_run(folder: Path):
    """`pylmp-lattice lmp -in in.lattice` in a run folder: the folder is claimed and recorded
    "running" by this process while LAMMPS (in this process) runs, and its end recorded from
    the log, or "interrupted" at the time LAMMPS's soft stop ended it (`Interrupted`), so that
    `status` knows at once that it ended, however it ended. A link at any run file's name is
    refused before LAMMPS starts, as the road's claim refuses it, and so is a folder another
    LAMMPS may still write (`refuse_unsettled`: LAMMPS would truncate its log and dumps)."""
    with claimed(folder):
        files.refuse_links(folder, layout.RUN_FILES)  # LAMMPS opens its files by name: never through a link
        refuse_unsettled(folder, "-in", "or remove its log and dumps yourself if no LAMMPS writes them")
        record(folder, RUNNING, runner=HAND_RUNNER)
        try:
            yield
        except Interrupted as err:  # LAMMPS's soft stop: its log ends as a finished run's does
            record(folder, INTERRUPTED, runner=HAND_RUNNER,
                   **({"time_ms": err.time_ms} if err.time_ms is not None else {}))
            raise
        except BaseException:
            record(folder, log_state(log_text(folder) or "") or INTERRUPTED, runner=HAND_RUNNER)
            raise
        record(folder, log_state(log_text(folder) or "") or INTERRUPTED, runner=HAND_RUNNER)


def being_written(folder: Path, quiet: float = QUIET) -> bool:
    """Whether a process may still write the run in `folder` (its log has not ended, or it has
    none): a process of this machine holds the log open for writing, or without a log one of
    the outputs there (`_writer_seen`), or the log or a dump changed in the last QUIET seconds
    (what /proc cannot see: a process of another user, LAMMPS on another machine writing a
    shared folder, a system without /proc)."""
    return _writer_seen(folder) or (quiet > 0 and _changed_within(folder, quiet))


def _writer_seen(folder: Path) -> bool:
    """Whether /proc shows a process of this machine holding the run's log open for writing (as
    `lsof` does: at once, where a file's age is not, LAMMPS flushing its log at each thermo row
    only); without a log, one of the outputs the folder holds (a LAMMPS run from another folder
    without -log logs there, but holds these dumps open). One look at /proc, none for a folder
    with neither (a file that does not exist has no writer)."""
    log = folder / layout.LOG
    paths = [log] if log.exists() else [folder / name for name in layout.OUTPUTS if (folder / name).exists()]
    return bool(paths) and bool(_open_for_writing(*paths))


def refuse_unsettled(folder: Path, field: str, remedy: str) -> str:
    """UsageError naming `field` while the run in `folder` may still be written, so that nothing
    replaces its files (`--overwrite`, a hand run): "running" (`status`), or "interrupted" or
    "unlogged" by inference and not yet `settled`, which says the file that changed last, its
    age and how long to wait, then `remedy` (the caller's other way out). Else its status."""
    state = status(folder)
    if state == RUNNING:
        raise _still_written(folder, field)
    newest = None if settled(folder, state) else _newest(folder)
    if newest is not None:  # (None: its files went meanwhile, nothing left to write over)
        name, age = newest
        raise UsageError(field, f"{folder} holds a run whose {name} changed {max(0, int(age))} s ago, with no writer "
                                f"seen; a LAMMPS this machine cannot see (another user's, or another machine's on a "
                                f"shared folder) may still write it until it stays unchanged for {SETTLED:.0f} s: "
                                f"wait {math.ceil(SETTLED - age)} s, {remedy}")
    return state


def settled(folder: Path, state: str | None = None) -> bool:
    """Whether the folder's files may be destroyed (its dumps converted, the folder overwritten):
    not while it is "running"; for a run "interrupted" by inference (a hand run's log without an
    end, no writer seen) or "unlogged", only once its log and dumps stayed unchanged for SETTLED seconds; a
    runner of this package records its own end, which stands. `state`: its `status`, if known
    (each look scans /proc)."""
    state = status(folder) if state is None else state
    if state == RUNNING:
        return False
    data = read(folder) or {}
    inferred = data.get("state", WRITTEN) in (WRITTEN, RUNNING) and not writer_gone(data)
    return not (state in (INTERRUPTED, UNLOGGED) and inferred and _changed_within(folder, SETTLED))


def quiet_wait(folder: Path) -> tuple[str, float, float] | None:
    """When a run is "running" by its files' ages alone (no runner of this package holds it, no
    process of this machine writes its log or, without one, its outputs: `_writer_seen`): the
    file that changed last, its age and the seconds until `being_written` stops counting it;
    None otherwise (no time can be said)."""
    if locked(folder) or _writer_seen(folder) or writer_gone(read(folder)):
        return None
    newest = _newest(folder)
    if newest is None or newest[1] >= QUIET:
        return None
    return (*newest, QUIET - newest[1])


def _newest(folder: Path) -> tuple[str, float] | None:
    """The log's or a dump's name that changed last, and its age in seconds; None without them."""
    ages = []
    for name in (layout.LOG, *layout.BINARY_GROUPS.values(), *layout.TEXT_GROUPS.values()):
        with suppress(FileNotFoundError):
            ages.append((time.time() - (folder / name).stat().st_mtime, name))
    return min(ages)[::-1] if ages else None


def _changed_within(folder: Path, seconds: float) -> bool:
    newest = _newest(folder)
    return newest is not None and newest[1] < seconds


def _open_for_writing(*paths: Path) -> bool | None:
    """Whether a process holds one of `paths` open for writing, by /proc (one look for all);
    None if /proc cannot tell."""
    try:
        real = {os.path.realpath(path) for path in paths}
        os.listdir("/proc/self/fd")
    except OSError:
        return None
    for fds in Path("/proc").glob("[0-9]*/fd"):
        try:
            names = os.listdir(fds)
        except OSError:  # a process that ended meanwhile, or another user's
            continue
        for name in names:
            with suppress(OSError):
                # the link's text, no stat: a file on a hung network mount must not block the look
                if os.readlink(fds / name) in real and _writes(fds.parent / "fdinfo" / name):
                    return True
    return False


def _writes(fdinfo: Path) -> bool:
    """Whether an open file (its /proc fdinfo) was opened for writing."""
    for line in fdinfo.read_text().splitlines():
        if line.startswith("flags:"):
            return bool(int(line.split()[1], 8) & (os.O_WRONLY | os.O_RDWR))
    return False
