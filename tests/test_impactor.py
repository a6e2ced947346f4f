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



def test_a_measured_motion_back_at_rest_is_a_pulse_and_one_still_moving_a_push():
    """`is_pulse`: a half-sine given as samples is a pulse as the half-sine is (its arrivals are
    first velocity peaks), also with 10 um of noise on every sample (the end's spline slope
    alone called half such draws pushes) and when its record ends where the pulse does; one
    that ends moving at most 10 % of its peak, or recoiling, is too; beyond that a push (level
    arrivals), as are the constant drive and the ramp."""
    from pylmp_lattice.impactor import Measured

    pulse = SinePulse(2.81, 47.8)
    t = np.arange(0.0, 60.0 + 1e-9, 0.1)
    assert pulse.is_pulse() and not Constant(2.0).is_pulse() and not Ramp(2.0, 5.0).is_pulse()
    u = pulse.displacement_at(t)
    assert Measured(tuple(t), tuple(u)).is_pulse()
    noise = np.random.default_rng(1).normal(0.0, 0.01, size=(50, len(t)))  # mm
    assert all(Measured(tuple(t), tuple(u + e)).is_pulse() for e in noise)
    ends = t <= 47.8 + 1e-9
    assert Measured(tuple(t[ends]), tuple(u[ends])).is_pulse()
    for end, expected in ((0.09, True), (-0.2, True), (0.11, False), (1.0, False)):  # v at the end, in V_I
        v = np.interp(t, [0.0, 20.0, 40.0, 60.0], [0.0, 1.0, end, end])  # up to V_I, down to `end`, held
        assert Measured(tuple(t), tuple(2.0 * v), column="v").is_pulse() is expected, end


@pytest.mark.lammps
def test_the_experiment_s_drive_given_as_samples_is_measured_as_the_half_sine(tmp_path):
    """The same impact as the stand-in half-sine or as its u1(t) samples (every 0.1 ms): the same
    arrival definition (a pulse's) and front speeds within 1e-4 (a trial found the samples
    measured by the V_I/2 level, 3 % slower in the lab frame, for the same motion)."""
    import dataclasses
    from pathlib import Path

    from pylmp_lattice.case import load_case
    from pylmp_lattice.impactor import Measured
    from pylmp_lattice.run_folder import run_case

    base = load_case(Path(__file__).parent.parent / "inputs" / "paper_experiment.toml")
    t = np.arange(0.0, 60.0 + 1e-9, 0.1)
    measured = dataclasses.replace(base, impactor=Measured(tuple(t), tuple(base.impactor.displacement_at(t))))
    one, other = (run_case(case, tmp_path / name, figure=False) for case, name in ((base, "sine"), (measured, "u1")))
    assert one["front_resolution"]["arrival_method"] == other["front_resolution"]["arrival_method"] == "velocity_peak"
    for key, field in (("front_speed_lab_m_per_s", "value"), ("front_speed_lab_m_per_s", "gap_frame_m_per_s"),
                       ("shock_velocity_plateau_m_per_s", "mean")):
        assert other[key][field] == pytest.approx(one[key][field], rel=1e-4), key
    assert other["particles_reached_by_front"] == one["particles_reached_by_front"]


# A measured motion on the camera's clock: samples from t0 = 5 ms, the impactor 3 mm along
# the rod at the first; u - u0 = POLY(t - t0), a cubic, which the not-a-knot spline through the
# samples (of u, or of v = its derivative, a quadratic) reproduces to round-off.
T0, U0, SPAN = 5.0, 3.0, 10.0  # ms, mm, ms


def _poly(tau):
    """u (mm), v (m/s) and a (m/s^2 = 1e3 mm/ms^2) of the cubic at times tau (ms) from the start."""
    return (0.5 * tau + 0.02 * tau**2 - 0.001 * tau**3, 0.5 + 0.04 * tau - 0.003 * tau**2,
            1e3 * (0.04 - 0.006 * tau))


def _camera_clock(column: str):
    t = T0 + np.linspace(0.0, SPAN, 21)
    u, v, _ = _poly(t - T0)
    return tuple(t), tuple(U0 + u if column == "u" else v)


@pytest.mark.parametrize("column", ["u", "v"])
def test_a_measured_motion_on_the_camera_s_clock_starts_when_and_where_its_samples_do(column):
    """Samples from t0 = 5 ms at u0 = 3 mm: the drive starts at t = 0 from where it is
    (displacement 0), follows the cubic they sample (to 1e-11 mm, 1e-11 m/s, 1e-8 m/s^2:
    round-off of a spline through values of order 10), lasts t_last - t0 = 10 ms, and then
    holds the impactor still (v = a = 0, u where it stopped), though it ended moving at
    0.6 m/s. Its peak is the cubic's, 0.5 + 0.04^2/(4 0.003) = 0.63333 m/s (to the 2.5e-4 ms
    grid's 1e-10), so it is a push, not a pulse."""
    from pylmp_lattice.impactor import Measured

    imp = Measured(*_camera_clock(column), column=column)
    assert imp.duration() == pytest.approx(SPAN, rel=1e-15)
    tau = np.linspace(0.0, SPAN, 401)
    u, v, a = _poly(tau)
    np.testing.assert_allclose(imp.displacement_at(tau), u, rtol=0, atol=1e-11)
    np.testing.assert_allclose(imp.velocity_at(tau), v, rtol=0, atol=1e-11)
    np.testing.assert_allclose(imp.acceleration_at(tau), a, rtol=0, atol=1e-8)
    after = np.array([SPAN + 1e-6, SPAN + 1.0, 3 * SPAN])
    u_end = _poly(SPAN)[0]
    np.testing.assert_allclose(imp.displacement_at(after), u_end, rtol=0, atol=1e-11)
    assert np.all(imp.velocity_at(after) == 0.0) and np.all(imp.acceleration_at(after) == 0.0)
    assert imp.peak_velocity() == pytest.approx(0.5 + 0.04**2 / (4 * 0.003), rel=1e-9)
    assert not imp.is_pulse()


