"""The run summary: strict JSON, plateau wording, friction energy."""

from __future__ import annotations

import json
import logging
import math

import numpy as np
import pytest

from pylmp_lattice import measures
from pylmp_lattice.run_folder import RunFolder, run_case
from pylmp_lattice.serialize import dumps
from pylmp_lattice.columnar import rows
from pylmp_lattice.summary import _plateaus, _round, _rounds, summary_of

from conftest import make_case


def _strict(text: str):
    def refuse(token):
        raise ValueError(f"not strict JSON: {token}")

    return json.loads(text, parse_constant=refuse)


@pytest.mark.lammps
def test_summary_is_strict_json_when_vp_is_undefined(tmp_path):
    """A short pulse seen for 5 ms: the front crosses 1-2 gaps, too few for a V_P plateau."""
    case = make_case(particles=10, duration=5.0, impactor={"profile": "sine", "velocity": 2.0, "duration": 2.0})
    run_case(case, tmp_path / "run")
    summary = _strict((tmp_path / "run" / "summary.json").read_text())
    plateau = summary["shock_velocity_plateau_m_per_s"]
    assert plateau["mean"] is None and plateau["converged"] is False
    assert plateau["first_gap"] is None and plateau["last_gap"] is None
    assert summary["first_peak_velocity_over_V_I"] is None


def test_plateau_says_whether_it_converged_and_which_way_it_drifts():
    gaps = np.arange(1, 201)
    steady = measures.trailing_plateau(3.9 + 1e-4 * np.sin(gaps))
    decaying = measures.trailing_plateau(3.9 - 0.004 * gaps)  # loses 0.2 of 3.9 m/s over the last 50
    growing = measures.trailing_plateau(3.0 + 0.004 * gaps)
    s, d, g = rows(_plateaus(measures.Plateaus.of([steady, decaying, growing]), [True] * 3))
    assert (s["converged"], s["trend"]) == (True, "steady") and (s["first_gap"], s["last_gap"]) == (151, 200)
    assert (d["converged"], d["trend"]) == (False, "decaying") and d["relative_drift"] < -0.01
    assert (g["converged"], g["trend"]) == (False, "growing")


def test_small_numbers_keep_three_significant_figures_and_others_their_decimals():
    """The trial's thermal-free plateau: a drift's standard error of 1.09e-6 was written as 0.0
    (5 decimals); it stays 1.09e-6 (3 significant figures), while a V_P of 3.9012345 m/s keeps
    its 5 decimals (3.90123) as before."""
    p = measures.Plateau(3.9012345, 4.2345e-6, 2.01e-4, 1, 50, drift_stderr=1.0912e-6)
    d = rows(_plateaus(measures.Plateaus.of([p]), [True]))[0]
    assert d["relative_drift_stderr"] == pytest.approx(1.09e-6, rel=1e-12)
    assert d["std"] == pytest.approx(4.23e-6, rel=1e-12)
    assert d["relative_drift"] == pytest.approx(2.01e-4, rel=1e-12) and d["mean"] == 3.90123
    assert _round(np.float64(1e-310), 5) == 1e-310  # numpy's round of a subnormal gave NaN


