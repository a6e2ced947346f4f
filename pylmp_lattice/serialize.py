"""Strict JSON for results: NaN and infinities become null, numpy values plain Python.

Results objects (measures, studies) go through `jsonable`; `dumps` refuses anything that would
not be strict JSON (`allow_nan=False`), so a NaN can never reach a file as the token `NaN`, and
`loads_object` reads back only what `dumps` could have written (a file holding `NaN` or `[1]`
is no summary or record of ours).
"""

from __future__ import annotations

import dataclasses
import json
import math
from pathlib import PurePath

import numpy as np


def jsonable(obj):
    """A structure of dicts, lists, str, int, float, bool and None equal to `obj`.

    Dataclasses become dicts of their fields, numpy arrays lists, non-finite floats None.
    An object with a `to_dict()` method is converted through it.
    """
    kind = type(obj)  # the common plain types first (a sweep's batch writes ~50 values a member)
    if kind is float:
        return obj if math.isfinite(obj) else None
    if isinstance(obj, dict):
        return {str(k): jsonable(v) for k, v in obj.items()}
    if obj is None or isinstance(obj, (bool, str)):
        return obj
    if isinstance(obj, (np.bool_,)):
        return bool(obj)
    if isinstance(obj, (int, np.integer)):
        return int(obj)
    if isinstance(obj, (float, np.floating)):
        value = float(obj)
        return value if math.isfinite(value) else None
    if isinstance(obj, PurePath):
        return str(obj)
    if hasattr(obj, "to_dict"):
        return jsonable(obj.to_dict())
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        return {f.name: jsonable(getattr(obj, f.name)) for f in dataclasses.fields(obj)}
    if isinstance(obj, (list, tuple, np.ndarray)):
        return [jsonable(v) for v in obj]
    raise TypeError(f"cannot write {type(obj).__name__} as JSON")


def dumps(obj, indent: int | None = 2) -> str:
    """Strict JSON text of `obj` (see `jsonable`), floats to 15 significant digits: what a
    double holds of a decimal number, without the noise of its last bits (64.525, not
    64.52499999999999, for 5162 steps of 0.0125 ms)."""
    return json.dumps(_short(jsonable(obj)), indent=indent, allow_nan=False)


def short_float(x: float) -> str:
    """A finite float as text to 15 significant digits (the JSON's rule), for CSV cells:
    3.96949, not 3.9694900000000004; a whole number keeps its ".0" so a column reads back as floats."""
    return repr(float(f"{x:.15g}"))


def _short(obj):
    if type(obj) is float:
        return float(f"{obj:.15g}")
    if isinstance(obj, dict):
        return {k: _short(v) for k, v in obj.items()}
    if isinstance(obj, list):
        return [_short(v) for v in obj]
    return obj


def _no_constant(token: str):
    raise ValueError(f"{token} is not strict JSON")


def loads_object(text: str | bytes) -> dict | None:
    """The JSON object in `text`, strict (no NaN or infinities); None if it is anything else."""
    try:
        data = json.loads(text, parse_constant=_no_constant)
    except (ValueError, RecursionError):  # JSONDecodeError and UnicodeDecodeError are ValueErrors
        return None
    return data if isinstance(data, dict) else None
