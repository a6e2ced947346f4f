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
import os
import re
import time
from contextlib import contextmanager, suppress
from pathlib import Path

from ..dump import find_contact, log_ended
from ..errors import ConfigError
from ..file_lock import Held, exclusive, is_held
from . import layout

PACKAGE = "pylmp_lattice"
# Seconds a writer waits for the folder's lock: a reader's look at it (`locked`) holds it for an
# instant; a writer or runner holds it for the whole run.
CLAIM_WAIT = 0.5
# How a run ended, as run.json records it; "written" until a runner of this package ran it.
WRITTEN, RUNNING, FINISHED, INTERRUPTED, CONTACT, FAILED = (
    "written", "running", "finished", "interrupted", "contact", "failed")
# run.json's hash of the deck as written (`deck_hash`): kept by every later record of the folder.
DECK_HASH = "deck_sha256"
# Seconds a hand-run log that has not ended must stay unchanged to count as no longer written,
# where the processes holding it cannot be seen (no readable /proc: not Linux); see `being_written`.
QUIET = 30.0


def deck_hash(text: str) -> str:
    """The hash run.json keeps of the deck (in.lattice) as written: a deck edited since differs."""
    return hashlib.sha256(text.encode()).hexdigest()


def record(folder: Path, state: str, **details) -> None:
    """Write run.json (atomically): the package, its version, the state and its details (the
    deck's hash of the earlier record is kept)."""
    from .. import __version__

    kept = {DECK_HASH: (read(folder) or {}).get(DECK_HASH)}
    data = {"package": PACKAGE, "version": __version__, "state": state,
            **{k: v for k, v in kept.items() if v is not None}, **details}
    tmp = folder / (layout.MARKER + ".tmp")
    tmp.write_text(json.dumps(data, indent=2) + "\n")
    os.replace(tmp, folder / layout.MARKER)


def read(folder: Path) -> dict | None:
    """run.json, if the folder has one written by this package."""
    try:
        data = json.loads((folder / layout.MARKER).read_text())
    except (OSError, ValueError):
        return None
    return data if isinstance(data, dict) and data.get("package") == PACKAGE else None


def is_run(folder: Path) -> bool:
    """Whether the folder holds a run of this package (case.toml and run.json)."""
    return (folder / layout.CASE).is_file() and read(folder) is not None


@contextmanager
def claimed(folder: Path):
    """Hold the folder's lock (run.lock): a writer from before it looks at the folder until it
    wrote it, a runner until its run is converted and summarised, a reader while it converts
    the dumps. Two cannot write one folder, and others leave its files alone meanwhile; in the
    thread that holds it (`file_lock`) it is simply held on. ConfigError if another holds it."""
    with contextlib.ExitStack() as stack:
        try:
            stack.enter_context(exclusive(folder / layout.LOCK, timeout=CLAIM_WAIT))
        except Held as err:
            raise ConfigError("output", f"{folder} holds a run that is still being written; wait for it or "
                                        "stop it") from err
        yield


def locked(folder: Path) -> bool:
    """Whether another runner or writer of this package (a process, or another thread) holds the folder's lock."""
    return is_held(folder / layout.LOCK)


def log_text(folder: Path) -> str | None:
    try:
        return (folder / layout.LOG).read_text(errors="replace")
    except FileNotFoundError:
        return None


def lammps_error(text: str) -> str | None:
    """The first ERROR line LAMMPS wrote into a log, if any."""
    m = re.search(r"^ERROR.*$", text, re.MULTILINE)
    return m.group().strip() if m else None


def status(folder: Path) -> str:
    """"running" while a runner of this package holds the folder's lock or a process writes its
    log (`being_written`); else how the run ended: "finished", "contact", "failed" (the log has
    an ERROR line), "interrupted" (its log has no end and no process writes it: killed, Ctrl-C,
    a time limit), or "written" for a deck never run. A lock this thread holds is no other
    runner's (`file_lock`)."""
    if locked(folder):
        return RUNNING
    state = (read(folder) or {}).get("state", WRITTEN)
    if state not in (WRITTEN, RUNNING):
        return state
    text = log_text(folder)
    if text is None:
        return WRITTEN if state == WRITTEN else INTERRUPTED  # a runner that died before LAMMPS wrote
    error = lammps_error(text)
    if not log_ended(text) and error is None:
        return RUNNING if being_written(folder / layout.LOG) else INTERRUPTED
    return CONTACT if find_contact(text) else FAILED if error else FINISHED


def being_written(path: Path) -> bool:
    """Whether a process may still write the file `path` (a log that has not ended).

    On Linux: whether a process of this machine holds it open for writing, by /proc/*/fd (as
    `lsof` does). That is exact at once, where the file's age is not: LAMMPS flushes its log at
    each thermo row only, minutes apart in a long run. What /proc cannot show counts as no
    writer: a process of another user, or LAMMPS on another machine writing a shared folder.
    Where /proc cannot be read (not Linux): whether the file changed in the last QUIET seconds."""
    writing = _open_for_writing(path)
    if writing is not None:
        return writing
    try:
        return time.time() - path.stat().st_mtime < QUIET
    except FileNotFoundError:
        return False


def _open_for_writing(path: Path) -> bool | None:
    """Whether a process holds `path` open for writing, by /proc; None if /proc cannot tell."""
    try:
        target = path.stat()
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
                st = os.stat(fds / name)  # the open file itself, wherever its path leads
                if (st.st_ino, st.st_dev) == (target.st_ino, target.st_dev) and _writes(fds.parent / "fdinfo" / name):
                    return True
    return False


def _writes(fdinfo: Path) -> bool:
    """Whether an open file (its /proc fdinfo) was opened for writing."""
    for line in fdinfo.read_text().splitlines():
        if line.startswith("flags:"):
            return bool(int(line.split()[1], 8) & (os.O_WRONLY | os.O_RDWR))
    return False