def test_rounding_without_the_logarithm_is_the_rounding_with_it():
    """`_round`'s short way (|x| well above 10**(significant - 1 - decimals): `decimals` alone) gives
    what the logarithm's way gives, bit for bit: values of every size, around the powers of ten
    within a few ulps, and 0, -0, inf, nan, subnormals; and so does `_rounds`, a column at a time."""
    def by_logarithm(x, decimals, significant=3):
        x = float(x)
        if x == 0 or not math.isfinite(x):
            return round(x, decimals)
        digits = significant - 1 - math.floor(math.log10(abs(x)))
        return round(x, digits if digits > decimals else decimals)

    rng = np.random.default_rng(3)
    values = [*(rng.choice([-1, 1], 20000) * 10 ** rng.uniform(-12, 6, 20000)).tolist(), 0.0, -0.0, math.inf,
              -math.inf, math.nan, 5e-324, 1e-310, 1.7976931348623157e308]
    for k in range(-8, 3):
        for x in (10.0**k, float(f"1e{k}")):
            values += (x + np.arange(-4, 5) * np.spacing(x)).tolist()
            values += [-x, *(x * (1 + np.array([-1, 1])[:, None] * 10.0 ** -np.arange(1, 12))).ravel().tolist()]
            values += (x * rng.uniform(0.99, 1.01, 200)).tolist()
    for decimals in (4, 5, 6):  # ties and near-ties of each: the array way steps aside there
        half = (np.arange(-3000, 3000) + 0.5) / 10.0**decimals
        values += [*half.tolist(), *np.nextafter(half, np.inf).tolist(), *np.nextafter(half, -np.inf).tolist(),
                   *(half * 10.0 ** rng.integers(-3, 4, half.size)).tolist()]
    values += [2.675, 0.125, 0.375, -2.5e-5, 1.00005, 2**52 + 0.5, 2.0**60, 1e22, 123456.78905]
    for decimals in (4, 5, 6):
        for significant in (1, 3, 5):
            got = [_round(v, decimals, significant) for v in values]
            want = [by_logarithm(v, decimals, significant) for v in values]
            assert np.array_equal(np.array(got).view(np.int64), np.array(want).view(np.int64))
            if significant == 3:  # the summaries' (SIGNIFICANT)
                column = _rounds(values, decimals)
                assert set(map(type, column)) == {float}
                assert np.array_equal(np.array(column).view(np.int64), np.array(want).view(np.int64))


def test_summary_writer_writes_null_for_values_that_are_not_finite():
    text = dumps({"a": float("nan"), "b": [1.0, float("inf")], "c": {"d": -float("inf")}, "e": 2})
    assert _strict(text) == {"a": None, "b": [1.0, None], "c": {"d": None}, "e": 2}


@pytest.mark.lammps
def test_friction_dissipated_energy_is_in_the_summary(tmp_path):
    """The calibration rig (Fig. S4: left magnet held, right one pushed off from 1.8 mm): the
    energy friction took is the potential plus kinetic energy lost, from the trajectory."""
    case = make_case(particles=3, duration=200.0, dt=0.002, interval=1.0, chain={"r0": [1.8, 28.3]},
                     impactor={"profile": "rest"}, friction={"mu": 0.285, "p": 0.012},
                     table={"r_max": 30.1, "points": 100000})
    summary = run_case(case, tmp_path / "rig")
    assert summary == _strict((tmp_path / "rig" / "summary.json").read_text())
    traj = RunFolder(tmp_path / "rig").trajectory()
    energy = case.force.energy(traj.gaps()).sum(axis=1) + 0.5 * np.sum(case.chain.masses() * traj.v ** 2, axis=1)
    assert summary["friction_dissipated_energy_mJ"] == pytest.approx(energy[0] - energy[-1], rel=1e-5)


def _frames_of_a_steady_front(case, interval: float):
    """A front at 4 m/s (12 mm gaps: 3 ms each) that sets each magnet moving at 2 m/s within
    ~0.5 ms, seen in frames every `interval` ms: the measures from those frames."""
    t = np.arange(0.0, 3.0 * case.chain.particles + interval, interval)
    arrival = 3.0 * np.arange(case.chain.particles)
    v = 1.0 + np.tanh((t[:, None] - arrival) / 0.25)
    return measures.front(t, v, np.gradient(v, t, axis=0), 2.0, case.chain.gaps(), slowest_linear_speed=1.6)


def test_v_p_from_frames_too_coarse_for_the_gaps_is_flagged_not_converged(caplog):
    """Frames every 0.25 ms resolve a 3 ms gap crossing: V_P 4 m/s within 0.1 %, converged.
    Frames every 10 ms (0.3 per gap, as the main job with run.output_interval = 10 and no
    engine record gave 7.24 m/s 'converged' for 3.91) do not: the summary says so, the plateau
    is not converged, and a warning names run.output_interval and output.front."""
    case = make_case(particles=60)
    fine = summary_of(case, _frames_of_a_steady_front(case, 0.25))
    plateau = fine["shock_velocity_plateau_m_per_s"]
    assert plateau["mean"] == pytest.approx(4.0, rel=1e-3) and plateau["converged"] is True
    assert fine["front_resolution"]["resolved"] is True and fine["front_resolution"]["frames_per_gap"] == pytest.approx(12)
    assert fine["front_resolution"]["source"] == "frames"
    with caplog.at_level("WARNING"):
        coarse = summary_of(case, _frames_of_a_steady_front(case, 10.0))
    plateau = coarse["shock_velocity_plateau_m_per_s"]
    assert (plateau["converged"], plateau["trend"]) == (False, "unresolved")
    res = coarse["front_resolution"]
    assert res["resolved"] is False and res["frames_per_gap"] == pytest.approx(0.3, rel=0.05)
    assert res["max_sample_interval_ms"] == pytest.approx(1.5, rel=0.05)
    assert "run.output_interval" in caplog.text and "output.front" in caplog.text
    json.loads(dumps(coarse), parse_constant=lambda c: pytest.fail(f"{c} in the summary"))


