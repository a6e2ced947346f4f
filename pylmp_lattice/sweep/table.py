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
from collections.abc import Callable
from dataclasses import dataclass
from itertools import chain, repeat
from pathlib import Path
from typing import Any

from ..errors import UsageError
from ..formats.layout import as_path
from .csv_cells import float_cells, kind, one_value, quoted, row_text, row_texts, text_fits
from .store import atomic_write

CSV = "results.csv"
PARQUET = "results.parquet"
STATS_CSV, STATS_PNG = "replica_stats.csv", "replica_stats.png"  # with replicas: their statistics (`stats`)
FILES = (CSV, PARQUET, STATS_CSV, STATS_PNG)
FIXED = ("id", "status", "error", "folder", "wall_time_s")
LONGEST = 600.0  # seconds a running sweep's table may wait for its rows to double (`Table.flush`)
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
        t = type(value)
        if t is float or t is int or t is bool or value is None:
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
    text: str | None = None  # the rows as results.csv lines, made where the rows were made (`row_text`)

    def __len__(self) -> int:
        return len(self.index)

    def __getstate__(self):
        """Sent (pickled) with each column of one value repeated as that value once (`_Same`):
        a batch's wall time, its magnets, most of its counts and flags, 138 of the 673 bytes a
        member of the 21-magnet experiment took through the coordinator's one pipe; its status,
        error and folder (a list each: 2 bytes a member each, and a step each to unpickle)."""
        return self.__dict__ | {"columns": {k: _Same.of(c) or c for k, c in self.columns.items()}}

    def __setstate__(self, state):
        columns = {k: c.array() if isinstance(c, _Same) else c for k, c in state["columns"].items()}
        self.__dict__.update(state | {"columns": columns})

    @classmethod
    def one(cls, index: int, row: dict) -> Rows:
        """The rows of one member (`member_row`)."""
        import numpy as np

        keys = list(row)
        first, last = keys.index("status"), keys.index("wall_time_s")
        return cls(np.array([index], dtype=np.int64), tuple(keys[1:first]), tuple(keys[last + 1:]),
                   {k: [v] for k, v in row.items()})


@dataclass
class _Same:
    """A column of `n` copies of `first`'s one cell: a numpy array of one (the same bytes), or a
    list of one text or None (a batch's status, error and folder), each cell of its type."""

    first: Any
    n: int

    @classmethod
    def of(cls, column) -> _Same | None:
        if len(column) < 2 or not one_value(column):  # (numbers and flags to the bit, text and None equal)
            return None
        if kind(column) or set(map(type, column)) in ({str}, {type(None)}):  # (no cell of another type equal)
            return cls(column[:1].copy(), len(column))
        return None

    def array(self):
        import numpy as np

        return self.first * self.n if isinstance(self.first, list) else np.repeat(self.first, self.n)


def batch_rows(index: list[int], ids: list[str], params: list[dict], folder: str, record: dict,
               summaries: dict, texts: dict | None = None) -> list[Rows]:
    """The rows of a batch's members, done, from their summaries as columns (`columnar.columns`,
    made strict): `member_row` of each, made a column at a time, as one Rows. A batch whose
    rows differ in their keys (summaries of other shapes) gets one Rows per member. texts: the
    columns of finite floats (`store.Floats`, `store.write_batch`'s), which their cells are made of."""
    import numpy as np

    from ..columnar import columns, rows

    flat = _flat_columns(columns(params)) or columns([flat_params(p) for p in params])
    measures: dict = {}
    texts = texts or {}
    if "cols" in flat and "cols" in summaries and _scalar_columns(summaries["cols"], "", measures, NOT_MEASURES, texts):
        n = len(ids)
        cols = {"id": ids} | {k: _packed(c["rows"]) for k, c in flat["cols"].items()}
        cols |= {"status": [record["status"]] * n, "error": [record.get("error")] * n, "folder": [folder] * n,
                 "wall_time_s": _packed([record.get("wall_time_s")] * n)}
        cols |= {k: _packed(v, texts) for k, v in measures.items()}
        made = {k: float_cells(v, texts) for k, v in measures.items()}
        return [Rows(np.asarray(index, dtype=np.int64), tuple(flat["cols"]), tuple(measures), cols,
                     row_text(list(cols.values()), list(map(made.get, cols))))]
    return [Rows.one(i, member_row(m, p, folder, record, s)) for i, m, p, s in zip(index, ids, params, rows(summaries))]


