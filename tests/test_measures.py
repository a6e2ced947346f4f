"""Shock measures on synthetic histories with known answers and on the exact harmonic chain."""

import importlib
import json

import numpy as np
import pytest
from numpy.testing import assert_allclose
from scipy.integrate import quad, solve_ivp
from scipy.optimize import brentq, minimize_scalar
from scipy.special import ai_zeros, airy, jn_zeros, jv

from pylmp_lattice import measures
from pylmp_lattice.serialize import dumps
from pylmp_lattice.measures import (
    arrival_times,
    centred_propagation_velocity,
    critical_velocities,
    critical_velocity,
    fit_propagation_velocity,
    phase_portrait,
    steady_onset_times,
    transition_zone,
    first_peaks,
    linear_frequency,
    linear_wave_speed,
    oscillations,
    propagation_velocity,
    steady_oscillation,
    trailing_plateau,
)

# The paper's magnet law F = K/(r+b)^q and lattice (main text).
K, B, Q, MASS, R0 = 413.8, 3.917, 3, 1.084, 12.0  # N mm^3, mm, -, g, mm


def smooth_step(x):
    return 0.5 * (1.0 + np.tanh(x))


# ---------------------------------------------------------------------------------------------
# Linear chain constants
# ---------------------------------------------------------------------------------------------


def test_linear_wave_speed_and_frequency_of_the_paper_law():
    force = lambda r: K / (r + B) ** Q  # noqa: E731
    h = 1e-4
    k = -(force(R0 + h) - force(R0 - h)) / (2 * h)  # N/mm, by central difference
    assert_allclose(k, Q * K / (R0 + B) ** (Q + 1), rtol=1e-7)

    v0 = linear_wave_speed(k, MASS, R0)
    assert 1.60 <= v0 <= 1.62  # paper: 1.62 m/s
    # Same number through SI: r0 [m] sqrt(k [N/m] / m [kg]).
    assert_allclose(v0, 12e-3 * np.sqrt(k * 1e3 / 1.084e-3), rtol=1e-12)
    # f0 = (1/pi) sqrt(k/m) = V0 / (pi r0), r0 in m for Hz.
    assert_allclose(linear_frequency(k, MASS), v0 / (np.pi * 12e-3), rtol=1e-12)


def test_linear_constants_reject_non_positive_input():
    with pytest.raises(ValueError, match="mass: got 0; expected > 0"):
        linear_wave_speed(0.02, 0, 12.0)


def test_a_value_that_is_no_number_is_named_not_a_numpy_comparison_error():
    t, v = np.linspace(0.0, 1.0, 5), np.zeros((5, 3))
    with pytest.raises(TypeError, match=r"^drive_velocity: got '2' \(str\); expected a number$"):
        arrival_times(t, v, "2")
    with pytest.raises(TypeError, match=r"^mass: got None \(NoneType\); expected a number$"):
        linear_wave_speed(0.02, None, 12.0)
    with pytest.raises(TypeError, match=r"^stiffness: got an array of shape \(2,\); expected one number$"):
        linear_wave_speed(np.array([0.02, 0.03]), 1.084, 12.0)
    assert linear_wave_speed(np.float64(0.02), np.int64(1), np.array(12.0)) == pytest.approx(12.0 * np.sqrt(0.02))


# ---------------------------------------------------------------------------------------------
# Front arrival and propagation velocity
# ---------------------------------------------------------------------------------------------


def test_smooth_step_front_travels_at_its_speed():
    # v_n(t) = V_I s((t - t_n)/w), t_n = 0.37 + n r0/c: V_I/2 is reached exactly at t_n.
    vi, c, w, n = 2.0, 3.92, 2.0, 30
    t = np.arange(0.0, 120.0, 0.0937)
    t_n = 0.37 + np.arange(n) * R0 / c
    v = vi * smooth_step((t[:, None] - t_n) / w)

    # Linear interpolation of tanh about its inflection point is accurate to O((dt/w)^3).
    assert_allclose(arrival_times(t, v, vi), t_n, atol=1e-5)
    # Where s = 0.01 the step is nearly exp(2x): interpolation is off by ~ dt^2 / (4 w) = 1e-3 ms.
    # (Particles 0 and 1 are already moving at t = 0.)
    start = first_peaks(t, v, np.gradient(v, t, axis=0), vi).start_time
    assert_allclose(start[2:], t_n[2:] + w * np.arctanh(2 * 0.01 - 1), atol=2e-3)
    assert_allclose(propagation_velocity(arrival_times(t, v, vi), R0), c, rtol=1e-5)


def test_propagation_velocity_uses_each_gap():
    gaps = np.array([10.0, 12.0, 14.0, 9.0])
    arrival = np.concatenate(([0.0], np.cumsum(gaps) / 3.5))
    assert_allclose(propagation_velocity(arrival, gaps), 3.5, rtol=1e-12)


def test_particles_never_reached_give_nan():
    t = np.linspace(0.0, 10.0, 101)
    v = np.zeros((101, 4))
    v[:, 0] = 1.0
    v[:, 1] = np.clip(t - 2.0, 0.0, 1.5)  # reaches 0.5 at t = 2.5, peaks at 1.5 but never falls
    arrival = arrival_times(t, v, 1.0)
    assert_allclose(arrival[:2], [0.0, 2.5])
    assert np.isnan(arrival[2:]).all()
    vp = propagation_velocity(arrival, 12.0)
    assert_allclose(vp[0], 12.0 / 2.5)
    assert np.isnan(vp[1:]).all()

    peaks = first_peaks(t, v, np.gradient(v, t, axis=0), 1.0)
    assert np.isnan(peaks.peak_velocity).all()  # no peak is confirmed by a later drop
    assert np.isnan(peaks.start_time[2:]).all()
    assert oscillations(t, v[:, 3], 1.0).max_time.size == 0
    never = steady_oscillation(t, v[:, 3], 1.0, window=(0.0, 10.0))
    assert never.n_periods == 0 and np.isnan(never.frequency)
    assert "had not arrived" in never.reason


