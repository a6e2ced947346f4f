"""Locks named by a file (file_lock): one holder at a time, no file left behind, and a run
folder's lock held from the check of the folder to the end of the run."""

from __future__ import annotations

import fcntl
import os
import threading
import time
from pathlib import Path

import pytest

from pylmp_lattice.errors import ConfigError
from pylmp_lattice.file_lock import Held, exclusive, is_held
from pylmp_lattice.formats import layout
from pylmp_lattice.run_folder import marker, write_folder

from conftest import held_elsewhere, make_case


def test_the_holder_removes_the_file_and_a_second_holder_is_refused_or_waits(tmp_path):
    path = tmp_path / "x.lock"
    with held_elsewhere(path):
        assert path.exists() and is_held(path)
        with pytest.raises(Held):
            with exclusive(path, timeout=0):
                pass
    assert not path.exists() and not is_held(path)
    with exclusive(path):  # inside its holder, a lock is held on, and is no other process's
        assert path.exists() and not is_held(path)
        with exclusive(path, timeout=0):
            assert path.exists()
        assert path.exists()
    assert not path.exists()


def test_a_waiter_whose_file_was_removed_locks_the_file_the_path_names_now(tmp_path):
    """The waiter opened the holder's file before the holder removed it: it must not hold a lock
    on a removed file (then a third process could lock a new file at the path beside it)."""
    path = tmp_path / "x.lock"
    seen = {}

    def wait():
        with exclusive(path):
            seen["exists"] = path.exists()

    with held_elsewhere(path):
        waiter = threading.Thread(target=wait)
        waiter.start()
        _until_waiting(path)  # the waiter has opened the file and waits in flock
    waiter.join(5)
    assert seen == {"exists": True}
    assert not path.exists()


def _until_waiting(path, seconds: float = 5.0) -> None:
    """Until a process waits for the lock of `path` (a blocked entry, "->", in /proc/locks)."""
    inode = f":{path.stat().st_ino} "
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        if any("->" in line and inode in line for line in Path("/proc/locks").read_text().splitlines()):
            return
        time.sleep(0.005)
    raise AssertionError(f"nobody waits for {path}")


def test_looking_at_a_folder_s_lock_never_makes_its_writer_fail(tmp_path):
    """A reader's look at the lock (`marker.locked`, e.g. for a status) holds it for an instant;
    a writer that claims the folder meanwhile waits for the look instead of failing ('still being
    written': 1 % of overwrites did beside a reader in a loop), and two looks at once do not
    take each other for a writer. Here a look is held open for 0.1 s."""
    case = make_case(particles=10, duration=1.0)
    folder = write_folder(case, tmp_path / "run")
    lock = folder / layout.LOCK
    fd = os.open(lock, os.O_RDWR | os.O_CREAT, 0o644)
    fcntl.flock(fd, fcntl.LOCK_SH)  # a look in progress
    assert not marker.locked(folder)  # another look sees no writer
    threading.Timer(0.1, os.close, (fd,)).start()  # the look ends
    write_folder(case, folder, overwrite=True)
    assert not lock.exists() and marker.status(folder) == marker.WRITTEN


def test_a_folder_being_written_cannot_be_overwritten_meanwhile(tmp_path):
    """Another writer (or runner) holds the folder: an overwrite is refused before it removes
    anything; once it is let go, the overwrite goes ahead and leaves no lock file."""
    case = make_case(particles=10, duration=1.0)
    folder = write_folder(case, tmp_path / "run")
    deck = (folder / layout.DECK).read_text()
    with held_elsewhere(folder / layout.LOCK):
        with pytest.raises(ConfigError, match="still being written"):
            write_folder(case, folder, overwrite=True)
        assert (folder / layout.DECK).read_text() == deck and marker.status(folder) == marker.RUNNING
    write_folder(case, folder, overwrite=True)
    assert not (folder / layout.LOCK).exists() and marker.status(folder) == marker.WRITTEN
