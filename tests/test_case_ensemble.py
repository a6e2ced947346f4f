"""Random chains (case.Chain): thermal initial velocities, mass/spacing disorder, defects, seeds."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pylmp_lattice.case import Chain, case_from_dict, case_to_dict
from pylmp_lattice.deck import data_text
from pylmp_lattice.errors import ConfigError

from conftest import make_case


def test_thermal_velocities_zero_momentum_and_seeded():
    case = make_case(particles=12, chain={"thermal_velocity": 0.05, "mass_disorder": 0.1, "seed": 7})
    v, m = case.chain.velocities(), case.chain.masses()
    assert v[0] == 0 and v[-1] == 0  # the impactor and the held end are driven, not thermal
    assert abs(np.sum(m * v)) < 1e-15 * np.sum(m * np.abs(v))
    again = make_case(particles=12, chain={"thermal_velocity": 0.05, "mass_disorder": 0.1, "seed": 7})
    np.testing.assert_array_equal(again.chain.velocities(), v)
    other = make_case(particles=12, chain={"thermal_velocity": 0.05, "mass_disorder": 0.1, "seed": 8})
    assert np.all(other.chain.velocities()[1:-1] != v[1:-1])


@pytest.mark.parametrize("mass_disorder", [None, 0.3])
def test_thermal_rms_matches_request_within_statistical_error(mass_disorder):
    """E[mean v^2] = v_rms^2 after the momentum is removed, equal masses or not.

    Over S seeds of n free magnets the estimate of mean v^2 has relative standard error
    sqrt(2/(S (n-1))) (Gaussian: var(v^2) = 2 sigma^4; one degree of freedom goes to the
    momentum): tolerance 4 of those, 6%. Without the rescaling the bias would be 1/(n-1) = 11%."""
    v_rms, particles, seeds = 0.02, 12, 1000
    free = particles - 2
    fields = {"thermal_velocity": v_rms} | ({"mass_disorder": mass_disorder, "disorder": "uniform"} if mass_disorder else {})
    ms = [np.mean(Chain(1.084, 12.0, particles, **fields, seed=s).velocities()[1:-1] ** 2) for s in range(seeds)]
    rel = np.mean(ms) / v_rms**2 - 1
    tol = 4 * math.sqrt(2 / (seeds * (free - 1)))
    assert abs(rel) < tol, (rel, tol)


@pytest.mark.parametrize("disorder", ["normal", "uniform"])
def test_disorder_has_the_requested_relative_std(disorder):
    w = 0.1
    case = make_case(particles=2001, duration=1.0, chain={"mass_disorder": w, "r0_disorder": w / 2, "disorder": disorder, "seed": 3})
    m, r = case.chain.masses() / 1.084 - 1, case.chain.gaps() / 12.0 - 1
    # the std of 2000 draws is within ~1.6% (normal) of the true one; 5% tolerance
    assert np.std(m) == pytest.approx(w, rel=0.05)
    assert np.std(r) == pytest.approx(w / 2, rel=0.05)
    if disorder == "uniform":
        assert np.max(np.abs(m)) <= math.sqrt(3) * w
    assert np.corrcoef(m[:-1], r)[0, 1] == pytest.approx(0, abs=0.1)  # independent streams


def test_streams_are_independent_and_defects_sit_at_their_index():
    base = {"thermal_velocity": 0.01, "seed": 5}
    plain = make_case(particles=10, chain=base).chain
    disordered = make_case(particles=10, chain=base | {"mass_disorder": 0.05}).chain
    # adding mass disorder changes the masses, hence the momentum correction, not the draws:
    # v differs only by the (small) mass-weighted mean subtracted
    assert np.max(np.abs(plain.velocities() - disordered.velocities())) < 0.3 * 0.01
    defect = make_case(particles=10, chain={"defect_index": 4, "defect_mass": 2.5, "defect_r0": 8.0}).chain
    assert defect.masses()[3] == 2.5 and np.all(np.delete(defect.masses(), 3) == 1.084)
    assert defect.gaps()[3] == 8.0 and np.all(np.delete(defect.gaps(), 3) == 12.0)
    np.testing.assert_allclose(np.diff(defect.positions()), defect.gaps())


def test_draws_come_from_the_children_of_the_seed_sequence():
    """Masses, gaps and velocities draw from children 0, 1, 2 of SeedSequence(seed).spawn(3): the
    numbers of every earlier release, though each stream is now made alone."""
    chain = make_case(particles=8, chain={"thermal_velocity": 0.02, "mass_disorder": 0.1, "r0_disorder": 0.05,
                                          "seed": 42}).chain
    masses, gaps, z = (np.random.default_rng(s) for s in np.random.SeedSequence(42).spawn(3))
    np.testing.assert_array_equal(chain.masses(), 1.084 * (1 + 0.1 * masses.standard_normal(8)))
    np.testing.assert_array_equal(chain.gaps(), 12.0 * (1 + 0.05 * gaps.standard_normal(7)))
    m = chain.masses()[1:-1]
    c = math.sqrt(6 / (6 - 2 + 6 * float(np.sum(m**2)) / float(np.sum(m)) ** 2))
    free = c * 0.02 * z.standard_normal(6)
    np.testing.assert_array_equal(chain.velocities()[1:-1], free - np.sum(m * free) / float(np.sum(m)))


def test_a_sample_of_the_first_draws_is_the_chain_s_own():
    """masses(first), gaps(first): the first of the chain's own numbers, drawn for those alone
    (preflight's sample of a long chain), defect included."""
    chain = make_case(particles=50, chain={"mass_disorder": 0.1, "r0_disorder": 0.05, "seed": 4,
                                           "defect_index": 6, "defect_mass": 2.5}).chain
    np.testing.assert_array_equal(chain.masses(7), chain.masses()[:7])
    np.testing.assert_array_equal(chain.gaps(7), chain.gaps()[:7])
    assert chain.masses(7)[5] == 2.5 and chain.masses(5).shape == (5,)


def test_data_file_carries_disorder_and_velocities():
    case = make_case(particles=6, chain={"thermal_velocity": 0.1, "r0_disorder": 0.05, "mass_disorder": 0.05, "seed": 1})
    text = data_text(case)
    atoms = text.split("Atoms # bond\n\n")[1].split("\n\n")[0].splitlines()
    x = np.array([float(line.split()[3]) for line in atoms])
    np.testing.assert_allclose(x * 1e3, case.chain.positions(), rtol=1e-15, atol=1e-12)
    # mass disorder: every magnet its own mass (deck.per_atom_masses), one atom type
    assert {line.split()[2] for line in atoms} == {"1"}
    magnet_masses = text.split("MagnetMasses\n\n")[1].split("\n\n")[0].splitlines()
    m = np.array([float(line.split()[1]) for line in magnet_masses])
    np.testing.assert_allclose(m * 1e3, case.chain.masses(), rtol=1e-15)
    vel = text.split("Velocities\n\n")[1].strip().splitlines()
    np.testing.assert_allclose([float(line.split()[1]) for line in vel], case.chain.velocities(), rtol=1e-15)
    assert "Velocities" not in data_text(make_case(particles=6))


def test_round_trip_through_case_to_dict():
    case = make_case(particles=9, chain={"thermal_velocity": 0.01, "mass_disorder": 0.02, "disorder": "uniform",
                                         "defect_index": 3, "defect_r0": 10.0, "seed": 11})
    assert case_from_dict(case_to_dict(case)) == case
    assert "seed" not in case_to_dict(make_case())["chain"]  # a plain chain writes no ensemble fields


@pytest.mark.parametrize(
    "values, field, expected",
    [
        ({"thermal_velocity": 0.1}, "chain.seed", "required when thermal_velocity"),
        ({"thermal_velocity": -0.1, "seed": 1}, "chain.thermal_velocity", "expected >= 0"),
        ({"mass_disorder": 0.1, "seed": -1}, "chain.seed", "expected an integer in [0, 2**63 - 1]"),
        # (it said "expected an integer >= 0" of a seed above the range)
        ({"mass_disorder": 0.1, "seed": 2**63}, "chain.seed", "got 9223372036854775808; expected an integer in [0, 2**63 - 1]"),
        ({"mass_disorder": 0.7, "disorder": "uniform", "seed": 1}, "chain.mass_disorder", "expected < 0.5774"),
        ({"mass_disorder": 0.1, "disorder": "lognormal", "seed": 1}, "chain.disorder", "choose one of normal, uniform"),
        ({"r0_disorder": 0.6, "seed": 2}, "chain.r0_disorder", "a draw gave a value <= 0"),
        ({"defect_index": 31, "defect_mass": 2.0}, "chain.defect_index", "expected an integer in [1, 30]"),
        ({"defect_index": 30, "defect_r0": 2.0}, "chain.defect_index", "expected an integer in [1, 29]"),
        ({"defect_mass": 2.0}, "chain.defect_index", "missing; required with chain.defect_mass"),
        ({"defect_index": 3}, "chain.defect_index", "without chain.defect_mass"),
        ({"defect_index": 3, "defect_mass": 0.0}, "chain.defect_mass", "got 0.0 g; expected > 0"),  # a massless magnet
        ({"defect_index": 3, "defect_r0": 0.0}, "chain.defect_r0", "got 0.0 mm; expected > 0"),  # magnets in contact
        ({"particles": 3, "thermal_velocity": 0.1, "seed": 1}, "chain.thermal_velocity", "needs at least 2 free magnets"),
        # an RMS speed that crosses the 12 mm gap in exactly one step of 0.0625 ms
        ({"thermal_velocity": 192.0, "seed": 1}, "chain.thermal_velocity", "expected >= 0 and < 192 m/s"),
    ],
)
def test_bad_ensemble_fields_name_the_field(values, field, expected):
    with pytest.raises(ConfigError) as info:
        make_case(chain=values, dt=0.0625, interval=0.125, duration=10.0)
    assert info.value.field == field
    assert expected in str(info.value)


def test_ensemble_fields_of_zero_are_the_plain_chain():
    """A sweep over disorder or temperature starts at 0 (`chain.mass_disorder = [0.0, 0.1]`):
    zero widths are taken, and give the nominal masses and gaps and a chain at rest; an RMS
    speed just under a gap per step (191 m/s x 0.0625 ms = 11.94 mm < 12 mm) is taken too."""
    zero = make_case(chain={"thermal_velocity": 0.0, "mass_disorder": 0.0, "r0_disorder": 0.0, "seed": 1})
    np.testing.assert_array_equal(zero.chain.masses(), np.full(30, 1.084))
    np.testing.assert_array_equal(zero.chain.gaps(), np.full(29, 12.0))
    assert not np.any(zero.chain.velocities())
    fast = make_case(chain={"thermal_velocity": 191.0, "seed": 1}, dt=0.0625, interval=0.125, duration=10.0)
    assert fast.chain.thermal_velocity == 191.0


@pytest.mark.lammps
def test_thermal_chain_in_the_engine_shares_its_energy_equally(tmp_path):
    """Equipartition (virial theorem) as an independent check of the thermal start.

    21 magnets, both ends held, at rest at equal gaps (an equilibrium), free magnets given
    thermal velocities: all energy starts kinetic. For small oscillations every normal mode
    spends on average half its energy as kinetic energy, so the time average of KE over
    T = 2 s is E/2 = KE(0)/2. Errors: the slowest mode (omega ~ 42 rad/s) averaged over
    omega T ~ 84 rad, at most about 1/(omega T) ~ 1 %; anharmonicity at strains ~ 1e-2, ~1 %
    at most. Tolerance 1 % (measured 0.013 %); a start that put energy elsewhere fails."""
    from pylmp_lattice.run_folder import simulate

    case = make_case(particles=21, duration=2000.0, dt=0.05, interval=1.0, impactor={"profile": "rest"},
                     chain={"thermal_velocity": 0.01, "seed": 4})
    traj = simulate(case, tmp_path)
    m = case.chain.masses() * 1e-3  # kg
    ke = 0.5 * np.sum(m * traj.v**2, axis=1) * 1e3  # mJ
    np.testing.assert_allclose(traj.v[0], case.chain.velocities(), rtol=1e-9, atol=1e-15)
    assert np.mean(ke) / ke[0] == pytest.approx(0.5, abs=0.01)
    assert np.min(ke) < 0.3 * ke[0]  # energy really moves into the springs and back (measured 0.15)


@pytest.mark.parametrize("draws", [False, True])
def test_a_replica_reseeded_by_a_worker_is_checked_as_its_case_built_afresh(draws):
    """`spec._reseeded` (a sweep worker's replica of a point: the template's case with another
    seed; `draws`: its masses and gaps drawn with the point's other replicas) against
    `dataclasses.replace` (every check again): the same masses, gaps, velocities and extremes,
    and the same refusal where the seed's draw makes the case invalid: a mass <= 0 (wide normal
    disorder) or a magnet so light that run.dt passes its stability limit."""
    import dataclasses

    from pylmp_lattice.case.chain import replica_draws
    from pylmp_lattice.sweep.spec import _reseeded

    template = make_case(particles=21, chain={"mass_disorder": 0.4, "r0_disorder": 0.1, "thermal_velocity": 0.02,
                                              "seed": 3}, run={"dt": 0.1})
    seeds = list(range(100, 400))
    masses, gaps = replica_draws(template.chain, seeds)
    outcomes = set()
    for k, seed in enumerate(seeds):
        try:
            want = dataclasses.replace(template, chain=dataclasses.replace(template.chain, seed=seed))
        except ConfigError as err:
            want = err
        try:
            got = _reseeded(template, seed, {"masses": masses[k], "gaps": gaps[k]} if draws else None)
        except ConfigError as err:
            got = err
        if isinstance(want, ConfigError):
            assert isinstance(got, ConfigError) and (got.field, str(got)) == (want.field, str(want)), seed
            outcomes.add(want.field)
            continue
        assert got == want and got._extremes == want._extremes
        for draw in (Chain.masses, Chain.gaps, Chain.velocities):
            assert draw(got.chain).tobytes() == draw(want.chain).tobytes()
        outcomes.add("valid")
    assert outcomes == {"valid", "chain.mass_disorder", "run.dt"}  # every branch met
