"""Exclusive locks named by a file (flock), which the holder removes before it lets go.

One rule for every lock of the package (a run folder's run.lock, a sweep task's lock): no lock
file is left behind, and never do two processes hold one at once. A process that opened the
file and waits may get the lock on a file its holder has just removed; it then checks that the
path still names the file it holds (the inode) and, if not, starts again on whatever the path
names now. The kernel drops a lock when its holder dies.
"""

from __future__ import annotations

import fcntl
import os
from contextlib import contextmanager
from pathlib import Path


class Held(Exception):
    """Another process holds the lock (raised by `exclusive(..., wait=False)`)."""


@contextmanager
def exclusive(path: str | Path, wait: bool = True):
    """Hold the lock of `path` (created if missing) while the block runs; the file is removed at
    the end. wait=False: raise `Held` at once if another process holds it."""
    path = Path(path)
    while True:
        fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o644)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | (0 if wait else fcntl.LOCK_NB))
        except BlockingIOError:
            os.close(fd)
            raise Held(str(path)) from None
        if _names(path, fd):
            break
        os.close(fd)
    try:
        yield
    finally:
        if _names(path, fd):
            path.unlink()
        os.close(fd)


def is_held(path: str | Path) -> bool:
    """Whether a process holds the lock of `path` (False if there is no such file)."""
    try:
        fd = os.open(path, os.O_RDONLY)
    except FileNotFoundError:
        return False
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        return True
    finally:
        os.close(fd)  # closing it lets go of a lock taken here
    return False


def _names(path: Path, fd: int) -> bool:
    """Whether `path` still names the open file `fd` (it was not removed or replaced)."""
    try:
        return os.stat(path).st_ino == os.fstat(fd).st_ino
    except FileNotFoundError:
        return False
