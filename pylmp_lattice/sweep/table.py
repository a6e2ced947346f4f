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
from dataclasses import dataclass
from pathlib import Path
from typing import Any

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


@dataclass
class Rows:
    """Some members' rows as columns (one object for a batch of 10^5 members, not a dict each):
    `index`, the members' numbers (int64, in row order); `params` and `measures`, the keys of
    the swept fields and of the measures, in a row's order; `columns`, every column's values
    (a list, or a numpy array of numbers without gaps), keyed id, params, FIXED[1:], measures.
    Every row has every key."""

    index: Any
    params: tuple
    measures: tuple
    columns: dict
    texts: list | None = None  # each row's measures as its CSV cells, where the rows were made (`measure_texts`)

    def __len__(self) -> int:
        return len(self.index)

    @classmethod
    def one(cls, index: int, row: dict) -> Rows:
        """The rows of one member (`member_row`)."""
        import numpy as np

        keys = list(row)
        first, last = keys.index("status"), keys.index("wall_time_s")
        return cls(np.array([index], dtype=np.int64), tuple(keys[1:first]), tuple(keys[last + 1:]),
                   {k: [v] for k, v in row.items()})


def batch_rows(index: list[int], ids: list[str], params: list[dict], folder: str, record: dict,
               summaries: dict) -> list[Rows]:
    """The rows of a batch's members, done, from their summaries as columns (`store.columns`,
    made strict): `member_row` of each, made a column at a time, as one Rows. A batch whose
    rows differ in their keys (summaries of other shapes) gets one Rows per member."""
    import numpy as np

    from .store import columns, rows

    flat = columns([flat_params(p) for p in params])
    measures: dict = {}
    if "cols" in flat and "cols" in summaries and _scalar_columns(summaries["cols"], "", measures, NOT_MEASURES):
        n = len(ids)
        cols = {"id": ids} | {k: _packed(c["rows"]) for k, c in flat["cols"].items()}
        cols |= {"status": [record["status"]] * n, "error": [record.get("error")] * n, "folder": [folder] * n,
                 "wall_time_s": _packed([record.get("wall_time_s")] * n)}
        cols |= {k: _packed(v) for k, v in measures.items()}
        return [Rows(np.asarray(index, dtype=np.int64), tuple(flat["cols"]), tuple(measures), cols,
                     measure_texts([cols[k] for k in measures]))]
    return [Rows.one(i, member_row(m, p, folder, record, s)) for i, m, p, s in zip(index, ids, params, rows(summaries))]


def measure_texts(columns: list) -> list[str] | None:
    """Each row's measures as results.csv writes them (`csv_text`), made by the worker (the
    texts of 10^5 members' floats are most of the table's time): where every column is a
    numpy array or all None (`_texted`; `csv_text` uses them where the table's columns are of
    the arrays' kinds, else makes its own)."""
    if not columns or not all(map(_texted, columns)):
        return None
    return list(map(",".join, zip(*(_array_texts(c) if _kind(c) else [""] * len(c) for c in columns))))


def _texted(column) -> bool:
    """Whether `measure_texts` can write the column: a numpy array, or nothing but None (empty
    cells, whatever the table's column turns out to be)."""
    return _kind(column) is not None or all(v is None for v in column)


def _kind(column) -> str | None:
    """A numpy array's kind ("f", "i", "b"); None for a list."""
    return getattr(getattr(column, "dtype", None), "kind", None)


def _scalar_columns(cols: dict, prefix: str, out: dict, skip: tuple = ()) -> bool:
    """`_scalars` of every row at once, on columns (`store.columns`): a column of numbers, flags
    and None is a column of the table, a column of other values (text, lists) is not; False
    where a column mixes them, or holds tables that differ in their keys (rows then differ)."""
    for key, column in cols.items():
        if key in skip:
            continue
        if "cols" in column:
            if not _scalar_columns(column["cols"], f"{prefix}{key}.", out):
                return False
            continue
        kinds = set(map(type, column["rows"]))
        scalar = {k for k in kinds if k is type(None) or issubclass(k, (bool, int, float))}
        if scalar == kinds:
            out[prefix + key] = column["rows"]
        elif scalar or any(issubclass(k, dict) for k in kinds):
            return False
    return True