@pytest.mark.lammps
@pytest.mark.parametrize("engine", ["chain", "stock"])
def test_lammps_plays_a_measured_motion_on_the_camera_s_clock(tmp_path, engine):
    """The same samples (u, from t0 = 5 ms) played by fix lattice/impactor for 15 ms, 5 ms past
    their end: magnet 1 follows the cubic from its own start, then stays where it stopped
    (hold), to 1e-9 mm and 1e-9 m/s (the spline in SI and the H5MD file's doubles: measured
    1.1e-14 m/s and 2.7e-15 mm): the plugin, as the profile, counts time from the first sample
    and displacement from where it starts."""
    t, values = _camera_clock("u")
    case = make_case(particles=10, velocity=1.0, duration=15.0,
                     impactor={"profile": "measured", "t": list(t), "values": list(values), "column": "u"},
                     run={"engine": engine})
    traj = simulate(case, tmp_path)
    u, v, _ = _poly(np.minimum(traj.t, SPAN))
    v = np.where(traj.t <= SPAN, v, 0.0)
    assert traj.t[-1] == pytest.approx(15.0)
    assert np.max(np.abs(traj.u[:, 0] - u)) < 1e-9
    assert np.max(np.abs(traj.v[:, 0] - v)) < 1e-9


@pytest.mark.parametrize("make, field", [
    (lambda: Constant(0.0), "impactor.velocity"),
    (lambda: Constant(float("inf")), "impactor.velocity"),
    (lambda: Constant(float("nan")), "impactor.velocity"),
    (lambda: Ramp(1.0, 0.0), "impactor.ramp_time"),
    (lambda: SinePulse(1.0, 0.0), "impactor.duration"),
    (lambda: SinePulse(1.0, -2.0), "impactor.duration"),
    (lambda: SinePulse(1.0, float("inf")), "impactor.duration"),
    (lambda: Ramp(1.0, float("inf")), "impactor.ramp_time"),
], ids=["zero", "inf", "nan", "ramp_time", "duration", "negative_duration", "infinite_duration", "infinite_ramp"])
def test_a_drive_without_a_forward_speed_or_a_time_is_refused(make, field):
    """Profiles built directly (the Python API, not through a case file whose loader checks
    numbers first): each checks its own fields. An infinite pulse duration was taken: its
    displacement was inf * 0 = NaN, and a case built with it wrote 'impactor ramp 2.0 inf' or
    'variable T_s equal inf' into its deck."""
    from pylmp_lattice.errors import ConfigError

    with pytest.raises(ConfigError) as info:
        make()
    assert info.value.field == field


@pytest.mark.parametrize("t, values, field", [
    ((0.0, 1.0, 2.0), (0.0, 1.0, 2.0), "impactor.t"),  # 3 samples: a not-a-knot cubic needs 4
    ((0.0, 1.0, 1.0, 2.0), (0.0, 1.0, 1.5, 2.0), "impactor.t"),  # two samples at one time
    ((0.0, 1.0, 2.0, 3.0), (2.0, 2.0, 2.0, 2.0), "impactor.values"),  # never moves
    ((0.0, 1.0, 2.0, 3.0), (0.0, -1.0, -2.0, -3.0), "impactor.values"),  # moves backward only
], ids=["three", "same_time", "still", "backward"])
def test_a_measured_motion_that_cannot_drive_is_refused(t, values, field):
    from pylmp_lattice.errors import ConfigError
    from pylmp_lattice.impactor import Measured

    with pytest.raises(ConfigError) as info:
        Measured(t, values)
    assert info.value.field == field


@pytest.mark.lammps
def test_a_measured_motion_that_stops_the_run_may_last_exactly_as_long_as_its_data(tmp_path):
    """after = 'stop': a run as long as the samples' span (10 ms) is taken, and LAMMPS plays it
    to its last step with the impactor at the cubic's end (to 1e-9 mm, as above); one step
    longer is refused before any deck exists, naming run.duration."""
    from pylmp_lattice.errors import ConfigError

    t, values = _camera_clock("u")
    drive = {"profile": "measured", "t": list(t), "values": list(values), "column": "u", "after": "stop"}
    case = make_case(particles=10, duration=SPAN, impactor=drive)
    traj = simulate(case, tmp_path)
    assert traj.t[-1] == pytest.approx(SPAN, abs=1e-12)
    assert abs(traj.u[-1, 0] - _poly(SPAN)[0]) < 1e-9
    with pytest.raises(ConfigError, match=r"^run\.duration: got 10\.01 ms; the measured impactor data end at 10\.0 ms"):
        make_case(particles=10, duration=SPAN + 0.01, impactor=drive)