def test_shape_errors_say_what_was_got_and_expected():
    t = np.linspace(0.0, 1.0, 5)
    with pytest.raises(ValueError, match=r"v: got shape \(4, 3\); expected \(5, N\)"):
        arrival_times(t, np.zeros((4, 3)), 1.0)
    with pytest.raises(ValueError, match=r"a: got shape \(5, 2\); expected \(5, 3\)"):
        first_peaks(t, np.zeros((5, 3)), np.zeros((5, 2)), 1.0)
    with pytest.raises(ValueError, match=r"v: got shape \(5, 3\); expected \(5,\)"):
        oscillations(t, np.zeros((5, 3)), 1.0)
    with pytest.raises(ValueError, match=r"spacing: got shape \(3,\); expected \(\) or \(4,\)"):
        propagation_velocity(np.arange(5.0), np.ones(3))
    with pytest.raises(ValueError, match="t: got non-increasing times"):
        arrival_times(t[::-1], np.zeros((5, 3)), 1.0)


def test_trailing_plateau_of_a_converging_series():
    n = np.arange(200, dtype=float)
    values = 3.9 * (1.0 - np.exp(-n / 10.0))
    values[150:] = np.nan  # the front stopped at gap 150
    plateau = trailing_plateau(values)
    # the last ceil(150/4) = 38 finite values, values[112:150]: gaps 113 to 150, numbered from 1
    assert (plateau.first, plateau.last) == (113, 150)
    assert json.loads(dumps(plateau))["first_gap"] == 113 and json.loads(dumps(plateau))["last_gap"] == 150
    assert_allclose(plateau.mean, 3.9, rtol=1e-4)
    assert plateau.converged(rtol=1e-4)

    early = trailing_plateau(values[:20])  # still rising: drift ~ +10 % across the window
    assert early.drift > 0.05 and not early.converged()
    assert np.isnan(trailing_plateau([1.0, np.nan]).mean)


def test_plateaus_of_rows_are_those_of_each_row_and_the_line_is_least_squares():
    """trailing_plateaus over 60 noisy series with different gaps missing (windows of several
    lengths, up to 500 values) gives each row's trailing_plateau bit for bit; the drift's
    closed-form line is numpy's least-squares fit (polyfit) to 1e-12."""
    from pylmp_lattice.measures import trailing_plateaus

    rng = np.random.default_rng(3)
    values = 3.9 + 0.05 * rng.standard_normal((60, 2000)) + np.linspace(0, 0.02, 2000)
    values[rng.random(values.shape) < 0.1] = np.nan
    for r, end in enumerate(rng.integers(3, 2000, 60)):
        values[r, end:] = np.nan
    values[7, :] = np.nan
    rows = trailing_plateaus(values)
    assert len({p.last - p.first for p in rows if p.first}) > 20 and np.isnan(rows[7].mean)
    for row, plateau in zip(values, rows):
        alone = trailing_plateau(row)
        assert dumps(alone) == dumps(plateau)
        if alone.first is not None:
            index = np.flatnonzero(np.isfinite(row))[-(alone.last - alone.first + 1):]
            index = index[index >= alone.first - 1]
            slope = np.polyfit(index, row[index], 1)[0]
            assert_allclose(alone.drift, slope * (index[-1] - index[0]) / alone.mean, rtol=1e-12, atol=1e-15)


# ---------------------------------------------------------------------------------------------
# First peaks
# ---------------------------------------------------------------------------------------------


def parabolic_pulses(t, t_peak, vi, height, width):
    """v = V_I height (1 - ((t - t_peak)/width)^2) on |t - t_peak| < width, else 0; a in m/s^2."""
    s = (t[:, None] - t_peak) / width
    cap = np.abs(s) < 1
    v = np.where(cap, vi * height * (1 - s**2), 0.0)
    a = np.where(cap, -2 * vi * height * s / width, 0.0) * 1e3  # (m/s)/ms -> m/s^2
    return v, a


def test_first_peak_of_parabolic_pulses_to_sub_sample_accuracy():
    vi, height, width, dt = 2.0, 1.6, 5.0, 0.3
    t = np.arange(0.0, 60.0, dt)
    t_peak = np.array([10.13, 17.71, 25.05, 33.333])  # off the sample grid
    v, a = parabolic_pulses(t, t_peak, vi, height, width)
    peaks = first_peaks(t, v, a, vi)

    # The parabola through three samples on the cap is the cap itself.
    assert_allclose(peaks.peak_time, t_peak, atol=1e-9)
    assert_allclose(peaks.peak_velocity, height * vi, rtol=1e-12)
    # Start of motion where v = 0.01 V_I, t_peak - width sqrt(1 - 0.01/height); interpolating
    # across the kink at the foot of the cap can only be wrong by less than one sample.
    assert_allclose(peaks.rise_time, width * np.sqrt(1 - 0.01 / height), atol=dt)
    # a falls linearly from 2 height V_I / width at the foot: the largest sample is the first in
    # motion, less than dt past the foot, and is not refined (a jumps at the foot).
    a_foot = 2 * height * vi / width * 1e3
    assert np.all(peaks.peak_acceleration <= a_foot)
    assert np.all(peaks.peak_acceleration >= a_foot * (1 - dt / width))