def _packed(values: list):
    """A column's values as a numpy array where that is what the table makes of them (all floats,
    or floats and None; all ints; all flags): small to send, and a column at once later."""
    import numpy as np

    kinds = set(map(type, values))
    try:
        if kinds == {float} or kinds == {float, type(None)}:
            return np.array(values, dtype=np.float64)
        if kinds == {int}:
            return np.array(values, dtype=np.int64)
    except OverflowError:  # an int beyond int64: the table keeps it as an object
        return values
    return np.array(values, dtype=bool) if kinds == {bool} else values


def frame(parts: list[Rows]):
    """Rows (`Rows`; a member's row set again is its last) as a DataFrame in member order: id,
    swept fields, status .. wall_time_s, measures; what `pd.DataFrame` makes of the rows as
    dicts, each key a column in the order the rows first name it, a missing cell NaN."""
    import numpy as np
    import pandas as pd

    parts = [p for p in parts if len(p)]
    if not parts:
        return pd.DataFrame([], columns=["id", *FIXED[1:]])
    n, targets = _placed(parts)
    firsts = [t[t >= 0].min(initial=n) for t in targets]  # each part's first row (n: none left)
    ranked = sorted((f, k) for k, f in enumerate(firsts) if f < n)
    params = dict.fromkeys(key for _, k in ranked for key in parts[k].params)
    measures = dict.fromkeys(key for _, k in ranked for key in parts[k].measures)
    df = pd.DataFrame({key: _column(key, n, parts, targets) for key in ["id", *params, *FIXED[1:], *measures]})
    for col in df.columns:  # parquet needs one type per column
        if df[col].dtype == object and len({type(v) for v in df[col].dropna()}) > 1:
            df[col] = df[col].map(lambda v: None if v is None else str(v))
    return df


def _placed(parts: list[Rows]) -> tuple[int, list]:
    """The table's rows (n) and where each part's rows go in it (-1: that member's row set
    again by a later part), parts of no rows left out."""
    import numpy as np

    index = np.concatenate([p.index for p in parts])
    order = np.lexsort((np.arange(len(index)), index))  # by member, then as set
    last = order[np.r_[index[order][1:] != index[order][:-1], True]]
    where = np.full(len(index), -1)
    where[last] = np.arange(len(last))
    starts = np.cumsum([0, *map(len, parts)])
    return len(last), [where[a:b] for a, b in zip(starts, starts[1:])]


def _column(key: str, n: int, parts: list[Rows], targets: list):
    """One column of `frame`: a numpy array where every row has it as numbers of one kind, else
    a list of its cells (NaN where a row lacks it), which pandas types as it types rows."""
    import numpy as np

    held = [(p.columns[key], t) for p, t in zip(parts, targets) if key in p.columns]
    kinds = {c.dtype.kind if isinstance(c, np.ndarray) else None for c, _ in held}
    if len(kinds) == 1 and None not in kinds and sum((t >= 0).sum() for _, t in held) == n:
        out = np.empty(n, dtype=held[0][0].dtype)
    else:
        out = np.full(n, np.nan, dtype=object)
    for values, t in held:
        kept = t >= 0
        if kept.all():
            out[t] = values if isinstance(values, np.ndarray) or out.dtype != object else _objects(values)
        else:
            out[t[kept]] = _objects(values)[kept]
    return out if out.dtype != object else out.tolist()


def _objects(values):
    """Values as an object array (each value one cell, whatever it is)."""
    import numpy as np

    out = np.empty(len(values), dtype=object)
    out[:] = values if isinstance(values, np.ndarray) else list(values)
    return out


def write_table(root: str | Path, parts: list[Rows]):
    """Write results.csv and results.parquet in `root` atomically; return the table."""
    df = frame(parts)
    root = Path(root)
    atomic_write(root / CSV, csv_text(df, parts), sync=True)
    buffer = io.BytesIO()
    df.to_parquet(buffer, index=False)
    atomic_write(root / PARQUET, buffer.getvalue(), sync=True)
    return df


def csv_text(df, parts: list[Rows] | None = None) -> str:
    """The table as CSV, floats to 15 significant digits as in the JSON (`short_float`), an empty
    cell for a missing one: what `df.to_csv(index=False, float_format=short_float)` writes
    (Python's csv module: a cell with a comma, a quote or a line end quoted), made a column at a
    time (a float whose shortest text is at most 16 characters has at most 15 digits, so that
    text is already its 15-digit form; pandas called `short_float` for every cell and its csv
    writer for every row, most of the coordinator's time with 10^5 members). With the `parts`
    the table is `frame` of: their rows' measures as the workers wrote them (`Rows.texts`),
    where every part has them and the table's columns are theirs."""
    import numpy as np

    ready = _measures_ready(df, parts)
    upto = df.shape[1] if ready is None else df.shape[1] - len(parts[0].measures)
    cells = [_texts(df.iloc[:, i]) for i in range(upto)]
    if ready is not None:
        n, targets = ready
        texts = np.empty(n, dtype=object)
        for part, t in zip(parts, targets):
            texts[t] = part.texts
        cells.append(texts.tolist())
    lines = [",".join(map(_quoted, map(str, df.columns))), *map(",".join, zip(*cells))]
    return "\n".join(lines) + "\n"


