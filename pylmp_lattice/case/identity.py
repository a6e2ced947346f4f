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
    return hashlib.sha256(_text(data).encode()).hexdigest()[:16]


def seeded_hashes(data: dict):
    """`normalised_hash` of `data` (normalised, with a "chain" section) with chain.seed set to a
    given `int`, as a function of the seed: a `SeededHashes` (picklable: a worker makes the
    identities of the replicas it runs, not the coordinator), or where the seed's place in the
    text cannot be found, a function that makes each seed's text whole."""
    mark = "\x00seed\x00"  # a text no case holds (should one, each seed's text is made whole)
    head, found, tail = _text(data | {"chain": data["chain"] | {"seed": mark}}).partition(json.dumps(mark))
    if not found or json.dumps(mark) in tail:
        return lambda seed: normalised_hash(data | {"chain": data["chain"] | {"seed": seed}})
    return SeededHashes(head, tail)


class SeededHashes:
    """The identities of one resolved case with chain.seed set to each seed: its text is `head`,
    the seed, `tail`; each seed's hash goes on from the hash of `head` (made once per process).
    Two seeds have one identity only if they are equal: `key` and the seed say whether two
    members are the same case, without a hash."""

    def __init__(self, head: str, tail: str):
        self.key = (head, tail)
        self._start = None

    def __call__(self, seed: int) -> str:
        if self._start is None:
            self._start = hashlib.sha256(self.key[0].encode())
        h = self._start.copy()
        h.update(f"{seed}{self.key[1]}".encode())
        return h.hexdigest()[:16]

    def __getstate__(self):
        return self.key

    def __setstate__(self, key):
        self.key, self._start = key, None


def _text(data: dict) -> str:
    return json.dumps(data, sort_keys=True, separators=(",", ":"), default=str)


def normalised(value):
    """A whole float as an int (1.0 -> 1), in nested dicts and lists: one text per number."""
    if isinstance(value, dict):
        return {k: normalised(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [normalised(v) for v in value]
    if isinstance(value, float) and value.is_integer():
        return int(value)
    return value
