"""Fig. S7: a ramp-then-constant drive, V_I = 2 m/s reached in T_r, through the sweep layer.

The steady state should not depend on T_r: per T_r the V_P plateau (with its drift), and the
steady oscillation of magnet 10 (amplitude, f/f0, eta) in the last fifth of the run; a longer
ramp takes longer to reach the steady V_P. Full: T_r = 1, 5, 10, 25, 50, 100 ms over 400 ms;
quick: 1 and 10 ms over 200 ms.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ... import measures
from ...case import case_from_dict
from ...plots import pyplot, style_figure
from ..output import StudyResult
from ..scaffold import done_runs, linear_constants, paper_dict, sweep_runs

NAME = "s7"
VI = 2.0
MAGNET = 10


def run(out: Path, quick: bool = False) -> StudyResult:
    """Run this study into `out` (`quick`: its small version) and return its results; what it
    runs and measures is the module's docstring."""
    ramps, duration = ([1.0, 10.0], 200.0) if quick else ([1.0, 5.0, 10.0, 25.0, 50.0, 100.0], 400.0)
    base = paper_dict("s7", {"profile": "ramp", "velocity": VI, "ramp_time": 1.0}, duration)
    _, f0 = linear_constants(case_from_dict(base))
    runs = sweep_runs(base, out / NAME, grid={"impactor.ramp_time": ramps})
    plt = pyplot()
    fig, ax = plt.subplots(1, 3, figsize=(14, 4.2), layout="constrained")
    rows = []
    for r, row in done_runs(runs, rows, "T_r_ms", "impactor.ramp_time"):
        tr = row["T_r_ms"]
        traj = r.trajectory()
        front = measures.front(traj.t, traj.v, traj.a, VI, r.member.case.chain.gaps())
        vp = front.accepted_velocity  # a long ramp's first gaps are crossed out of order
        steady = measures.steady_oscillation(traj.t, traj.v[:, MAGNET - 1], VI, (0.8 * duration, duration))
        row |= {"V_P_plateau": measures.trailing_plateau(vp), "steady_oscillation": steady,
                "f_over_f0": steady.frequency / f0}
        ax[0].plot(np.arange(1, vp.size + 1), vp, ".", ms=2.5, label=f"$T_r$ = {tr:g} ms")
    done = [row for row in rows if row["status"] == "done"]
    x = [row["T_r_ms"] for row in done]
    ax[0].set(xlabel="gap n (magnets n and n+1)", ylabel="$V_P$ (m/s)", title="propagation velocity")
    ax[0].legend(fontsize="small")
    ax[1].plot(x, [row["steady_oscillation"].amplitude for row in done], "o-")
    ax[1].set(xlabel="$T_r$ (ms)", ylabel="amplitude (m/s)", title=f"steady amplitude, magnet {MAGNET}",
              xscale="log")
    ax[2].plot(x, [row["f_over_f0"] for row in done], "o-")
    ax[2].set(xlabel="$T_r$ (ms)", ylabel="$f/f_0$", title=f"steady frequency, magnet {MAGNET}", xscale="log")
    for a in ax[1:]:
        _at_least_percent(a, 2.0)
    style_figure(fig, f"Fig. S7: long lattice, ramp to $V_I$ = {VI:g} m/s in $T_r$, no friction, {duration:g} ms",
                 quick=quick, letters="bcd")
    spread = {key: _spread([get(row) for row in done]) for key, get in (
        ("V_P_plateau", lambda row: row["V_P_plateau"].mean),
        ("amplitude", lambda row: row["steady_oscillation"].amplitude),
        ("frequency", lambda row: row["steady_oscillation"].frequency))}
    numbers = {"V_I_m_per_s": VI, "duration_ms": duration, "f0_Hz": f0, "particle": MAGNET, "runs": rows,
               "relative_spread_over_T_r": spread}
    table = {"T_r_ms": x, "V_P_plateau_m_per_s": [row["V_P_plateau"].mean for row in done],
             "amplitude_m_per_s": [row["steady_oscillation"].amplitude for row in done],
             "f_over_f0": [row["f_over_f0"] for row in done]}
    return StudyResult(NAME, numbers, tables={"ramp": table}, figure=fig, quick=quick)


def _at_least_percent(ax, percent):
    """A y range of at least +-percent about its middle: values that agree to 1e-4 look flat."""
    lo, hi = ax.get_ylim()
    mid = 0.5 * (lo + hi)
    ax.set_ylim(min(lo, mid * (1 - percent / 100)), max(hi, mid * (1 + percent / 100)))
    ax.ticklabel_format(axis="y", useOffset=False)


def _spread(values) -> float:
    """(max - min) / mean of the finite values: how much a steady measure depends on T_r."""
    v = np.asarray(values, float)
    v = v[np.isfinite(v)]
    return float((v.max() - v.min()) / v.mean()) if v.size >= 2 else float("nan")