def test_front_speed_is_fitted_over_a_window_set_by_the_case_with_no_plateau_criterion():
    """`front_speed_m_per_s`: over gaps 24-48 of a 60-magnet chain run 400 ms (the second half
    of the gaps a wave at 0.9 V0 crosses: V0 = r0 sqrt(q K / (r0 + b)^(q+1) / m) = 1.6029 m/s,
    0.9 V0 400 ms / 12 mm = 48.1 gaps), the least-squares slope of the arrival times against the
    positions, checked against scipy's linregress; an accelerating front with a per-gap scatter
    of 30 % (no plateau) still has one; a front that stopped inside the window has none."""
    from scipy import stats

    from pylmp_lattice.summary import front_window, summaries

    case = make_case(particles=60, duration=400.0)
    v0 = 12.0 * np.sqrt(3 * 413.8 / (12.0 + 3.917) ** 4 / 1.084)
    assert v0 == pytest.approx(1.6029, abs=1e-4) and int(0.9 * v0 * 400 / 12) == 48
    assert front_window(case) == (24, 48)
    rng = np.random.default_rng(7)
    x = 12.0 * np.arange(60)
    steps = 12.0 / (3.0 + 0.01 * np.arange(59)) * (1 + 0.3 * rng.standard_normal(59)).clip(0.3)  # ms per gap
    arrival = np.concatenate([[0.0], np.cumsum(steps)])
    stopped = np.where(np.arange(60) < 40, arrival, np.nan)  # never reached magnet 41
    front = measures.stack_fronts([
        measures.Front(t, measures.propagation_velocity(t, 12.0), measures.first_peaks(
            np.array([0.0, 1.0]), np.zeros((2, 60)), np.zeros((2, 60)), 2.0), "level", 0.0, 1.6, 0.0)
        for t in (arrival, stopped)])
    out = summaries([case, case], front)
    line = stats.linregress(x[23:49], arrival[23:49])  # magnets 24-49: gaps 24-48
    speed = out[0]["front_speed_m_per_s"]
    assert speed["value"] == pytest.approx(1 / line.slope, rel=1e-4)
    assert speed["stderr"] == pytest.approx(line.stderr / line.slope**2, rel=1e-2)
    assert (speed["first_gap"], speed["last_gap"]) == (24, 48)
    assert out[0]["shock_velocity_plateau_m_per_s"]["converged"] is False  # no plateau, a speed all the same
    assert out[1]["front_speed_m_per_s"]["value"] is None or np.isnan(out[1]["front_speed_m_per_s"]["value"])
    json.loads(dumps(out[1]), parse_constant=lambda c: pytest.fail(f"{c} in the summary"))
    assert front_window(make_case(particles=60, duration=20.0)) is None  # 2.4 gaps: no window
    assert front_window(make_case(particles=21, duration=400.0)) == (10, 19)  # up to the last free magnet, 20


