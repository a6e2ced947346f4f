"""Fig. S9: phase portraits, the velocity of magnet 10 against its gap to magnet 11, for
V_I = 0.01, 0.1, 1 and 2 m/s (long lattice, constant drive, no friction).

Per V_I: the steady oscillation of magnet 10 in the run's last WINDOW ms (NaN with the reason
when it has decayed: the magnet then moves with the impactor, Fig. S9(a, b)), eta in windows of
the same length ending at each of CHECKPOINTS (how it settles), the extent of the orbit, and
the transition cycles: velocity maxima of magnet 10 between the front and its settling into
that final state (within 0.1 V_I of its final maxima and minima; of V_I itself when the
oscillation decays). The oscillation at 1 m/s settles slowly (eta 0.021 at 0.6 s, 0.015 from
2 s on), so that run lasts LONG ms; the others 600 ms. Quick: every run 200 ms, which cannot
show the settling at 1 m/s (said in the JSON's `quick_cannot_show`).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ... import measures
from ...plots import pyplot, style_figure
from ...run_folder import execute
from ..output import StudyResult
from ..scaffold import paper_case

NAME = "s9"
VELOCITIES = (0.01, 0.1, 1.0, 2.0)  # m/s
MAGNET = 10  # magnet 10, and the gap to magnet 11
DURATION, LONG, QUICK = 600.0, 3000.0, 200.0  # ms
SLOW = 1.0  # m/s: the V_I whose oscillation needs LONG to settle
WINDOW = 120.0  # ms, the steady window (the last fifth of 600 ms)
CHECKPOINTS = (600.0, 1000.0, 2000.0, 3000.0)  # ms


def run(out: Path, quick: bool = False) -> StudyResult:
    """Run this study into `out` (`quick`: its small version) and return its results; what it
    runs and measures is the module's docstring."""
    plt = pyplot()
    fig, axes = plt.subplots(2, 2, figsize=(10, 8), layout="constrained")
    rows = []
    for vi, ax in zip(VELOCITIES, axes.flat):
        duration = QUICK if quick else LONG if vi == SLOW else DURATION
        window = (duration - WINDOW, duration)
        case = paper_case(f"s9_VI_{vi:g}", {"profile": "constant", "velocity": vi}, duration)
        # magnets 10 and 11 only: the 3 s run has 30001 frames of ~800 magnets
        pair = execute(case, out / NAME / case.name, overwrite=True).trajectory("chain", magnets=(MAGNET, MAGNET + 1))
        t, v = pair.t, pair.v[:, 0]
        portrait = measures.phase_portrait(t, pair.x0 + pair.u, pair.v, MAGNET, first_magnet=MAGNET)
        steady = measures.steady_oscillation(t, v, vi, window)
        reference = (steady.max_velocity, steady.min_velocity) if steady.measured else (vi, vi)
        onset = measures.steady_onset_times(t, pair.v[:, :1], vi, reference)[0]
        maxima = measures.oscillations(t, v, vi).max_time
        rows.append({
            "V_I_m_per_s": vi,
            "duration_ms": duration,
            "window_ms": list(window),
            "steady_oscillation": steady,
            "eta_by_time_ms": {f"{end:g}": measures.steady_oscillation(t, v, vi, (end - WINDOW, end)).energy_ratio
                               for end in CHECKPOINTS if end <= duration},
            "orbit_in_window": portrait.ranges(window),
            "settling_time_ms": onset,
            "transition_cycles": int(np.sum(maxima < onset)) if np.isfinite(onset) else None,
        })
        early = portrait.time < window[0]
        ax.plot(portrait.gap[early], portrait.velocity[early], lw=0.3, color="0.6", label="before the window")
        ax.plot(portrait.gap[~early], portrait.velocity[~early], lw=0.6, color="C0",
                label=f"last {WINDOW:g} ms ({window[0]:g}-{window[1]:g} ms)")
        ax.axhline(vi, color="k", ls=":", lw=0.8, label="$V_I$")
        ax.set(title=f"$V_I$ = {vi:g} m/s", xlabel="gap $r_{10}$ (mm)", ylabel="$v_{10}$ (m/s)")
        ax.legend(fontsize="x-small", loc="upper right")
    style_figure(fig, "Fig. S9: long lattice, constant drive, no friction: magnet 10", quick=quick)
    numbers = {"particle": MAGNET, "window_length_ms": WINDOW, "runs": rows}
    if quick:
        numbers["quick_cannot_show"] = {"eta_by_time_ms": f"the settling at V_I = {SLOW:g} m/s, which needs "
                                                          f"{LONG:g} ms"}
    table = {"V_I_m_per_s": [r["V_I_m_per_s"] for r in rows],
             "duration_ms": [r["duration_ms"] for r in rows],
             "eta": [r["steady_oscillation"].energy_ratio for r in rows],
             "settling_time_ms": [r["settling_time_ms"] for r in rows],
             "transition_cycles": [r["transition_cycles"] if r["transition_cycles"] is not None else np.nan for r in rows]}
    return StudyResult(NAME, numbers, tables={"runs": table}, figure=fig, quick=quick)
