"""A run folder's state: the package's record of it (run.json), the lock a writer or runner holds
while it writes the folder (run.lock, see `claimed`), and how the run stands, read from both and
from the log.

The format of two small files, as `bindump` is that of the binary dumps: the writer
(`run_folder.write`, `run_folder.execution`) and the reader (`run_folder.folder`) share it.
"""

from __future__ import annotations

import contextlib
import json
import os
import re
from contextlib import contextmanager
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


def record(folder: Path, state: str, **details) -> None:
    """Write run.json (atomically): the package, its version, the state and its details."""
    from .. import __version__

    data = {"package": PACKAGE, "version": __version__, "state": state, **details}
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


def status(folder: Path) -> str:
    """"running" while a runner of this package or, by its log, LAMMPS writes the folder; else
    how the run ended ("finished", "interrupted", "contact", "failed"), or "written" for a deck
    never run. A lock this thread holds is no other runner's (`file_lock`)."""
    if locked(folder):
        return RUNNING
    state = (read(folder) or {}).get("state", WRITTEN)
    if state not in (WRITTEN, RUNNING):
        return state
    text = log_text(folder)
    if text is None:
        return WRITTEN if state == WRITTEN else INTERRUPTED  # a runner that died before LAMMPS wrote
    if not log_ended(text):
        return RUNNING if state == WRITTEN else INTERRUPTED  # by hand: LAMMPS may still be writing
    return CONTACT if find_contact(text) else FAILED if re.search(r"^ERROR", text, re.MULTILINE) else FINISHED