def _measures_ready(df, parts: list[Rows] | None):
    """`_placed` of the parts where their `texts` are the table's measure cells: every part has
    them, for the table's measures, each column of one kind with the table's, no row set twice."""
    if not parts:
        return None
    parts = [p for p in parts if len(p)]
    measures = parts[0].measures if parts else ()
    if (not measures or list(df.columns[-len(measures):]) != list(measures) or len(set(df.columns)) != df.shape[1]
            or any(p.texts is None or p.measures != measures for p in parts)):
        return None
    kinds = df.dtypes.iloc[-len(measures):].map(lambda d: d.kind).tolist()
    if any(_kind(p.columns[k]) not in (None, kind) for p in parts for k, kind in zip(measures, kinds)):
        return None  # (a list: all None, see `_texted`)
    n, targets = _placed(parts)
    return (n, targets) if all((t >= 0).all() for t in targets) and n == len(df) else None


def _texts(column) -> list[str]:
    """A column's cells as `to_csv` writes them (floats as `csv_text` says)."""
    values = column.to_numpy()
    if values.dtype.kind in "fiub":
        return _array_texts(values)
    missing = column.isna().to_numpy().tolist()
    texts = ["" if gone else str(v) for v, gone in zip(values.tolist(), missing)]
    every = "".join(texts)  # most columns (ids, folders) need no quotes: one look for the whole column
    return list(map(_quoted, texts)) if any(c in every for c in ',"\n\r') else texts


def _array_texts(values) -> list[str]:
    """A numpy array of numbers or flags as CSV cells (floats as `csv_text` says)."""
    import numpy as np

    if values.dtype.kind != "f":
        return list(map(str, values.tolist()))
    floats = values.tolist()
    texts = list(map(repr, floats))  # at C speed; then the few missing or long ones
    for i in np.flatnonzero(np.isnan(values)).tolist():
        texts[i] = ""
    for i in np.flatnonzero(np.fromiter(map(len, texts), dtype=np.int64, count=len(texts)) > 16).tolist():
        texts[i] = short_float(floats[i])
    return texts


def _quoted(text: str) -> str:
    """A cell as the csv module's QUOTE_MINIMAL writes it."""
    if "," in text or '"' in text or "\n" in text or "\r" in text:
        return '"' + text.replace('"', '""') + '"'
    return text


class Table:
    """The rows of a running sweep (`Rows`, a batch's or a member's): added in O(1), and the
    files rewritten at most every `every` seconds, and no sooner than 10 times the last write
    took (`flush`: a table of 10^5 rows takes about a second, which the coordinator's other
    work waits for), and at the end (`write`)."""

    def __init__(self, root: str | Path, every: float = 30.0):
        self.root, self.every = Path(root), every
        self.parts: list[Rows] = []
        self.written = time.monotonic()
        self.took = 0.0  # seconds the last write took
        self.dirty = False

    def set(self, index: int, row: dict) -> None:
        """Set member `index`'s row (`member_row`); written at the next `flush`."""
        self.add(Rows.one(index, row))

    def add(self, rows: Rows) -> None:
        """Set these members' rows; written at the next `flush`."""
        self.parts.append(rows)
        self.dirty = True

    def frame(self):
        """The table as it stands (`frame`)."""
        return frame(self.parts)

    def flush(self) -> None:
        """Write the files if rows changed and the last write is `every` seconds old."""
        if self.dirty and time.monotonic() - self.written >= max(self.every, 10 * self.took):
            self.write()

    def write(self):
        """Write the files now; return the table."""
        start = time.monotonic()
        df = write_table(self.root, self.parts)
        self.written, self.dirty = time.monotonic(), False
        self.took = self.written - start
        return df


def load_results(root: str | Path):
    """A sweep's table as a pandas DataFrame (from results.parquet; results.csv if that is missing)."""
    import pandas as pd

    root = Path(root)
    if (root / PARQUET).exists():
        return pd.read_parquet(root / PARQUET)
    return pd.read_csv(root / CSV)
