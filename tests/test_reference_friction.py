"""The friction reference integrator (tests/reference.py) checked against exact results.

Units: mm, g, ms, N (energies in mJ = N mm, velocities in mm/ms = m/s). Measured values
(scipy 1.17, rtol = atol = 1e-12) are quoted next to each tolerance; the file runs in ~5 s.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import quad

from reference import integrate_chain, integrate_chain_friction, integrate_rig, power_force

MASS, MU, P, G = 1.084, 0.285, 0.012, 9.81e-3
K, B = 413.8, 3.917


def magnet_potential(r):
    """U with F = -dU/dr for F = K/(r+b)^3 (written out, not taken from the code under test)."""
    return K / (2.0 * (r + B) ** 2)


# --- Coulomb oscillator: one particle between two linear springs, p = 0 ------------------------


def test_linear_coulomb_oscillator_matches_the_analytic_solution():
    """Each spring F(r) = k (10 - r) (fixed ends at -10 and +10 mm): net force -2k x, so
    k_eff = 2k and friction mu m g shifts the centre by +-delta = mu m g / k_eff. Turning
    points are at t_j = j pi / omega, with amplitude |A_j| = A_0 - 2 j delta, sign
    alternating; the particle sticks at the first turning point with |A_j| <= delta."""
    k, a0 = 0.05, 0.731
    k_eff = 2 * k
    omega = np.sqrt(k_eff / MASS)
    delta = MU * MASS * G / k_eff
    n_half = int(np.ceil((a0 - delta) / (2 * delta)))  # half cycles until inside the band
    t_out = np.linspace(0.0, (n_half + 3) * np.pi / omega, 301)

    zero = lambda t: np.zeros_like(np.asarray(t, dtype=float))  # noqa: E731
    spring = lambda r: k * (10.0 - r)  # noqa: E731
    run = integrate_chain_friction(
        spring, MASS, 0.0, 3, zero, zero, t_out, MU, 0.0, G, x_init=[-10.0, a0, 10.0]
    )

    j = np.arange(1, n_half + 1)
    a_exact = (-1.0) ** j * (a0 - 2 * j * delta)
    t_exact = j * np.pi / omega
    times = np.array([e[0] for e in run.events])
    turning = np.array([e[4] for e in run.events])
    # Reverses at each turning point (new mode (-1)^(j+1)), sticks at the last one.
    assert [e[3] for e in run.events] == [int((-1) ** (i + 1)) for i in j[:-1]] + [0]
    assert abs(a_exact[-1]) <= delta < abs(a_exact[-2])
    np.testing.assert_allclose(turning, a_exact, rtol=1e-9, atol=0)  # measured 2e-10
    np.testing.assert_allclose(times, t_exact, rtol=1e-9, atol=0)  # measured 1.3e-12
    after = t_out > t_exact[-1] + 1e-6
    assert np.all(run.v[after] == 0.0)
    np.testing.assert_allclose(run.x[after, 1], a_exact[-1], rtol=1e-9, atol=0)


# --- the calibration rig of Fig. S4 with the magnets' law ---------------------------------------


@pytest.mark.parametrize("gap", [249.5, 30.1])
def test_rig_energy_lost_between_turning_points_is_the_friction_work(gap):
    """Released from rest 1.8 mm from the left magnet. Between consecutive turning points
    (v = 0) U(x_a) - U(x_b) = |int_{x_a}^{x_b} L(x) dx|, L by quadrature over x, independent of
    the time integration. Measured: max relative error 8e-12 (249.5 mm, 9 half cycles),
    4e-10 (30.1 mm, 77 half cycles)."""
    force = power_force(K, B)
    run = integrate_rig(force, MASS, gap, 1.8, np.linspace(0.0, 5000.0, 501), MU, P, G)

    def limit(x):
        return MU * (MASS * G + P * (force(x) + force(gap - x)))

    def potential(x):
        return magnet_potential(x) + magnet_potential(gap - x)

    stops = [1.8] + [e[4] for e in run.events]
    assert all(e[3] != 0 for e in run.events[:-1]) and run.events[-1][3] == 0
    for xa, xb in zip(stops[:-1], stops[1:]):
        work = abs(quad(limit, xa, xb, epsabs=0.0, epsrel=1e-13, limit=200)[0])
        assert potential(xa) - potential(xb) == pytest.approx(work, rel=1e-8)

    # At rest at the end, held by friction.
    x = run.x[-1, 1]
    assert run.x[-1, 1] == stops[-1] and np.all(run.v[-60:] == 0.0)
    assert abs(force(x) - force(gap - x)) <= limit(x)


def test_mirror_symmetric_movers_stop_together_and_a_balanced_particle_stays():
    """Three free magnets, fixed ends at +-30 mm, outer ones pushed in symmetrically: the
    middle one has net force 0 (up to rounding) < L and never moves; the outer two stop and
    reverse at the same instants (measured: identical times) - simultaneous events."""
    force = power_force(K, B)
    zero = lambda t: np.zeros_like(np.asarray(t, dtype=float))  # noqa: E731
    x_init = [-30.0, -27.0, 0.0, 27.0, 30.0]
    t_out = np.linspace(0, 2000.0, 201)
    run = integrate_chain_friction(force, MASS, 0.0, 5, zero, zero, t_out, MU, P, G, x_init=x_init)
    assert np.all(run.x[:, 2] == 0.0) and np.all(run.v[:, 2] == 0.0)
    left = [e for e in run.events if e[1] == 1]
    right = [e for e in run.events if e[1] == 3]
    assert len(left) == len(right) > 3 and left[-1][3] == 0
    for a, b in zip(left, right):
        assert a[0] == pytest.approx(b[0], rel=1e-9) and a[3] == -b[3]
        assert a[4] == pytest.approx(-b[4], rel=1e-9)


# --- the 21-magnet chain with a half-sine pulse ------------------------------------------------

PULSE_T, PULSE_V = 47.8, 2.81


def pulse_v(t):
    t = np.asarray(t, dtype=float)
    return np.where(t < PULSE_T, PULSE_V * np.sin(np.pi * t / PULSE_T), 0.0)


def pulse_x(t):
    t = np.minimum(np.asarray(t, dtype=float), PULSE_T)
    return PULSE_V * PULSE_T / np.pi * (1.0 - np.cos(np.pi * t / PULSE_T))


def chain_run(mu):
    return integrate_chain_friction(
        power_force(K, B), MASS, 12.0, 21, pulse_x, pulse_v, np.linspace(0.0, 100.0, 501), mu, P, G,
        t_breaks=[PULSE_T],
    )


def test_chain_energy_balance_with_friction():
    """KE + U + friction work = U(0) + drive work, at every output (measured 1.6e-9 relative;
    143 mode changes: 19 first slips at the front, 120 reversals, 2 sticks, 2 re-slips)."""
    run = chain_run(MU)
    kinetic = 0.5 * MASS * np.sum(run.v[:, 1:-1] ** 2, axis=1)
    potential = np.sum(magnet_potential(np.diff(run.x, axis=1)), axis=1)
    supplied = potential[0] + run.w_drive
    balance = kinetic + potential + run.w_friction - supplied
    assert np.max(np.abs(balance) / supplied) < 1e-7
    assert run.w_friction[-1] > 0.1 * run.w_drive[-1]  # friction matters: ~19 of 83 mJ
    assert len(run.events) > 100


def test_chain_without_friction_is_integrate_chain():
    """mu = 0 against the frictionless reference. The drive has a kink at 47.8 ms, where
    integrate_chain (no restart there) is only good to ~1.6e-8 m/s at rtol 1e-12, so it runs at
    1e-13 here. Measured: 2.3e-9 m/s, i.e. 4e-10 of the peak velocity."""
    run = chain_run(0.0)
    ref = integrate_chain(
        power_force(K, B), MASS, 12.0, 21, pulse_x, pulse_v, run.t, rtol=1e-13, atol=1e-13
    )
    assert np.max(np.abs(run.v - ref)) < 1e-9 * np.max(np.abs(ref))