def test_first_peak_ignores_sampling_noise():
    vi, height, width = 2.0, 1.6, 5.0
    t = np.arange(0.0, 40.0, 0.025)
    v, a = parabolic_pulses(t, np.array([20.0]), vi, height, width)
    v = v + np.random.default_rng(1).uniform(-0.01, 0.01, v.shape) * vi

    peak = first_peaks(t, v, a, vi)  # default prominence 0.05 V_I
    assert abs(peak.peak_time[0] - 20.0) < 0.1 * width
    assert abs(peak.peak_velocity[0] - height * vi) < 0.02 * vi
    naive = first_peaks(t, v, a, vi, prominence=1e-9)  # any wiggle counts: stops on the rise
    assert naive.peak_time[0] < 20.0 - 0.3 * width


def test_first_peaks_same_in_column_blocks(monkeypatch):
    vi, t = 2.0, np.arange(0.0, 60.0, 0.3)
    v, a = parabolic_pulses(t, np.linspace(8.0, 40.0, 7), vi, 1.6, 5.0)
    whole = first_peaks(t, v, a, vi)
    monkeypatch.setattr(importlib.import_module("pylmp_lattice.measures.peaks"), "_BLOCK_ELEMENTS", 2 * len(t))  # blocks of two particles
    blocked = first_peaks(t, v, a, vi)
    for name in ("start_time", "peak_time", "peak_velocity", "peak_acceleration"):
        assert_allclose(getattr(blocked, name), getattr(whole, name), rtol=0, atol=0)


# ---------------------------------------------------------------------------------------------
# Oscillations
# ---------------------------------------------------------------------------------------------


@pytest.mark.parametrize("amplitude", [1.0, 0.4])
def test_sine_gives_its_frequency_amplitude_and_energy_ratio(amplitude):
    # v = V_I (1 + A sin(2 pi f t)): eta = A^2 / 2, i.e. 0.5 for A = 1; ~24.7 samples/period.
    vi, f = 2.0, 37.0  # m/s, Hz
    t = np.arange(0.0, 400.0, 1.093)
    v = vi * (1 + amplitude * np.sin(2 * np.pi * f * t * 1e-3))

    osc = oscillations(t, v, vi)
    # Parabolic refinement of a sine crest: times to 0.005 ms (dt = 1.093 ms), values to 5e-4.
    assert_allclose(osc.max_time, (np.arange(osc.max_time.size) + 0.25) * 1e3 / f, atol=5e-3)
    assert_allclose(osc.frequency, f, rtol=5e-4)
    assert_allclose(osc.max_velocity, vi * (1 + amplitude), rtol=5e-4)
    assert_allclose(osc.min_velocity, vi * (1 - amplitude), atol=5e-4 * vi)

    # Maxima at (k + 1/4)/f = 27.03 k + 6.76 ms: k = 10..14 lie in the window, 4 whole periods.
    steady = steady_oscillation(t, v, vi, window=(260.0, 400.0))
    assert steady.n_periods == 4 and steady.measured
    assert_allclose(steady.frequency, f, rtol=1e-5)
    assert_allclose(steady.energy_ratio, amplitude**2 / 2, rtol=1e-4)
    assert_allclose(steady.amplitude, amplitude * vi, rtol=2e-4)
    assert steady.period_spread < 5e-4


# ---------------------------------------------------------------------------------------------
# The semi-infinite harmonic chain driven at constant velocity
# ---------------------------------------------------------------------------------------------
#
# m u_n'' = k (u_{n+1} - 2 u_n + u_{n-1}) for n >= 1, u_0 = V_I t, all at rest at t = 0.
# The velocities obey the same equation with v_0 = V_I. For w_n = V_I - v_n (w_0 = 0, w_n(0) =
# V_I) extend oddly, w_{-n} = -w_n, and use the infinite chain's propagator J_{2n}(2 omega t)
# (J_{2n}'' = (J_{2n-2} - 2 J_{2n} + J_{2n+2})/4, J_{2n}(0) = delta_n0), with omega = sqrt(k/m)
# and sum_m J_{2m} = 1 over all integers m. This gives
#     v_n(t) = V_I [J_{2n}(x) + 2 sum_{m > n} J_{2m}(x)],  x = 2 omega t,
#     a_n(t) = V_I omega [J_{2n-1}(x) + J_{2n+1}(x)] = 2 n V_I J_{2n}(x) / t.
# So the first velocity peak of particle n >= 1 is at the first zero of J_{2n}: x = j_{2n,1}.

SPRING, CHAIN_MASS, VI, N_CHAIN = 0.02, 1.0, 1.0, 200  # N/mm, g, m/s, particles
OMEGA = np.sqrt(SPRING / CHAIN_MASS)  # 1/ms
T_END = 140 / OMEGA  # the front reaches particle ~140 of 200: no reflection
T_CHAIN = np.linspace(0.0, T_END, 2801)  # 0.05 / omega per frame, ~140 frames per site


def harmonic_chain(t):
    """Exact v (m/s) and a (m/s^2) of particles 0..N_CHAIN-1, shape (len(t), N_CHAIN)."""
    x = 2 * OMEGA * t[:, None]
    m_max = N_CHAIN + 20
    assert jv(2 * m_max, x.max()) < 1e-30  # the truncated tail is negligible
    bessel = jv(2 * np.arange(m_max + 1), x)
    tail = np.cumsum(bessel[:, ::-1], axis=1)[:, ::-1]  # tail[:, j] = sum_{m >= j} J_2m
    n = np.arange(N_CHAIN)
    v = VI * (bessel[:, n] + 2 * tail[:, n + 1])
    with np.errstate(divide="ignore", invalid="ignore"):
        a = np.where(t[:, None] > 0, 2 * n * VI * bessel[:, n] / t[:, None], 0.0) * 1e3
    return v, a


@pytest.fixture(scope="module")
def chain():
    return harmonic_chain(T_CHAIN)