def _flat_columns(table: dict) -> dict | None:
    """`columns` of the rows' `flat_params`, made of `columns` of the rows (no dict per member)
    where no cell is a section or a list (a section's table is its fields' columns, as
    flat_params names them); None otherwise."""
    if "cols" not in table:
        return None
    out: dict = {}

    def walk(cols: dict, prefix: str) -> bool:
        for key, column in cols.items():
            if "cols" in column:
                if not walk(column["cols"], f"{prefix}{key}."):
                    return False
            elif any(isinstance(v, (dict, list)) for v in column["rows"]):
                return False
            else:
                out[prefix + key] = {"rows": column["rows"]}
        return True
    return {"cols": out} if walk(table["cols"], "") else None


def _scalar_columns(cols: dict, prefix: str, out: dict, skip: tuple = (), floats: dict | None = None) -> bool:
    """`_scalars` of every row at once, on columns (`columnar.columns`): a column of numbers, flags
    and None is a column of the table, a column of other values (text, lists) is not; False
    where a column mixes them, or holds tables that differ in their keys (rows then differ).
    floats: columns known to be of floats (`store.Floats`) by id of their lists."""
    for key, column in cols.items():
        if key in skip:
            continue
        if "cols" in column:
            if not _scalar_columns(column["cols"], f"{prefix}{key}.", out, floats=floats):
                return False
            continue
        if floats and id(column["rows"]) in floats:
            out[prefix + key] = column["rows"]
            continue
        kinds = set(map(type, column["rows"]))
        scalar = {k for k in kinds if k is type(None) or issubclass(k, (bool, int, float))}
        if scalar == kinds:
            out[prefix + key] = column["rows"]
        elif scalar or any(issubclass(k, dict) for k in kinds):
            return False
    return True


