"""Fig. 1 (b, c): the 21-magnet experiment, struck by a smooth synthetic impact.

The measured impact u1(t) is not published, so a half-sine velocity pulse stands in for it
(peak 2.81 m/s, rising in 23.9 ms, the paper's magnet-1 rise time), with the calibrated
friction and magnet 21 fixed: `scaffold.experiment_case`, the case of
inputs/paper_experiment.toml. Shows the x-t diagram
of the magnets (Fig. 1(b)) and velocity profiles (Fig. 1(c)); numbers: the rise time of every
magnet (paper: 23.9 ms for n = 1, 4.9 ms for n = 6) and the front speed, fitted over magnets
2-12 and 6-18 (paper: V_P = 6.42 m/s, from the x-t diagram).
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
# 0-based magnet ranges for the front speed: the front accelerates, so its speed depends on where
# it is read; the paper does not say where its red arrow was drawn.
FITS = {"n=2..12": (2, 12), "n=6..18": (6, 18)}  # first and last magnet


def run(out: Path, quick: bool = False) -> StudyResult:
    case = experiment_case()  # small enough to run whole in the quick version too
    traj = simulate(case, out / NAME / case.name, overwrite=True)
    t, v, a = traj.t, traj.v, traj.a
    peaks = measures.first_peaks(t, v, a, VI)
    x = traj.x0 + traj.u
    speeds = {}
    for method in ("velocity_peak", "level", "acceleration_peak"):
        arrival = measures.arrival_times(t, v, VI, method=method, a=a)
        speeds[method] = {k: measures.fit_propagation_velocity(arrival, traj.x0, *w) for k, w in FITS.items()}
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
        # image over magnet centres covers r0 + L per magnet (our hypothesis for 6.42 m/s).
        "V_P_over_centre_spacing_r0_plus_L_m_per_s": {
            k: f.velocity * (R0 + MAGNET_LENGTH) / R0 for k, f in speeds["velocity_peak"].items()},
        "paper": PAPER,
        "stand_in_impact": STAND_IN,
    }
    tables = {"magnets": {"n": np.arange(1, len(rise) + 1), "start_time_ms": peaks.start_time,
                          "first_peak_time_ms": peaks.peak_time, "first_peak_velocity_m_per_s": peaks.peak_velocity,
                          "rise_time_ms": rise}}
    return StudyResult(NAME, numbers, tables=tables, figure=figure(t, x, v, quick), quick=quick)


def figure(t, x, v, quick):
    """The paper's panels (b) and (c)."""
    plt = pyplot()
    fig, (left, right) = plt.subplots(1, 2, figsize=(12, 5.5), layout="constrained")
    left.plot(x, t, color="k", lw=0.8)
    left.set(title="magnet trajectories", xlabel="x (mm)", ylabel="t (ms)", ylim=(t[-1], t[0]))
    for n in PROFILES:
        right.plot(t, v[:, n], lw=0.8, label=f"n = {n + 1}")
    right.set(title="velocity profiles", xlabel="t (ms)", ylabel="v (m/s)")
    right.legend(fontsize="small")
    return style_figure(fig, "Fig. 1: the 21-magnet experiment (model), calibrated friction, magnet 21 fixed",
                        quick=quick, stand_in=STAND_IN, letters="bc")
