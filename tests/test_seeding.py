"""case.seeding: NumPy's SeedSequence and PCG64 seeding made with array operations give NumPy's
own numbers bit for bit, so that a batch's chains draw what each chain alone draws."""

import dataclasses

import numpy as np
import pytest

from pylmp_lattice.case.chain import GAP_STREAM, MASS_STREAM, VELOCITY_STREAM, Chain, replica_draws, thermal_normals
from pylmp_lattice.case_measures import chain_draws
from pylmp_lattice.case.seeding import _words, pcg64_states, seed_words, stream_normals
from conftest import make_case

# seeds of one and two words, their edges, and 3000 drawn over [0, 2^63) and [0, 2^32)
RNG = np.random.default_rng(20261127)
SEEDS = [0, 1, 2, 2**31, 2**32 - 1, 2**32, 2**32 + 1, 2**62, 2**63 - 1,
         *RNG.integers(0, 2**63, 2000).tolist(), *RNG.integers(0, 2**32, 1000).tolist()]


def test_seed_words_are_numpys_generate_state_for_any_entropy_length():
    """seed_words of entropy of 1 to 7 words, with and without a spawn key: NumPy's
    generate_state, for a few words and for more than the pool's 4."""
    for seed in (0, 7, 2**32 - 1, 2**40 + 3, 2**63 - 1, 2**96 + 5, 2**200 + 2**100 + 1):
        for key in ((), (2,), (0, 2**33)):
            want = np.random.SeedSequence(seed, spawn_key=key)
            entropy = _words(seed)
            if key:  # as SeedSequence assembles it: zeros up to the pool, then the key's words
                entropy = entropy + [0] * max(0, 4 - len(entropy)) + [w for k in key for w in _words(k)]
            for words in (1, 2, 8, 9):
                got = seed_words(entropy, 1, words)[:, 0]
                assert got.tolist() == want.generate_state(words).tolist(), (seed, key, words)


def test_pcg64_states_are_numpys_seeding():
    for stream in (MASS_STREAM, GAP_STREAM, VELOCITY_STREAM):
        got = pcg64_states(SEEDS[:300], stream)
        for seed, (state, inc) in zip(SEEDS[:300], got):
            want = np.random.PCG64(np.random.SeedSequence(seed, spawn_key=(stream,))).state["state"]
            assert (state, inc) == (want["state"], want["inc"]), (seed, stream)


def test_stream_normals_are_each_seed_s_own_generator_bit_for_bit():
    """3009 seeds, every stream, draws of 1, 19 (the paper's free magnets) and 300 numbers: the
    same bits as a generator made for each seed."""
    for stream, count in ((VELOCITY_STREAM, 19), (VELOCITY_STREAM, 1), (MASS_STREAM, 300), (GAP_STREAM, 19)):
        seeds = SEEDS if count == 19 else SEEDS[:200]
        got = stream_normals(seeds, stream, count)
        want = np.stack([np.random.default_rng(np.random.SeedSequence(s, spawn_key=(stream,))).standard_normal(count)
                         for s in seeds])
        assert got.view(np.uint64).tolist() == want.view(np.uint64).tolist(), (stream, count)
        assert len({row[0] for row in got.tolist()}) == len(set(seeds))  # no two seeds alike
    assert stream_normals([], VELOCITY_STREAM, 19).shape == (0, 19)


def test_a_batch_s_thermal_normals_are_each_chain_s():
    case = make_case(particles=21, chain={"thermal_velocity": 0.02, "seed": 1})
    chains = [dataclasses.replace(case.chain, seed=s) for s in SEEDS[:500]]
    got = thermal_normals(chains)
    want = np.stack([c.thermal_normals() for c in chains])
    assert got.shape == (500, 19) and got.view(np.uint64).tolist() == want.view(np.uint64).tolist()


@pytest.mark.parametrize("chain", [
    {"mass_disorder": 0.01, "r0_disorder": 0.005, "disorder": "uniform"},  # the shipped thermal example's
    {"mass_disorder": 0.1, "thermal_velocity": 0.02},  # normal, masses alone
    {"r0_disorder": 0.2, "disorder": "uniform", "defect_index": 7, "defect_r0": 30.0},
    {"mass_disorder": 0.05, "r0_disorder": 0.05, "defect_index": 21, "defect_mass": 3.0, "thermal_velocity": 0.5},
])
def test_a_point_s_replicas_under_disorder_draw_together_what_each_draws_alone(chain):
    """`chain.replica_draws` (a sweep worker's draws for a point's replicas) and `chain_draws`
    (their velocities together, each chain its own masses): each replica's masses, gaps and
    velocities bit for bit as its chain alone draws them (`Chain.masses`, `gaps`, `velocities`)."""
    case = make_case(particles=21, chain={"seed": 1} | chain)
    seeds = SEEDS[:300]
    masses, gaps = replica_draws(case.chain, seeds)
    alone = [dataclasses.replace(case, chain=dataclasses.replace(case.chain, seed=s)) for s in seeds]
    for got, draw in ((masses, Chain.masses), (gaps, Chain.gaps)):
        want = np.stack([draw(c.chain) for c in alone])
        assert got.view(np.uint64).tolist() == want.view(np.uint64).tolist()
    assert len({row[1] for row in masses.tolist()}) == (len(seeds) if "mass_disorder" in chain else 1)
    together = chain_draws(alone)
    for got, draw in ((together.masses, Chain.masses), (together.gaps, Chain.gaps),
                      (together.velocities, Chain.velocities)):
        want = np.stack([draw(c.chain) for c in alone])
        assert got.view(np.uint64).tolist() == want.view(np.uint64).tolist()
