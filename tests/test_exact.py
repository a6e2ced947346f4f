"""Exact solutions (exact.py) checked independently, then the package against them."""

from __future__ import annotations

import numpy as np
import pytest

from pylmp_lattice.exact import (harmonic_overshoot_limit, harmonic_piston_velocity, jump, toda_lead_soliton,
                                 toda_piston_wake, toda_soliton, toda_soliton_speed, wake_energy, weak_shock)
from pylmp_lattice.forcelaw import LinearSpring, PowerLaw, Toda
from pylmp_lattice.measures import lead_pulse, staggered_amplitude
from pylmp_lattice.run_folder import simulate
from pylmp_lattice.studies.literature.toda import piston_case, soliton_case, soliton_speed
from pylmp_lattice.studies.scaffold import MAGNET_STIFFNESS, chain_case
from pylmp_lattice.studies.scaffold import MASS as MAGNET_MASS

from reference import integrate_chain


def test_harmonic_piston_solution_matches_an_independent_integration():
    """The Bessel series against DOP853 on a 120-particle harmonic chain (k = 0.5 N/mm, m = 1 g):
    particle n = 0 is the piston, n = 1, 2, ... the chain (measured agreement 4.5e-11)."""
    k, m, u_p = 0.5, 1.0, 0.3
    t = np.linspace(0.0, 80.0, 401)
    v_ref = integrate_chain(lambda r: k * (20.0 - r), m, 10.0, 120, lambda t: u_p * t,
                            lambda t: np.full_like(t, u_p), t)
    v = harmonic_piston_velocity(np.arange(40), t, u_p, np.sqrt(k / m))
    assert np.max(np.abs(v_ref[:, 1:40])) > 0.3  # the front has passed these particles
    assert np.max(np.abs(v - v_ref[:, :40])) < 1e-9 * u_p
    assert np.all(v[:, 0] == u_p) and np.all(v[0, 1:] == 0)


def test_harmonic_overshoot_approaches_the_airy_limit():
    """The exact first peak (w = 1) at n = 50 and 200: 1.2593 and 1.2683, rising toward the Airy
    limit 1.27435 as the front widens."""
    assert harmonic_overshoot_limit() == pytest.approx(1.274352, abs=1e-6)
    peaks = [harmonic_piston_velocity([n], np.linspace(n - 5.0, n + 15.0, 201), 1.0, 1.0).max() for n in (50, 200)]
    assert peaks[0] < peaks[1] < harmonic_overshoot_limit() < peaks[1] + 1e-2


def test_harmonic_first_peak_of_the_paper_chain_continuous_and_at_the_study_frames():
    """The exact first peak at magnets 31 and 74 (n = 30, 73) of the paper's linear chain,
    w = 0.133573 rad/ms: 1.253419 and 1.262571 in continuous time (referee's direct sum
    J_2n + 2 sum_{k>n} J_2k on a 0.003-wide grid in x = 2 w t: 1.2534187, 1.2625714), while
    sampled at the harmonic study's 0.5 ms frames the maximum is 1.253316 and 1.262535, the
    "exact" column of docs/literature.md: 1e-4 lower, the frames missing the crest."""
    omega = np.sqrt(MAGNET_STIFFNESS / MAGNET_MASS)
    for n, continuous, framed in ((30, 1.2534187, 1.2533160), (73, 1.2625714, 1.2625346)):
        fine = np.arange(0.0, 600.0, 0.005)
        first = harmonic_piston_velocity([n], fine[np.abs(fine - n / omega) < 40], 1.0, omega).max()
        assert first == pytest.approx(continuous, abs=2e-7)
        frames = np.arange(0.0, 600.0 + 0.25, 0.5)
        assert harmonic_piston_velocity([n], frames[np.abs(frames - n / omega) < 40], 1.0, omega).max() == \
            pytest.approx(framed, abs=2e-7)


def test_toda_lead_soliton_peak_velocity_is_twice_the_piston_speed():
    """cosh(kappa) = 1 + u_p: the soliton's particle velocity peaks at 2 sinh(kappa) tanh(kappa/2)
    = 2 u_p exactly (referee's derivation), and its height sinh^2(kappa) is u_p^2 + 2 u_p."""
    for u_p in (0.25, 1.0, 1.9):
        kappa = float(toda_lead_soliton(u_p)[0])
        _, v, r = toda_soliton([0], np.linspace(-3.0, 3.0, 600001) / np.sinh(kappa), kappa)
        assert v.max() == pytest.approx(2 * u_p, rel=1e-9)
        assert np.expm1(-r).max() == pytest.approx(u_p**2 + 2 * u_p, rel=1e-9)