def test_lab_frame_front_speed_counts_the_magnet_length():
    """A front crossing each 12 mm gap in 12/4.18 ms (4.18 m/s in the gap frame) with magnets
    L = 6.35 mm long: over magnets 2-12 (lab_window of 21 magnets) the centres are 10 x 18.35 =
    183.5 mm apart and the front takes 10 x 12/4.18 ms, so 183.5 / (120/4.18) = 6.3919 m/s,
    with the gap-frame 4.18 beside it; a case without magnet_length has no lab-frame speed."""
    from pylmp_lattice.summary import summaries

    arrival = 12.0 / 4.18 * np.arange(21.0)
    arrival[20] = np.nan  # the fixed magnet 21 never moves
    front = measures.stack_fronts([measures.Front(arrival, measures.propagation_velocity(arrival, 12.0),
                                                  measures.first_peaks(np.array([0.0, 1.0]), np.zeros((2, 21)),
                                                                       np.zeros((2, 21)), 2.0), "level", 0.0, 1.6, 0.0)])
    lab = summaries([make_case(particles=21, chain={"magnet_length": 6.35})], front)[0]["front_speed_lab_m_per_s"]
    assert lab["magnets"] == [2, 12] and lab["pitch_mm"] == pytest.approx(18.35, abs=1e-9)
    assert lab["value"] == pytest.approx(183.5 / (120 / 4.18), rel=1e-5)
    assert lab["gap_frame_m_per_s"] == pytest.approx(4.18, rel=1e-5)
    assert "front_speed_lab_m_per_s" not in summaries([make_case(particles=21)], front)[0]


@pytest.mark.parametrize("particles, window", [(3, None), (4, None), (5, [2, 4])])
def test_a_short_chain_s_lab_window_holds_three_magnets_or_is_left_out(particles, window):
    """Magnets 2 .. 2 + (N-1)//2: under 3 magnets (N < 5) no slope with an error, so no
    lab-frame speed (N = 3 and 4 raised ValueError in fit_front_speeds before)."""
    from pylmp_lattice.summary import summaries

    arrival = 12.0 / 4.18 * np.arange(float(particles))
    arrival[-1] = np.nan
    peaks = measures.first_peaks(np.array([0.0, 1.0]), np.zeros((2, particles)), np.zeros((2, particles)), 2.0)
    front = measures.stack_fronts([measures.Front(arrival, measures.propagation_velocity(arrival, 12.0), peaks,
                                                  "level", 0.0, 1.6, 0.0)])
    summary = summaries([make_case(particles=particles, chain={"magnet_length": 6.35})], front)[0]
    lab = summary.get("front_speed_lab_m_per_s")
    assert (lab and lab["magnets"]) == window
    if window:
        assert lab["value"] == pytest.approx(18.35 / (12 / 4.18), abs=1e-5)  # 5 decimals


