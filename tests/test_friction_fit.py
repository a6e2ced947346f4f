"""The friction calibration (measures.friction_fit): its rig model against an exact solution
and the package's LAMMPS rig, and the fit recovering mu and p from noisy traces."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose

from pylmp_lattice.forcelaw import LinearSpring, PowerLaw
from pylmp_lattice.measures import fit_friction, rig_motion

MASS, MU, P = 1.084, 0.285, 0.012
G = 9.81  # m/s^2; the weight m g = 1.084e-3 kg * 9.81 m/s^2 N


def test_rig_motion_is_the_coulomb_oscillator_for_linear_springs():
    """Two springs F = k (r_free - r), p = 0: net force k (r1 - 2 x), so the magnet oscillates
    about r1/2 at omega = sqrt(2 k/m), turning at t_j = j pi/omega with amplitudes falling by
    2 delta per half cycle, delta = mu m g / (2 k), until one is within delta: it sticks there."""
    k, r1, a0 = 0.05, 20.0, 7.31  # N/mm, mm, mm from the centre
    spring = LinearSpring(k=k, r_free=30.0)
    omega = np.sqrt(2 * k / MASS)  # rad/ms
    delta = MU * MASS * 1e-3 * G / (2 * k)  # mm
    n_half = int(np.ceil((a0 - delta) / (2 * delta)))
    j = np.arange(1, n_half + 1)
    amplitude = (-1.0) ** j * (a0 - 2 * j * delta)
    t = np.linspace(0.0, (n_half + 2) * np.pi / omega, 3001)
    m = rig_motion(t, r1, MU, 0.0, spring, MASS, G, start=r1 / 2 + a0)
    assert_allclose(np.array(m.turning[1:]) - r1 / 2, amplitude, rtol=1e-9)
    assert_allclose(m.rest_time, n_half * np.pi / omega, rtol=1e-6)
    # between turning points: x = centre + shift + (x_j - centre - shift) cos(omega (t - t_j))
    first = t < np.pi / omega
    shift = delta  # sliding towards smaller x, friction pushes towards larger x: centre + delta
    assert_allclose(m.x[first], r1 / 2 + shift + (a0 - shift) * np.cos(omega * t[first]), atol=1e-6)


def test_bad_traces_are_refused():
    t = np.linspace(0, 100, 50)
    with pytest.raises(ValueError, match="one per trace"):
        fit_friction([t, t], [t, t], [30.0], PowerLaw(), MASS)
    with pytest.raises(ValueError, match="start\\[0\\]: got 40"):
        fit_friction(t, t, 30.0, PowerLaw(), MASS, start=40.0)
    with pytest.raises(ValueError, match="two equal 1D arrays"):
        fit_friction(t, t[:-1], 30.0, PowerLaw(), MASS)


@pytest.fixture(scope="module")
def lammps_rig(tmp_path_factory):
    """The package's S4 rig (LAMMPS, dt = 0.002 ms) at r1 = 30.1 and 249.5 mm, 1400 ms (both at
    rest from ~1300 ms): t (ms) and x (mm from the left magnet), every 0.5 ms."""
    from pylmp_lattice.run_folder import simulate
    from pylmp_lattice.studies.paper.s4 import rig_case

    traces = {}
    for r1 in (30.1, 249.5):
        traj = simulate(rig_case(r1, 1400.0), tmp_path_factory.mktemp("rig") / "run")
        traces[r1] = (traj.t[::5], (traj.x0[1] + traj.u[:, 1])[::5])
    return traces


@pytest.mark.lammps
def test_rig_motion_against_the_lammps_rig(lammps_rig):
    """The model (turning points by energy balance, times by quadrature) and LAMMPS's Verlet
    with the friction fix agree to 1e-3 mm over the whole motion (measured 4e-5 and 1.9e-4)."""
    for r1, (t, x) in lammps_rig.items():
        m = rig_motion(t, r1, MU, P, PowerLaw(), MASS, G)
        assert np.max(np.abs(m.x - x)) < 1e-3
        assert abs(m.rest_position - x[-1]) < 1e-3


@pytest.mark.lammps
def test_fit_friction_recovers_mu_and_p_from_noisy_traces(lammps_rig):
    """1 % noise (std 1 % of each trace's range): mu and p within 3 % (measured 3e-5 and 2e-4),
    and within 4 of their standard errors; the rest positions within 4 of theirs."""
    rng = np.random.default_rng(7)
    t, x, r1 = [], [], []
    for sep, (ti, xi) in lammps_rig.items():
        t.append(ti)
        x.append(xi + rng.normal(0.0, 0.01 * np.ptp(xi), xi.size))
        r1.append(sep)
    fit = fit_friction(t, x, r1, PowerLaw(), MASS, G)
    assert abs(fit.mu / MU - 1) < 0.03 and abs(fit.p / P - 1) < 0.03
    assert abs(fit.mu - MU) < 4 * fit.mu_error and abs(fit.p - P) < 4 * fit.p_error
    for rest, err, (_, xi) in zip(fit.rest_position, fit.rest_position_error, lammps_rig.values()):
        assert abs(rest - xi[-1]) < 4 * err + 1e-3
    assert fit.reduced_chi2 == pytest.approx(1.0, abs=0.1)
    assert 1.0 <= fit.correlation_time < 1.15  # white noise: independent residuals


def test_errors_of_a_fit_to_correlated_noise_cover_the_truth():
    """Noise correlated from sample to sample (white noise smoothed by a Gaussian of 20 samples,
    1 % of the trace's range, as a filtered or smoothed measurement has): the standard errors
    assumed independent samples and were 8 times too small (the fit 15 of them from the truth).
    They are now widened by the square root of the residuals' integrated autocorrelation time,
    for this noise 2 sqrt(pi) 20 = 70.9 samples (measured 66.6): the fit is 1.9 of them from
    it. The
    model's own motion is the truth here, so the fit's errors are the noise's alone."""
    from scipy.ndimage import gaussian_filter1d

    r1 = 249.5
    t = np.linspace(0.0, 1.05 * rig_motion(np.array([0.0]), r1, MU, P, PowerLaw(), MASS, G).rest_time, 3000)
    x = rig_motion(t, r1, MU, P, PowerLaw(), MASS, G).x
    noise = gaussian_filter1d(np.random.default_rng(0).standard_normal(t.size), 20)
    fit = fit_friction(t, x + 0.01 * np.ptp(x) * noise / noise.std(), r1, PowerLaw(), MASS, G)
    assert fit.correlation_time == pytest.approx(2 * np.sqrt(np.pi) * 20, rel=0.4)
    assert abs(fit.mu - MU) < 3 * fit.mu_error and abs(fit.p - P) < 3 * fit.p_error
    assert abs(fit.mu - MU) > 3 * fit.mu_error / np.sqrt(fit.correlation_time)  # (the errors as they were)
