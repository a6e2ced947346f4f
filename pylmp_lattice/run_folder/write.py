"""Writing a case into a run folder: the deck, its input files, case.toml and run.json.

`write_folder` is the only writer of a run's inputs; LAMMPS then runs the folder
(`run_folder.execution`, or `lmp -in in.lattice` by hand).
"""

from __future__ import annotations

import os
from pathlib import Path

import tomli_w

from ..case import Case, case_to_dict
from ..deck import render
from ..errors import ConfigError
from ..formats import layout
from ..formats.files import atomic_write, refuse_links
from . import marker


def write_folder(case: Case, path: str | Path, overwrite: bool = False) -> Path:
    """Write the deck, its input files, case.toml and run.json (with the deck's hash, so that a
    deck edited by hand is told apart) into `path`; return it.

    A folder holding a run of this package (case.toml and run.json) is refused unless
    `overwrite`; then the earlier run's files (layout.RUN_FILES) are removed first, so none of
    them stays beside the new run, and only those: the user's own files and folders beside
    them, and the folder itself, always stay. Refused: the working directory, a parent of it,
    runs/ itself, a folder holding files a run would write but no run, and one still being
    written: another writer or runner of this package holds it (its lock, `marker.claimed`, is
    held meanwhile) or a process writes its log (`marker.status`; a run that failed or was
    interrupted may be replaced).
    """
    path = Path(path)
    files = render(case)  # first: a case the deck refuses (see Case._extremes) leaves the folder as it was
    with marker.claimed(layout.make_place(path)):
        write_claimed(case, path, overwrite, files)
    return path


def write_claimed(case: Case, path: Path, overwrite: bool, files: dict[str, str]) -> None:
    """`write_folder` in a folder whose lock this thread holds (`marker.claimed`; a runner holds
    it until its run is converted and summarised), so that the check and the removal of an
    earlier run cannot race another writer. files: the case's deck (`deck.render`)."""
    if check_target(path, overwrite):
        for name in layout.RUN_FILES:
            if name != layout.LOCK:  # ours, held
                (path / name).unlink(missing_ok=True)
    try:
        for name, text in files.items():
            atomic_write(path / name, text)
        atomic_write(path / layout.CASE, tomli_w.dumps(case_to_dict(case)))
        marker.record(path, marker.WRITTEN, **{marker.DECK_HASH: marker.deck_hash(files[layout.DECK])})
    except BaseException:  # a write stopped half-way (a signal, a full disk) is no run: its files go,
        for name in [*files, layout.CASE, layout.MARKER]:  # else no command could replace them
            (path / name).unlink(missing_ok=True)
        raise


def check_target(path: Path, overwrite: bool) -> bool:
    """Whether `path` holds a run to replace; ConfigError if it may not be written (see
    `write_folder`). Under this thread's own claim of the folder, its lock is no other runner's."""
    path = Path(path)
    layout.check_place(path, "run")
    run = marker.is_run(path)
    if not (run and overwrite):  # a link where LAMMPS or the package writes a file: refused (--overwrite removes it)
        refuse_links(path, layout.RUN_FILES)
    if run:
        if not overwrite:
            raise ConfigError("output", f"{path} already holds a run; pass --overwrite (overwrite=True) to "
                                        "replace it, or choose another --name or -o")
        state = marker.status(path)
        if state == marker.RUNNING:
            raise ConfigError("output", f"{path} holds a run that is still being written; wait for it or stop it")
        if not marker.settled(path, state):
            raise ConfigError("output", f"{path} holds a run that stopped less than {marker.SETTLED:.0f} s ago, which a "
                                        "LAMMPS this machine cannot see may still write; wait, or remove the folder "
                                        "yourself")
        odd = [name for name in layout.RUN_FILES if (path / name).exists() and not (path / name).is_symlink()
               and not (path / name).is_file()]
        if odd:  # checked before anything is removed: an overwrite never stops half-way
            raise ConfigError("output", f"{path / odd[0]} is not a file; a run writes a file there")
        return True
    # a lock file alone is no run's (a writer's, this thread's own, or left by a killed one)
    clash = sorted(name for name in layout.RUN_FILES if os.path.lexists(path / name) and name != layout.LOCK)
    if clash:
        raise ConfigError("output", f"{path} holds {', '.join(clash)} but no run of this package; "
                                    "choose an empty or new folder")
    return False
