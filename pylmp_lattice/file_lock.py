"""Exclusive locks named by a file (flock), which the holder removes before it lets go.

One rule for every lock of the package (a run folder's run.lock, a sweep task's lock): a holder
that lets go removes the file, and never do two processes hold one at once. A holder that is
killed leaves its file behind, but the kernel drops its lock: the file blocks nothing, and the
next `exclusive` on it takes it and removes it (`sweep.store.remove_stale_locks` does so for
tasks). A process that opened the file and waits may get the lock on a file its holder has just
removed; it then checks that the path still names the file it holds (the inode) and, if not,
starts again on whatever the path names now.

A lock is its holder thread's: taken again by that thread (a runner that converts its own
dumps), it is simply held on; `is_held` speaks of other holders, threads or processes.
"""

from __future__ import annotations

import fcntl
import os
import threading
import time
from contextlib import contextmanager
from pathlib import Path


# Seconds between tries while a lock is held (`exclusive` with a timeout).
POLL = 0.01
# The locks each thread holds (real paths).
_HERE = threading.local()


class Held(Exception):
    """Another process or thread holds the lock (raised by `exclusive` with a timeout)."""


@contextmanager
def exclusive(path: str | Path, timeout: float | None = None):
    """Hold the lock of `path` (created if missing) while the block runs; the file is removed at
    the end. timeout: seconds to wait for another holder (None: as long as it takes); then
    `Held` is raised (0: at once)."""
    path = Path(path)
    key, mine = os.path.realpath(path), _mine()
    if key in mine:  # this thread holds it already
        yield
        return
    deadline = None if timeout is None else time.monotonic() + timeout
    while True:
        fd = os.open(path, os.O_RDWR | os.O_CREAT | os.O_NOFOLLOW, 0o644)  # a link there: ELOOP, never followed
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | (0 if deadline is None else fcntl.LOCK_NB))
        except BlockingIOError:
            os.close(fd)
            if time.monotonic() >= deadline:
                raise Held(str(path)) from None
            time.sleep(POLL)
            continue
        if _names(path, fd):
            break
        os.close(fd)
    mine.add(key)
    try:
        yield
    finally:
        mine.discard(key)
        if _names(path, fd):
            path.unlink()
        os.close(fd)


def is_held(path: str | Path) -> bool:
    """Whether another thread or process holds the lock of `path` (False if there is no such
    file). The look takes a shared lock for an instant: it never makes another look, or a
    holder's `exclusive` with a timeout, fail."""
    if os.path.realpath(path) in _mine():
        return False
    try:
        fd = os.open(path, os.O_RDONLY | os.O_NOFOLLOW)
    except (FileNotFoundError, OSError):  # none, or a link: no lock of ours
        return False
    try:
        fcntl.flock(fd, fcntl.LOCK_SH | fcntl.LOCK_NB)
    except BlockingIOError:
        return True
    finally:
        os.close(fd)  # closing it lets go of a lock taken here
    return False


def _mine() -> set[str]:
    if not hasattr(_HERE, "locks"):
        _HERE.locks = set()
    return _HERE.locks


def _names(path: Path, fd: int) -> bool:
    """Whether `path` still names the open file `fd` (it was not removed or replaced)."""
    try:
        return os.lstat(path).st_ino == os.fstat(fd).st_ino
    except FileNotFoundError:
        return False
