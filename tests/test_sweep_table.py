"""The sweep's table (`sweep.table.frame`) of batches' rows whose text columns hold one value a
batch (status, error, folder), beside columns that do not: what pandas makes of the rows as
dicts, whether the rows came as the workers made them or through their pickles."""

from __future__ import annotations

import pickle
from itertools import chain

import numpy as np
import pandas as pd
import pytest

from pylmp_lattice.columnar import columns
from pylmp_lattice.sweep.table import Rows, _joined, _texts_typed, batch_rows, frame, member_row

from conftest import frame_of_dicts

DONE = {"status": "done", "error": None, "wall_time_s": 0.25}
FAILED = {"status": "failed", "error": 'bad "q", here', "wall_time_s": 0.0}


class Text(str):
    """Text of its own type, equal to the same str."""


def _summary(i: int, batch: int) -> dict:
    """A member's measures: numbers, and a count some members lack (None), as a front's gaps."""
    gaps = None if batch != 1 or i % 2 else i
    return {"v": 0.5 * i - 1.25, "n": 21, "gaps": gaps, "ok": bool(i % 3)}


# Batches (member numbers) and single members' rows (number, record) in the order they are set.
CASES = {
    "batches out of order": ([[3, 4, 5], [0, 1, 2], [6, 7]], []),
    "a batch of one": ([[0, 1], [2]], []),
    "and members alone": ([[0, 1, 2], [5, 6]], [(3, FAILED), (4, DONE)]),
    "rows set again": ([[0, 1, 2], [3, 4]], [(1, FAILED), (4, DONE)]),
    "a batch set again": ([[0, 1, 2], [3, 4], [2, 3]], []),
}


@pytest.mark.parametrize("case", CASES)
@pytest.mark.parametrize("pickled", [False, True])
def test_the_table_of_batches_with_one_status_error_and_folder_each_is_that_of_its_rows(case, pickled):
    """A batch's status, error (None) and folder are one value each; its ids and a swept text
    ("tag") are not; "gaps" is None in some batches and numbers and None in another. Members'
    own rows (`Rows.one`) set after the batches: a failed member's error text among the batches'
    None, a row that one sets again. The frame is the rows' as dicts, dtypes and all (text as
    pandas' text; the error column objects where it is None alone, else text and NaN)."""
    batches, members = CASES[case]
    parts, rows = [], {}
    for batch, indices in enumerate(batches):
        ids = [f"m{i}" for i in indices]
        params = [{"replica": i, "tag": "a,b" if i % 2 else "c"} for i in indices]
        sums = [_summary(i, batch) for i in indices]
        parts += batch_rows(indices, ids, params, f"batches/b{batch}", DONE, columns(sums))
        rows |= {i: member_row(m, p, f"batches/b{batch}", DONE, s) for i, m, p, s in zip(indices, ids, params, sums)}
    assert len(parts) == len(batches)  # a batch's rows as columns, one Rows each
    for i, record in members:
        rows[i] = member_row(f"m{i}", {"replica": i, "tag": "alone"}, f"members/m{i}", record, _summary(i, 0))
        parts.append(Rows.one(i, rows[i]))
    if pickled:  # as the workers send them: a column of one value once
        parts = [pickle.loads(pickle.dumps(p)) for p in parts]
    df = frame(parts)
    expected = frame_of_dicts(rows)
    pd.testing.assert_frame_equal(df, expected)
    assert list(df.dtypes) == list(expected.dtypes)
    assert df["status"].dtype == df["folder"].dtype == df["id"].dtype == pd.Series(["text"]).dtype
    failed = sum(r is FAILED for i, r in members if rows[i]["status"] == "failed")
    assert (df["error"].dtype == object) == (not failed) and df["error"].isna().sum() == len(df) - failed


def test_lists_one_after_the_other_are_typed_as_their_cells():
    """`_joined` of lists of one text or None each, and of others: what `_texts_typed` makes of
    their cells one after the other (the same type, values and text)."""
    cases = [[["done"] * 3, ["done"] * 2, ["failed"]], [["batches/b0"] * 4, ["m1", "m2"], ["é,\"x\""] * 2],
             [[None] * 3, [None]], [[None] * 2, ["bad"]], [["a", "b"], ["c", "d"]], [["a", "b", "a"], ["a"] * 2],
             [[None, 1], [None] * 2], [["x"] * 2, [1.5] * 2], [[""] * 3, ["a"]], [["1"] * 2, [1] * 2]]
    for lists in cases:
        cells = list(chain.from_iterable(lists))
        made = _joined(lists)
        pd.testing.assert_series_equal(pd.Series(made), pd.Series(_texts_typed(cells)))
        assert not isinstance(made, list) or made == cells


def test_a_batch_s_status_error_and_folder_go_through_a_pickle_once():
    """A batch's rows pickled: its status, error and folder (a list each of one value) cost
    that value once, not bytes a member; its ids each; the lists come back the same."""
    n = 5000
    cols = {"id": [f"m{i}" for i in range(n)], "wall_time_s": np.full(n, 0.5)}
    same = {"status": ["done"] * n, "error": [None] * n, "folder": ["batches/m0"] * n}
    bare = len(pickle.dumps(Rows(np.arange(n), (), (), cols)))
    rows = Rows(np.arange(n), (), (), cols | same)
    sent = pickle.dumps(rows)
    assert len(sent) - bare < 300
    back = pickle.loads(sent)
    assert list(back.columns) == list(rows.columns)
    for key, column in (cols | same).items():
        assert type(back.columns[key]) is type(column) and list(back.columns[key]) == list(column), key
    # equal but not one type (1 and True and 1.0), a str subclass, one cell, two values: each cell sent
    for column in ([1, True, 1.0], ["a", Text("a")], ["a"], ["a", "b"], [None, "a"]):
        back = pickle.loads(pickle.dumps(Rows(np.arange(len(column)), (), (), {"x": column})))
        assert list(map(type, back.columns["x"])) == list(map(type, column)) and back.columns["x"] == column
