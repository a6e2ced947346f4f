"""Rows of nested dicts as columns and back: a batch's outcomes (`sweep.store`) and its members'
summaries (`summary.summary_columns`) are kept a key at a time, not a dict per member.

`columns(rows)`: dicts with the same keys become {"cols": {key: columns(their values)}} (each key
once, in the first's order), anything else {"rows": rows}; `rows(table)` undoes it. The form is a
function of the values alone: a table made a key at a time equals `columns` of its rows.
"""

from __future__ import annotations

from itertools import repeat
from operator import is_, itemgetter


def columns(rows: list, same: dict | None = None):
    """Rows as columns, for a batch of up to 10^6 members (see the module's docstring).
    same: gets each column that is one value n times (the same object), by id of its list."""
    first = rows[0] if rows else None
    if rows and all(map(is_, rows, repeat(first))):  # one value n times (replicas' cases share most of theirs)
        return repeated(first, len(rows), same)
    if type(first) is dict and first and set(map(type, rows)) == {dict} and len(set(map(len, rows))) == 1:
        try:  # as many keys each, and each has the first's: the same keys (map: at C speed)
            values = {key: list(map(itemgetter(key), rows)) for key in first}
        except KeyError:
            return {"rows": rows}
        return {"cols": {key: columns(column, same) for key, column in values.items()}}
    return {"rows": rows}


def repeated(value, n: int, same: dict | None = None) -> dict:
    """`columns` of `n` times one value, without looking at each (same: as `columns`')."""
    if type(value) is dict and value:
        return {"cols": {key: repeated(v, n, same) for key, v in value.items()}}
    rows = [value] * n
    if same is not None:
        same[id(rows)] = value
    return {"rows": rows}


def rows(table: dict) -> list:
    """`columns` undone."""
    if "rows" in table:
        return table["rows"]
    cols = {key: rows(column) for key, column in table["cols"].items()}
    return [dict(zip(cols, values)) for values in zip(*cols.values(), strict=True)]
