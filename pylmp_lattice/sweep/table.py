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
        row |= scalar_measures(summary)
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


def scalar_measures(summary: dict, prefix: str = "") -> dict:
    """The numbers and flags of a summary, nested keys joined by '.' (lists are left out)."""
    out = {}
    for key, value in summary.items():
        if not prefix and key in NOT_MEASURES:
            continue
        name = f"{prefix}{key}"
        if isinstance(value, dict):
            out |= scalar_measures(value, prefix=f"{name}.")
        elif value is None or isinstance(value, (bool, int, float)):
            out[name] = value
    return out


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
    atomic_write(root / CSV, df.to_csv(index=False, float_format=short_float), sync=True)  # as the JSON
    buffer = io.BytesIO()
    df.to_parquet(buffer, index=False)
    atomic_write(root / PARQUET, buffer.getvalue(), sync=True)
    return df


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