def test_a_batch_s_summary_columns_are_its_summaries_as_columns_and_each_the_case_s_alone():
    """summary_columns, made a key at a time (no dict per member), is `columnar.columns` of the
    batch's summaries, and each summary is the case's alone: for a batch of one point (a
    sweep's task: columns all through) and one of points with and without magnet_length, a
    chain whose front never left the impactor (no V_P: null maximum and fit) and a long far
    end beside fixed ones (keys some summaries lack: a list of summaries)."""
    from pylmp_lattice.columnar import columns
    from pylmp_lattice.summary import summaries, summary_columns

    def front_of(arrival):
        peaks = measures.first_peaks(np.array([0.0, 1.0]), np.zeros((2, 21)), np.zeros((2, 21)), 2.0)
        return measures.Front(arrival, measures.propagation_velocity(arrival, 12.0), peaks, "level", 0.0, 1.6, 0.0)

    rng = np.random.default_rng(3)
    steady = [np.concatenate([[0.0], np.cumsum(12.0 / (4.18 + 0.05 * rng.standard_normal(20)))]) for _ in range(4)]
    for a in steady:
        a[20] = np.nan  # the fixed magnet 21 never moves
    stuck = np.full(21, np.nan)
    stuck[0] = 0.0
    lab, plain = make_case(particles=21, chain={"magnet_length": 6.35}), make_case(particles=21)
    long = make_case(particles=21, chain={"far_end": "long"})
    max_speed = np.zeros((4, 21))
    mixed = [steady[0], steady[1], stuck, steady[3]]
    for cases, points, arrivals in (([lab] * 4, ["a"] * 4, steady),
                                    ([lab, plain, lab, long], ["a", "b", "a", "c"], mixed)):
        fronts = [front_of(a) for a in arrivals]
        front = measures.stack_fronts(fronts)
        table = summary_columns(cases, front, max_speed, points=points)
        out = summaries(cases, front, max_speed, points=points)
        assert json.dumps(table) == json.dumps(columns(out))  # (json: NaN as text, keys in order)
        assert ("cols" in table) == (len(set(points)) == 1)
        for case, one, speed, summary in zip(cases, fronts, max_speed, out):
            assert json.dumps(summary) == json.dumps(summaries([case], measures.stack_fronts([one]), speed[None])[0])
    # the keys in summary.json's order (members.json's columns follow them)
    assert list(out[0]) == ["case", "particles", "impactor_peak_velocity_m_per_s", "linear_wave_speed_V0_m_per_s",
                            "linear_frequency_f0_Hz", "particles_reached_by_front", "shock_velocity_plateau_m_per_s",
                            "front_speed_m_per_s", "shock_velocity_max_m_per_s", "first_peak_velocity_plateau_m_per_s",
                            "first_peak_velocity_over_V_I", "front_flags", "front_resolution", "front_speed_lab_m_per_s"]
    assert list(out[0]["shock_velocity_plateau_m_per_s"]) == ["mean", "std", "relative_drift", "relative_drift_stderr",
                                                              "converged", "trend", "first_gap", "last_gap"]
    assert list(out[0]["first_peak_velocity_plateau_m_per_s"])[-2:] == ["first_magnet", "last_magnet"]
    assert list(out[0]["front_speed_m_per_s"]) == ["value", "stderr", "first_gap", "last_gap"]
    assert list(out[0]["shock_velocity_max_m_per_s"]) == ["value", "gap"]
    assert list(out[0]["front_flags"]) == ["out_of_order", "below_linear_speed", "out_of_order_gaps",
                                           "below_linear_speed_gaps", "slowest_linear_speed_m_per_s",
                                           "noise_velocity_m_per_s"]
    assert list(out[0]["front_resolution"]) == ["arrival_method", "sample_interval_ms", "gap_crossing_time_ms", "frames_per_gap",
                                                "max_sample_interval_ms", "resolved", "source"]
    assert list(out[0]["front_speed_lab_m_per_s"]) == ["value", "stderr", "gap_frame_m_per_s", "magnets", "pitch_mm"]
    assert out[2]["shock_velocity_max_m_per_s"] is None and out[0]["shock_velocity_max_m_per_s"]["gap"] >= 2
    assert "front_speed_lab_m_per_s" in out[0] and "front_speed_lab_m_per_s" not in out[1]
    assert out[3]["far_end_quiet"] is True and "far_end_quiet" not in out[0]


@pytest.mark.parametrize("thermal", [0.0, 0.05])
def test_a_long_lattice_s_far_end_is_quiet_below_the_noise_level(caplog, thermal):
    """far_end_quiet: the last free magnet's largest |v| at most max(QUIET_FRACTION V_I, 5 sigma),
    the other levels' rule (`levels`). V_I = 2 m/s: without noise the limit is 2e-3 m/s (1.9e-3
    quiet; 2.1e-3 not, with a warning naming magnet N-1); with thermal motion (sigma = 0.0464 m/s,
    `chain_noise`) the limit is 5 sigma, and 4 sigma, which thermal motion alone reaches in a long
    run (a Gaussian's 1-in-16000 sample), is quiet. Motion of the held last magnet, or of the one
    before the last free one, does not count."""
    from pylmp_lattice.case_measures import chain_noise
    from pylmp_lattice.summary import summaries

    chain = {"particles": None, "far_end": "long"} | ({"thermal_velocity": thermal, "seed": 3} if thermal else {})
    case = make_case(duration=50.0, chain=chain)
    sigma, n, last_free = chain_noise(case), case.chain.particles, min(case.held()) - 1
    assert case.held() == [n - 1] and (sigma == 0.0) == (thermal == 0.0)
    limit = max(1e-3 * 2.0, 5 * sigma)
    assert limit == pytest.approx(2e-3 if not thermal else 0.2322, rel=1e-3)
    t = np.arange(0.0, 50.0, 0.1)
    v = 1.0 + np.tanh((t[:, None] - 3.0 * np.arange(n)) / 0.25)
    front = measures.stack_fronts([measures.front(t, v, np.gradient(v, t, axis=0), 2.0, case.chain.gaps(),
                                                  noise=sigma, slowest_linear_speed=1.6)])

    def quiet(speed_of_last_free, elsewhere=0.0):
        max_speed = np.zeros((1, n))
        max_speed[0, [last_free - 1, n - 1]] = elsewhere
        max_speed[0, last_free] = speed_of_last_free
        return summaries([case], front, max_speed)[0]["far_end_quiet"]

    below = 0.95 * limit if not thermal else 4 * sigma
    assert quiet(below, elsewhere=10.0) is True
    caplog.clear()
    assert quiet(1.05 * limit) is False
    assert f"magnet {n - 1} moved" in caplog.text and "long lattice too short" in caplog.text


