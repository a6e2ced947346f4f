"""Energy conservation once the impactor stops: kinetic + bond energy over 10^5 steps."""

from __future__ import annotations

import pytest

from pylmp_lattice.run_folder import simulate

from conftest import make_case

pytestmark = pytest.mark.lammps


def test_energy_is_conserved_after_a_kick(tmp_path):
    """A 20 ms half-sine kick, then the impactor is held: 10^5 steps of dt = 0.01 ms.

    Energy is computed from the dump (1/2 m v^2 + U(gaps), mJ), independently of LAMMPS's
    own accounting. Velocity Verlet conserves a shadow energy: E oscillates by O(dt^2)
    (measured 8e-6 relative) without drift (measured 1e-9 between the first and last 50 ms).
    """
    case = make_case(particles=21, duration=1000.0, run={"output_interval": 0.5},
                     impactor={"profile": "sine", "velocity": 2.0, "duration": 20.0})
    assert case.run.steps() == 100_000
    traj = simulate(case, tmp_path)
    energy = 0.5 * (case.chain.masses() * traj.v**2).sum(axis=1) + case.force.energy(traj.gaps()).sum(axis=1)
    e = energy[traj.t > 20.0]
    assert (e.max() - e.min()) / e.mean() < 2e-5
    assert abs(e[-100:].mean() - e[:100].mean()) / e.mean() < 1e-7