def test_harmonic_chain_solution_matches_direct_integration(chain):
    v_exact, a_exact = chain
    k_over_m = SPRING / CHAIN_MASS  # 1/ms^2

    def rhs(t, y):
        u = np.concatenate(([VI * t], y[: N_CHAIN - 1], [y[N_CHAIN - 2]]))  # driven end, free end
        return np.concatenate((y[N_CHAIN - 1 :], k_over_m * (u[2:] - 2 * u[1:-1] + u[:-2])))

    sol = solve_ivp(rhs, (0, T_END), np.zeros(2 * (N_CHAIN - 1)), "DOP853", T_CHAIN, rtol=1e-10, atol=1e-12)
    assert sol.success
    assert_allclose(sol.y[N_CHAIN - 1 :].T, v_exact[:, 1:], rtol=0, atol=1e-7 * VI)
    a_direct = np.array([rhs(t, y)[N_CHAIN - 1 :] for t, y in zip(sol.t, sol.y.T)]) * 1e3
    assert_allclose(a_direct[1:], a_exact[1:, 1:], rtol=0, atol=1e-7 * np.abs(a_exact).max())


def test_harmonic_chain_front_speed_tends_to_v0(chain):
    v, _ = chain
    v0 = linear_wave_speed(SPRING, CHAIN_MASS, R0)
    vp = propagation_velocity(arrival_times(T_CHAIN, v, VI), R0)
    n = np.arange(vp.size)

    # Near the front v_n ~ V_I int_{z}^inf Ai, z = (2/x)^(1/3) (2n - x), so V_I/2 arrives at
    # x = 2n - z* n^(1/3) with int_{z*}^inf Ai = 1/2, and V_P/V0 = 1 - (|z*|/6) n^(-2/3) + ...
    z_star = brentq(lambda z: quad(lambda s: airy(s)[0], z, np.inf)[0] - 0.5, -2.0, 0.0)
    deficit = 1 - vp / v0
    assert np.all(deficit[5:135] > 0) and np.all(np.diff(deficit[5:135]) < 0)
    assert_allclose(deficit[50:135] * n[50:135] ** (2 / 3), -z_star / 6, atol=2e-3)  # 0.0683

    plateau = trailing_plateau(vp)
    assert 130 <= plateau.last <= 145  # the front reached ~140 magnets
    assert_allclose(plateau.mean, v0, rtol=4e-3)  # the n^(-2/3) deficit is 0.3 % there
    assert plateau.converged(rtol=1e-3)


def test_harmonic_chain_first_peaks(chain):
    v, a = chain
    peaks = first_peaks(T_CHAIN, v, a, VI)
    n = np.arange(1, 131)

    t_peak = np.array([jn_zeros(2 * i, 1)[0] for i in n]) / (2 * OMEGA)
    dt = T_CHAIN[1] - T_CHAIN[0]
    assert_allclose(peaks.peak_time[n], t_peak, atol=0.02 * dt)  # sub-sample
    v_at_peak = np.array([harmonic_chain(np.array([tp]))[0][0, i] for i, tp in zip(n, t_peak)])
    assert_allclose(peaks.peak_velocity[n], v_at_peak, rtol=1e-5)
    # Largest a_n = 2 n V_I J_2n(2 omega t) / t before the peak: on a fine grid, then polished.
    a_max = []
    for i, tp in zip(n, t_peak):
        s = np.linspace(tp / 1000, tp, 1000)
        s_best = s[np.argmax(jv(2 * i, 2 * OMEGA * s) / s)]
        a_of = lambda s, i=i: 2e3 * i * VI * jv(2 * i, 2 * OMEGA * s) / s  # noqa: E731
        bracket = (s_best - tp / 999, s_best + tp / 999)
        a_max.append(a_of(minimize_scalar(lambda s: -a_of(s), bounds=bracket, method="bounded").x))
    assert_allclose(peaks.peak_acceleration[n], a_max, rtol=1e-5)

    # Paper Fig. S5(c): the first peak velocity grows with n, towards the Airy limit
    # V_I int_{a1}^inf Ai (a1 the first zero of Ai), and the first peak acceleration falls.
    assert np.all(np.diff(peaks.peak_velocity[n]) > 0)
    limit = VI * quad(lambda s: airy(s)[0], ai_zeros(1)[0][0], np.inf)[0]  # 1.2744
    assert limit * 0.99 < peaks.peak_velocity[130] < limit
    assert np.all(np.diff(peaks.peak_acceleration[n]) < 0)


def test_harmonic_chain_oscillations_decay_towards_f0(chain):
    v, a = chain
    osc = oscillations(T_CHAIN, v[:, 10], VI)
    # The first maximum is the first peak.
    peak = first_peaks(T_CHAIN, v[:, 10:11], a[:, 10:11], VI)
    assert_allclose(osc.max_time[0], peak.peak_time[0], rtol=1e-12)
    # Paper Fig. S5(d,e): amplitude and period fall with time; the frequency rises towards the
    # band edge f0 = (1/pi) sqrt(k/m) and stays below it.
    assert osc.max_time.size >= 5
    assert np.all(np.diff(osc.max_velocity) < 0) and np.all(np.diff(osc.min_velocity) > 0)
    f0 = linear_frequency(SPRING, CHAIN_MASS)
    assert np.all(np.diff(osc.frequency) > 0)
    assert 0.9 * f0 < osc.frequency[-1] < f0


# ---------------------------------------------------------------------------------------------
# Arrival definitions, V_P per gap / centred / fitted (synthetic fronts with known answers)
# ---------------------------------------------------------------------------------------------


