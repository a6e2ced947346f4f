"""NumPy's seeding, many seeds at a time with array operations: `seed_words` (SeedSequence's
generate_state) and `pcg64_states` (the state `default_rng(SeedSequence(...))` starts from), so
that a batch of chains gets its draws from one generator re-seeded per chain (about 2 us) instead
of a SeedSequence and a generator per chain (about 16 us), with the same numbers bit for bit
(tests/test_seeding.py compares them with NumPy's over many seeds). The sweep's member seeds
(`sweep.seeds`) are made the same way.
"""

from __future__ import annotations

import numpy as np

# NumPy's SeedSequence (numpy/random/bit_generator.pyx): its pool of 4 words mixed from the
# entropy, then the words of generate_state. All arithmetic is on 32-bit words, modulo 2**32.
POOL = 4
INIT_A, MULT_A, INIT_B, MULT_B = 0x43B0D7E5, 0x931E8875, 0x8B51F9DD, 0x58F38DED
MIX_MULT_L, MIX_MULT_R, XSHIFT = 0xCA01F9DD, 0x4973F715, 16
MASK = 0xFFFFFFFF
# PCG64's 128-bit LCG multiplier (numpy/random/src/pcg64: PCG_DEFAULT_MULTIPLIER_128)
PCG_MULT = (2549297995355413924 << 64) + 4865540595714422341
MASK128 = (1 << 128) - 1


def seed_words(entropy: list, count: int, words: int) -> np.ndarray:
    """`SeedSequence(...).generate_state(words)` (uint32) of `count` sequences at once, shape
    (words, count): `entropy` is each sequence's assembled entropy a word at a time (an int, the
    same for all, or a uint32 array of `count`), as SeedSequence assembles it: the run entropy's
    32-bit words, low first, then, with a spawn key, zeros up to the pool's 4 words and the key's
    words."""
    const = INIT_A

    def hashmix(value):
        nonlocal const
        value = value ^ np.uint32(const)
        const = const * MULT_A & MASK
        value = value * np.uint32(const)
        return value ^ (value >> np.uint32(XSHIFT))

    def mix(x, y):
        mixed = np.uint32(MIX_MULT_L) * x - np.uint32(MIX_MULT_R) * y
        return mixed ^ (mixed >> np.uint32(XSHIFT))

    entropy = [np.broadcast_to(np.asarray(w, dtype=np.uint32), (count,)) for w in entropy]
    zero = np.zeros(count, dtype=np.uint32)
    pool = [hashmix(entropy[i] if i < len(entropy) else zero) for i in range(POOL)]
    for src in range(POOL):
        for dst in range(POOL):
            if src != dst:
                pool[dst] = mix(pool[dst], hashmix(pool[src]))
    for word in entropy[POOL:]:  # entropy beyond the pool: each word into every pool word
        for dst in range(POOL):
            pool[dst] = mix(pool[dst], hashmix(word))
    const, state = INIT_B, np.empty((words, count), dtype=np.uint32)
    for k in range(words):  # the pool's words in turn, hashed again
        word = pool[k % POOL] ^ np.uint32(const)
        const = const * MULT_B & MASK
        word = word * np.uint32(const)
        state[k] = word ^ (word >> np.uint32(XSHIFT))
    return state


def uint64s(words: np.ndarray) -> np.ndarray:
    """generate_state(n, np.uint64) from generate_state(2 n) (uint32, (2 n, count)): each pair of
    words, the low one first; shape (n, count)."""
    words = words.astype(np.uint64)
    return words[0::2] | words[1::2] << np.uint64(32)


def pcg64_states(seeds, stream: int) -> list[tuple[int, int]]:
    """(state, inc) of `np.random.PCG64(np.random.SeedSequence(seed, spawn_key=(stream,)))` for
    each seed (ints in [0, 2^63)), as PCG64 seeds itself from generate_state(4, np.uint64)
    (pcg64_set_seed: state s = words 0, 1 and sequence i = words 2, 3, high word first; then
    inc = 2 i + 1, state = ((inc + s) MULT + inc) mod 2^128)."""
    seeds = np.asarray(seeds, dtype=np.uint64)
    if seeds.size and int(seeds.max()) >= 2**63:
        raise ValueError("seeds must be in [0, 2^63)")
    low, high = (seeds & np.uint64(MASK)).astype(np.uint32), (seeds >> np.uint64(32)).astype(np.uint32)
    # a seed below 2^63 is one or two words; padded with zeros to the pool either way
    words = uint64s(seed_words([low, high, 0, 0, *_words(stream)], len(seeds), 8)).tolist()
    out = []
    for s_high, s_low, i_high, i_low in zip(*words):
        inc = ((i_high << 65) | (i_low << 1) | 1) & MASK128
        out.append(((((s_high << 64) | s_low) + inc) * PCG_MULT + inc & MASK128, inc))
    return out


def stream_normals(seeds, stream: int, count: int) -> np.ndarray:
    """`np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(stream,))).standard_normal(count)`
    of each seed, shape (len(seeds), count), bit for bit: one generator, its state set per seed."""
    return stream_draws(seeds, stream, count, lambda rng, out: rng.standard_normal(out=out))


def stream_draws(seeds, stream: int, count: int, draw) -> np.ndarray:
    """`draw(rng, out)` into each seed's row of a (len(seeds), count) array, `rng` the generator
    `np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(stream,)))` would be, bit for
    bit: one generator, its state set per seed."""
    bits = np.random.PCG64(0)
    rng = np.random.Generator(bits)
    out = np.empty((len(seeds), count))
    for r, (state, inc) in enumerate(pcg64_states(seeds, stream)):
        bits.state = {"bit_generator": "PCG64", "state": {"state": state, "inc": inc}, "has_uint32": 0, "uinteger": 0}
        draw(rng, out[r])
    return out


def _words(n: int) -> list[int]:
    """An integer's 32-bit words, the low one first (0 is one word), as SeedSequence reads it."""
    words = [0] if n == 0 else []
    while n > 0:
        words.append(n & MASK)
        n >>= 32
    return words
