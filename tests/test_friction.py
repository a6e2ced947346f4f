"""Coulomb friction (fix lattice/friction) in whole runs: the paper's experiment and Fig. S6.

Single-magnet calibration rig, stick at rest, MPI ranks: tests/test_plugin.py.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from pylmp_lattice import measures
from pylmp_lattice.case import load_case
from pylmp_lattice.formats.dump import read_log
from pylmp_lattice.run_folder import simulate

from conftest import make_case
from reference import integrate_chain_friction, power_force

pytestmark = pytest.mark.lammps
INPUTS = Path(__file__).parent.parent / "inputs"


@pytest.fixture(scope="module")
def experiment(tmp_path_factory):
    """The paper's experiment with friction, dumped every step (dt = 0.0125 ms)."""
    case = load_case(INPUTS / "paper_experiment.toml", ["run.output_interval=0.0125"])
    assert case.friction is not None and case.friction.mu == 0.285
    folder = tmp_path_factory.mktemp("experiment")
    return case, simulate(case, folder), folder


def test_experiment_matches_the_independent_stick_slip_integrator(experiment):
    case, traj, folder = experiment
    pulse = case.impactor
    ref = integrate_chain_friction(
        power_force(), 1.084, 12.0, 21, pulse.displacement_at, pulse.velocity_at, traj.t,
        mu=0.285, p=0.012, g=9.81e-3, t_breaks=[pulse.duration],
    )
    error = np.max(np.abs(traj.v - ref.v))
    assert error < 1e-3 * pulse.velocity
    # both agree on how much energy friction took (mJ), from LAMMPS's own tally
    thermo = read_log(folder / "log.lammps").runs[-1]
    dissipated = thermo["f_friction"][-1] * 1e3
    assert dissipated == pytest.approx(ref.w_friction[-1], rel=1e-3)


def test_energy_balance_with_friction(experiment):
    """KE + bond energy + friction work - drive work stays at its initial value.

    LAMMPS's TotEng counts the impactor's kinetic energy too; the drive work is done on the
    chain by the impactor, so that term is taken out."""
    case, traj, folder = experiment
    thermo = read_log(folder / "log.lammps").runs[-1]
    # drive work: F(r_1) times the impactor's velocity, trapezoid over every step (mJ)
    power = case.force.force(traj.gaps()[:, 0]) * traj.v[:, 0]
    work = np.concatenate([[0.0], np.cumsum(0.5 * (power[1:] + power[:-1]) * np.diff(traj.t))])
    rows = (thermo["Step"] // case.run.steps("output_interval")).astype(int)  # the frame of each thermo row
    impactor_ke = 0.5 * case.chain.masses()[0] * traj.v[rows, 0] ** 2
    balance = (thermo["TotEng"] + thermo["f_friction"]) * 1e3 - impactor_ke - work[rows]
    scale = work[-1]
    assert np.max(np.abs(balance - balance[0])) < 2e-5 * scale  # measured 5.5e-6


def test_friction_makes_the_propagation_velocity_rise_then_decay(tmp_path):
    """Fig. S6: with friction V_P peaks within the first ~20 magnets, then decays; the larger
    mu, the lower the peak and the faster the decay. Without friction it only rises."""
    peak, final = {}, {}
    for mu in (0.0, 0.1, 0.285, 0.5):
        case = load_case(INPUTS / "paper_friction_long_lattice.toml", [f"friction.mu={mu}", "run.duration=250"])
        traj = simulate(case, tmp_path / f"mu{mu}")
        vp = measures.propagation_velocity(measures.arrival_times(traj.t, traj.v, 2.0), 12.0)
        reached = vp[:60]  # all four fronts cross the first 60 gaps within 250 ms
        assert np.all(np.isfinite(reached))
        peak[mu], final[mu] = np.max(reached), np.mean(reached[-10:])
        if mu == 0.0:
            assert final[mu] >= peak[mu] - 0.01  # still rising towards 3.92 m/s
        else:
            assert np.argmax(reached) < 30 and final[mu] < peak[mu] - 0.05
    assert peak[0.0] > peak[0.1] > peak[0.285] > peak[0.5]
    decay = {mu: 1 - final[mu] / peak[mu] for mu in (0.1, 0.285, 0.5)}
    assert decay[0.1] < decay[0.285] < decay[0.5]


def test_calibration_rig_through_the_case_layer(tmp_path):
    """Fig. S4 rig from a case (impactor at rest, gaps 1.8 and 28.3 mm): the potential energy
    lost equals LAMMPS's friction tally, and the magnet ends at rest inside the stick band."""
    case = make_case(particles=3, duration=2000.0, dt=0.002, chain={"r0": [1.8, 28.3]},
                     impactor={"profile": "rest"}, friction={"mu": 0.285, "p": 0.012},
                     table={"r_max": 30.1, "points": 100000})
    traj = simulate(case, tmp_path)
    energy = case.force.energy(traj.gaps()).sum(axis=1)
    dissipated = read_log(tmp_path / "log.lammps").runs[-1]["f_friction"][-1] * 1e3
    assert dissipated == pytest.approx(energy[0] - energy[-1], rel=1e-6)
    assert np.all(traj.v[-1000:, 1] == 0.0)  # the last 100 ms exactly at rest
    left, right = traj.gaps()[-1]
    net = case.force.force(left) - case.force.force(right)
    limit = 0.285 * (1.084 * 9.81e-3 + 0.012 * (case.force.force(left) + case.force.force(right)))
    assert abs(net) <= limit


def test_the_experiments_input_says_when_the_front_and_the_contact_come(tmp_path):
    """inputs/paper_experiment.toml's comments: the front (V_I/2) reaches magnet 19 at 59.1 ms,
    and run on, the pulse brings magnets 20 and 21 into contact at 64.525 ms (it said 64.6 ms,
    the stock engine's check every output interval; the default chain engine checks every step)."""
    from pylmp_lattice.errors import ContactError

    text = (INPUTS / "paper_experiment.toml").read_text()
    assert "magnet 19 at 59.1 ms" in text and "at 64.525 ms this stand-in" in text
    case = load_case(INPUTS / "paper_experiment.toml", ["run.duration=70", "output.format=none"])
    with pytest.raises(ContactError) as err:
        simulate(case, tmp_path / "on")
    assert err.value.pair == (20, 21) and err.value.time_ms == pytest.approx(64.525, abs=1e-9)
    front = load_case(INPUTS / "paper_experiment.toml")
    traj = simulate(front, tmp_path / "front")
    arrival = measures.arrival_times(traj.t, traj.v, front.impactor.peak_velocity(), method="level")
    assert arrival[18] == pytest.approx(59.1, abs=0.05)  # magnet 19