def _packed(values: list, floats: dict | None = None):
    """A column's values as a numpy array where that is what the table makes of them (all floats,
    or floats and None; all ints; all flags): small to send, and a column at once later. floats:
    columns of floats (`store.Floats`, their arrays made once) by id of their lists."""
    import numpy as np

    known = floats.get(id(values)) if floats else None
    if known is not None:
        return known.array
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
    dicts, each key a column in the order the rows first name it, a missing cell NaN. Made a
    column at a time (no step per row or per part and column in Python)."""
    import pandas as pd

    parts = [p for p in parts if len(p)]
    if not parts:
        return pd.DataFrame([], columns=["id", *FIXED[1:]])
    n, targets = _placed(parts)
    firsts = [t[t >= 0].min(initial=n) for t in targets]  # each part's first row (n: none left)
    ranked = sorted((f, k) for k, f in enumerate(firsts) if f < n)
    params = dict.fromkeys(key for _, k in ranked for key in parts[k].params)
    measures = dict.fromkeys(key for _, k in ranked for key in parts[k].measures)
    where, tiled = _concatenated(targets), _tiled(targets)
    cells = {key: _texts_typed(_column(key, n, parts, targets, where, tiled))
             for key in ["id", *params, *FIXED[1:], *measures]}
    df = pd.DataFrame(cells, copy=False)  # (new arrays: not copied)
    for col in df.columns:  # parquet needs one type per column (of pandas' typing of a list: `_joined`'s None are one)
        if df[col].dtype == object and isinstance(cells[col], list) and _mixed(df[col]):
            df[col] = df[col].map(lambda v: None if v is None else str(v))
    return df


def _texts_typed(values):
    """A column of text only (ids, statuses, folders) as the array pandas would make of it, made
    by Arrow where pandas keeps text in Arrow (pandas 3's "str"): 2-3 times faster than pandas
    typing the list (0.37 -> 0.13 s for the 3 such columns of 10^6 members). Else `values`."""
    dtype = _arrow_text(values) if isinstance(values, list) else None
    if dtype is None:
        return values
    import pandas as pd
    import pyarrow as pa

    return pd.array(pa.array(values, pa.large_string()), dtype=dtype)


def _joined(lists: list[list]):
    """Lists of cells one after the other, as `_texts_typed` makes of them; a list of one text or
    None repeated (a batch's status, error and folder) made a column without a step per cell in
    Python where every cell is text (that text taken again by Arrow) or None (an object array,
    which pandas types as the list, faster). Else the list of their cells (for `_texts_typed`)."""
    import numpy as np

    ones = [(c[0] is None or type(c[0]) is str) and c[0] == c[-1] and c.count(c[0]) == len(c)
            for c in lists]  # (the ends first: a batch's ids differ there)
    cells = list(chain.from_iterable(c[:1] if one else c for one, c in zip(ones, lists))) if any(ones) else []
    if cells and cells.count(None) == len(cells):
        return np.full(sum(map(len, lists)), None, dtype=object)
    dtype = _arrow_text(cells)
    if dtype is None:
        return list(chain.from_iterable(lists))
    import pandas as pd
    import pyarrow as pa

    times = list(chain.from_iterable([len(c)] if one else repeat(1, len(c)) for one, c in zip(ones, lists)))
    return pd.array(pa.array(cells, pa.large_string()).take(np.repeat(np.arange(len(cells)), times)), dtype=dtype)


def _arrow_text(values: list):
    """pandas' text dtype where `values` are text only and pandas keeps text in Arrow, else None."""
    if not values or set(map(type, values)) != {str}:
        return None
    import pandas as pd

    dtype = pd.Series(["text"]).dtype
    return dtype if getattr(dtype, "storage", None) == "pyarrow" else None


def _mixed(column) -> bool:
    """Whether a column of Python objects holds values of more than one type (missing ones aside)."""
    kinds = set(map(type, column.to_numpy().tolist())) - {type(None)}  # at C speed: most columns pass here
    return len(kinds) > 1 and len({type(v) for v in column.dropna()}) > 1  # (NaN: a float, and missing)


def _tiled(targets: list) -> list[int] | None:
    """The parts in table order where each one's rows are consecutive rows of the table, none
    set twice (so a column is its parts' values one after the other); else None."""
    import numpy as np

    if any(len(t) > 1 and not (np.diff(t) == 1).all() for t in targets) or min(t[0] for t in targets) < 0:
        return None
    return sorted(range(len(targets)), key=lambda k: targets[k][0])


def _concatenated(arrays: list):
    import numpy as np

    return np.concatenate(arrays) if arrays else np.empty(0, dtype=np.int64)


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


def _column(key: str, n: int, parts: list[Rows], targets: list, where, tiled: list[int] | None):
    """One column of `frame`: a numpy array where every row has it as numbers of one kind, else
    a list of its cells (NaN where a row lacks it), which pandas types as it types rows, or what
    `_joined` makes of the parts' lists where they are its rows one after the other. `where`:
    the targets of all parts, concatenated; `tiled`: `_tiled` of the targets."""
    import numpy as np

    held = [k for k, p in enumerate(parts) if key in p.columns]
    if tiled is not None and len(held) == len(parts):  # the parts' values one after the other
        values = [parts[k].columns[key] for k in tiled]
        if all(isinstance(c, np.ndarray) for c in values) and len({c.dtype for c in values}) == 1:
            return np.concatenate(values)
        if all(isinstance(c, list) for c in values):
            return _joined(values)
    values = [parts[k].columns[key] for k in held]
    t = where if len(held) == len(parts) else _concatenated([targets[k] for k in held])
    kept = t >= 0
    kinds = {c.dtype.kind if isinstance(c, np.ndarray) else None for c in values}
    if len(kinds) == 1 and None not in kinds and int(kept.sum()) == n:
        out = np.empty(n, dtype=values[0].dtype)
        cells = np.concatenate(values)
    else:
        out = np.full(n, np.nan, dtype=object)
        cells = _objects(list(chain.from_iterable(c.tolist() if isinstance(c, np.ndarray) else c for c in values)))
    out[t[kept]] = cells[kept]
    return out if out.dtype != object else out.tolist()


def _objects(values: list):
    """Values as an object array (each value one cell, whatever it is)."""
    import numpy as np

    out = np.empty(len(values), dtype=object)
    out[:] = values
    return out


def write_table(root: str | Path, parts: list[Rows], beside: Callable[[Any], None] | None = None):
    """Write results.csv and results.parquet in `root` atomically; return the table. Where the
    workers' lines make the CSV alone (`_lines`), it is written in a thread while this one makes
    the table (10^6 members: 1.1 s, this VM); the parquet file is encoded and written in a thread
    while this one makes and writes the CSV (Arrow's encoding and both files' writes and syncs
    wait without the GIL: 2.5-3.9 s one after the other, 1.8-2.3 s side by side). beside: called
    with the table in a third thread meanwhile (the replica figure, drawn while the CSV is
    written and synced), returned from before this returns."""
    from concurrent.futures import ThreadPoolExecutor

    root = Path(root)
    lines = _lines(parts)

    def parquet(df):
        buffer = io.BytesIO()
        df.to_parquet(buffer, index=False)
        atomic_write(root / PARQUET, buffer.getvalue(), sync=True)

    with ThreadPoolExecutor(3, thread_name_prefix="results") as pool:
        csv = pool.submit(atomic_write, root / CSV, lines, True) if lines else None
        df = frame(parts)
        done = [pool.submit(parquet, df), *([pool.submit(beside, df)] if beside is not None else [])]
        if csv is None:
            atomic_write(root / CSV, csv_text(df, parts), sync=True)
        for future in [*([csv] if csv else []), *done]:
            future.result()
    return df


def _lines(parts: list[Rows]) -> list[str] | None:
    """results.csv as the header and the parts' lines (`Rows.text`), each part's ending in a
    line end, where they make it alone, as `csv_text` would: every part has its text, the same
    columns in the order `frame` puts them (id, params, FIXED[1:], measures) and of the same
    kinds (so the table's columns are these), and its rows are the table's next ones (each
    part's members in order, after the previous part's last). None otherwise (the CSV is made
    of the table)."""
    parts = [p for p in parts if len(p)]
    if not parts or any(p.text is None for p in parts):
        return None
    first = parts[0]
    names = tuple(first.columns)
    if len(set(names)) != len(names) or names != ("id", *first.params, *FIXED[1:], *first.measures):
        return None
    if any(tuple(p.columns) != names for p in parts[1:]):
        return None
    for key in names:  # one kind a column; or floats, and None alone (a float column, its cells empty)
        kinds = {kind(p.columns[key]) for p in parts}
        if len(kinds) > 1 and not (kinds == {"f", None} and all(
                kind(c) or c.count(None) == len(c) for c in (p.columns[key] for p in parts))):
            return None
    import numpy as np

    order = sorted(range(len(parts)), key=lambda k: parts[k].index[0])
    last = -1
    for k in order:  # each part's members in order, after the previous part's: its rows follow
        index = parts[k].index
        if index[0] <= last or (len(index) > 1 and not (np.diff(index) > 0).all()):
            return None
        last = index[-1]
    return [",".join(map(quoted, names)) + "\n", *chain.from_iterable((parts[k].text, "\n") for k in order)]


def csv_text(df, parts: list[Rows] | None = None) -> str:
    """The table as CSV, floats to 15 significant digits as in the JSON (`short_float`), an empty
    cell for a missing one: what `df.to_csv(index=False, float_format=short_float)` writes
    (Python's csv module: a cell with a comma, a quote or a line end quoted), made a column at a
    time (a float whose shortest text is at most 16 characters has at most 15 digits, so that
    text is already its 15-digit form; pandas called `short_float` for every cell and its csv
    writer for every row, most of the coordinator's time with 10^5 members). With the `parts`
    the table is `frame` of: their rows as the workers wrote them (`Rows.text`) where they fit
    (`text_fits`), the others' rows made here."""
    import numpy as np

    header = ",".join(map(quoted, map(str, df.columns)))
    parts = [p for p in parts or () if len(p)]
    fits = list(map(text_fits(df), parts))
    if not any(fits):
        return "\n".join([header, *row_texts(df)]) + "\n"
    _, targets = _placed(parts)
    tiled = _tiled(targets) if all(fits) else None
    if tiled is not None:  # each part's lines as they came, one after the other
        return "\n".join([header, *(parts[k].text for k in tiled)]) + "\n"
    lines = np.empty(len(df), dtype=object)
    made = np.zeros(len(df), dtype=bool)
    for part, t, fit in zip(parts, targets, fits):
        if fit:
            kept = t >= 0
            lines[t[kept]] = _objects(part.text.split("\n"))[kept]
            made[t[kept]] = True
    rest = np.flatnonzero(~made)
    if len(rest):
        lines[rest] = row_texts(df.iloc[rest])
    return "\n".join([header, *lines.tolist()]) + "\n"


class Table:
    """The rows of a running sweep (`Rows`, a batch's or a member's): added in O(1), written at
    the end (`write`) and while the sweep runs (`flush`): at most every `every` seconds, no
    sooner than 10 times the last write took, only once the rows have doubled since (or after
    LONGEST seconds), and not when the sweep's end is nearer than the next write would be. A
    write takes time in proportion to the rows (a quarter of a second at 10^5), which the
    coordinator's other work waits for: so the writes while it runs cost at most about twice
    the last one, however long the sweep."""

    def __init__(self, root: str | Path, every: float = 30.0):
        self.root, self.every = Path(root), every
        self.parts: list[Rows] = []
        self.started = self.written = time.monotonic()
        self.took = 0.0  # seconds the last write took
        self.dirty = False
        self.rows = self.rows_written = 0  # rows set, and at the last write (a row set twice counts twice)

    def set(self, index: int, row: dict) -> None:
        """Set member `index`'s row (`member_row`); written at the next `flush`."""
        self.add(Rows.one(index, row))

    def add(self, rows: Rows) -> None:
        """Set these members' rows; written at the next `flush`."""
        self.parts.append(rows)
        self.rows += len(rows)
        self.dirty = True

    def frame(self):
        """The table as it stands (`frame`)."""
        return frame(self.parts)

    def flush(self, total: int | None = None) -> None:
        """Write the files if due (see the class): with the sweep's `total` rows, not when at
        the rate the rows came so far the last one is due within `every` seconds."""
        now = time.monotonic()
        since = now - self.written
        if not self.dirty or since < max(self.every, 10 * self.took):
            return
        if self.rows < 2 * self.rows_written and since < LONGEST:
            return
        if total is not None and self.rows and (total - self.rows) * (now - self.started) < self.every * self.rows:
            return
        self.write()

    def write(self, beside: Callable[[Any], None] | None = None):
        """Write the files now (`write_table`, with `beside`); return the table."""
        start = time.monotonic()
        df = write_table(self.root, self.parts, beside)
        self.written, self.dirty, self.rows_written = time.monotonic(), False, self.rows
        self.took = self.written - start
        return df


def load_results(root: str | Path):
    """A sweep's table as a pandas DataFrame (from results.parquet; results.csv if that is missing)."""
    import pandas as pd

    root = as_path(root, "root", "a sweep's folder")
    if (root / PARQUET).exists():
        return pd.read_parquet(root / PARQUET)
    if not (root / CSV).is_file():
        raise UsageError("root", f"got {str(root)!r}; expected a sweep's folder (it has no {CSV} nor {PARQUET})")
    return pd.read_csv(root / CSV)
