"""Fig. S8: a half-sine velocity pulse of peak V_I = 2 m/s and duration T_s, through the sweep
layer, T_s from well below to well above the linear period T0 = 1/f0 (23.5 ms).

The pulse's front is timed by its first velocity peak (a short pulse never reaches V_I/2 far
out; see `measures.arrival`), and its steady propagation velocity is the V_P plateau over the
last quarter of the gaps crossed (gap 1 is the drive's, `Front.drive_gap`, and flagged gaps
are no front's: neither counts). Limits: T_s << T0 gives V0; T_s >> T0 gives the constant
drive's V_P (a run with constant V_I in the same sweep). (c, d): velocity maxima and minima and
the frequency of magnet 10 against time for T_s = 100 ms, decaying once the pulse has passed.
Full: T_s / T0 = 0.1 .. 10 (9 values) and 100 ms over 400 ms; quick: 0.1 T0, 1 T0 and
100 ms (4.3 T0) over 250 ms.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ... import measures
from ...case import case_from_dict
from ...plots import pyplot, style_figure
from ...run_folder import RunFolder
from ...units import period
from ..output import StudyResult
from ..scaffold import done_runs, linear_constants, paper_dict, sweep_runs

NAME = "s8"
VI = 2.0
MAGNET = 10
SHOWN_TS = 100.0  # ms, the paper's Fig. S8(c, d)


def run(out: Path, quick: bool = False) -> StudyResult:
    """Run this study into `out` (`quick`: its small version) and return its results; what it
    runs and measures is the module's docstring."""
    duration = 250.0 if quick else 400.0
    base = paper_dict("s8", {"profile": "sine", "velocity": VI, "duration": 10.0}, duration)
    v0, f0 = linear_constants(case_from_dict(base))
    t0 = period(f0)  # ms
    # quick: 10 T0 = 235 ms would last nearly the whole 250 ms run; 100 ms = 4.3 T0 is the long pulse
    ratios = [0.1, 1.0] if quick else list(np.geomspace(0.1, 10.0, 9))
    durations = sorted({float(np.round(x * t0, 3)) for x in ratios} | {SHOWN_TS})
    runs = sweep_runs(base, out / NAME, grid={"impactor.duration": durations})
    steady_drive = paper_dict("s8_constant", {"profile": "constant", "velocity": VI}, duration)
    constant = sweep_runs(steady_drive, out / NAME / "constant", grid={"impactor.velocity": [VI]})[0]
    v_const = constant.summary["shock_velocity_plateau_m_per_s"]["mean"] if constant.done else float("nan")
    plt = pyplot()
    fig, ax = plt.subplots(1, 3, figsize=(14, 4.2), layout="constrained")
    rows, shown = [], None
    for r, row in done_runs(runs, rows, "T_s_ms", "impactor.duration"):
        ts = row["T_s_ms"]
        front = RunFolder(r.folder).front()
        vp = front.accepted_velocity  # gap 1 is the drive's (`Front.drive_gap`), flagged gaps no front's
        row |= {"T_s_over_T0": ts / t0, "V_P_plateau": measures.trailing_plateau(vp),
                "gaps_crossed": int(np.sum(np.isfinite(vp)))}
        if ts == SHOWN_TS:
            traj = r.trajectory()
            osc = measures.oscillations(traj.t, traj.v[:, MAGNET - 1], VI)
            ax[1].plot(osc.max_time, osc.max_velocity, "^", ms=3, label="maxima")
            ax[1].plot(osc.min_time, osc.min_velocity, "v", ms=3, label="minima")
            ax[1].set(title=f"extrema, magnet {MAGNET}, $T_s$ = {ts:g} ms", xlabel="t (ms)",
                      ylabel="peak velocity (m/s)")
            ax[1].legend(fontsize="small")
            ax[2].plot(osc.frequency_time, osc.frequency / f0, "o-", ms=3)
            ax[2].set(title=f"frequency, magnet {MAGNET}, $T_s$ = {ts:g} ms", xlabel="t (ms)", ylabel="$f/f_0$")
            shown = {"T_s_ms": ts, "oscillations": osc}
    done = [row for row in rows if row["status"] == "done"]
    x = np.array([row["T_s_over_T0"] for row in done])
    y = np.array([row["V_P_plateau"].mean for row in done])
    ax[0].semilogx(x, y, "o-", label="half-sine pulse")
    ax[0].axhline(v0, color="k", ls=":", label=f"$V_0$ = {v0:.3f} m/s")
    ax[0].axhline(v_const, color="C3", ls="--",
                  label=f"$V_P$ = {v_const:.3f} m/s under a constant drive, $V_I$ = {VI:g} m/s")
    shown_values = np.r_[y, v0, v_const][np.isfinite(np.r_[y, v0, v_const])]
    pad = 0.06 * np.ptp(shown_values)  # the reference lines off the spines
    ax[0].set(title="steady propagation velocity", xlabel="$T_s/T_0$", ylabel="$V_P$ (m/s)",
              ylim=(shown_values.min() - pad, shown_values.max() + pad))
    ax[0].legend(fontsize="small")
    style_figure(fig, f"Fig. S8: long lattice, half-sine pulse of peak $V_I$ = {VI:g} m/s and length $T_s$, "
                 f"no friction, {duration:g} ms", quick=quick, letters="bcd")
    numbers = {"V_I_peak_m_per_s": VI, "duration_ms": duration, "V0_m_per_s": v0, "T0_ms": t0,
               "V_P_constant_drive_m_per_s": v_const, "runs": rows, "shown": shown,
               "V_P_shortest_over_V0": y[0] / v0 if y.size else None,
               "V_P_longest_over_constant_drive": y[-1] / v_const if y.size else None}
    table = {"T_s_ms": [row["T_s_ms"] for row in done], "T_s_over_T0": x, "V_P_m_per_s": y}
    return StudyResult(NAME, numbers, tables={"pulse": table}, figure=fig, quick=quick)
