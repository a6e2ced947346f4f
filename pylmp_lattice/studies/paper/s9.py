"""Fig. S9: phase portraits, the velocity of magnet 10 against its gap to magnet 11, for
V_I = 0.01, 0.1, 1 and 2 m/s (long lattice, constant drive, no friction).

Per V_I: the steady oscillation of magnet 10 in the last fifth of the run (NaN with the reason
when it has decayed: the magnet then moves with the impactor, Fig. S9(a, b)), the extent of the
orbit there, and the transition cycles: velocity maxima of magnet 10 between the front and its
settling into that final state (within 0.1 V_I of its final maxima and minima; of V_I itself
when the oscillation decays). Full: 600 ms; quick: 200 ms.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ... import measures
from ...plots import pyplot
from ...run_folder import simulate
from ..output import StudyResult
from ..scaffold import paper_case

NAME = "s9"
VELOCITIES = (0.01, 0.1, 1.0, 2.0)  # m/s
PARTICLE = 9  # 0-based: magnet 10, and the gap to magnet 11


def run(out: Path, quick: bool = False) -> StudyResult:
    duration = 200.0 if quick else 600.0
    window = (0.8 * duration, duration)
    plt = pyplot()
    fig, axes = plt.subplots(2, 2, figsize=(10, 8), layout="constrained")
    rows = []
    for vi, ax in zip(VELOCITIES, axes.flat):
        case = paper_case(f"s9_VI_{vi:g}", {"profile": "constant", "velocity": vi}, duration)
        traj = simulate(case, out / NAME / case.name, overwrite=True)
        portrait = measures.phase_portrait(traj.t, traj.x0 + traj.u, traj.v, PARTICLE)
        steady = measures.steady_oscillation(traj.t, traj.v[:, PARTICLE], vi, window)
        reference = (steady.max_velocity, steady.min_velocity) if steady.measured else (vi, vi)
        column = traj.v[:, PARTICLE : PARTICLE + 1]
        onset = measures.steady_onset_times(traj.t, column, vi, reference)[0]
        maxima = measures.oscillations(traj.t, traj.v[:, PARTICLE], vi).max_time
        rows.append({
            "V_I_m_per_s": vi,
            "steady_oscillation": steady,
            "orbit_in_window": portrait.ranges(window),
            "settling_time_ms": onset,
            "transition_cycles": int(np.sum(maxima < onset)) if np.isfinite(onset) else None,
        })
        ax.plot(portrait.gap, portrait.velocity, lw=0.4)
        ax.axhline(vi, color="k", ls=":", lw=0.8)
        ax.set(title=f"$V_I$ = {vi:g} m/s", xlabel="gap $r_{10}$ (mm)", ylabel="$v_{10}$ (m/s)")
    numbers = {"particle": PARTICLE + 1, "duration_ms": duration, "window_ms": list(window), "runs": rows}
    table = {"V_I_m_per_s": [r["V_I_m_per_s"] for r in rows],
             "eta": [r["steady_oscillation"].energy_ratio for r in rows],
             "settling_time_ms": [r["settling_time_ms"] for r in rows],
             "transition_cycles": [r["transition_cycles"] if r["transition_cycles"] is not None else np.nan for r in rows]}
    return StudyResult(NAME, numbers, tables={"runs": table}, figure=fig, quick=quick)
