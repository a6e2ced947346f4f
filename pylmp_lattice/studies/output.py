"""The one writer of study outputs: NAME.json, NAME_<table>.csv, NAME.png and NAME.pdf."""

from __future__ import annotations

import csv
import glob
import logging
import math
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..formats.files import replacing
from ..serialize import dumps, short_float, jsonable

log = logging.getLogger(__name__)


@dataclass
class StudyResult:
    """What a study found.

    name     the study's name (the files' stem)
    numbers  its numbers as a JSON-able dict, units in the keys (`vp_m_per_s`, `t_ms`);
             NaN is written as null
    tables   table name -> columns (column name with unit -> 1D sequence, all the same length)
    figure   a matplotlib Figure, written as PNG and PDF (None: no figure)
    quick    whether this was the small version
    """

    name: str
    numbers: dict[str, Any]
    tables: dict[str, dict[str, Any]] = field(default_factory=dict)
    figure: Any = None
    quick: bool = False

    def to_dict(self) -> dict:
        """The results as a dict of plain values (JSON), units in the keys."""
        return jsonable({"study": self.name, "quick": self.quick, **self.numbers})


FIGURES = ("png", "pdf")  # the formats a study's figure is written in


def study_file(out: Path, name: str, kind: str) -> Path:
    """Where study `name`'s file of `kind` goes in `out`: "json" or a figure's format (NAME.KIND),
    or "table KEY" (NAME_KEY.csv)."""
    return out / (f"{name}_{kind[len('table '):]}.csv" if kind.startswith("table ") else f"{name}.{kind}")


def study_files(out: Path, name: str) -> list[Path]:
    """The files `write_study` writes for study `name` in `out`: NAME.json, its figure's, and
    the tables (NAME_<table>.csv) there now."""
    tables = sorted(out.glob(f"{glob.escape(name)}_*.csv"))  # study_file's NAME_KEY.csv, any KEY
    return [study_file(out, name, kind) for kind in ("json", *FIGURES)] + tables


def write_study(result: StudyResult, out: str | Path) -> dict[str, Path]:
    """Write a study's files into `out`; returns {kind: path}.

    Each file is written beside its final name and then renamed over it, so an interrupted
    write never leaves half a file, and a replaced file is reported in the log."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    files, replaced = {}, []
    for key, columns in result.tables.items():
        kind = f"table {key}"
        files[kind] = _replace(study_file(out, result.name, kind), lambda p, c=columns: _write_csv(p, c), replaced)
    if result.figure is not None:
        from ..plots import pyplot

        for ext in FIGURES:
            save = lambda p, e=ext: result.figure.savefig(p, dpi=120, format=e)  # noqa: E731
            files[ext] = _replace(study_file(out, result.name, ext), save, replaced)
        pyplot().close(result.figure)  # saved: pyplot need not keep it (`study all` draws dozens)
    data = result.to_dict() | {"files": {k: p.name for k, p in files.items()}}
    files["json"] = _replace(study_file(out, result.name, "json"), lambda p: p.write_text(dumps(data) + "\n"), replaced)
    if replaced:
        log.info("study %s: replaced %s in %s", result.name, ", ".join(replaced), out)
    return files


def _replace(path: Path, write, replaced: list) -> Path:
    """Write `path` through a partial file renamed over it; a replaced file's name joins `replaced`."""
    with replacing(path) as tmp:
        write(tmp)
        if os.path.lexists(path):
            replaced.append(path.name)
    return path


def _write_csv(path: Path, columns: dict[str, Any]) -> None:
    """Columns as CSV; non-finite numbers as empty cells (what pandas reads as NaN)."""
    names = list(columns)
    values = [np.asarray(columns[n]).ravel() for n in names]
    lengths = {len(v) for v in values}
    if len(lengths) > 1:
        raise ValueError(f"table {path.name}: columns of different lengths {sorted(lengths)}")
    with open(path, "w", newline="") as fh:
        writer = csv.writer(fh)
        writer.writerow(names)
        for row in zip(*values):
            writer.writerow([_cell(x) for x in row])


def _cell(x):
    if isinstance(x, (float, np.floating)):
        return short_float(float(x)) if math.isfinite(x) else ""
    return x.item() if isinstance(x, np.generic) else x
