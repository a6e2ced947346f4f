"""Writing a run folder: the deck, its input files, the cases and run.json, into a claimed folder.

`write` is the only writer of a run's inputs, of one case (`deck.render`, case.toml) or of a
batch of chains (`deck.render_replicas`, replicas.toml), in a claimed folder (`claim`);
`write_folder` claims one and writes it. LAMMPS then runs the folder
(`run_folder.execution`, or `lmp -in in.lattice` by hand).
"""

from __future__ import annotations

from collections.abc import Sequence
from contextlib import ExitStack
from pathlib import Path

from .. import deck
from ..case import Case
from ..errors import require_bool
from ..formats import layout
from ..formats.files import atomic_write
from . import marker
from .cases import case_text, replicas_text
from .claim import Claimed, claim


def write_folder(case: Case | Sequence[Case], path: str | Path, overwrite: bool = False) -> Path:
    """Write a run folder (see `write`) for `case`, or for a batch of equal-length chains (a
    list of cases, see `deck.render_replicas`), into `path`; return it.

    A folder holding a run of this package is refused unless `overwrite`; then the earlier
    run's files (layout.RUN_FILES) are removed first, so none of them stays beside the new
    run, and only those: the user's own files and folders beside them, and the folder itself,
    always stay. Refused: the working directory, a parent of it, runs/ itself, a folder
    holding files a run would write but no run, and one still being written (see `claim`).
    """
    require_bool(overwrite=overwrite)
    cases = [case] if isinstance(case, Case) else list(case)
    files = deck.render_folder(cases)  # first: a case the deck refuses (see Case._extremes) leaves the folder as it was
    with ExitStack() as held:
        claimed = claim(path, overwrite, held)
        write(claimed, cases, files)
    return claimed.path


def write(claimed: Claimed, cases: Sequence[Case], files: dict[str, str], state: str = marker.WRITTEN) -> None:
    """Write the deck files of `cases` (`deck.render_folder`), the cases (case.toml, or
    replicas.toml for a batch) and run.json (`state`: "written", or "running" for a runner
    that starts it at once; with the deck's hash, so that a deck edited by hand is told apart)
    into the claimed folder, replacing the run it held (`Claimed.replaces`)."""
    path = claimed.path
    if claimed.replaces:
        for name in layout.RUN_FILES:
            if name != layout.LOCK:  # ours, held
                (path / name).unlink(missing_ok=True)
    names = [*files, layout.REPLICAS if len(cases) > 1 else layout.CASE, layout.MARKER]
    try:
        for name, text in files.items():
            atomic_write(path / name, text)
        if len(cases) > 1:
            atomic_write(path / layout.REPLICAS, replicas_text(cases))
        else:
            atomic_write(path / layout.CASE, case_text(cases[0]))
        claimed.cases = tuple(cases)
        claimed.record = {marker.DECK_HASH: marker.deck_hash(files[layout.DECK]),
                          **({marker.CHAINS: len(cases)} if len(cases) > 1 else {})}
        marker.record(path, state, **claimed.record)
    except BaseException:  # a write stopped half-way (a signal, a full disk) is no run: its files go,
        for name in names:  # else no command could replace them
            (path / name).unlink(missing_ok=True)
        raise