def test_steps_at_known_times_give_the_known_propagation_velocity():
    # v_n jumps from 0 to V_I at sample k_n: V_I/2 is crossed half a sample earlier for every n.
    dt, c, vi = 0.01, 3.92, 2.0  # ms, m/s, m/s
    t = np.arange(0.0, 100.0, dt)
    k = np.round(np.arange(25) * R0 / c / dt).astype(int) + 1
    v = vi * (np.arange(t.size)[:, None] >= k)
    arrival = arrival_times(t, v, vi)
    assert_allclose(arrival, t[k] - dt / 2, atol=1e-12)
    # rounding the steps to the grid moves each by <= dt/2: V_P = r0/(t_{n+1}-t_n) to dt/(r0/c)
    assert_allclose(propagation_velocity(arrival, R0), c, rtol=dt * c / R0)
    assert_allclose(centred_propagation_velocity(arrival, R0)[1:-1], c, rtol=dt * c / (2 * R0))
    fit = fit_propagation_velocity(arrival, np.arange(25) * R0)
    assert abs(fit.velocity - c) < 3 * fit.velocity_stderr + 1e-6 and fit.n_points == 25


def test_centred_velocity_is_exact_for_a_quadratic_front():
    # t(x) = x/c0 + beta x^2: the centred difference of t over x is exact, dt/dx = 1/c0 + 2 beta x;
    # the per-gap value belongs to the gap's middle.
    c0, beta = 4.0, 2e-4
    x = np.arange(40) * R0
    arrival = x / c0 + beta * x**2
    centred = centred_propagation_velocity(arrival, R0)
    assert np.isnan(centred[[0, -1]]).all()
    assert_allclose(centred[1:-1], 1 / (1 / c0 + 2 * beta * x[1:-1]), rtol=1e-12)
    mid = 0.5 * (x[1:] + x[:-1])
    assert_allclose(propagation_velocity(arrival, R0), 1 / (1 / c0 + 2 * beta * mid), rtol=1e-12)
    # a straight line through an accelerating front leaves residuals; a window keeps it local
    whole, local = fit_propagation_velocity(arrival, x), fit_propagation_velocity(arrival, x, 31, 33)
    assert whole.residual_rms > 100 * local.residual_rms
    # magnets 31, 32, 33: x[30:33]; the slope of a parabola through three points is its middle's
    assert_allclose(local.velocity, 1 / (1 / c0 + 2 * beta * x[31]), rtol=1e-12)
    assert (local.first_magnet, local.last_magnet, local.n_points) == (31, 33, 3)


def test_front_fits_against_scipy_linregress():
    # A noisy line with one magnet never reached: the single fit leaves it out, the batched one
    # gives no speed for a window that holds it; both are scipy's least squares to 1e-12 of V_P.
    from scipy.stats import linregress

    rng = np.random.default_rng(3)
    x = np.cumsum(rng.uniform(10.0, 14.0, 30))
    arrival = x / 4.2 + rng.normal(0.0, 0.2, 30)
    arrival[20] = np.nan
    keep = np.isfinite(arrival)
    line = linregress(x[keep], arrival[keep])
    fit = fit_propagation_velocity(arrival, x)
    assert fit.n_points == 29
    assert_allclose([fit.velocity, fit.velocity_stderr], [1 / line.slope, line.stderr / line.slope**2],
                    rtol=0, atol=1e-12 / line.slope)
    rows = np.stack([arrival, np.where(keep, arrival, 0.0)])
    speed, stderr = measures.fit_front_speeds(rows, x, 2, 15)  # magnets 2-15 all reached in both rows
    whole, _ = measures.fit_front_speeds(rows, x, 2, 30)
    part = fit_propagation_velocity(arrival, x, 2, 15)
    assert_allclose(speed, part.velocity, rtol=1e-12)
    assert_allclose(stderr, part.velocity_stderr, rtol=1e-12)
    assert np.isnan(whole[0]) and np.isfinite(whole[1])


def test_short_pulse_arrival_by_first_velocity_and_acceleration_peak():
    # A Gaussian pulse v = h_n V_I exp(-((t - t_n)/w)^2) that weakens to 0.3 V_I: it never
    # reaches V_I/2 far out, but its maximum (t_n) and its steepest rise (t_n - w/sqrt 2) do.
    vi, w, dt = 2.0, 3.0, 0.05
    t = np.arange(0.0, 120.0, dt)
    t_n = 10.0 + np.arange(12) * R0 / 2.5
    height = np.linspace(0.9, 0.3, 12)
    s = (t[:, None] - t_n) / w
    v = vi * height * np.exp(-(s**2))
    a = -2 * s / w * v * 1e3  # m/s^2
    level = arrival_times(t, v, vi)
    assert np.isfinite(level[:4]).all() and np.isnan(level[-4:]).all()
    peak = arrival_times(t, v, vi, method="velocity_peak")
    assert_allclose(peak, t_n, atol=1e-4)  # the parabola through three samples of a Gaussian cap
    steep = arrival_times(t, v, vi, method="acceleration_peak", a=a)
    assert_allclose(steep, t_n - w / np.sqrt(2), atol=2e-3)
    assert_allclose(propagation_velocity(peak, R0), 2.5, rtol=1e-4)
    assert measures.default_arrival_method(pulse=True) == "velocity_peak"
    assert measures.default_arrival_method(pulse=False) == "level"
    with pytest.raises(ValueError, match="needs the accelerations"):
        arrival_times(t, v, vi, method="acceleration_peak")
    with pytest.raises(ValueError, match="choose one of level, velocity_peak, acceleration_peak"):
        arrival_times(t, v, vi, method="half")