def test_a_batch_s_loud_far_ends_are_one_warning_line(caplog):
    """A batch of long lattices (a sweep's) warns once for all its chains whose far end moved,
    with their count, the magnet and the largest speed, where each chain had its own line (a
    trial: 11 bare lines for 300 replicas); far_end_quiet is each member's."""
    from pylmp_lattice.summary import summaries

    case = make_case(duration=50.0, chain={"particles": None, "far_end": "long"})
    n, last_free = case.chain.particles, min(case.held()) - 1
    t = np.arange(0.0, 50.0, 0.1)
    v = 1.0 + np.tanh((t[:, None] - 3.0 * np.arange(n)) / 0.25)
    one = measures.front(t, v, np.gradient(v, t, axis=0), 2.0, case.chain.gaps(), slowest_linear_speed=1.6)
    front = measures.stack_fronts([one, one, one])
    max_speed = np.zeros((3, n))
    max_speed[:, last_free] = [1e-3, 3e-3, 5e-3]  # the limit: 2e-3 m/s
    caplog.clear()
    with caplog.at_level(logging.WARNING, logger="pylmp_lattice"):
        rows = summaries([case] * 3, front, max_speed)
    assert [r["far_end_quiet"] for r in rows] == [True, False, False]
    assert [r.getMessage() for r in caplog.records] == [
        f"long lattice too short in 2 of 3 chains: magnet {n - 1} moved at up to 0.005 m/s; their results may "
        "include a reflection (far_end_quiet false in their rows)"]


def test_v0_and_f0_of_a_disordered_chain_are_those_of_its_mean_gap_and_mass():
    """Gaps and masses drawn with 5 % disorder: V0 = r sqrt(k(r)/m) and f0 = sqrt(k(r)/m)/pi at
    the drawn chain's mean gap r and mean mass m (hand calculation from the draws; the summary
    rounds V0 to 6 decimals and f0 to 4), not at a single gap (the first is 3.4 % short here and
    would give V0 1.7 % high)."""
    case = make_case(particles=40, chain={"r0_disorder": 0.05, "mass_disorder": 0.05, "seed": 4})
    gaps, masses = case.chain.gaps(), case.chain.masses()
    r, m = gaps.mean(), masses.mean()
    k = float(case.force.stiffness(r))
    summary = summary_of(case, None)
    assert summary["linear_wave_speed_V0_m_per_s"] == pytest.approx(r * np.sqrt(k / m), abs=5e-7)
    assert summary["linear_frequency_f0_Hz"] == pytest.approx(1e3 * np.sqrt(k / m) / np.pi, abs=5e-5)
    assert abs(gaps[0] / r - 1) > 0.03  # a draw where one gap would not do


@pytest.mark.parametrize("token", ["NaN", "Infinity", "-Infinity"])
def test_a_summary_or_record_holding_a_non_finite_token_is_none_of_ours(tmp_path, token):
    """The package writes its JSON strict (`dumps`: null for NaN): summary.json, status.json or
    members.json holding NaN or an infinity was never written by it and does not count (a done
    member with it runs again). Mutation: `loads_object` parsing those tokens survived."""
    from pylmp_lattice.run_folder import RunFolder
    from pylmp_lattice.serialize import loads_object
    from pylmp_lattice.sweep.store import read_batch, read_json

    text = f'{{"status": "done", "front_speed": {token}}}\n'
    assert loads_object(text) is None and loads_object(text.replace(token, "null")) == {"status": "done", "front_speed": None}
    (tmp_path / "summary.json").write_text(text)
    member = f'{{"id": "a", "index": 0, "params": {{}}, "chain": 0, "summary": {{"v": {token}}}}}'
    (tmp_path / "members.json").write_text(f'{{"status": "done", "members": [{member}]}}')
    assert RunFolder(tmp_path).summary is None and read_json(tmp_path / "summary.json") is None
    assert read_batch(tmp_path / "members.json") == {}
