"""LAMMPS against an independent integrator (scipy DOP853) on a 30-magnet chain."""

from __future__ import annotations

import numpy as np
import pytest

from pylmp_lattice.forcelaw import PowerLaw
from pylmp_lattice.run_folder import simulate

from conftest import make_case
from reference import integrate_chain, power_force

pytestmark = pytest.mark.lammps


def _max_velocity_error(tmp_path, velocity, duration, dt):
    case = make_case(particles=30, velocity=velocity, duration=duration, dt=dt)
    traj = simulate(case, tmp_path / f"dt{dt}")
    v_ref = integrate_chain(
        power_force(), 1.084, 12.0, 30, lambda t: velocity * t, lambda t: np.full_like(t, velocity), traj.t
    )
    return np.max(np.abs(traj.v - v_ref))


# V_I = 2 m/s for 90 ms: the front crosses the 348 mm chain and reflects from the fixed end;
# at ~97 ms magnets 28 and 29 touch (see test_contact). V_I = 0.1 m/s: a weak, smooth wave.
@pytest.mark.parametrize("velocity, duration", [(0.1, 200.0), (2.0, 90.0)])
def test_lammps_matches_independent_integrator(tmp_path, velocity, duration):
    error = _max_velocity_error(tmp_path, velocity, duration, dt=0.01)
    assert error < 1e-3 * velocity


def test_error_is_second_order_in_dt(tmp_path):
    """Velocity Verlet: halving dt divides the error by 4 (measured, not assumed)."""
    e1 = _max_velocity_error(tmp_path, 2.0, 90.0, dt=0.02)
    e2 = _max_velocity_error(tmp_path, 2.0, 90.0, dt=0.01)
    assert 3.5 < e1 / e2 < 4.5


def test_sampled_force_law_runs_like_the_exact_law(tmp_path):
    """Samples of the paper's law every 0.1 mm (a 'measured' law), with friction: the same
    trajectory as the exact law within 1e-5 V_I (measured 7.5e-7 V_I; the spline through the
    samples is off by ~1e-6 relative near contact); the chain engine reads the table."""
    r = np.linspace(0.0, 40.0, 401)
    sampled = {"law": "sampled", "r": list(r), "F": list(PowerLaw().force(r))}
    case = make_case(particles=30, velocity=2.0, duration=90.0, force=sampled, table={"r_max": 36.0},
                     friction={"mu": 0.285, "p": 0.012})
    traj = simulate(case, tmp_path)
    assert "law table ${dir}/force.table FORCE_LAW" in (tmp_path / "in.lattice").read_text()
    exact = simulate(make_case(particles=30, velocity=2.0, duration=90.0, friction={"mu": 0.285, "p": 0.012}),
                     tmp_path / "exact")
    assert np.max(np.abs(traj.v - exact.v)) < 1e-5 * 2.0


def test_second_neighbours_match_independent_integrator(tmp_path):
    """Second-neighbour bonds (type 2, i to i+2): an attractive law of 5 % of the nearest force
    at r0 (paper Sec. S2) changes the velocities by up to 1.2 V_I within 60 ms (it shifts the
    front), and LAMMPS follows the independent integrator to < 1e-3 V_I (measured 1.5e-4 V_I,
    as the nearest-neighbour runs above)."""
    second = {"law": "power", "K": 206.2, "b": 10.267, "q": 3.0, "sign": -1}
    case = make_case(particles=30, velocity=2.0, duration=60.0, second_neighbour=second)
    traj = simulate(case, tmp_path)
    assert "bond_coeff      2 ${dir}/second.table" in (tmp_path / "in.lattice").read_text()
    law = PowerLaw(206.2, 10.267, 3.0)
    drive = (lambda t: 2.0 * t, lambda t: np.full_like(t, 2.0))
    v_ref = integrate_chain(power_force(), 1.084, 12.0, 30, *drive, traj.t, force2=lambda d: -law.force(d))
    v_nearest = integrate_chain(power_force(), 1.084, 12.0, 30, *drive, traj.t)
    assert np.max(np.abs(traj.v - v_ref)) < 1e-3 * 2.0
    assert np.max(np.abs(v_ref - v_nearest)) > 0.5 * 2.0


def test_second_neighbours_with_a_short_nearest_table(tmp_path):
    """The second-neighbour table spans twice the nearest one's range: with the nearest table
    ending at 20 mm (gaps of 12 mm), pairs start 24 mm apart, beyond it, inside the second
    table's [0, 40] mm; LAMMPS follows the independent integrator as above (< 1e-3 V_I; measured
    1e-4 V_I)."""
    second = {"law": "power", "K": 206.2, "b": 10.267, "q": 3.0, "sign": -1}
    case = make_case(particles=21, velocity=2.0, duration=40.0, second_neighbour=second, table={"r_max": 20.0})
    assert case.second_table_range() == (0.0, 40.0)
    traj = simulate(case, tmp_path)
    law = PowerLaw(206.2, 10.267, 3.0)
    drive = (lambda t: 2.0 * t, lambda t: np.full_like(t, 2.0))
    v_ref = integrate_chain(power_force(), 1.084, 12.0, 21, *drive, traj.t, force2=lambda d: -law.force(d))
    assert np.max(np.abs(v_ref[:, 10])) > 2.0  # the front has passed magnet 11 (of 21)
    assert np.max(np.abs(traj.v - v_ref)) < 1e-3 * 2.0
