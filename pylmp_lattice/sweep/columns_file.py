"""A batch's members.json as columns in an Arrow IPC file beside it, DIR/batches/<name>/
members.arrow: what a resumed sweep reads of its finished members. Parsing members.json's
numbers takes about 15 us a member (some 60 of them, each a Python float made from text), this
file's columns a small part of that; members.json stays the record, read where this file does
not fit.

The file holds members.json's record (as JSON, in the schema's metadata) and its columns
(`columnar.columns`) but the cases' (not read back), one Arrow column a leaf, named by its path of
keys as JSON. It is written before members.json, which names the batch done, and counts only
where it names the SHA-256 of the members.json beside it. It is written only where every leaf
is exact in Arrow: numbers of one kind, flags, text, lists of integers, each with nulls (else
the JSON is read back, as before).
"""

from __future__ import annotations

import hashlib
import json
from itertools import chain, repeat
from operator import is_not
from pathlib import Path

from ..formats.files import atomic_write

COLUMNS_FILE = "members.arrow"
DIGEST, RECORD = b"members.json sha256", b"record"
LEFT_OUT = "case"  # the column of members.json this file leaves out


def write_columns(folder: Path, record: dict, table: dict, text: bytes, floats: dict | None = None,
                  same: dict | None = None) -> None:
    """members.arrow for a batch whose members.json is `text`, holding `record` and the columns
    `table` (strict, `columnar.columns`): written where every leaf is exact in Arrow. floats: its
    columns of finite floats (`store.Floats`) by id of their lists; same: its columns of one
    value n times (`columnar.columns`), likewise."""
    if "cols" not in table:
        return
    leaves: dict = {}
    if not _leaves({k: v for k, v in table["cols"].items() if k != LEFT_OUT}, [], leaves, floats or {}, same or {}):
        return
    import pyarrow as pa

    meta = {DIGEST: hashlib.sha256(text).hexdigest().encode(), RECORD: json.dumps(record).encode()}
    arrow = pa.Table.from_arrays(list(leaves.values()), names=list(leaves)).replace_schema_metadata(meta)
    sink = pa.BufferOutputStream()
    with pa.ipc.new_file(sink, arrow.schema) as writer:
        writer.write_table(arrow)
    atomic_write(folder / COLUMNS_FILE, sink.getvalue().to_pybytes(), sync=False)


def _leaves(cols: dict, path: list, out: dict, floats: dict, same: dict) -> bool:
    """Each leaf column of `cols` as an Arrow array into `out` by its path (JSON); False if one
    is not exact in Arrow. floats, same: as `write_columns`'s."""
    import pyarrow as pa

    for key, column in cols.items():
        where = [*path, key]
        if "cols" in column:
            if not _leaves(column["cols"], where, out, floats, same):
                return False
            continue
        known = floats.get(id(column["rows"]))
        if known is not None:  # `_array` of floats without a null, from the array made once
            out[json.dumps(where)] = pa.Array.from_buffers(pa.float64(), len(known.values),
                                                           [None, pa.py_buffer(known.array)], 0)
            continue
        array = _exact(column["rows"], id(column["rows"]) in same)
        if array is None:
            return False
        out[json.dumps(where)] = array
    return True


def _exact(values: list, same: bool = False):
    """The values as an Arrow array that gives them back as they are (`to_pylist`), or None.
    Made from its buffers, as `pa.array(values, type)` (then `dictionary_encode` for text) makes
    it, buffer for buffer: `pa.array` imports pandas (pyarrow's check for pandas arrays), 0.3 s
    of each sweep worker's first task. same: the values are one value n times (its kind and
    its array's buffers are made from it, not by a look at each)."""
    import pyarrow as pa

    kinds = ({type(values[0])} if same and values else set(map(type, values))) - {type(None)}
    if not kinds:
        return pa.nulls(len(values))
    kind = {frozenset({float}): float, frozenset({int}): int, frozenset({bool}): bool, frozenset({str}): str}.get(frozenset(kinds))
    looked = values[:1] if same else values
    if kind is None and kinds == {list} and set(map(type, chain.from_iterable(v for v in looked if v))) <= {int}:
        kind = list
    if kind is None:
        return None
    try:
        return _repeated(values, kind) if same else _array(values, kind)
    except (OverflowError, UnicodeError):  # an int beyond int64, text that is not UTF-8 (a lone surrogate)
        return None


