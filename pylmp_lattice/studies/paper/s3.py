"""Fig. S3 and Sec. S2: the second-neighbour interaction, left out of the paper's model.

The paper measured the force between magnets n and n+2 at about 5 % of the nearest one, and
attractive (the magnets alternate in polarity). As a model option (`[second_neighbour]`) it is
F2(d) = -K2/(d + b2)^q, d = x_(n+2) - x_n: the magnet law's q, b2 = b + L (the middle magnet's
length L = 6.35 mm sits between the pair's faces), K2 such that |F2(2 r0)| = 5 % F(r0).
Runs at V_I = 2 m/s without it, with it, and with a repulsive one of the same size, compare V_P
and the first peaks; and at V_I = 0.01 m/s (linear) the ratio of the front speeds with and
without it against the linear theory, V0' / V0 = sqrt((k1 + 4 k2) / k1), k2 = -dF2/dd at 2 r0.
Each chain starts at rest in its static equilibrium: with second neighbours the equally spaced
chain is not in balance near its ends (a magnet next to the impactor has a second neighbour on
one side only), and at V_I = 0.01 m/s that imbalance would move magnet 2 faster than the wave
does; the impactor and the far end stay where they were, the gaps between relax.
Full: 400 ms; quick: 150 ms.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ... import measures
from ...case import SecondNeighbour, case_from_dict, case_to_dict
from ...forcelaw import PowerLaw
from ...plots import pyplot, style_figure
from ...run_folder import simulate
from ..output import StudyResult
from ..scaffold import MAGNET_LENGTH, PAPER_LAW, R0, paper_case

NAME = "s3"
FRACTION = 0.05  # |F2(2 r0)| / F(r0), paper Sec. S2
VARIANTS = {"nearest only": None, "attractive 5 %": -1, "repulsive 5 %": 1}
STRONG, WEAK = 2.0, 0.01  # m/s


def second_neighbour_section(sign: int, fraction: float = FRACTION) -> dict:
    """The [second_neighbour] section: F2 = sign K2/(d + b + L)^q with |F2(2 r0)| = fraction F(r0)."""
    law = PAPER_LAW
    b2 = law.b + MAGNET_LENGTH
    k2 = fraction * float(law.force(R0)) * (2 * R0 + b2) ** law.q
    return {"law": "power", "K": k2, "b": b2, "q": law.q, "sign": sign}


def relaxed(case):
    """The case with its chain at static equilibrium (per-gap r0), impactor and held magnets fixed."""
    if case.second_neighbour is None:
        return case
    from scipy.optimize import root

    x0 = case.chain.positions()
    held = case.held()
    free = np.arange(1, held[0])

    def net_force(xf):
        x = x0.copy()
        x[free] = xf
        f1 = case.force.force(np.diff(x))  # on n from n-1 (+), from n+1 (-)
        f2 = case.second_neighbour.force(x[2:] - x[:-2])
        total = np.zeros_like(x)
        total[1:] += f1
        total[:-1] -= f1
        total[2:] += f2
        total[:-2] -= f2
        return total[free]

    sol = root(net_force, x0[free], method="hybr", tol=1e-13)
    if not sol.success:
        raise RuntimeError(f"static equilibrium not found: {sol.message}")
    x = x0.copy()
    x[free] = sol.x
    data = case_to_dict(case)
    data["chain"]["r0"] = list(np.diff(x))
    return case_from_dict(data)


def run(out: Path, quick: bool = False) -> StudyResult:
    """Run this study into `out` (`quick`: its small version) and return its results; what it
    runs and measures is the module's docstring."""
    duration = 150.0 if quick else 400.0
    plt = pyplot()
    fig, (left, right) = plt.subplots(1, 2, figsize=(12, 4.8), layout="constrained")
    strong, weak = {}, {}
    for label, sign in VARIANTS.items():
        extra = {} if sign is None else {"second_neighbour": second_neighbour_section(sign)}
        tag = label.split()[0]
        for vi, store in ((STRONG, strong), (WEAK, weak)):
            case = relaxed(paper_case(f"s3_{tag}_VI_{vi:g}", {"profile": "constant", "velocity": vi}, duration, **extra))
            traj = simulate(case, out / NAME / case.name, overwrite=True)
            front = measures.front(traj.t, traj.v, traj.a, vi, case.chain.gaps())
            store[label] = front
            if vi == STRONG:
                n = np.arange(1, len(front.arrival) + 1)
                left.plot(n[:-1] + 0.5, front.accepted_velocity, ".", ms=3, label=label)
                right.plot(n, front.peaks.peak_velocity, ".", ms=3, label=label)
        reached = measures.particles_reached(store[label].arrival)
    left.set(title=f"propagation velocity, $V_I$ = {STRONG:g} m/s", xlabel="magnet n", ylabel="$V_P$ (m/s)",
             xlim=(0, reached))
    right.set(title=f"first peak velocity, $V_I$ = {STRONG:g} m/s", xlabel="magnet n",
              ylabel="first peak velocity (m/s)", xlim=(0, reached))
    left.legend(fontsize="small", title="second neighbours")
    right.legend(fontsize="small", title="second neighbours")
    style_figure(fig, f"Fig. S3: long lattice, constant drive, no friction, second neighbours, {duration:g} ms",
                 quick=quick)

    attractive = SecondNeighbour(PowerLaw(**{k: v for k, v in second_neighbour_section(-1).items()
                                             if k in ("K", "b", "q")}), -1.0)
    law = PAPER_LAW
    k1, k2 = float(law.stiffness(R0)), float(attractive.stiffness(2 * R0))
    plateau = {k: measures.trailing_plateau(f.propagation_velocity) for k, f in strong.items()}
    peaks = {k: measures.trailing_plateau(f.peaks.driven_peak_velocity, over="magnet") for k, f in strong.items()}
    weak_vp = {k: measures.trailing_plateau(f.propagation_velocity) for k, f in weak.items()}
    base = "nearest only"
    numbers = {
        "fraction_of_nearest_force_at_r0": FRACTION,
        "second_neighbour_law": second_neighbour_section(-1),
        "force_ratio_F2_2r0_over_F_r0": float(-attractive.force(2 * R0) / law.force(R0)),
        "k1_N_per_mm": k1,
        "k2_N_per_mm": k2,
        "duration_ms": duration,
        f"V_I_{STRONG:g}_m_per_s": {
            k: {"V_P_plateau_m_per_s": plateau[k], "first_peak_plateau_m_per_s": peaks[k],
                "V_P_change_vs_nearest_only": plateau[k].mean / plateau[base].mean - 1,
                "first_peak_change_vs_nearest_only": peaks[k].mean / peaks[base].mean - 1}
            for k in VARIANTS},
        f"V_I_{WEAK:g}_m_per_s": {
            "V_P_plateau_m_per_s": {k: weak_vp[k] for k in VARIANTS},
            "V_P_ratio_attractive_over_nearest": weak_vp["attractive 5 %"].mean / weak_vp[base].mean,
            "V0_ratio_linear_theory": float(np.sqrt((k1 + 4 * k2) / k1)),
        },
    }
    return StudyResult(NAME, numbers, figure=fig, quick=quick)
