"""Studies: the paper's figures, each one module with `run(out, quick) -> StudyResult`.

`pylmp-lattice study NAME [-o DIR] [--quick]` runs a study and writes, through the one writer
`write_study`: DIR/NAME.json (its numbers, units in the keys, strict JSON), DIR/NAME_<table>.csv
for each table, DIR/NAME.png and DIR/NAME.pdf. A study's own run folders go under DIR/NAME/.
`--quick` runs a small version (fewer or shorter runs) for tests and a first look.

To add a study: write `studies/<name>.py` with `run(out: Path, quick: bool) -> StudyResult`
and add its name and one-line title to STUDIES.
"""

from __future__ import annotations

import importlib
import logging
from pathlib import Path

from .output import StudyResult, write_study

__all__ = ["STUDIES", "StudyResult", "run_study", "write_study"]

log = logging.getLogger(__name__)

# name -> title; the module pylmp_lattice.studies.<name> runs it.
STUDIES: dict[str, str] = {
    "s4": "Fig. S4: the friction calibration rig (one magnet between two fixed magnets)",
}


def run_study(name: str, out: str | Path = Path("runs/studies"), quick: bool = False) -> StudyResult:
    """Run study `name`, write its files into `out`, and return its results."""
    if name not in STUDIES:
        raise ValueError(f"study: got {name!r}; choose one of {', '.join(STUDIES)}")
    out = Path(out)
    log.info("study %s: %s -> %s", name, STUDIES[name], out)
    result = importlib.import_module(f"{__name__}.{name}").run(out, quick)
    write_study(result, out)
    return result
