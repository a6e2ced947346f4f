"""Fig. S4: the friction calibration rig (paper Sec. S3): one magnet between two fixed magnets
r1 apart, released at rest 1.8 mm from the left one, oscillates and stops by friction.

Six separations r1 from 249.5 mm to 30.1 mm (the paper's range; the four inner values are ours,
the paper does not list them), mu = 0.285, p = 0.012; the middle magnet's position against time
as in Fig. S4(c-h). Per r1: the final position (at rest once the run is long enough), the number of half cycles, and the energy
check: mechanical energy lost between the release and the end against the friction work
(LAMMPS's f_friction). Quick: the two end separations, 600 ms.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ...case import case_from_dict
from ...plots import pyplot
from ...run_folder import RunFolder, simulate
from ..output import StudyResult
from ..scaffold import FRICTION, MASS, PAPER_FORCE

NAME = "s4"
SEPARATIONS = (249.5, 150.0, 90.0, 60.0, 40.0, 30.1)  # mm, r1
RELEASE_GAP = 1.8  # mm, the middle magnet's start from the left magnet


def rig_case(r1: float, duration: float = 2000.0):
    """The rig for separation r1 (mm), run for `duration` ms."""
    return case_from_dict({
        "name": f"rig_r1_{r1:g}mm",
        "chain": {"particles": 3, "mass": MASS, "r0": [RELEASE_GAP, r1 - RELEASE_GAP]},
        "force": dict(PAPER_FORCE),
        "impactor": {"profile": "rest"},
        "friction": {"mu": FRICTION["mu"], "p": FRICTION["p"]},
        "run": {"duration": duration, "dt": 0.002, "output_interval": 0.1},
        "table": {"r_max": r1, "points": 100000},
    })


def run(out: Path, quick: bool = False) -> StudyResult:
    separations = (SEPARATIONS[0], SEPARATIONS[-1]) if quick else SEPARATIONS
    duration = 600.0 if quick else 2000.0
    plt = pyplot()
    fig, axes = plt.subplots(2, len(separations) // 2, figsize=(4 * len(separations) // 2, 6.5),
                             layout="constrained", sharex=True, squeeze=False)
    rows = []
    for r1, ax in zip(separations, axes.T.flat):
        case = rig_case(r1, duration)
        folder = out / NAME / case.name
        traj = simulate(case, folder, overwrite=True)
        x = traj.x0[1] + traj.u[:, 1]  # mm from the left magnet
        turning = np.flatnonzero(np.diff(np.sign(traj.v[:, 1])) != 0)
        # mechanical energy, mJ (g (m/s)^2 = mJ): the magnet may still move at the end of a short run
        energy = case.force.energy(traj.gaps()).sum(axis=1) + 0.5 * case.chain.masses()[1] * traj.v[:, 1] ** 2
        friction = RunFolder(folder).friction_work()
        lost = energy[0] - energy[-1]
        rows.append((r1, x[-1], len(turning), lost, friction, friction / lost - 1))
        ax.plot(traj.t / 1e3, x, lw=0.8)
        ax.axhline(r1 / 2, color="k", ls=":", lw=0.8)
        ax.set(title=f"$r_1$ = {r1:g} mm", ylabel="position (mm)")
    for ax in axes[-1]:
        ax.set_xlabel("t (s)")
    columns = ("r1_mm", "final_position_mm", "half_cycles", "mechanical_energy_lost_mJ", "friction_work_mJ",
               "energy_balance_relative_error")
    table = {c: [row[k] for row in rows] for k, c in enumerate(columns)}
    numbers = {
        "mu": FRICTION["mu"], "p": FRICTION["p"], "duration_ms": duration,
        "rig": [dict(zip(columns, row)) for row in rows],
        "max_abs_energy_balance_relative_error": float(np.max(np.abs(table["energy_balance_relative_error"]))),
    }
    return StudyResult(NAME, numbers, tables={"rig": table}, figure=fig, quick=quick)
