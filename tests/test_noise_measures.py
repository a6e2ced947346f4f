"""Front measures that hold under noise: the levels (measures.levels), the chain's noise velocity,
the flagged gaps, and the binding test of the engine's record against the array measures on
noisy runs."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest

from pylmp_lattice import measures
from pylmp_lattice.case_measures import case_front, chain_noise, chain_noises, read_front_record
from pylmp_lattice.deck import render
from pylmp_lattice.serialize import dumps
from pylmp_lattice.run_folder import simulate
from pylmp_lattice.formats.layout import FRONT_BIN
from pylmp_lattice.summary import summary_of

from conftest import make_case

FRICTION = {"mu": 0.285, "p": 0.012}
PULSE = {"profile": "sine", "velocity": 2.0, "duration": 10.0}
NOISY = {"thermal_velocity": 0.1, "r0_disorder": 0.01, "seed": 7}  # 5 % of V_I = 2 m/s


def test_levels_without_noise_are_the_fractions_of_V_I():
    lv = measures.front_levels(2.0)
    assert (lv.start, lv.front, lv.drop, lv.pulse_drop, lv.pulse_floor) == (0.02, 1.0, 0.1, 0.1, 0.0)


def test_levels_rise_with_the_noise_as_multiples_of_sigma():
    lv = measures.front_levels(2.0, noise=0.1)
    assert lv.start == pytest.approx(0.5) and lv.front == 1.0  # 5 sigma; V_I/2 is larger
    assert lv.drop == pytest.approx(0.3) and lv.pulse_floor == pytest.approx(0.3)  # 3 sigma
    with pytest.raises(ValueError, match="noise: got -1"):
        measures.front_levels(2.0, noise=-1.0)


def test_noise_velocity_of_a_harmonic_chain_is_its_energy_above_rest():
    """Linear spring U = k (r_free - r)^2 / 2: the disorder's energy is k/2 sum (r_n - mean r)^2
    exactly, so sigma^2 = (sum m v^2 + k sum (r_n - mean)^2) / sum m over the free magnets."""
    rng = np.random.default_rng(1)
    m, v, r = 1.0 + 0.1 * rng.random(12), rng.normal(0, 0.05, 12), 10.0 + 0.2 * rng.standard_normal(11)
    free = np.r_[False, np.ones(10, bool), False]
    v[~free] = 0.0
    k = 0.5
    energy = lambda x: 0.5 * k * (30.0 - np.asarray(x)) ** 2  # noqa: E731
    expected = np.sqrt((np.sum(m * v**2) + k * np.sum((r - r.mean()) ** 2)) / m[free].sum())
    assert measures.noise_velocity(m, v, r, energy, free) == pytest.approx(expected, rel=1e-12)
    assert measures.noise_velocity(m, 0 * v, np.full(11, 10.0), energy, free) == 0.0  # mass disorder alone


@pytest.mark.parametrize("law", [None, {"law": "toda", "A": 1.0, "B": 0.5, "a": 12.0}])
def test_noise_velocities_of_a_batch_are_those_of_each_chain_alone(law):
    """chain_noises over 40 disordered thermal chains gives each chain's chain_noise bit for bit
    (rows of C-ordered arrays, each reduced as a 1-D array), and the levels of each, as arrays."""
    cases = [make_case(particles=300, chain={"thermal_velocity": 0.02, "r0_disorder": 0.05, "mass_disorder": 0.05,
                                             "seed": seed}, **({"force": law} if law else {})) for seed in range(40)]
    batch = chain_noises(cases)
    alone = np.array([chain_noise(case) for case in cases])
    assert batch.view(np.uint64).tolist() == alone.view(np.uint64).tolist() and len(set(alone)) == 40
    levels = measures.front_levels(2.0, batch)
    for k in (0, 17):
        one = measures.front_levels(2.0, alone[k])
        assert [levels.start[k], levels.front[k], levels.drop[k], levels.pulse_floor[k]] == \
            [one.start, one.front, one.drop, one.pulse_floor]


def test_a_batch_s_chain_draws_are_each_chain_s_own():
    """chain_draws (the chains a sweep's batch draws once for its engine and measures): row r is
    case r's masses, gaps, velocities and positions bit for bit, and the summaries' per-point
    shortcut (`summary._points`) groups replicas of one point and nothing else."""
    from pylmp_lattice.case_measures import chain_draws
    from pylmp_lattice.summary import _points

    first = make_case(particles=25, chain={"thermal_velocity": 0.02, "r0_disorder": 0.05, "mass_disorder": 0.05,
                                            "seed": 0})
    cases = [dataclasses.replace(first, chain=dataclasses.replace(first.chain, seed=s)) for s in range(12)]
    other = make_case(particles=25, chain={"thermal_velocity": 0.03, "seed": 1})  # an equal N, another point
    draws = chain_draws([*cases, other])
    for r, case in enumerate([*cases, other]):
        for name in ("masses", "gaps", "velocities", "positions"):
            got, want = getattr(draws, name)[r], getattr(case.chain, name)()
            assert got.view(np.uint64).tolist() == want.view(np.uint64).tolist(), (r, name)
    assert len({tuple(row) for row in draws.velocities.tolist()}) == 13
    thermal = [dataclasses.replace(other, chain=dataclasses.replace(other.chain, seed=s)) for s in range(12)]
    together = chain_draws(thermal)  # masses and gaps drawn once, the velocities of all rows together
    for r, case in enumerate(thermal):
        for name in ("masses", "gaps", "velocities", "positions"):
            got, want = getattr(together, name)[r], getattr(case.chain, name)()
            assert got.view(np.uint64).tolist() == want.view(np.uint64).tolist(), (r, name)
    assert _points(["a"] * 6 + ["b"] + ["a"] * 6) == [[*range(6), *range(7, 13)], [6]]  # by key, in order


def test_noise_velocity_of_a_thermal_chain_is_its_rms_velocity():
    case = make_case(particles=200, chain={"thermal_velocity": 0.05, "seed": 3})
    v = case.chain.velocities()[1:-1]
    assert chain_noise(case) == pytest.approx(np.sqrt(np.mean(v**2)), rel=1e-12)
    assert chain_noise(case) == pytest.approx(0.05, rel=0.15)  # the draw's RMS scatters about the nominal
    assert chain_noise(make_case()) == 0.0


def test_thermal_motion_is_not_a_start_of_motion():
    """A magnet moving at 0.1 m/s before a front of 2 m/s arrives: with the noise-blind levels
    (start 0.02 m/s) it 'starts' at t = 0 and its pulse 'arrives' at a thermal maximum; with
    sigma = 0.1 m/s both wait for the front."""
    t = np.linspace(0, 40, 4001)
    thermal = 0.1 * np.sin(2 * np.pi * t / 7.0)
    pulse = 2.0 * np.exp(-((t - 25.0) / 2.0) ** 2)
    v = (thermal + pulse)[:, None]
    blind = measures.arrival_times(t, v, 2.0, method="velocity_peak")
    robust = measures.arrival_times(t, v, 2.0, method="velocity_peak", noise=0.1)
    assert blind[0] < 5.0 and robust[0] == pytest.approx(25.0, abs=0.1)
    peaks = measures.first_peaks(t, v, np.gradient(v, t, axis=0), 2.0, noise=0.1)
    assert peaks.start_time[0] > 20.0


def test_gaps_out_of_order_or_slower_than_linear_waves_are_flagged_not_averaged():
    arrival = np.array([0.0, 3.0, 6.0, 5.5, 9.0, 20.0, 23.0, 26.0, 29.0])
    peaks = measures.FirstPeaks(*(np.full(9, np.nan),) * 4)
    front = measures.Front(arrival, measures.propagation_velocity(arrival, 12.0), peaks,
                           slowest_linear_speed=1.6)
    np.testing.assert_array_equal(np.flatnonzero(front.out_of_order), [2])  # gap 3: magnet 4 before 3
    np.testing.assert_array_equal(np.flatnonzero(front.below_linear_speed), [4])  # 12 mm in 11 ms
    assert np.isnan(front.accepted_velocity[[2, 4]]).all() and np.isfinite(front.accepted_velocity).sum() == 6
    assert front.flags()["out_of_order_gaps"] == [3] and front.flags()["below_linear_speed_gaps"] == [5]


def test_summary_has_no_inf_where_arrivals_coincide():
    """Two magnets moving at t[0] gave V_P = inf over their gap, and shock_velocity_max inf in
    the table (null in summary.json); the gap is now out of order, and no number is infinite."""
    case = make_case(particles=10)
    arrival = np.array([0.0, 0.0, 3.0, 6.0, 9.0, 12.0, 15.0, 18.0, 21.0, np.nan])
    peaks = measures.FirstPeaks(*(np.full(10, 3.9),) * 4)
    vp = measures.propagation_velocity(arrival, case.chain.gaps())
    front = measures.Front(arrival, vp, peaks, slowest_linear_speed=1.6)
    assert np.isinf(vp[0])
    summary = summary_of(case, front)
    assert summary["shock_velocity_max_m_per_s"] == {"value": 4.0, "gap": 2}
    assert summary["front_flags"]["out_of_order_gaps"] == [1]
    json.loads(dumps(summary), parse_constant=lambda c: pytest.fail(f"{c} in the summary"))


def test_plateau_of_a_noisy_series_converges_within_its_standard_error():
    """A flat series with 1 % scatter per value, window of 3 values (12 values): its drift is
    about its standard error (median ratio 0.67 for a Gaussian; the error is itself estimated
    from 4 second differences), so it is a plateau in 96 % of draws (measured over 2000), where
    a 1 % tolerance alone accepts 53 %. A series growing by 5 % across its window, without
    scatter, is not a plateau."""
    rng = np.random.default_rng(0)
    calls = [measures.trailing_plateau(3.6 * (1 + 0.01 * rng.standard_normal(12))) for _ in range(1000)]
    assert np.mean([p.converged() for p in calls]) > 0.93
    assert np.mean([abs(p.drift) <= 0.01 for p in calls]) < 0.6
    assert np.median([abs(p.drift) / p.drift_stderr for p in calls]) == pytest.approx(0.67, abs=0.15)
    growing = measures.trailing_plateau(np.linspace(3.0, 3.6, 12))
    assert growing.drift_stderr == pytest.approx(0.0, abs=1e-12) and not growing.converged()


def test_a_series_that_scatters_widely_is_no_plateau_whatever_its_drift_stderr():
    """V_P from frames far coarser than a gap's crossing (a main-job run with frames every 10 ms,
    3 ms per gap: drift -203 %, standard error 102 %) scatters by about its mean, so its drift
    lies within three of its huge standard errors: no level, not converged. V_P in a thermal
    chain at 10 % of V_I scatters by 8.5 % per gap and stays a plateau; at 25 % it is none."""
    rng = np.random.default_rng(1)
    wild = measures.trailing_plateau(np.abs(7.0 + 6.5 * rng.standard_normal(200)))
    assert wild.std > 0.5 * wild.mean and abs(wild.drift) <= 3 * wild.drift_stderr and not wild.converged()
    thermal = measures.trailing_plateau(3.9 * (1 + 0.085 * rng.standard_normal(200)))
    scatter = measures.trailing_plateau(3.9 * (1 + 0.25 * rng.standard_normal(200)))
    assert thermal.converged() and abs(scatter.drift) <= 3 * scatter.drift_stderr and not scatter.converged()


def test_deck_passes_the_noise_levels_to_the_record():
    deck = render(make_case(impactor=PULSE, chain=NOISY))["in.lattice"]
    sigma = chain_noise(make_case(impactor=PULSE, chain=NOISY))
    line = next(x for x in deck.splitlines() if "lattice/front" in x)
    values = dict(zip(line.split()[4::2], map(float, line.split()[5::2])))
    assert values["start"] == pytest.approx(5 * sigma) and values["pulse_floor"] == pytest.approx(3 * sigma)
    assert values["front"] == pytest.approx(1.0) and values["drop"] == pytest.approx(max(0.1, 3 * sigma))
    assert "pulse_floor" not in render(make_case(impactor=PULSE))["in.lattice"]


@pytest.mark.lammps
@pytest.mark.parametrize("sections, method", [
    ({}, "level"), ({"friction": FRICTION}, "level"), ({"impactor": PULSE}, "velocity_peak"),
    ({"impactor": PULSE, "friction": FRICTION}, "velocity_peak"),
], ids=["constant", "constant-friction", "pulse", "pulse-friction"])
def test_record_equals_the_array_measures_on_noisy_runs(tmp_path, sections, method):
    """The binding test of the one definition: on a chain with thermal motion (5 % of V_I) and
    gap disorder, sampled at every step, the engine's record and the array measures agree to
    1e-9; and the noise matters: with noise-blind levels the arrays would start most magnets at
    t = 0."""
    case = make_case(particles=40, duration=40.0, interval=0.01, chain=NOISY, **sections)
    traj = simulate(case, tmp_path)
    arrays = case_front(case, traj.t, traj.v, traj.a, method)
    record = read_front_record(case, tmp_path / FRONT_BIN, method).front
    assert record.noise == arrays.noise == chain_noise(case) > 0.05
    assert np.sum(np.isfinite(record.peaks.peak_velocity)) >= 8 and np.sum(np.isfinite(record.arrival)) >= 8
    p, q = arrays.peaks, record.peaks
    for a, b in ((arrays.arrival, record.arrival), (p.start_time, q.start_time), (p.peak_time, q.peak_time),
                 (p.peak_velocity, q.peak_velocity), (p.peak_acceleration, q.peak_acceleration)):
        np.testing.assert_array_equal(np.isnan(a), np.isnan(b))
        np.testing.assert_allclose(b, a, rtol=1e-9, atol=1e-12)
    np.testing.assert_array_equal(record.out_of_order, arrays.out_of_order)
    blind = measures.first_peaks(traj.t, traj.v, traj.a, 2.0)
    assert np.sum(blind.start_time[1:] == traj.t[0]) > 10
    assert not np.any(record.peaks.start_time[1:] == traj.t[0])


@pytest.mark.parametrize("signal", ["sine", "noisy", "ramp", "quiet"])
def test_one_signal_against_many_noise_levels_is_each_column_alone(signal):
    """A drive shared by C chains is measured once against their C noise velocities (one
    column, searchsorted crossings, grouped falls): bit for bit each column of the general
    (n_frames, C) path, for every arrival method and the first peaks."""
    rng = np.random.default_rng(11)
    t = np.arange(4001) * 0.0125
    v = {"sine": 2.0 * np.sin(np.pi * t / 30.0) * (t < 30.0),
         "noisy": np.sin(np.pi * t / 20.0) + 0.3 * np.sin(7 * t) + 0.05 * rng.standard_normal(t.size),
         "ramp": np.minimum(t / 5.0, 1.0) * 2.0,
         "quiet": 0.01 * np.sin(t)}[signal]
    a = np.gradient(v, t) * 1e3
    noise = np.concatenate([[0.0, 0.0], rng.uniform(0, 0.6, 40), [0.02, 0.02]])
    wide = np.ascontiguousarray(np.repeat(v[:, None], noise.size, axis=1)), np.repeat(a[:, None], noise.size, axis=1)
    one = measures.first_peaks(t, v[:, None], a[:, None], 2.0, noise=noise)
    each = measures.first_peaks(t, *wide, 2.0, noise=noise)
    for name in ("start_time", "peak_time", "peak_velocity", "peak_acceleration"):
        np.testing.assert_array_equal(getattr(one, name), getattr(each, name), err_msg=name)
    for method in measures.ARRIVAL_METHODS:
        np.testing.assert_array_equal(measures.arrival_times(t, v[:, None], 2.0, method=method, a=a[:, None], noise=noise),
                                      measures.arrival_times(t, wide[0], 2.0, method=method, a=wide[1], noise=noise),
                                      err_msg=method)
    found = {"sine": one.peak_time, "noisy": one.peak_time, "ramp": one.start_time, "quiet": one.start_time}[signal]
    # levels above the signal (5 sigma > 2 m/s) find nothing: both kinds of column are checked
    count = np.isfinite(found).sum()
    assert count == 0 if signal == "quiet" else 10 < count < noise.size
