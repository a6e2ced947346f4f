"""Fig. S5: the linear lattice under a constant impact velocity.

Springs F = k (r_free - r) with k the paper law's stiffness at r0 (so V0 and f0 are the magnet
chain's) and r_free giving the same preload; V_I = 0.5 m/s (a linear chain's response scales
with V_I; it must stay below V0 or the magnets touch). The panels of Fig. 3 for it (`studies.long_lattice`): V_P falls
towards V0, the first peak velocity grows and the first peak acceleration falls with n, and
the oscillation decays completely. The decay is measured as eta of particle 10 in successive
windows, against the same measure on the exact semi-infinite chain, whose v_n/V_I - 1 is a sum
of Bessel functions J_2m(2 omega t) that all fall as t^(-1/2): eta -> 0 like 1/t at long times.
Full: 600 ms; quick: 200 ms.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ... import measures
from ...exact import harmonic_piston_velocity
from ...run_folder import simulate
from ..long_lattice import analyse
from ..output import StudyResult
from ..scaffold import MAGNET_STIFFNESS, MASS, PAPER_LAW, R0, paper_case

NAME = "s5"
VI = 0.5  # m/s
MAGNET = 10
DECAY_PROMINENCE = 1e-3  # of V_I


def linear_case(duration: float):
    """The paper's chain with the linear spring of its rest stiffness (same r0, same F(r0)), driven at VI."""
    k = MAGNET_STIFFNESS
    return paper_case("s5_linear_lattice", {"profile": "constant", "velocity": VI}, duration,
                      force={"law": "linear", "k": k, "r_free": R0 + float(PAPER_LAW.force(R0)) / k})


def run(out: Path, quick: bool = False) -> StudyResult:
    """Run this study into `out` (`quick`: its small version) and return its results; what it
    runs and measures is the module's docstring."""
    duration = 200.0 if quick else 600.0
    case = linear_case(duration)
    traj = simulate(case, out / NAME / case.name, overwrite=True)
    result = analyse(NAME, f"Fig. S5: linear lattice, constant $V_I$ = {VI:g} m/s, {duration:g} ms", traj, case, VI,
                     duration, quick, zone=False)
    # eta of particle 10 in successive windows of about two periods after its front, measured
    # and exact (the same measure on the exact semi-infinite chain's velocity)
    k = float(case.force.k)
    t0 = float(measures.arrival_times(traj.t, traj.v[:, MAGNET - 1 : MAGNET], VI)[0])
    span = 2.2e3 / result.numbers["f0_Hz"]  # ms: two periods at f0, the band edge, and a margin
    edges = np.arange(t0 + 0.2 * (duration - t0), duration, span)
    windows = list(zip(edges, edges[1:]))
    exact_v = harmonic_piston_velocity(MAGNET - 1, traj.t, VI, np.sqrt(k / MASS))[:, 0]
    eta, eta_exact = (np.array([measures.steady_oscillation(traj.t, vv, VI, w, prominence=DECAY_PROMINENCE).energy_ratio
                                for w in windows]) for vv in (traj.v[:, MAGNET - 1], exact_v))
    mid = 0.5 * (edges[1:] + edges[:-1])
    result.numbers |= {
        "spring_k_N_per_mm": k,
        "V0_exact_m_per_s": R0 * np.sqrt(k / MASS),
        "decay_particle": MAGNET,
        "decay_window_mid_ms": mid,
        "decay_eta": eta,
        "decay_eta_exact": eta_exact,
        "decay_eta_relative_difference_max": float(np.nanmax(np.abs(eta / eta_exact - 1))) if len(windows) else None,
        "max_velocity_error_vs_exact_over_V_I": float(np.max(np.abs(traj.v[:, MAGNET - 1] - exact_v))) / VI,
        "first_peak_acceleration_falls_with_n": bool(np.all(np.diff(_finite(result)) < 0)),
    }
    result.tables["decay"] = {"window_mid_ms": mid, "eta": eta, "eta_exact": eta_exact}
    ax = result.figure.axes[5]  # the transition-zone panel: a linear chain has none; its decay instead
    ax.semilogy(mid, eta, "o", label="LAMMPS")
    ax.semilogy(mid, eta_exact, "-", label="exact chain")
    ax.set(title=f"decay: $\\eta$ of magnet {MAGNET}", ylabel=r"$\eta$")
    ax.legend(fontsize="small")
    return result



def _finite(result):
    """The first peak accelerations of particles 2 .. N that have one."""
    a = np.asarray(result.tables["particles"]["first_peak_acceleration_m_per_s2"], float)[1:]
    return a[np.isfinite(a)]
