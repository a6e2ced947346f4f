"""Writing a case into a run folder: the deck, its input files, case.toml and run.json.

`write_folder` is the only writer of a run's inputs; LAMMPS then runs the folder
(`run_folder.execution`, or `lmp -in in.lattice` by hand).
"""

from __future__ import annotations

from pathlib import Path

import tomli_w

from ..case import Case, case_to_dict
from ..deck import render
from ..errors import ConfigError
from . import layout, marker


def write_folder(case: Case, path: str | Path, overwrite: bool = False) -> Path:
    """Write the deck, its input files, case.toml and run.json into `path`; return it.

    A folder holding a run of this package (case.toml and run.json) is refused unless
    `overwrite`; then the earlier run's files (layout.RUN_FILES) are removed first, so none of
    them stays beside the new run, and only those: the user's own files and folders beside
    them, and the folder itself, always stay. Refused: the working directory, a parent of it,
    runs/ itself, and a folder holding files a run would write but no run.
    """
    path = Path(path)
    files = render(case)  # first: a case the deck refuses (see Case._extremes) leaves the folder as it was
    if check_target(path, overwrite):
        for name in layout.RUN_FILES:
            (path / name).unlink(missing_ok=True)
    path.mkdir(parents=True, exist_ok=True)
    for name, text in files.items():
        (path / name).write_text(text)
    (path / layout.CASE).write_bytes(tomli_w.dumps(case_to_dict(case)).encode())
    marker.record(path, marker.WRITTEN)
    return path


def check_target(path: Path, overwrite: bool) -> bool:
    """Whether `path` holds a run to replace; ConfigError if it may not be written (see `write_folder`)."""
    path = Path(path)
    check_place(path, "run")
    if marker.is_run(path):
        if not overwrite:
            raise ConfigError("output", f"{path} already holds a run; pass --overwrite (overwrite=True) to "
                                        "replace it, or choose another --name or -o")
        if marker.status(path) == marker.RUNNING:
            raise ConfigError("output", f"{path} holds a run that is still being written; wait for it or stop it")
        odd = [name for name in layout.RUN_FILES if (path / name).exists() and not (path / name).is_file()]
        if odd:  # checked before anything is removed: an overwrite never stops half-way
            raise ConfigError("output", f"{path / odd[0]} is not a file; a run writes a file there")
        return True
    clash = sorted(name for name in layout.RUN_FILES if (path / name).exists())
    if clash:
        raise ConfigError("output", f"{path} holds {', '.join(clash)} but no run of this package; "
                                    "choose an empty or new folder")
    return False


def check_place(path: Path, what: str) -> None:
    """ConfigError unless `path` may be the output folder of a `what` ("run", "sweep"): never the
    working directory, a parent of it or runs/ itself (they hold the user's files), nor a file."""
    path = Path(path)
    resolved, here = path.resolve(), Path.cwd().resolve()
    if resolved == here or resolved in here.parents or resolved == here / "runs":
        raise ConfigError("output", f"got {str(path)!r}: the working directory, a parent of it or runs/; "
                                    f"choose a new folder for the {what} (-o)")
    if path.exists() and not path.is_dir():
        raise ConfigError("output", f"got {str(path)!r}: a file, not a folder")
