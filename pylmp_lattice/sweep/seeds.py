"""Members' seeds: `member_seed` of one member (NumPy's SeedSequence), and `member_seeds`, the
same numbers for consecutive members made a block at a time with array operations (a sweep of
10^4 replicas made one SeedSequence per member, about 8-14 us each, in the coordinator that feeds
the workers; the arrays cost 0.06-0.2 us a member in a block of 4096, and 140-250 us a block of
1-16, still less than numpy.random's import, 14-18 ms CPU, which the coordinator does not need)."""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np

from ..case.seeding import _words, seed_words, uint64s

BLOCK = 4096  # members whose seeds are made at once


def member_seed(sweep_seed: int, index: int) -> int:
    """The seed of member `index`: independent streams for every (sweep seed, index) pair.
    With the arrays where they hold it: the coordinator asks for member 0's seed before its
    first task, and numpy.random's import is 14-18 ms CPU of its start-up."""
    if _arrays_hold(sweep_seed, index, 1):
        return _mixed(sweep_seed, index, 1)[0]
    return int(np.random.SeedSequence([sweep_seed, index]).generate_state(1, np.uint64)[0] >> 1)


def member_seeds(sweep_seed: int, start: int, count: int) -> Iterator[int]:
    """`member_seed(sweep_seed, i)` for i in start .. start + count - 1, in order."""
    for first in range(start, start + count, BLOCK):
        yield from _block(sweep_seed, first, min(BLOCK, start + count - first))


def _block(sweep_seed: int, start: int, count: int) -> list[int]:
    if not _arrays_hold(sweep_seed, start, count):  # as NumPy makes them
        return [member_seed(sweep_seed, i) for i in range(start, start + count)]
    return _mixed(sweep_seed, start, count)


def _arrays_hold(sweep_seed: int, start: int, count: int) -> bool:
    """Whether `_mixed` makes these seeds: the index of one word (any sweep seed)."""
    return start + count <= 2**32


def _mixed(sweep_seed: int, start: int, count: int) -> list[int]:
    """SeedSequence([sweep_seed, i]).generate_state(1, np.uint64)[0] >> 1 for `count` members from
    `start`, with array operations (see `_arrays_hold`)."""
    index = np.arange(start, start + count, dtype=np.uint64).astype(np.uint32)
    return (uint64s(seed_words([*_words(sweep_seed), index], count, 2))[0] >> np.uint64(1)).tolist()


class PointSeeds:
    """The seeds of a parameter point's `count` members from sweep member `start` (`member_seeds`),
    made `run` at a time as they are asked for (`spec.Sweep.iter_runs`)."""

    def __init__(self, sweep_seed: int, start: int, count: int, run: int):
        self.sweep_seed, self.start, self.count, self.size = sweep_seed, start, count, run
        self.lo, self.made = 0, []  # the seeds of the point's members lo .. lo + len(made) - 1

    def run(self, lo: int, hi: int) -> list[int]:
        """The seeds of the point's members lo .. hi - 1."""
        if not (self.lo <= lo and hi <= self.lo + len(self.made)):
            self.lo = lo
            self.made = list(member_seeds(self.sweep_seed, self.start + lo,
                                          min(self.count, max(hi, lo + self.size)) - lo))
        return self.made[lo - self.lo:hi - self.lo]
