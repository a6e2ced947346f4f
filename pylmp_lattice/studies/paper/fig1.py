"""Fig. 1 (b, c): the 21-magnet experiment, struck by a smooth synthetic impact.

The measured impact u1(t) is not published, so a half-sine velocity pulse stands in for it
(peak 2.81 m/s, rising in 23.9 ms, the paper's magnet-1 rise time), with the calibrated
friction and magnet 21 fixed: `scaffold.experiment_case`, the case of
inputs/paper_experiment.toml. Shows the x-t diagram
of the magnets (Fig. 1(b)), velocity profiles (Fig. 1(c)) and the x-t map of the magnet
centres in the lab frame (pitch r0 + L, L the magnet length the paper's model leaves out) with
the fitted front line; numbers: the rise time of every magnet (paper: 23.9 ms for n = 1, 4.9 ms
for n = 6) and the front speed, fitted over magnets 2-12 and 6-18, in the gap frame (the
model's, arrival times against the initial positions) and in the lab frame (against the magnet
centres: the paper's V_P = 6.42 m/s is read off an x-t image of the magnets).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ... import measures
from ...plots import pyplot, style_figure
from ...run_folder import simulate
from ..output import StudyResult
from ..scaffold import EXPERIMENT_PEAK as VI
from ..scaffold import EXPERIMENT_RISE as RISE
from ..scaffold import EXPERIMENT_STAND_IN as STAND_IN
from ..scaffold import MAGNET_LENGTH, R0, experiment_case

NAME = "fig1"
PAPER = {"rise_time_n1_ms": 23.9, "rise_time_n6_ms": 4.9, "V_P_m_per_s": 6.42}
PROFILES = (0, 1, 3, 5, 7, 11, 15)  # 0-based: magnets n = 1, 2, 4, 6, 8, 12, 16
# Magnet ranges (first, last; 1-based, inclusive) for the front speed: the front accelerates, so
# its speed depends on where it is read; the paper does not say where its red arrow was drawn.
FITS = {"n=2..12": (2, 12), "n=6..18": (6, 18)}  # first and last magnet


def run(out: Path, quick: bool = False) -> StudyResult:
    """Run this study into `out` (`quick`: its small version) and return its results; what it
    runs and measures is the module's docstring."""
    case = experiment_case()  # small enough to run whole in the quick version too
    traj = simulate(case, out / NAME / case.name, overwrite=True)
    t, v, a = traj.t, traj.v, traj.a
    peaks = measures.first_peaks(t, v, a, VI)
    x = traj.x0 + traj.u
    centres = traj.x0 + MAGNET_LENGTH * np.arange(traj.x0.size)  # the lab frame: pitch r0 + L
    speeds, arrivals = {}, {}
    for method in ("velocity_peak", "level", "acceleration_peak"):
        arrival = arrivals[method] = measures.arrival_times(t, v, VI, method=method, a=a)
        speeds[method] = {k: measures.fit_propagation_velocity(arrival, traj.x0, *w) for k, w in FITS.items()}
    lab = {k: measures.fit_propagation_velocity(arrivals["velocity_peak"], centres, *w) for k, w in FITS.items()}
    rise = peaks.rise_time
    numbers = {
        "V_I_peak_m_per_s": VI,
        "pulse_duration_T_s_ms": 2 * RISE,
        "rise_time_ms": {f"n={n + 1}": rise[n] for n in range(len(rise))},
        "rise_time_n1_ms": rise[0],
        "rise_time_n6_ms": rise[5],
        "first_peak_velocity_m_per_s": {f"n={n + 1}": peaks.peak_velocity[n] for n in range(len(rise))},
        "V_P_fit_by_arrival_definition_and_magnets": speeds,
        # The paper's r (and V_P) ignore the magnets' length; a front speed read from an x-t
        # image of the magnets covers r0 + L per magnet: the lab frame, fitted to the centres.
        "magnet_length_mm": MAGNET_LENGTH, "pitch_r0_plus_L_mm": R0 + MAGNET_LENGTH,
        "V_P_lab_frame_m_per_s": {k: f.velocity for k, f in lab.items()},
        "V_P_lab_frame_vs_paper": {k: f.velocity / PAPER["V_P_m_per_s"] - 1 for k, f in lab.items()},
        "paper": PAPER,
        "stand_in_impact": STAND_IN,
    }
    tables = {"magnets": {"n": np.arange(1, len(rise) + 1), "start_time_ms": peaks.start_time,
                          "first_peak_time_ms": peaks.peak_time, "first_peak_velocity_m_per_s": peaks.peak_velocity,
                          "rise_time_ms": rise}}
    tables["lab_frame"] = {"window": list(FITS), "first_magnet": [w[0] for w in FITS.values()],
                           "last_magnet": [w[1] for w in FITS.values()],
                           "V_P_gap_frame_m_per_s": [speeds["velocity_peak"][k].velocity for k in FITS],
                           "V_P_lab_frame_m_per_s": [lab[k].velocity for k in FITS],
                           "V_P_lab_frame_stderr_m_per_s": [lab[k].velocity_stderr for k in FITS]}
    line = _front_line(arrivals["velocity_peak"], centres, lab["n=2..12"], f"paper {PAPER['V_P_m_per_s']:g}")
    gap_line = _front_line(arrivals["velocity_peak"], traj.x0, speeds["velocity_peak"]["n=2..12"], "gap frame")
    return StudyResult(NAME, numbers, tables=tables,
                       figure=figure(t, x, v, quick, (t, x + centres - traj.x0, line), gap_line), quick=quick)


