"""A sweep's folder: where one may go (`check_folder`), one coordinator at a time (`lock`), and
the sweep it holds (`claim`, DIR/sweep.json)."""

from __future__ import annotations

import contextlib
import fcntl
import os
from pathlib import Path

from ..errors import UsageError
from .spec import Sweep
from .store import BATCHES, MEMBERS, SWEEP_FILE, Outcomes, atomic_write, read_json

@contextlib.contextmanager
def lock(root: Path):
    """One coordinator per sweep folder: a lock on the folder itself (no lock file to leave
    behind; the kernel drops it when the coordinator dies)."""
    fd = os.open(root, os.O_RDONLY)
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError as err:
            raise UsageError("-o", _RUNNING.format(root=root)) from err
        yield
    finally:
        os.close(fd)


_RUNNING = "another sweep is running in {root}; wait for it or choose another folder"


def refuse_running(root: Path) -> None:
    """`lock`'s refusal, without taking the lock: a look that never makes a coordinator's own
    `lock` fail (`file_lock.is_held`)."""
    from ..file_lock import is_held

    if is_held(root):
        raise UsageError("-o", _RUNNING.format(root=root))


def check_folder(root: str | Path) -> None:
    """UsageError unless `root` may be a sweep's folder: where a run may go (`check_place`), not
    a run's folder, and not inside another sweep's members/ or batches/ (a study's sweeps may
    sit side by side in one sweep's folder)."""
    from ..formats import layout
    from ..formats.files import refuse_links
    from ..run_folder import marker
    from .table import FILES as TABLE_FILES

    root = layout.as_path(root, "root", "the sweep's folder")
    layout.check_place(root, "sweep")
    refuse_links(root, (SWEEP_FILE, MEMBERS, BATCHES, *TABLE_FILES))  # written in DIR: never through a link
    if marker.is_run(Path(root)):
        raise UsageError("output", f"{root} holds a run of this package; choose a new folder for the sweep (-o)")
    outer = layout.inside_sweep(root)
    if outer is not None:
        raise UsageError("output", f"{root} is {outer} or inside it, which holds a sweep's members; choose another "
                          "folder (-o)")


def refuse_other(root: Path, sweep: Sweep, overwrite: bool) -> dict | None:
    """UsageError if DIR holds a different sweep (DIR/sweep.json) and not `overwrite`; else what
    DIR/sweep.json holds (None: nothing)."""
    held = read_json(root / SWEEP_FILE)
    if held is not None and held.get("identity") != sweep.identity() and not overwrite:
        raise UsageError("-o", f"{root} holds a different sweep ({SWEEP_FILE}); choose another folder, "
                          "or pass --overwrite (overwrite=True) to replace it")
    return held


def claim(root: Path, sweep: Sweep, overwrite: bool) -> None:
    """DIR/sweep.json names the sweep in DIR: another sweep is refused unless `overwrite`, which
    makes DIR this sweep's (its table is replaced; member folders are named by their case, so
    those of identical cases are reused and the others stay on disk, out of the table: sweep.json
    then says `"others": true`, and what is kept is counted among this sweep's members only)."""
    import json

    identity = sweep.identity()
    held = refuse_other(root, sweep, overwrite)
    if held is None or held.get("identity") != identity:
        record = {"identity": identity, "sweep": sweep.describe()}
        if held is not None or Outcomes(root).at_most():
            record["others"] = True
        atomic_write(root / SWEEP_FILE, json.dumps(record, indent=2) + "\n", sync=True)
