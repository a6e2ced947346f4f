"""A case's identity: a hash of its resolved form, which names run folders and sweep members."""

from __future__ import annotations

import hashlib
import json

from .case import Case
from .toml import case_to_dict


def case_id(case: Case) -> str:
    """The case's identity: 16 hex digits of a hash of its resolved form, the name left out (a
    label, not physics). One identity names run folders (`runs/NAME-<first 8>`) and sweep members."""
    return identity_hash({k: v for k, v in case_to_dict(case).items() if k != "name"})


def identity_hash(data: dict) -> str:
    """16 hex digits of a hash of a resolved case dict (keys sorted, so the order never matters;
    numbers normalised, so that 1 and 1.0 are one value)."""
    return normalised_hash(normalised(data))


def normalised_hash(data: dict) -> str:
    """`identity_hash` of a dict that is `normalised` already."""
    text = json.dumps(data, sort_keys=True, separators=(",", ":"), default=str)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def normalised(value):
    """A whole float as an int (1.0 -> 1), in nested dicts and lists: one text per number."""
    if isinstance(value, dict):
        return {k: normalised(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [normalised(v) for v in value]
    if isinstance(value, float) and value.is_integer():
        return int(value)
    return value