def _front_line(arrival, positions, fit, note: str) -> tuple[np.ndarray, np.ndarray, str]:
    """The fitted front over its magnets: their initial positions (mm; centres in the lab
    frame) and the times (ms) of the line t = t0 + x / V_P through their arrivals, and its legend."""
    window = slice(fit.first_magnet - 1, fit.last_magnet)
    xs, ts = positions[window], arrival[window]
    t0 = np.nanmean(ts - xs / fit.velocity)
    return xs, t0 + xs / fit.velocity, (f"front, magnets {fit.first_magnet}-{fit.last_magnet}: "
                                        f"{fit.velocity:.2f} m/s ({note})")


def figure(t, x, v, quick, lab, gap_line):
    """The paper's panels (b), with the fitted front line where the paper has its red arrow,
    and (c), and the lab-frame x-t map of the magnet centres with its fitted front line."""
    plt = pyplot()
    fig, (left, right, third) = plt.subplots(1, 3, figsize=(17, 5.5), layout="constrained")
    left.plot(x, t, color="k", lw=0.8)
    xs, ts, label = gap_line
    left.plot(xs, ts, color="C3", lw=2, label=label)
    left.legend(fontsize="small", loc="lower left")
    left.set(title="magnet trajectories", xlabel="x (mm)", ylabel="t (ms)", ylim=(t[-1], t[0]))
    for n in PROFILES:
        right.plot(t, v[:, n], lw=0.8, label=f"n = {n + 1}")
    right.set(title="velocity profiles", xlabel="t (ms)", ylabel="v (m/s)")
    right.legend(fontsize="small")
    times, centres, (xs, ts, label) = lab
    third.plot(centres, times, color="k", lw=0.8)
    third.plot(xs, ts, color="C3", lw=2, label=label)
    third.set(title=f"magnet centres, lab frame (pitch $r_0 + L$ = {R0 + MAGNET_LENGTH:g} mm)", xlabel="x (mm)",
              ylabel="t (ms)", ylim=(times[-1], times[0]))
    # below the panel: every region inside it holds a magnet's line
    third.legend(fontsize="small", loc="upper center", bbox_to_anchor=(0.5, -0.12), frameon=False)
    return style_figure(fig, "Fig. 1: the 21-magnet experiment (model), calibrated friction, magnet 21 fixed",
                        quick=quick, stand_in=STAND_IN, letters="bcd")
