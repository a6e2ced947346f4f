"""The mean state behind a shock (measures.wake_state), and the magnet chain's weak-shock limit."""

from __future__ import annotations

import numpy as np
import pytest

from pylmp_lattice.exact import weak_shock
from pylmp_lattice.forcelaw import LinearSpring, PowerLaw
from pylmp_lattice.measures import wake_state
from pylmp_lattice.run_folder import RunFolder, run_case
from pylmp_lattice.studies.literature.hugoniot import measure
from pylmp_lattice.studies.scaffold import MASS as MAGNET_MASS
from pylmp_lattice.studies.scaffold import R0 as MAGNET_R0
from pylmp_lattice.studies.scaffold import chain_case


def test_wake_state_of_a_synthetic_oscillation():
    """Gaps r = 10 + 0.5 cos(w t) and v = 1 + 0.2 sin(w t) over whole periods, linear spring k = 2:
    mean gap 10, mean velocity 1, kinetic m <dv^2>/2 = m 0.02/2, potential k <dr^2>/2 = 0.125;
    for a linear law the mean force is the force of the mean gap."""
    t = np.linspace(0.0, 100.0, 100000, endpoint=False)
    w = 2 * np.pi / 10.0
    gaps = np.tile((10.0 + 0.5 * np.cos(w * t))[:, None], (1, 5))
    v = np.tile((1.0 + 0.2 * np.sin(w * t))[:, None], (1, 6))
    law = LinearSpring(k=2.0, r_free=20.0)
    s = wake_state(t, v, gaps, law, 3.0, (2, 4), (0.0, 100.0))  # gaps 2, 3, 4
    assert (s.first_gap, s.last_gap) == (2, 4)
    assert s.mean_gap == pytest.approx(10.0, abs=1e-6) and s.mean_velocity == pytest.approx(1.0, abs=1e-6)
    assert s.kinetic == pytest.approx(3.0 * 0.02 / 2, rel=1e-4)
    assert s.potential == pytest.approx(2.0 * 0.125 / 2, rel=1e-4)
    assert s.mean_force == pytest.approx(law.force(10.0), rel=1e-9)
    assert s.oscillation_energy == pytest.approx(s.kinetic + s.potential)
    with pytest.raises(ValueError, match="gap_range"):
        wake_state(t, v, gaps, law, 3.0, (4, 9), (0.0, 1.0))


def test_wake_state_takes_the_magnets_right_of_its_gaps_never_the_impactor():
    """Magnet j + 1 (column j) at 1 + 0.1 j + 0.2 sin(w t), the impactor (column 0) at 5 m/s: gaps
    1-3 lie between magnets 1-4 and take magnets 2-4 (columns 1-3), mean velocity 1.2 m/s and
    kinetic m (0.02 + 0.02/3)/2 (the oscillation's variance 0.02 plus the offsets' 0.1^2 2/3, by hand)."""
    t = np.linspace(0.0, 100.0, 100000, endpoint=False)
    w = 2 * np.pi / 10.0
    v = 1.0 + 0.1 * np.arange(6)[None, :] + 0.2 * np.sin(w * t)[:, None]
    v[:, 0] = 5.0
    gaps = np.full((t.size, 5), 10.0)
    s = wake_state(t, v, gaps, LinearSpring(k=2.0, r_free=20.0), 3.0, (1, 3), (0.0, 100.0))
    assert s.mean_velocity == pytest.approx(1.2, rel=1e-9)
    assert s.kinetic == pytest.approx(3.0 * (0.02 + 0.02 / 3) / 2, rel=1e-6)


@pytest.mark.lammps
def test_magnet_chain_weak_shock_limit(tmp_path):
    """The magnet chain pushed at 0.1 and 0.5 m/s for 600 ms (c0 = 1.6029 m/s, s = 0.7539).
    The mean state behind obeys the jump conditions: its Rankine-Hugoniot particle velocity is
    u_p (measured 4.0e-4 and 8.2e-3 off; tolerances 1e-3 and 1e-2) and its R-H speed lies on the
    weak-shock line c0 + s u_p (3.6e-4, 7.9e-3). The front does not: at 0.1 m/s it is near the line (+0.2 %), at 0.5 m/s 7 %
    above it and within 1 % of c0 + (4/3) s u_p (measured +0.5 %), the speed of the lead
    soliton of a developed dispersive shock (KdV limit), which leaves the mean state behind."""
    ws = weak_shock(PowerLaw(), MAGNET_R0, MAGNET_MASS)
    assert ws.s == pytest.approx(0.753911, abs=1e-6) and ws.c0 == pytest.approx(1.602876, abs=1e-6)
    rows = {}
    for u_p in (0.1, 0.5):
        case = chain_case("magnet", f"up{u_p}", {"velocity": u_p}, 600.0, output=0.5)
        summary = run_case(case, tmp_path / case.name, figure=False)
        rows[u_p] = measure("magnet", u_p, case, summary, RunFolder(tmp_path / case.name).trajectory())
    for u_p, row in rows.items():
        line, tol = ws.c0 + ws.s * u_p, (1e-3 if u_p < 0.2 else 1e-2)
        assert row["rankine_hugoniot_u_p_m_per_s"] == pytest.approx(u_p, rel=tol)
        assert row["rankine_hugoniot_D_m_per_s"] == pytest.approx(line, rel=tol)
    assert rows[0.1]["U_s_m_per_s"] == pytest.approx(ws.c0 + ws.s * 0.1, rel=5e-3)
    assert rows[0.5]["U_s_m_per_s"] > 1.05 * (ws.c0 + ws.s * 0.5)
    assert rows[0.5]["U_s_m_per_s"] == pytest.approx(ws.c0 + 4 / 3 * ws.s * 0.5, rel=1e-2)


def test_each_point_names_its_units_the_model_chains_reduced():
    """The Toda, LJ and Morse points sat in columns named *_m_per_s with nothing saying they are
    in the models' reduced units: each row's `units` says it (the magnets' are the columns'),
    and it is the table's second column."""
    from pylmp_lattice.studies.literature.hugoniot import units
    from pylmp_lattice.trajectory import Trajectory

    case = chain_case("toda", "t", {"profile": "constant", "velocity": 1.0}, 10.0, particles=40)
    n, t = case.chain.particles, np.linspace(0.0, 10.0, 11)
    x0 = 10.0 * np.arange(n)
    traj = Trajectory(t, x0, np.tile(-0.1 * np.arange(n), (t.size, 1)), np.ones((t.size, n)), np.zeros((t.size, n)))
    summary = {"particles_reached_by_front": 30, "shock_velocity_plateau_m_per_s": {"mean": 13.0, "converged": True},
               "first_peak_velocity_over_V_I": 1.9}
    row = measure("toda", 1.0, case, summary, traj)
    assert list(row)[:3] == ["chain", "units", "u_p_m_per_s"]
    assert row["units"] == "reduced, m = A = B = 1"
    assert row["mean_gap_mm"] == pytest.approx(9.9, abs=1e-12)  # gaps 10 - 0.1 mm, in the models' length unit
    assert [units(c) for c in ("magnet", "lj", "morse")] == ["m/s, mm, N, mJ", "reduced, m = epsilon = sigma = 1",
                                                              "reduced, m = D = 1, alpha r_e = 6"]
