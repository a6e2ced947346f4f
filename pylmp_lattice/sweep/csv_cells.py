"""results.csv's cells and lines as text: a column's cells as the csv module and pandas' to_csv
write them (floats to 15 significant digits, `short_float`), and a batch's rows as lines, made
by the worker where its rows are made (`row_text`), which the table's CSV takes as they came
where they fit it (`text_fits`; `table.csv_text`, `table.write_table`).
"""

from __future__ import annotations

from itertools import repeat

from ..serialize import short_float


def row_text(columns: list, made: list | None = None) -> str | None:
    """The rows as results.csv writes them (`csv_text`), a line each, joined by newlines: made
    by the worker (the texts of 10^5 members' floats were most of the table's time), used by
    the coordinator where the table's columns are these, of the same kinds (`text_fits`).
    None unless every column is a numpy array, or holds text and None only (`_texted`), and no
    cell holds a line end (the lines are split again where a row is set twice). made: a
    column's cells where already made (`float_cells`), else None."""
    if not columns or not all(map(_texted, columns)):
        return None
    n = len(columns[0])
    parts: list = []  # each column's cells, or the one text of a run of columns of one value each
    for column, cells in zip(columns, made or [None] * len(columns)):
        if cells is None and n > 1 and one_value(column):  # its cell made once (a batch's status, wall time, ...)
            cells = array_texts(column[:1]) if kind(column) else list_texts(column[:1], lines=False)
            if cells is None:
                return None
            parts.append(f"{parts.pop()},{cells[0]}" if parts and type(parts[-1]) is str else cells[0])
            continue
        if cells is None:
            cells = array_texts(column) if kind(column) else list_texts(column, lines=False)
        if cells is None:
            return None
        parts.append(cells)
    return "\n".join(map(",".join, zip(*(repeat(p, n) if type(p) is str else p for p in parts))))


def _texted(column) -> bool:
    """Whether `row_text` can write the column: a numpy array, or text and None only (the
    table's column is text then, or empty cells where all are None)."""
    return kind(column) is not None or set(map(type, column)) <= {str, type(None)}


def one_value(column) -> bool:
    """Whether every cell of a column is its first: a numpy array's the same bytes (so -0.0 is not
    0.0, and one NaN is itself; False where it is not contiguous), text and None equal."""
    if not kind(column):
        return column.count(column[0]) == len(column)
    if not column.flags.c_contiguous or column.dtype.kind not in "fiub":
        return False
    cells = column.view("u1").reshape(len(column), -1)
    return bool((cells == cells[0]).all())


def kind(column) -> str | None:
    """A numpy array's kind ("f", "i", "b"); None for a list."""
    return getattr(getattr(column, "dtype", None), "kind", None)


def float_cells(values: list, texts: dict | None) -> list[str] | None:
    """The CSV cells (`array_texts`) of a list of finite floats whose texts (repr) are in `texts`
    by its id (`store.Floats`), made of them; None if they are not there."""
    made = texts.get(id(values)) if texts else None
    if made is None:
        return None
    import numpy as np

    cells = made.cells
    long = np.flatnonzero(np.fromiter(map(len, cells), dtype=np.int64, count=len(cells)) > 16).tolist()
    if long:
        cells = cells.copy()
        for i in long:
            cells[i] = short_float(values[i])
    return cells


def list_texts(values: list, lines: bool = True) -> list[str] | None:
    """Text and None as CSV cells (None empty, a cell with a comma, quote or line end quoted);
    None if a cell holds a line end and not `lines`."""
    texts = ["" if v is None else v for v in values]
    every = "".join(texts)  # most columns (ids, folders) need no quotes: one look for the whole column
    if not lines and ("\n" in every or "\r" in every):
        return None
    return list(map(quoted, texts)) if any(c in every for c in ',"\n\r') else texts


def text_fits(df):
    """Whether a part's `text` is its rows as `csv_text` writes them in this table: its
    columns are the table's, in order, each a numpy array of the table column's kind, or text
    (the table's column then holds text: it is of kind "O") or nothing but None (empty cells).
    (A function of the part: the table's columns and kinds are read once, not for each of a
    LAMMPS sweep's thousands of parts, 0.19 ms each at 47 columns.)"""
    names, kinds = tuple(df.columns), [dtype.kind for dtype in df.dtypes]
    unique = len(set(names)) == len(names)

    def fits(part) -> bool:  # a table.Rows
        if part.text is None or not unique or tuple(part.columns) != names:
            return False
        for values, want in zip(part.columns.values(), kinds):
            got = kind(values)
            if not (got == want or got is None and (want == "O" or values.count(None) == len(values))):
                return False
        return True
    return fits


def row_texts(df) -> list[str]:
    """The table's rows as CSV lines (`csv_text`), made a column at a time."""
    return list(map(",".join, zip(*(_texts(df.iloc[:, i]) for i in range(df.shape[1])))))


def _texts(column) -> list[str]:
    """A column's cells as `to_csv` writes them (floats as `csv_text` says)."""
    values = column.to_numpy()
    if values.dtype.kind in "fiub":
        return array_texts(values)
    missing = column.isna().to_numpy().tolist()
    texts = ["" if gone else str(v) for v, gone in zip(values.tolist(), missing)]
    every = "".join(texts)  # most columns (ids, folders) need no quotes: one look for the whole column
    return list(map(quoted, texts)) if any(c in every for c in ',"\n\r') else texts


def array_texts(values) -> list[str]:
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


def quoted(text: str) -> str:
    """A cell as the csv module's QUOTE_MINIMAL writes it."""
    if "," in text or '"' in text or "\n" in text or "\r" in text:
        return '"' + text.replace('"', '""') + '"'
    return text