def test_toda_soliton_solves_the_toda_equations():
    """x, v, r are consistent (r = x_(n+1) - x_n, v = dx/dt) and x'' = exp(-r_(n-1)) - exp(-r_n),
    by finite differences in t (step 1e-3: errors ~1e-6)."""
    n, t, kappa = np.arange(-20, 21), np.linspace(0.0, 3.0, 3001), 1.3
    x, v, r = toda_soliton(n, t, kappa)
    np.testing.assert_allclose(np.diff(x, axis=1), r[:, :-1], atol=1e-13)
    inner = slice(5, -5)
    np.testing.assert_allclose(np.gradient(x, t, axis=0)[inner], v[inner], atol=1e-5)
    acc = np.gradient(v, t, axis=0)
    np.testing.assert_allclose(acc[inner, 1:-1], (np.exp(-r[:, :-2]) - np.exp(-r[:, 1:-1]))[inner], atol=1e-5)
    assert np.max(np.exp(-r) - 1) == pytest.approx(np.sinh(kappa) ** 2, rel=1e-3)  # peak sampled near a gap
    assert x[0, 0] == pytest.approx(0.0, abs=1e-10) and x[0, -1] == pytest.approx(-2 * kappa, abs=1e-10)


def test_toda_piston_formulas():
    """Small u_p: the lead soliton's speed sinh(k)/k -> 1 + u_p/3 (cosh k = 1 + u_p); the wake
    keeps the Riemann invariant v - 2 exp(-r/2) = -2 of the rest state; no uniform wake above 2."""
    u = np.array([1e-4, 0.5, 1.0, 1.9])
    kappa, speed = toda_lead_soliton(u)
    assert speed[0] == pytest.approx(1 + u[0] / 3, rel=1e-8)
    np.testing.assert_allclose(speed, toda_soliton_speed(np.arccosh(1 + u)))
    np.testing.assert_allclose(u - 2 * np.exp(-toda_piston_wake(u) / 2), -2.0, rtol=1e-14)
    assert np.isnan(toda_piston_wake(2.1))


def test_weak_shock_of_the_paper_law():
    """s = (q+1) r0 / (4 (r0 + b)) = 0.75391 for the magnets; c0 = V0 = 1.6029 m/s; the jump
    conditions at a tiny compression give D = c0 + s u_p."""
    law = PowerLaw()
    ws = weak_shock(law, 12.0, 1.084)
    assert ws.s == pytest.approx(4 * 12.0 / (4 * 15.917), rel=1e-9)
    assert ws.c0 == pytest.approx(12.0 * np.sqrt(law.stiffness(12.0) / 1.084), rel=1e-12)
    j = jump(law, 12.0, 1.084, 12.0 - 1e-4)
    assert j.D == pytest.approx(ws.c0 + ws.s * j.u_p, rel=1e-9)
    assert j.e_wake == pytest.approx(0.0, abs=1e-14)


def test_jump_conditions():
    """Harmonic chain: D = c0 at any strength and no energy left for the wake; Toda: D^2 and u_p^2
    from dF and delta, and e_wake > 0 (convex law)."""
    spring = LinearSpring(k=0.3, r_free=20.0)
    j = jump(spring, 12.0, 1.0, np.array([11.0, 8.0]))
    np.testing.assert_allclose(j.D, 12.0 * np.sqrt(0.3), rtol=1e-14)
    np.testing.assert_allclose(j.e_wake, 0.0, atol=1e-14)
    toda = Toda(A=1.0, B=1.0, a=10.0)
    j = jump(toda, 10.0, 1.0, 9.0)
    dF = np.e - 1
    assert j.D == pytest.approx(10.0 * np.sqrt(dF), rel=1e-14) and j.u_p == pytest.approx(np.sqrt(dF), rel=1e-14)
    assert j.e_wake == pytest.approx(dF / 2 - (np.e - 2), rel=1e-12) and j.e_wake > 0
    assert wake_energy(toda, 10.0, 1.0, j.u_p, 9.0, np.e - 1) == pytest.approx(j.e_wake, rel=1e-12)


# ----------------------------------------------------------------------------- the package against them

