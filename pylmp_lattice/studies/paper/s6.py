"""Fig. S6: friction and the propagation velocity, V_I = 2 m/s, long lattice, several mu (p =
0.012), through the sweep layer.

Without friction V_P settles to a plateau; with friction it peaks and then decays, faster for
larger mu. Per mu: the largest V_P and where, and the last quarter of the gaps crossed as a
`trailing_plateau` with its drift: a decaying series is reported as not converged, not as a
plateau. Full: mu = 0, 0.02, 0.05, 0.1, 0.2, 0.285 over 300 ms; quick: 0, 0.1, 0.285 over 150 ms.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ... import measures
from ...numbering import number
from ...plots import pyplot, style_figure
from ...run_folder import RunFolder
from ..output import StudyResult
from ..scaffold import FRICTION, done_runs, paper_dict, sweep_runs

NAME = "s6"
VI = 2.0


def run(out: Path, quick: bool = False) -> StudyResult:
    """Run this study into `out` (`quick`: its small version) and return its results; what it
    runs and measures is the module's docstring."""
    mus, duration = ([0.0, 0.1, 0.285], 150.0) if quick else ([0.0, 0.02, 0.05, 0.1, 0.2, 0.285], 300.0)
    base = paper_dict("s6", {"profile": "constant", "velocity": VI}, duration,
                      friction=dict(FRICTION))
    runs = sweep_runs(base, out / NAME, grid={"friction.mu": mus})
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(8, 5), layout="constrained")
    rows, table = [], {}
    for r, row in done_runs(runs, rows, "mu", "friction.mu"):
        mu = row["mu"]
        vp = RunFolder(r.folder).front().accepted_velocity
        best = int(np.nanargmax(vp))
        row |= {"V_P_max_m_per_s": vp[best], "V_P_max_gap": number(best), "V_P_last_quarter": measures.trailing_plateau(vp),
                "V_P_last_m_per_s": vp[np.isfinite(vp)][-1], "gaps_crossed": int(np.sum(np.isfinite(vp)))}
        table[f"V_P_mu_{mu:g}_m_per_s"] = vp
        ax.plot(np.arange(1, vp.size + 1), vp, ".", ms=2.5, label=f"$\\mu$ = {mu:g}")
    ax.set(xlabel="gap n (magnets n and n+1)", ylabel="$V_P$ (m/s)", title="propagation velocity along the chain")
    ax.legend(fontsize="small", title="friction")
    style_figure(fig, f"Fig. S6: long lattice, constant $V_I$ = {VI:g} m/s, friction p = {FRICTION['p']:g}, "
                 f"{duration:g} ms", quick=quick, letters="")
    size = max((len(v) for v in table.values()), default=0)
    table = {"gap": np.arange(1, size + 1)} | {k: np.pad(v, (0, size - len(v)), constant_values=np.nan)
                                              for k, v in table.items()}
    numbers = {"V_I_m_per_s": VI, "p": FRICTION["p"], "duration_ms": duration, "runs": rows}
    return StudyResult(NAME, numbers, tables={"V_P": table}, figure=fig, quick=quick)
