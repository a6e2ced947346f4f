"""Impactor profiles: LAMMPS's impactor follows the profile's position and velocity exactly."""

from __future__ import annotations

import numpy as np
import pytest

from pylmp_lattice.impactor import Constant, Ramp, SinePulse
from pylmp_lattice.run_folder import simulate

from conftest import make_case

PROFILES = [
    {"profile": "constant", "velocity": 1.5},
    {"profile": "ramp", "velocity": 1.5, "ramp_time": 7.3},
    {"profile": "sine", "velocity": 1.5, "duration": 7.3},
]


@pytest.mark.parametrize("profile", [Constant(1.5), Ramp(1.5, 7.3), SinePulse(1.5, 7.3)])
def test_profile_is_self_consistent(profile):
    """v = du/dt and a = dv/dt, checked by finite differences (central, h = 1e-4 ms)."""
    t = np.linspace(0.01, 20.0, 997)
    h = 1e-4
    dudt = (profile.displacement_at(t + h) - profile.displacement_at(t - h)) / (2 * h)
    dvdt = (profile.velocity_at(t + h) - profile.velocity_at(t - h)) / (2 * h) * 1e3
    smooth = np.abs(t - 7.3) > 2 * h  # the ramp's and pulse's kinks
    assert np.allclose(dudt, profile.velocity_at(t), atol=1e-7)
    assert np.allclose(dvdt[smooth], profile.acceleration_at(t)[smooth], rtol=1e-5, atol=1e-3)
    assert profile.displacement_at(0.0) == 0.0


@pytest.mark.lammps
@pytest.mark.parametrize("impactor", PROFILES, ids=[p["profile"] for p in PROFILES])
def test_lammps_impactor_follows_profile(tmp_path, impactor):
    case = make_case(particles=10, duration=20.0, impactor=impactor)
    traj = simulate(case, tmp_path)
    # 12 printed digits of positions in m of up to 0.1 m: 1e-10 m = 1e-7 mm
    assert np.max(np.abs(traj.u[:, 0] - case.impactor.displacement_at(traj.t))) < 1e-7
    assert np.max(np.abs(traj.v[:, 0] - case.impactor.velocity_at(traj.t))) < 1e-10


@pytest.mark.lammps
@pytest.mark.parametrize("column", ["u", "v"])
def test_measured_impactor_sampled_at_8_khz_matches_the_analytic_run(tmp_path, column):
    """A u1(t) sampled at the camera's 8 kHz, played by fix lattice/impactor, against the same
    motion given analytically (fix move): all 30 magnets' velocities agree to 2e-3 V_I.

    The half-sine's acceleration jumps at t = 0 and T_s, where a cubic spline through samples
    is locally first order: measured 1.4e-3 V_I there from u samples, 1e-5 V_I from v samples.
    """
    pulse = SinePulse(2.0, 40.0)
    t = np.arange(0.0, 100.0 + 1e-9, 0.125)
    values = pulse.displacement_at(t) if column == "u" else pulse.velocity_at(t)
    measured = {"profile": "measured", "t": list(t), "values": list(values), "column": column}
    analytic = simulate(make_case(duration=80.0, dt=0.0125, interval=0.125, impactor={"profile": "sine", "velocity": 2.0, "duration": 40.0}), tmp_path / "analytic")
    played = simulate(make_case(duration=80.0, dt=0.0125, interval=0.125, impactor=measured), tmp_path / "measured")
    assert np.max(np.abs(played.v - analytic.v)) < 2e-3 * 2.0