def test_decaying_series_is_not_a_plateau():
    # V_P falling by friction: 3.9 exp(-n/300) changes by -74/300 of its level across the last
    # quarter of 300 gaps (the line's slope and the mean both taken mid-window, to ~0.3 %).
    n = np.arange(300.0)
    decay = trailing_plateau(3.9 * np.exp(-n / 300))
    assert not decay.converged()
    assert_allclose(decay.drift, -74 / 300, rtol=0.01)
    data = json.loads(dumps(decay))
    assert data["converged"] is False and data["relative_drift"] < -0.07
    assert json.loads(dumps(trailing_plateau([1.0, np.nan])))["mean"] is None  # null, never NaN


# ---------------------------------------------------------------------------------------------
# Steady oscillation in a window: decayed signals give NaN and say why
# ---------------------------------------------------------------------------------------------


def test_decayed_oscillation_gives_nan_and_a_reason():
    vi, f = 2.0, 37.0
    t = np.arange(0.0, 400.0, 0.1)
    v = vi * (1 + np.exp(-t / 20.0) * np.sin(2 * np.pi * f * t * 1e-3))
    early = steady_oscillation(t, v, vi, window=(0.0, 100.0))
    assert early.measured and early.n_periods >= 2
    late = steady_oscillation(t, v, vi, window=(300.0, 400.0))
    assert np.isnan(late.frequency) and np.isnan(late.energy_ratio) and late.n_periods == 0
    assert "no oscillation left in [300, 399.9] ms" in late.reason
    assert json.loads(dumps(late))["energy_ratio_eta"] is None
    short = steady_oscillation(t, v, vi, window=(10.0, 30.0))  # less than one period (27 ms)
    assert "at least two are needed" in short.reason
    with pytest.raises(ValueError, match="to overlap the record"):
        steady_oscillation(t, v, vi, window=(400.0, 500.0))


def test_extrema_sequence_of_a_chirp_gives_its_frequency_against_time():
    # v = V_I (1 + 0.5 sin(phi)), phi = 2 pi (f1 t + g t^2 / 2): frequency f1 + g t rising.
    vi, f1, g = 1.0, 20.0, 0.1  # Hz, Hz/ms
    t = np.arange(0.0, 300.0, 0.05)
    v = vi * (1 + 0.5 * np.sin(2 * np.pi * (f1 * t + g * t**2 / 2) * 1e-3))
    osc = oscillations(t, v, vi)
    assert osc.max_time.size >= 10
    # the period between maxima averages the frequency over it: the midpoint value to O(g T)^2
    assert_allclose(osc.frequency, f1 + g * osc.frequency_time, rtol=2e-3)
    assert np.all(osc.min_time[1:] > osc.max_time[0])


# ---------------------------------------------------------------------------------------------
# V* from eta(V_I)
# ---------------------------------------------------------------------------------------------


def test_prominent_maxima_are_scipy_find_peaks():
    """The package's peak finder (no scipy.signal import) against scipy.signal.find_peaks:
    identical indices on noisy oscillations, flat maxima and plateaus at the ends, for
    prominences from none kept to all kept."""
    from scipy.signal import find_peaks

    from pylmp_lattice.measures._common import prominent_maxima

    rng = np.random.default_rng(7)
    t = np.linspace(0, 40, 4001)
    signals = [np.sin(t) * np.exp(-t / 20) + 0.05 * rng.standard_normal(t.size),
               np.round(3 * np.sin(t) + np.sin(7.3 * t), 1),  # flat maxima
               np.r_[np.full(5, 2.0), np.sin(t[:200]), np.full(5, 1.0)],  # plateaus at both ends
               rng.integers(0, 4, 500).astype(float)]
    checked = 0
    for y in signals:
        for p in (0.0, 0.01, 0.1, 0.5, 1.0, 10.0):
            expected = find_peaks(y, prominence=p)[0]
            np.testing.assert_array_equal(prominent_maxima(y, p), expected)
            np.testing.assert_array_equal(prominent_maxima(-y, p), find_peaks(-y, prominence=p)[0])
            checked += expected.size
    assert checked > 1000  # the comparison saw many peaks


def test_critical_velocity_of_a_broken_line():
    # eta = 0.02 V below V* = 0.8 m/s and 0.02 V + 0.5 (V - 0.8) above it.
    vi = np.linspace(0.05, 2.0, 40)
    eta = 0.02 * vi + 0.5 * np.maximum(vi - 0.8, 0)
    assert_allclose(critical_velocity(vi, eta, "two_line").value, 0.8, atol=0.005)
    # tangent of the steep branch crosses eta = 0 at 0.8 - 0.016/0.52
    assert_allclose(critical_velocity(vi, eta, "tangent").value, 0.8 - 0.016 / 0.52, rtol=1e-9)
    # eta = 0.1 at V = 0.8 + (0.1 - 0.016)/0.52
    assert_allclose(critical_velocity(vi, eta, "threshold", level=0.1).value, 0.8 + 0.084 / 0.52, rtol=1e-9)
    assert_allclose(critical_velocity(vi, eta, "kneedle").value, 0.8, atol=0.01)
    flat = critical_velocity(vi, np.full_like(vi, 0.01), "threshold")
    assert np.isnan(flat.value) and "stays below" in flat.reason
    assert set(critical_velocities(vi, eta)) == {"threshold", "tangent", "two_line", "kneedle"}


# ---------------------------------------------------------------------------------------------
# Transition zone and phase portrait
# ---------------------------------------------------------------------------------------------


