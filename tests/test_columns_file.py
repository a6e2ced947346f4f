"""members.arrow's columns (`sweep.columns_file`): made from their buffers, equal to what
`pa.array` makes, and without pandas in the sweep worker that writes them."""

import subprocess
import sys

import pyarrow as pa
import pytest

from pylmp_lattice.sweep.columns_file import _exact

COLUMNS = {
    "float": [1.5, None, float("nan"), -0.0, float("inf"), 1e-300, 2.0**60, None, 3.25],
    "float, no nulls": [0.1 * k for k in range(17)],
    "int": [0, -1, 2**63 - 1, -(2**63), None, 7, None, 8, 9, 10],
    "int, no nulls": list(range(-3, 30)),
    "bool": [True, False, None, True, True, False, False, True, None, False],
    "bool, no nulls": [k % 3 == 0 for k in range(19)],
    "text": ["batches/a", "batches/a", None, "", "b,c", "\u00e9\u4e2d\U0001f600", "batches/a", None, ""],
    "text, no nulls": [f"label {k % 4}" for k in range(11)],
    "list": [[1, 2], [], None, [2**62], [-5, 0, 5], None, []],
    "list, no nulls": [[k] * (k % 3) for k in range(9)],
    "none": [None, None, None],
    "empty": [],
}


def _ipc(array) -> bytes:
    table = pa.Table.from_arrays([array], names=["c"])
    sink = pa.BufferOutputStream()
    with pa.ipc.new_file(sink, table.schema) as writer:
        writer.write_table(table)
    return sink.getvalue().to_pybytes()


@pytest.mark.parametrize("name", COLUMNS)
def test_a_column_from_its_buffers_is_pa_array_s_buffer_for_buffer(name):
    """Equal values, type and nulls, and the same bytes in an Arrow IPC file, as pa.array (then
    dictionary_encode for text) makes them; its values come back as they went in."""
    values = COLUMNS[name]
    kinds = set(map(type, values)) - {type(None)}
    kind = {float: pa.float64(), int: pa.int64(), bool: pa.bool_(), str: pa.string(),
            list: pa.list_(pa.int64())}[kinds.pop()] if kinds else pa.null()
    expected = pa.array(values, type=kind)
    if kind == pa.string():
        expected = expected.dictionary_encode()
    made = _exact(values)
    assert made.type == expected.type and made.null_count == expected.null_count
    assert _ipc(made) == _ipc(expected)  # (equals() would not: nan != nan)
    back = made.to_pylist()
    assert [type(v) for v in back] == [type(v) for v in values]
    assert repr(back) == repr(values)  # nan, -0.0 and the large ints as they were


@pytest.mark.parametrize("values", [[1, 2**63], [None, -(2**63) - 1], ["a", "\ud800"], [[1], [2**64]], [1, 2.5],
                                    [True, 1], [[1, 2.0]], [{"a": 1}]])
def test_a_column_that_arrow_would_not_give_back_exactly_is_none(values):
    """Ints beyond int64, text that is not UTF-8, mixed kinds: no array (members.json is read)."""
    assert _exact(values) is None


def test_writing_a_batch_s_columns_does_not_import_pandas(tmp_path):
    """pa.array imports pandas (0.3 s of each sweep worker's first task): write_batch's
    members.arrow is made without it."""
    code = ("import sys\n"
            "from pathlib import Path\n"
            "from pylmp_lattice.sweep.columns_file import COLUMNS_FILE\n"
            "from pylmp_lattice.sweep.store import write_batch\n"
            "s = {'a': 1.5, 'n': 2, 'ok': True, 't': 'x', 'gaps': [1], 'none': None}\n"
            "members = [{'id': i, 'index': k, 'params': {'replica': k}, 'chain': k, 'case': {}, 'summary': s}\n"
            "           for k, i in enumerate('ab')]\n"
            f"write_batch(Path({str(tmp_path)!r}), {{'status': 'done', 'batch': 'batches/a'}}, members)\n"
            f"assert (Path({str(tmp_path)!r}) / COLUMNS_FILE).is_file()\n"
            "print('pandas' in sys.modules)\n")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert done.stdout.strip() == "False"
