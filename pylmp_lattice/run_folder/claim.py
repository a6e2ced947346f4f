"""Claiming a run folder: every check of the folder, once, before anything is written in it.

`claim(path, overwrite, held)` checks where the folder is (never the working directory, a parent of
it or runs/, nor a file: `layout.check_place`), makes it, takes its lock (`marker.claimed`),
and then looks at what it holds: nothing of a run, a run to replace (with `overwrite`, once
LAMMPS no longer writes it), or files of no run of this package (refused). It hands on a
`Claimed` folder: the later steps of a run (write, run, record, convert, summarize) take that
object and never look at the folder's state again; the lock is held until the caller's
`held` (an ExitStack) closes, after the run is converted and summarized.
"""

from __future__ import annotations

import os
from contextlib import ExitStack
from dataclasses import dataclass, field
from pathlib import Path

from ..errors import UsageError
from ..formats import layout
from ..formats.files import refuse_links
from . import marker


@dataclass
class Claimed:
    """A run folder this thread holds: `path`; `replaces`: it holds an earlier run, whose files
    the writer removes (those alone) before it writes; `cases`: what the writer wrote there
    (one case, or the chains of a batch), and `record`: what each record of run.json keeps
    (the deck's hash, a batch's chains)."""

    path: Path
    replaces: bool
    cases: tuple = ()
    record: dict = field(default_factory=dict)


def claim(path: str | Path, overwrite: bool, held: ExitStack) -> Claimed:
    """Claim `path` for a run (see the module's docstring): the `Claimed` folder, whose lock is
    held until `held` closes. UsageError if it may not be written: its place, a folder another
    writer holds or LAMMPS still writes, a run without `overwrite`, files of no run. The
    caller's `preflight.check` found the place writable."""
    path = layout.as_path(path)
    layout.check_place(path, "run")
    path.mkdir(parents=True, exist_ok=True)
    with ExitStack() as lock:
        lock.enter_context(marker.claimed(path))
        claimed = Claimed(path, _holds_run(path, overwrite))
        held.push(lock.pop_all())  # the lock stays with the caller
    return claimed


def look(path: Path, overwrite: bool) -> bool:
    """`claim`'s checks without the claim (`run --dry-run`): whether `path` holds a run to
    replace; UsageError if it may not be written."""
    layout.check_place(path, "run")
    return _holds_run(path, overwrite)


def _holds_run(path: Path, overwrite: bool) -> bool:
    """Whether `path` holds a run to replace; UsageError if it may not be written (see `claim`,
    whose lock makes this look final). Under this thread's own claim, the lock is no other
    runner's."""
    run = marker.is_run(path)
    if not (run and overwrite):  # a link where LAMMPS or the package writes a file: refused (--overwrite removes it)
        refuse_links(path, layout.RUN_FILES)
    if run:
        if not overwrite:
            raise UsageError("output", f"{path} already holds a run; pass --overwrite (overwrite=True) to "
                                        "replace it, or choose another --name or -o")
        marker.refuse_unsettled(path, "output", "or remove the folder yourself")
        odd = [name for name in layout.RUN_FILES if (path / name).exists() and not (path / name).is_symlink()
               and not (path / name).is_file()]
        if odd:  # checked before anything is removed: an overwrite never stops half-way
            raise UsageError("output", f"{path / odd[0]} is not a file; a run writes a file there")
        return True
    # a lock file alone is no run's (a writer's, this thread's own, or left by a killed one)
    clash = sorted(name for name in layout.RUN_FILES if os.path.lexists(path / name) and name != layout.LOCK)
    if clash:
        raise UsageError("output", f"{path} holds {', '.join(clash)} but no run of this package; "
                                    "choose an empty or new folder")
    return False