@pytest.mark.lammps
def test_harmonic_chain_matches_the_bessel_solution(tmp_path):
    """The paper's linear lattice (k = F'(r0) of the magnets, m = 1.084 g, omega = 0.1336 rad/ms)
    driven at 0.1 m/s, default dt: max |v - exact| over particles 1-30 for 300 ms (the front
    passes particle 30 at ~225 ms) is 9.1e-7 u_p (Verlet's phase error, deterministic); the issue
    asks for 1e-5, the test holds it to 2e-6."""
    u_p = 0.1
    case = chain_case("harmonic", "harmonic", {"velocity": u_p}, 300.0, particles=80, output=0.5)
    assert case.run.dt == 0.01
    traj = simulate(case, tmp_path)
    v = harmonic_piston_velocity(np.arange(31), traj.t, u_p, np.sqrt(MAGNET_STIFFNESS / MAGNET_MASS))
    assert np.max(v[:, 30]) > 1.1 * u_p  # the first peak has passed particle 30
    assert np.max(np.abs(traj.v[:, 1:31] - v[:, 1:])) < 2e-6 * u_p


@pytest.mark.lammps
@pytest.mark.parametrize("kappa, dt", [(0.5, 0.01), (1.0, 0.01), (1.5, 0.01), (2.0, 0.005)])
def test_toda_soliton_speed(tmp_path, kappa, dt):
    """An exact soliton entering a Toda chain through particle 0 (a measured
    impactor on the exact solution); the time centroids of exp(-r_n) - 1 at gaps 10-40 (exactly
    kappa (n - n0) / sinh(kappa) for the exact soliton). Speed within 1e-4 of sinh(kappa)/kappa:
    measured 5.8e-9, 6.9e-7 and 2.6e-5 at dt = 0.01 ms; kappa = 2 gives ~9.0e-5 at 0.01 ms and
    2.2e-5 at 0.005 ms (Verlet, second order), so it runs at the latter."""
    traj = simulate(soliton_case(kappa, dt=dt), tmp_path)
    assert np.max(np.expm1(-(traj.gaps()[-1, 10:41] - 10.0))) < 1e-4 * np.sinh(kappa) ** 2  # the pulse has passed
    assert soliton_speed(traj.t, traj.gaps()) == pytest.approx(toda_soliton_speed(kappa), rel=1e-4)


@pytest.mark.lammps
@pytest.mark.parametrize("u_p", [0.5, 1.0, 1.5])
def test_toda_piston_uniform_wake_and_lead_soliton(tmp_path, u_p):
    """Below the critical speed: by t = 100 the first 10 gaps, averaged over the last 10 time
    units, sit at exp(-r) = (1 + u_p/2)^2 within 1e-3 relative (measured < 5e-5), moving at u_p;
    what is left of the oscillation there is < 1e-2 of r. The front moves within 1 % of the lead
    soliton's sinh(k)/k, cosh k = 1 + u_p (measured 0.4-0.9 % slow: the lead soliton is still
    growing toward its final height sinh^2 k, which it is 1.9-6.3 % below)."""
    traj = simulate(piston_case(u_p, 100.0), tmp_path)
    r, t = traj.gaps() - 10.0, traj.t
    late = t > 90
    expected = float(toda_piston_wake(u_p))
    assert np.mean(r[late, :10]) == pytest.approx(expected, rel=1e-3)
    assert np.mean(traj.v[late, 1:11]) == pytest.approx(u_p, rel=1e-3)
    assert np.max(np.abs(r[-1, :10] - expected)) < 1e-2 * abs(expected)
    kappa, lead = toda_lead_soliton(u_p)
    speed, height = lead_pulse(t, np.expm1(-r))
    assert speed == pytest.approx(float(lead), rel=1e-2)
    assert height == pytest.approx(np.sinh(kappa) ** 2, rel=0.07)


@pytest.mark.lammps
@pytest.mark.slow
def test_toda_piston_critical_speed_bracketed_within_5_percent(tmp_path):
    """Period two next to the piston, 5 % either side of u_c = 2. Below, the staggered
    amplitude |r_(n+1) - r_n| relaxes: it halves (or better) each time t doubles (measured
    ratio 0.42 from t = 100 to 200 at u_p = 1.9, 0.33-0.40 from 0.5 to 1.9, and 0.40 per
    doubling up to t = 800). Above, a period-two oscillation persists: it falls by less (0.56
    at 2.1, 0.65 at 2.2, 1.00 at 3.0; at 2.1 the ratio rises to 0.61 and 0.68 by t = 800)."""
    ratios = {}
    for u_p in (0.95 * 2, 1.05 * 2):
        # 240 particles: the wave reflected at the held end is back at gap 6 after t = 200
        # (the values agree with a 360-particle chain to all digits)
        traj = simulate(piston_case(u_p, 200.0, particles=240), tmp_path / str(u_p))
        r = traj.gaps() - 10.0
        ratios[u_p] = staggered_amplitude(traj.t, r, 200.0) / staggered_amplitude(traj.t, r, 100.0)
    assert ratios[1.9] < 0.5 < ratios[2.1]
