"""The friction calibration rig of the paper (Sec. S3, Fig. S4): one magnet between two fixed
magnets r1 apart, released at rest 1.8 mm from the left one, oscillates and stops by friction.

Runs the rig for six separations r1 from 249.5 mm to 30.1 mm (the paper's range; the four
inner values are ours, the paper does not list them) with mu = 0.285, p = 0.012, and plots
the middle magnet's position against time as in Fig. S4(c-h). Prints, per r1, the final
position, the number of half cycles and the energy check: potential energy lost between the
release and the final rest = friction work (LAMMPS's f_friction), relative error.

    python analysis/friction_calibration.py [-o OUTDIR]
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from pylmp_lattice.case import case_from_dict
from pylmp_lattice.dump import read_log
from pylmp_lattice.plots import pyplot
from pylmp_lattice.simulation import simulate

SEPARATIONS = (249.5, 150.0, 90.0, 60.0, 40.0, 30.1)  # mm, r1
RELEASE_GAP = 1.8  # mm, the middle magnet's start from the left magnet


def rig_case(r1: float, duration: float = 2000.0):
    return case_from_dict({
        "name": f"rig_r1_{r1:g}mm",
        "chain": {"particles": 3, "mass": 1.084, "r0": [RELEASE_GAP, r1 - RELEASE_GAP]},
        "force": {"law": "power", "K": 413.8, "b": 3.917, "q": 3.0},
        "impactor": {"profile": "rest"},
        "friction": {"mu": 0.285, "p": 0.012},
        "run": {"duration": duration, "dt": 0.002, "output_interval": 0.1},
        "table": {"r_max": r1, "points": 100000},
    })


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("-o", "--output", type=Path, default=Path("runs/friction_calibration"))
    out = parser.parse_args(argv).output
    plt = pyplot()
    fig, axes = plt.subplots(2, 3, figsize=(12, 6.5), layout="constrained", sharex=True)
    print(f"{'r1 (mm)':>8} {'rest at (mm)':>13} {'half cycles':>12} {'dU (mJ)':>10} {'friction (mJ)':>14} {'rel. err':>9}")
    for r1, ax in zip(SEPARATIONS, axes.flat):
        case = rig_case(r1)
        traj = simulate(case, out / case.name)
        x = traj.x0[1] + traj.u[:, 1]  # mm from the left magnet
        turning = np.flatnonzero(np.diff(np.sign(traj.v[:, 1])) != 0)
        energy = case.force.energy(traj.gaps()).sum(axis=1)  # mJ
        friction = read_log(out / case.name / "log.lammps").runs[-1]["f_friction"][-1] * 1e3
        lost = energy[0] - energy[-1]
        print(f"{r1:8.1f} {x[-1]:13.4f} {len(turning):12d} {lost:10.5f} {friction:14.5f} {friction / lost - 1:9.1e}")
        ax.plot(traj.t / 1e3, x, lw=0.8)
        ax.axhline(r1 / 2, color="k", ls=":", lw=0.8)
        ax.set(title=f"$r_1$ = {r1:g} mm", ylabel="position (mm)")
    for ax in axes[-1]:
        ax.set_xlabel("t (s)")
    fig.savefig(out / "fig_s4.png", dpi=120)
    print(f"figure: {out / 'fig_s4.png'}")


if __name__ == "__main__":
    main()
