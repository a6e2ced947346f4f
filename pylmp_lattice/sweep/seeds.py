"""Members' seeds: `member_seed` of one member (NumPy's SeedSequence), and `member_seeds`, the
same numbers for consecutive members made a block at a time with array operations (a sweep of
10^4 replicas made one SeedSequence per member, about 8 us each, in the coordinator that feeds
the workers; the arrays cost about 0.2 us a member in a block of 4096, more than SeedSequence
below SMALL)."""

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
SMALL = 16  # fewer members: one SeedSequence each (blocks of 1-8 took 25-97 us a member)


def member_seed(sweep_seed: int, index: int) -> int:
    """The seed of member `index`: independent streams for every (sweep seed, index) pair."""
    return int(np.random.SeedSequence([sweep_seed, index]).generate_state(1, np.uint64)[0] >> 1)


def member_seeds(sweep_seed: int, start: int, count: int) -> Iterator[int]:
    """`member_seed(sweep_seed, i)` for i in start .. start + count - 1, in order."""
    for first in range(start, start + count, BLOCK):
        yield from _block(sweep_seed, first, min(BLOCK, start + count - first))


def _block(sweep_seed: int, start: int, count: int) -> list[int]:
    words = _words(sweep_seed)
    # few members, or an index of two words: as NumPy makes it
    if count < SMALL or start + count > 2**32 or len(words) + 1 > POOL:
        return [member_seed(sweep_seed, i) for i in range(start, start + count)]
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