def _array(values: list, kind: type):
    """`_exact`'s array of values of one `kind` (float, int, bool, str, list of int) and None
    (its loops at C speed: a batch of 834 members has some 60 columns)."""
    import numpy as np
    import pyarrow as pa

    n, nulls = len(values), values.count(None)  # (no value of these kinds equals None)
    bitmap = filled = None
    if nulls:
        bitmap = pa.py_buffer(np.packbits(np.fromiter(map(is_not, values, repeat(None)), bool, n), bitorder="little"))
    if kind is not str:  # a null's slot holds 0 (an empty list), as pa.array leaves it
        filled = [(() if kind is list else 0) if v is None else v for v in values] if nulls else values
    if kind is float or kind is int:
        data = np.array(filled, np.float64 if kind is float else np.int64)
        return pa.Array.from_buffers(pa.float64() if kind is float else pa.int64(), n, [bitmap, pa.py_buffer(data)], nulls)
    if kind is bool:
        data = np.packbits(np.array(filled, bool), bitorder="little")
        return pa.Array.from_buffers(pa.bool_(), n, [bitmap, pa.py_buffer(data)], nulls)
    if kind is list:
        items = np.array(list(chain.from_iterable(filled)), np.int64)
        child = pa.Array.from_buffers(pa.int64(), len(items), [None, pa.py_buffer(items)], 0)
        offsets = _offsets(np.fromiter(map(len, filled), np.int64, n))
        return pa.Array.from_buffers(pa.list_(pa.int64()), n, [bitmap, pa.py_buffer(offsets)], nulls, children=[child])
    # text: dictionary-encoded, its dictionary in order of first appearance (as `dictionary_encode`),
    # a null's index 0
    texts = [t for t in dict.fromkeys(values) if t is not None]
    indices = np.fromiter(map(dict(zip(texts, range(len(texts)))).get, values, repeat(0)), np.int32, n)
    data = [t.encode() for t in texts]
    offsets = _offsets(np.fromiter(map(len, data), np.int64, len(data)))
    dictionary = pa.Array.from_buffers(pa.string(), len(data), [None, pa.py_buffer(offsets), pa.py_buffer(b"".join(data))], 0)
    return pa.DictionaryArray.from_arrays(pa.Array.from_buffers(pa.int32(), n, [bitmap, pa.py_buffer(indices)], nulls),
                                          dictionary)


def _repeated(values: list, kind: type):
    """`_array` of one value n times (not None), its buffers made from that value."""
    import numpy as np
    import pyarrow as pa

    n, value = len(values), values[0]
    if kind is float or kind is int:
        data = np.full(n, value, np.float64 if kind is float else np.int64)
        return pa.Array.from_buffers(pa.float64() if kind is float else pa.int64(), n, [None, pa.py_buffer(data)], 0)
    if kind is bool:
        data = np.packbits(np.full(n, value, bool), bitorder="little")
        return pa.Array.from_buffers(pa.bool_(), n, [None, pa.py_buffer(data)], 0)
    if kind is list:
        items = np.tile(np.array(value, np.int64), n)
        child = pa.Array.from_buffers(pa.int64(), len(items), [None, pa.py_buffer(items)], 0)
        offsets = _offsets(np.full(n, len(value), np.int64))
        return pa.Array.from_buffers(pa.list_(pa.int64()), n, [None, pa.py_buffer(offsets)], 0, children=[child])
    data = value.encode()
    dictionary = pa.Array.from_buffers(pa.string(), 1, [None, pa.py_buffer(np.array([0, len(data)], np.int32)),
                                                         pa.py_buffer(data)], 0)
    indices = pa.Array.from_buffers(pa.int32(), n, [None, pa.py_buffer(np.zeros(n, np.int32))], 0)
    return pa.DictionaryArray.from_arrays(indices, dictionary)


def _offsets(lengths):
    """Arrow's 32-bit offsets of items of these lengths (OverflowError past them)."""
    import numpy as np

    ends = np.concatenate([[0], np.cumsum(lengths)])
    if ends[-1] > np.iinfo(np.int32).max:
        raise OverflowError("more than 2**31 - 1 items")
    return ends.astype(np.int32)


def _values(array) -> list:
    """An Arrow array's values as Python objects: as `to_pylist` gives them, for text and numbers
    without gaps through numpy (`to_pylist` makes an Arrow scalar of each text first)."""
    import numpy as np
    import pyarrow as pa

    if pa.types.is_dictionary(array.type):
        values = np.array([*array.dictionary.to_pylist(), None], dtype=object)
        return values[array.indices.fill_null(len(values) - 1).to_numpy()].tolist()
    if array.null_count == 0 and (pa.types.is_floating(array.type) or pa.types.is_integer(array.type)
                                  or pa.types.is_boolean(array.type)):
        return array.to_numpy(zero_copy_only=False).tolist()
    return array.to_pylist()


def read_columns(folder: Path, text: bytes) -> tuple[dict, dict] | None:
    """The record and the columns (`columnar.columns`, the cases' left out) of the batch whose
    members.json is `text`, from its members.arrow; None if that is missing, unreadable, or
    not that members.json's."""
    from ..serialize import loads_object

    try:
        data = (folder / COLUMNS_FILE).read_bytes()
    except OSError:
        return None
    import pyarrow as pa

    try:
        reader = pa.ipc.open_file(pa.py_buffer(data))
        meta = reader.schema.metadata or {}
        if meta.get(DIGEST) != hashlib.sha256(text).hexdigest().encode():
            return None
        record = loads_object(meta[RECORD])
        arrow = reader.read_all()
        table: dict = {"cols": {}}
        for name, column in zip(arrow.column_names, arrow.columns):
            path = json.loads(name)
            if not (isinstance(path, list) and path and all(isinstance(key, str) for key in path)):
                return None
            place = table
            for key in path:
                if "rows" in place:
                    return None
                place = place.setdefault("cols", {}).setdefault(key, {})
            if place:  # a path named twice, or a leaf above another
                return None
            place["rows"] = _values(column.combine_chunks())
    except (pa.ArrowException, KeyError, ValueError, TypeError, AttributeError):
        return None
    return (record, table) if record is not None else None