def test_transition_zone_grows_as_constructed():
    # Particle n >= 1: front at t_n = 3 n ms; for D_n = 4 n ms it oscillates with amplitude
    # 0.8 V_I (disordered), then steadily with 0.3 V_I about V_I. Onset: the first extremum
    # after t_n + D_n; the steady index at time T is the largest n with 7 n + (<1 period) <= T.
    vi, f, nmax = 1.0, 200.0, 25  # Hz: period 5 ms
    t = np.arange(0.0, 200.0, 0.01)
    n = np.arange(nmax)
    t_n, d_n = 3.0 * n, 4.0 * n
    s = t[:, None] - t_n
    amp = np.where(s < d_n, 0.8, 0.3)
    v = np.where(s > 0, vi * (1 - np.cos(2 * np.pi * f * s * 1e-3) * amp), 0.0)
    onset = steady_onset_times(t, v, vi, reference=(1.3 * vi, 0.7 * vi), tolerance=0.05)
    settled = np.isfinite(onset)
    assert settled[1:20].all()
    after = onset[1:20] - (t_n + d_n)[1:20]
    assert np.all((after >= 0) & (after <= 2.5 + 0.01))  # the next extremum: within half a period
    arrival = arrival_times(t, v, vi, fraction=0.01)
    zone = transition_zone([31.0, 61.0, 100.0, 140.0], arrival, onset)
    # magnet numbers, from 1: index n is magnet n + 1
    assert_allclose(zone.front_magnet, [11, 21, 25, 25])  # floor(T / 3) + 1, capped by the 25 magnets
    assert_allclose(zone.settled_magnet, [5, 9, 15, 20], atol=1)  # about floor(T / 7) + 1
    assert zone.width[1] > zone.width[0] + 3  # T (1/3 - 1/7): 5.7 and 11.4
    assert json.loads(dumps(zone))["width_magnets"][0] == pytest.approx(zone.width[0])


def test_phase_portrait_of_an_ellipse():
    t = np.linspace(0.0, 10.0, 1001)
    w = 2.0  # 1/ms
    x = np.column_stack([np.zeros_like(t), 12.0 + 0.5 * np.sin(w * t), np.full_like(t, 24.0)])
    v = np.column_stack([np.zeros_like(t), 0.5 * w * np.cos(w * t), np.zeros_like(t)])
    portrait = phase_portrait(t, x, v, magnet=2)
    assert_allclose((portrait.gap - 12.0) ** 2 / 0.25 + portrait.velocity**2 / 1.0, 1.0, rtol=1e-12)
    ranges = portrait.ranges((0.0, 10.0))
    assert_allclose([ranges["gap_min_mm"], ranges["gap_max_mm"]], [11.5, 12.5], atol=1e-4)
    assert portrait.magnet == 2
    # the same magnet among columns that start at magnet 2
    assert_allclose(phase_portrait(t, x[:, 1:], v[:, 1:], magnet=2, first_magnet=2).gap, portrait.gap, rtol=0)
    with pytest.raises(ValueError, match="it needs a next one"):
        phase_portrait(t, x, v, magnet=3)


def test_fronts_of_different_sampling_are_not_stacked():
    """stack_fronts keeps one method and one sample interval: fronts read from frames of
    another spacing are refused, not given the first one's."""
    import dataclasses

    from pylmp_lattice.measures.front import stack_fronts

    t = np.linspace(0.0, 10.0, 101)
    v = np.clip(t[:, None] - np.arange(5), 0.0, 1.0)
    one = measures.front(t, v, np.gradient(v, t, axis=0), 1.0, np.full(4, 10.0))
    assert stack_fronts([one, one]).arrival.shape == (2, 5)
    with pytest.raises(ValueError, match="a stack needs one of each"):
        stack_fronts([one, dataclasses.replace(one, sample_interval=0.2)])


# ---------------------------------------------------------------------------------------------
# Flags against the linear speed, centred V_P over unequal gaps, pulses (mutation tests)
# ---------------------------------------------------------------------------------------------


def test_the_exact_harmonic_front_is_not_flagged_below_the_linear_speed(chain):
    """The exact harmonic piston's half-level front lags V0 (Airy: 0.903 V0 over gap 1, then
    0.923, 0.953, ... towards V0), never by more than LINEAR_LAG = 10 %: no gap is flagged
    below the linear speed (V_P < 0.9 V0). The same arrival times over gaps 0.85 times as long
    (a front at most 0.85 V0: slower than any linear wave) are flagged at every gap."""
    v, _ = chain
    v0 = linear_wave_speed(SPRING, CHAIN_MASS, R0)
    arrival = arrival_times(T_CHAIN, v, VI)[:139]  # the magnets the front reached
    assert np.isfinite(arrival).all()
    vp = propagation_velocity(arrival, R0)
    assert_allclose(vp[:3] / v0, [0.90291, 0.92321, 0.95264], atol=1e-5)  # measured, Airy lag
    front = measures.Front(arrival, vp, peaks=None, slowest_linear_speed=v0)
    assert not front.below_linear_speed.any() and np.array_equal(front.accepted_velocity, vp)
    slow = measures.Front(arrival, propagation_velocity(arrival, 0.85 * R0), peaks=None, slowest_linear_speed=v0)
    assert slow.below_linear_speed.all() and np.isnan(slow.accepted_velocity).all()


def test_slowest_linear_speed_of_a_diatomic_chain_is_below_its_sound_speed():
    """Masses alternating 1 and 4 g, spring k: the long-wave (acoustic) speed is
    r0 sqrt(2 k / (m1 + m2)) = r0 sqrt(k / 2.5) (textbook diatomic chain), above which no front is
    slower; the local bound per gap takes the heavier magnet, r0 sqrt(k / 4) (hand calculation),
    below the acoustic speed as a lower bound must be. A uniform chain's is V0."""
    k, n = 0.05, 40
    masses = np.where(np.arange(n) % 2 == 0, 1.0, 4.0)
    gaps = np.full(n - 1, R0)
    slowest = measures.slowest_linear_speed(np.full(n - 1, k), masses, gaps)
    assert slowest == pytest.approx(R0 * np.sqrt(k / 4.0), rel=1e-12)
    assert slowest < R0 * np.sqrt(2 * k / (1.0 + 4.0))
    uniform = measures.slowest_linear_speed(np.full(n - 1, k), np.full(n, 1.084), gaps)
    assert uniform == pytest.approx(linear_wave_speed(k, 1.084, R0), rel=1e-12)


