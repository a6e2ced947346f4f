"""Locks named by a file (file_lock): one holder at a time, no file left behind, and a run
folder's lock held from the check of the folder to the end of the run."""

from __future__ import annotations

import threading
import time

import pytest

from pylmp_lattice.errors import ConfigError
from pylmp_lattice.file_lock import Held, exclusive, is_held
from pylmp_lattice.run_folder import layout, marker, write_folder

from conftest import make_case


def test_the_holder_removes_the_file_and_a_second_holder_is_refused_or_waits(tmp_path):
    path = tmp_path / "x.lock"
    with exclusive(path):
        assert path.exists() and is_held(path)
        with pytest.raises(Held):
            with exclusive(path, wait=False):
                pass
    assert not path.exists() and not is_held(path)


def test_a_waiter_whose_file_was_removed_locks_the_file_the_path_names_now(tmp_path):
    """The waiter opened the holder's file before the holder removed it: it must not hold a lock
    on a removed file (then a third process could lock a new file at the path beside it)."""
    path = tmp_path / "x.lock"
    seen = {}
    first = exclusive(path)
    first.__enter__()

    def wait():
        with exclusive(path):
            seen["exists"], seen["held"] = path.exists(), is_held(path)

    waiter = threading.Thread(target=wait)
    waiter.start()
    time.sleep(0.2)  # the waiter has opened the file and waits in flock
    first.__exit__(None, None, None)
    waiter.join(5)
    assert seen == {"exists": True, "held": True}
    assert not path.exists()


def test_a_folder_being_written_cannot_be_overwritten_meanwhile(tmp_path):
    """Another writer (or runner) holds the folder: an overwrite is refused before it removes
    anything; once it is let go, the overwrite goes ahead and leaves no lock file."""
    case = make_case(particles=10, duration=1.0)
    folder = write_folder(case, tmp_path / "run")
    deck = (folder / layout.DECK).read_text()
    with marker.claimed(folder):
        with pytest.raises(ConfigError, match="still being written"):
            write_folder(case, folder, overwrite=True)
        assert (folder / layout.DECK).read_text() == deck and marker.status(folder) == marker.RUNNING
    write_folder(case, folder, overwrite=True)
    assert not (folder / layout.LOCK).exists() and marker.status(folder) == marker.WRITTEN
