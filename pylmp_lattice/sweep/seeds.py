"""Members' seeds: `member_seed` of one member (NumPy's SeedSequence), and `member_seeds`, the
same numbers for consecutive members made a block at a time with array operations (a sweep of
10^4 replicas made one SeedSequence per member, about 8-14 us each, in the coordinator that feeds
the workers; the arrays cost 0.06-0.2 us a member in a block of 4096, and 140-250 us a block of
1-16, still less than numpy.random's import, 14-18 ms CPU, which the coordinator does not need)."""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np

# NumPy's SeedSequence (numpy/random/bit_generator.pyx): its pool of 4 words mixed from the
# entropy, then the words of generate_state. All arithmetic is on 32-bit words, modulo 2**32.
POOL = 4
INIT_A, MULT_A, INIT_B, MULT_B = 0x43B0D7E5, 0x931E8875, 0x8B51F9DD, 0x58F38DED
MIX_MULT_L, MIX_MULT_R, XSHIFT = 0xCA01F9DD, 0x4973F715, 16
MASK = 0xFFFFFFFF
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
    """Whether `_mixed` makes these seeds: the index of one word, the entropy within the pool."""
    return start + count <= 2**32 and len(_words(sweep_seed)) + 1 <= POOL


def _mixed(sweep_seed: int, start: int, count: int) -> list[int]:
    """SeedSequence([sweep_seed, i]).generate_state(1, np.uint64)[0] >> 1 for `count` members from
    `start`, with array operations (see `_arrays_hold`)."""
    words = _words(sweep_seed)
    entropy = [np.full(count, w, dtype=np.uint32) for w in words]
    entropy.append(np.arange(start, start + count, dtype=np.uint64).astype(np.uint32))
    const = INIT_A

    def hashmix(value):
        nonlocal const
        value = value ^ np.uint32(const)
        const = const * MULT_A & MASK
        value = value * np.uint32(const)
        return value ^ (value >> np.uint32(XSHIFT))

    zero = np.zeros(count, dtype=np.uint32)
    pool = [hashmix(entropy[i] if i < len(entropy) else zero) for i in range(POOL)]
    for src in range(POOL):
        for dst in range(POOL):
            if src != dst:
                mixed = np.uint32(MIX_MULT_L) * pool[dst] - np.uint32(MIX_MULT_R) * hashmix(pool[src])
                pool[dst] = mixed ^ (mixed >> np.uint32(XSHIFT))
    const, state = INIT_B, []
    for word in pool[:2]:  # generate_state(1, np.uint64): two 32-bit words, the low one first
        word = word ^ np.uint32(const)
        const = const * MULT_B & MASK
        word = word * np.uint32(const)
        state.append((word ^ (word >> np.uint32(XSHIFT))).astype(np.uint64))
    return ((state[0] | state[1] << np.uint64(32)) >> np.uint64(1)).tolist()


def _words(n: int) -> list[int]:
    """An integer's 32-bit words, the low one first (0 is one word), as SeedSequence reads it."""
    words = [0] if n == 0 else []
    while n > 0:
        words.append(n & MASK)
        n >>= 32
    return words