def test_centred_velocity_over_unequal_gaps_is_the_distance_over_the_time():
    """A front at a constant 3.7 m/s over gaps drawn within +-20 % of r0 (t_n = x_n / c): per gap
    and centred, V_P is c exactly: the centred value spans both gaps, (r_(n-1) + r_n) / (t_(n+1) - t_(n-1))."""
    rng = np.random.default_rng(5)
    gaps = R0 * (1 + 0.2 * rng.uniform(-1.0, 1.0, 39))
    c = 3.7
    arrival = np.concatenate(([0.0], np.cumsum(gaps))) / c
    assert_allclose(propagation_velocity(arrival, gaps), c, rtol=1e-12)
    assert_allclose(centred_propagation_velocity(arrival, gaps)[1:-1], c, rtol=1e-12)


def test_lead_pulse_of_a_travelling_pulse_sampled_coarsely():
    """w_n(t) = H sech^2(k (n - s t)), s = 1.3 sites per unit time, sampled every 0.37 (0.48 of a
    gap's crossing): the parabola-refined peak times give s within 3e-4 (measured 9e-5; peaks
    taken at the frames alone, or refined the wrong way, are off by ~4e-3); the height is the
    frames' largest sample, within 1.1 % of H (the pulse's top falls between frames)."""
    s, k, height = 1.3, 0.8, 2.0
    n = np.arange(120)
    t = np.arange(0.0, 120 / s + 20, 0.37)
    w = height / np.cosh(k * (n[None, :] - s * t[:, None])) ** 2
    speed, top = measures.lead_pulse(t, w)
    assert speed == pytest.approx(s, rel=3e-4)
    assert top == pytest.approx(height, rel=1.1e-2) and top <= height


def test_staggered_amplitude_is_the_period_two_difference_between_neighbouring_gaps():
    """r_n = 10 + A(t) (-1)^n cos(w t) + 0.01 n with A = 0.3 exp(-t/50), period 4, sampled every
    0.25 (the cosine's extremes on frames): over gaps 1-6 and the 10 time units before t_end,
    |r_(n+1) - r_n| peaks at 2 A |cos| + 0.01 (by hand: at the window's first extreme, t = 92 for
    t_end = 100); a larger pattern beyond gap 6 is not counted."""
    t = np.arange(0.0, 200.0 + 1e-9, 0.25)
    n = np.arange(12)
    amplitude = 0.3 * np.exp(-t / 50)[:, None] * np.where(n < 6, 1.0, 3.0)[None, :]
    r = 10 + amplitude * (-1.0) ** n[None, :] * np.cos(2 * np.pi * t / 4)[:, None] + 0.01 * n[None, :]
    assert measures.staggered_amplitude(t, r, 100.0) == pytest.approx(0.6 * np.exp(-92 / 50) + 0.01, rel=1e-12)
    assert measures.staggered_amplitude(t, r, 200.0) == pytest.approx(0.6 * np.exp(-192 / 50) + 0.01, rel=1e-12)


def test_a_magnet_number_or_window_of_the_wrong_kind_is_named():
    """phase_portrait(..., 2.5) failed as a numpy IndexError, steady_oscillation(window=None) as
    "'NoneType' object is not iterable", and fit_propagation_velocity took first_magnet = 1.5."""
    t, v = np.linspace(0.0, 1.0, 5), np.zeros((5, 3))
    with pytest.raises(TypeError, match=r"^magnet: got 2.5 \(float\); expected an integer$"):
        measures.phase_portrait(t, v, v, 2.5)
    with pytest.raises(TypeError, match=r"^window: got None; expected \(start, end\) in ms, two numbers$"):
        measures.steady_oscillation(t, v[:, 0], 1.0, window=None)
    with pytest.raises(TypeError, match=r"^window: got \(0.5,\); expected \(start, end\) in ms, two numbers$"):
        measures.steady_oscillation(t, v[:, 0], 1.0, window=(0.5,))
    with pytest.raises(TypeError, match=r"^first_magnet: got 1.5 \(float\); expected an integer$"):
        measures.fit_propagation_velocity(np.arange(5.0), 12.0 * np.arange(5.0), 1.5, 3)
    assert measures.fit_propagation_velocity(np.arange(5.0), 12.0 * np.arange(5.0), np.int64(1), 3).velocity == pytest.approx(12.0)


def test_to_dict_gives_strict_json_plain_values():
    """FirstPeaks.to_dict() and others held numpy arrays (json.dumps: "Object of type ndarray is
    not JSON serializable") and NaN (the token NaN, not strict JSON), though each says "plain
    values (JSON)"."""
    t = np.linspace(0.0, 10.0, 201)
    v = np.clip(np.sin(np.pi * t[:, None] / 4 - np.arange(3)), 0.0, None)
    peaks = measures.first_peaks(t, v, np.gradient(v, t, axis=0), 1.0)
    plateau = measures.trailing_plateau(np.full(5, np.nan))
    for result in (peaks, plateau, measures.oscillations(t, v[:, 0], 1.0), measures.phase_portrait(t, v, v, 1),
                   measures.steady_oscillation(t, v[:, 0], 1.0, window=(0.0, 3.0))):
        data = result.to_dict()
        assert json.loads(json.dumps(data, allow_nan=False)) == data
    assert peaks.to_dict()["peak_velocity_m_per_s"] == [pytest.approx(1.0, abs=1e-3)] * 3
    assert plateau.to_dict()["mean"] is None and plateau.to_dict()["first_gap"] is None
