"""The sweep's table: one row per member, DIR/results.csv and DIR/results.parquet.

Columns: `id`; the swept fields by dotted key (a section swept as a whole gives one column per
field, "force.law", "force.q", ...; "replica" and "chain.seed" where the sweep sets them);
`status` ("done", "failed" or "interrupted"); `error` (one line, paths relative to DIR);
`folder` (relative to DIR; empty for an interrupted member that has none); `wall_time_s`; then the member's scalar measures from its
summary.json, nested keys joined by "." (e.g. "shock_velocity_plateau_m_per_s.mean"). Both
files are replaced atomically. Members that never started have no row.
"""

from __future__ import annotations

import io
import json
import time
from pathlib import Path

from ..serialize import short_float
from .store import atomic_write

CSV = "results.csv"
PARQUET = "results.parquet"
STATS_CSV, STATS_PNG = "replica_stats.csv", "replica_stats.png"  # with replicas: their statistics (`stats`)
FILES = (CSV, PARQUET, STATS_CSV, STATS_PNG)
FIXED = ("id", "status", "error", "folder", "wall_time_s")
# Not measures: labels, file paths, and the run's own timing (the member's is wall_time_s).
NOT_MEASURES = ("case", "files", "wall_time_s")


def member_row(member_id: str, params: dict, folder: str, record: dict, summary: dict | None) -> dict:
    """A member's row: id, swept fields, status, error, folder, wall time, scalar measures."""
    row = {"id": member_id} | flat_params(params)
    row |= {"status": record["status"], "error": record.get("error"), "folder": folder,
            "wall_time_s": record.get("wall_time_s")}
    if summary:
        _scalars(summary, "", row, NOT_MEASURES)
    return row


def flat_params(params: dict) -> dict:
    """Swept values as table cells: a section's table is split by field, a list is JSON text."""
    out = {}
    for key, value in params.items():
        if isinstance(value, dict):
            out |= flat_params({f"{key}.{k}": v for k, v in value.items()})
        else:
            out[key] = json.dumps(value) if isinstance(value, list) else value
    return out


def _scalars(table: dict, prefix: str, out: dict, skip: tuple = ()) -> None:
    """`table`'s numbers and flags into `out`, but the keys in `skip` (a row is made for every
    member in the coordinator: no dict is built per nested table, common types come first)."""
    for key, value in table.items():
        if key in skip:
            continue
        kind = type(value)
        if kind is float or kind is int or kind is bool or value is None:
            out[prefix + key] = value
        elif isinstance(value, dict):
            _scalars(value, f"{prefix}{key}.", out)
        elif isinstance(value, (bool, int, float)):
            out[prefix + key] = value


def frame(rows: list[dict]):
    """Rows (in member order) as a DataFrame: id, swept fields, status .. wall_time_s, measures."""
    import pandas as pd

    params, measures = {}, {}
    for row in rows:
        keys = list(row)
        params |= dict.fromkeys(keys[1:keys.index("status")])
        measures |= dict.fromkeys(keys[keys.index("wall_time_s") + 1:])
    df = pd.DataFrame(rows, columns=["id", *params, *FIXED[1:], *measures])
    for col in df.columns:  # parquet needs one type per column
        if df[col].dtype == object and len({type(v) for v in df[col].dropna()}) > 1:
            df[col] = df[col].map(lambda v: None if v is None else str(v))
    return df


def write_table(root: str | Path, rows: list[dict]):
    """Write results.csv and results.parquet in `root` atomically; return the table."""
    df = frame(rows)
    root = Path(root)
    atomic_write(root / CSV, csv_text(df), sync=True)
    buffer = io.BytesIO()
    df.to_parquet(buffer, index=False)
    atomic_write(root / PARQUET, buffer.getvalue(), sync=True)
    return df


def csv_text(df) -> str:
    """The table as CSV, floats to 15 significant digits as in the JSON (`short_float`), an empty
    cell for a missing one: what `df.to_csv(index=False, float_format=short_float)` writes, with
    the floats' texts made a column at a time (a float whose shortest text is at most 16
    characters has at most 15 digits, so that text is already its 15-digit form; pandas called
    `short_float` for every cell, about half the time of the whole file)."""
    import numpy as np

    out = df.copy(deep=False)
    for i in range(df.shape[1]):
        values = df.iloc[:, i].to_numpy()
        if values.dtype.kind == "f":
            floats = values.tolist()
            out.isetitem(i, np.array([None if x != x else t if len(t) <= 16 else short_float(x)
                                      for x, t in zip(floats, map(repr, floats))], dtype=object))
    return out.to_csv(index=False)


class Table:
    """The rows of a running sweep by member index: a row is set in O(1), and the files are
    rewritten at most every `every` seconds (`flush`) and at the end (`write`)."""

    def __init__(self, root: str | Path, every: float = 30.0):
        self.root, self.every = Path(root), every
        self.rows: dict[int, dict] = {}
        self.written = time.monotonic()
        self.dirty = False

    def set(self, index: int, row: dict) -> None:
        """Set member `index`'s row; written at the next `flush`."""
        self.rows[index] = row
        self.dirty = True

    def flush(self) -> None:
        """Write the files if rows changed and the last write is `every` seconds old."""
        if self.dirty and time.monotonic() - self.written >= self.every:
            self.write()

    def write(self):
        """Write the files now; return the table."""
        df = write_table(self.root, [self.rows[i] for i in sorted(self.rows)])
        self.written, self.dirty = time.monotonic(), False
        return df


def load_results(root: str | Path):
    """A sweep's table as a pandas DataFrame (from results.parquet; results.csv if that is missing)."""
    import pandas as pd

    root = Path(root)
    if (root / PARQUET).exists():
        return pd.read_parquet(root / PARQUET)
    return pd.read_csv(root / CSV)
