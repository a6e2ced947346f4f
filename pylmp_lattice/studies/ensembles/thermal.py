"""Thermal motion and mass disorder (the paper's future work): the long lattice at V_I = 2 m/s
(inputs/paper_long_lattice.toml), with V_P, the first peak and the wake's eta against the
thermal RMS velocity (0 to 10 % of V_I) and against the magnets' mass disorder, each point the
mean of its replicas with its standard error.

Measures: the headline front speed, fitted to the arrival times over a fixed window of gaps
(`summary.front_window`, the same for every member: no plateau criterion, so every member with
a front counts); V_P and first-peak plateaus from the engine's record (levels set against each
member's noise velocity, `measures.levels`), each counted only where its plateau converged, so
each point states its coverage (values used of members run, failed ones counted; below 90 %
drawn hollow);
eta of magnet 10's steady oscillation over the last fifth of the run (at least 3.5 linear
periods), with the prominence set against the noise as well. A noise-free point (RMS 0, no
disorder) is one run, shared by both axes, and equals the plain noise-free run (tested).
Full: RMS 0, 0.5, 1, 2, 5, 10 % of V_I and mass disorder 0.5, 1, 2, 5, 10 % (normal), 8
replicas each, 600 ms. Quick: RMS 0, 2, 10 %, disorder 5 %, 2 replicas, 150 ms.
"""

from __future__ import annotations

import logging
from pathlib import Path

import numpy as np
import pandas as pd

from ... import measures
from ...case_measures import chain_noise
from ...plots import pyplot, style_figure
from ...run_folder import RunFolder
from ...sweep import replica_stats
from ...sweep.stats import low_coverage_warnings
from ...units import period
from ..output import StudyResult
from ..scaffold import linear_constants, paper_dict, sweep_runs

NAME = "thermal"
VI = 2.0  # m/s
MAGNET = 10  # whose wake oscillation gives eta (as in Fig. 4)
WINDOW_PERIODS = 3.5  # the steady window spans at least this many linear periods 1/f0
THERMAL, DISORDER = "chain.thermal_velocity", "chain.mass_disorder"
FRONT, VP, PEAK, ETA = "front_speed_m_per_s", "V_P_m_per_s", "first_peak_m_per_s", "eta"
NAMES = (FRONT, VP, PEAK, ETA)
SEED = 2026
FULL_REPLICAS, FULL_DURATION = 8, 600.0  # the full study's replicas a point and run length (ms)
log = logging.getLogger(__name__)
UNITS = {THERMAL: "thermal_rms_m_per_s", DISORDER: "mass_disorder"}  # table columns with units


def base_case(duration: float) -> dict:
    """The paper's long lattice at V_I = 2 m/s (inputs/paper_long_lattice.toml), writing magnet 10
    every 0.1 ms for eta and the whole chain only every 10 ms."""
    return paper_dict(NAME, {"profile": "constant", "velocity": VI}, duration, output_interval=10.0,
                      output={"fine": [MAGNET], "fine_interval": 0.1})


def run(out: Path, quick: bool = False) -> StudyResult:
    """Run this study into `out` (`quick`: its small version) and return its results; what it
    runs and measures is the module's docstring."""
    if quick:
        rms, disorder, replicas, duration = [0.0, 0.02, 0.1], [0.05], 2, 150.0
    else:
        rms, disorder = [0.0, 0.005, 0.01, 0.02, 0.05, 0.1], [0.005, 0.01, 0.02, 0.05, 0.1]
        replicas, duration = FULL_REPLICAS, FULL_DURATION
    # one sweep: the thermal axis (no disorder), then the disorder axis (no thermal motion)
    points = [(f * VI, 0.0) for f in rms] + [(0.0, d) for d in disorder]
    base = base_case(duration)
    runs = sweep_runs(base, out / NAME, replicas=replicas, seed=SEED,
                      zip={THERMAL: [p[0] for p in points], DISORDER: [p[1] for p in points]})
    members = pd.DataFrame([_measure(r) for r in runs])
    stats = replica_stats(members, list(NAMES))
    for line in low_coverage_warnings(stats):
        log.warning("study thermal: %s", line)
    quiet = stats[(stats[THERMAL] == 0) & (stats[DISORDER] == 0)].iloc[0]
    thermal = stats[stats[DISORDER] == 0].sort_values(THERMAL)
    mass = pd.concat([quiet.to_frame().T, stats[stats[DISORDER] > 0]]).sort_values(DISORDER)
    v0, f0 = linear_constants(runs[0].member.case)
    numbers = {
        "V_I_m_per_s": VI, "duration_ms": duration, "replicas": replicas, "particle_for_eta": MAGNET,
        "V0_m_per_s": v0, "f0_Hz": f0, "members": len(runs), "members_done": int(sum(r.done for r in runs)),
        "front_window_gaps": _window(runs),
        "noise_free": {name: quiet[f"{name}.mean"] for name in NAMES},
        "against_thermal_rms": _points(thermal, THERMAL), "against_mass_disorder": _points(mass, DISORDER),
    }
    if quick:
        numbers["quick_cannot_show"] = {
            "stderr": f"standard errors from {replicas} replicas (the full study: {FULL_REPLICAS})",
            "plateaus": f"V_P and first-peak plateaus over {duration:g} ms runs, not the full study's {FULL_DURATION:g} ms: shorter "
                        "windows, and fewer converge (a member's value is empty where its plateau did not)"}
    tables = {"thermal": _table(thermal, THERMAL), "disorder": _table(mass, DISORDER),
              "members": {UNITS.get(c, c): members[c].to_numpy() for c in members.columns}}
    return StudyResult(NAME, numbers, tables=tables, figure=_figure(thermal, mass, quiet, v0, quick), quick=quick)


def _measure(run) -> dict:
    """A member's row: its point, replica, status; V_P and first peak (NaN unless converged), eta."""
    p = run.member.params
    row = {"id": run.member.id, THERMAL: p[THERMAL], DISORDER: p[DISORDER], "replica": p.get("replica", 0),
           "status": run.status, FRONT: np.nan, VP: np.nan, PEAK: np.nan, ETA: np.nan,
           "noise_velocity_m_per_s": np.nan}
    if not run.done:
        return row
    case, summary = run.member.case, run.summary
    speed, peak = summary["shock_velocity_plateau_m_per_s"], summary["first_peak_velocity_plateau_m_per_s"]
    traj = RunFolder(run.folder).trajectory("fine")
    f0 = summary["linear_frequency_f0_Hz"]
    end = case.run.duration
    span = max(0.2 * end, WINDOW_PERIODS * period(f0))  # ms
    noise = chain_noise(case)
    steady = measures.steady_oscillation(traj.t, traj.v[:, 0], VI, (end - span, end), noise=noise)
    front = summary["front_speed_m_per_s"]
    return row | {FRONT: np.nan if front is None or front["value"] is None else front["value"],
                  VP: speed["mean"] if speed["converged"] else np.nan,
                  PEAK: peak["mean"] if peak["converged"] else np.nan,
                  ETA: steady.energy_ratio, "noise_velocity_m_per_s": noise}


def _window(runs) -> list[int] | None:
    """The front speed's gaps (first, last), the same for every member (set by the case)."""
    windows = {tuple(r.summary["front_speed_m_per_s"][k] for k in ("first_gap", "last_gap"))
               for r in runs if r.done and r.summary["front_speed_m_per_s"]}
    return list(windows.pop()) if len(windows) == 1 else None


def _points(stats: pd.DataFrame, x: str) -> list[dict]:
    return [{x: float(row[x]), "members": int(row["n"]), "failed": int(row["failed"]),
             **{name: {"mean": row[f"{name}.mean"], "stderr": row[f"{name}.sem"], "count": int(row[f"{name}.count"]),
                       "coverage": row[f"{name}.coverage"], "low_coverage": bool(row[f"{name}.low_coverage"])}
                for name in NAMES}} for _, row in stats.iterrows()]


def _table(stats: pd.DataFrame, x: str) -> dict:
    out = {UNITS[x]: stats[x].to_numpy(float), "members": stats["n"].to_numpy(int), "failed": stats["failed"].to_numpy(int)}
    for name in NAMES:
        out |= {f"{name}_mean": stats[f"{name}.mean"].to_numpy(float), f"{name}_stderr": stats[f"{name}.sem"].to_numpy(float),
                f"{name}_count": stats[f"{name}.count"].to_numpy(int),
                f"{name}_coverage": stats[f"{name}.coverage"].to_numpy(float),
                f"{name}_low_coverage": stats[f"{name}.low_coverage"].to_numpy(bool)}
    return out


def _figure(thermal, mass, quiet, v0, quick):
    plt = pyplot()
    fig, ax = plt.subplots(2, 4, figsize=(17, 7.5), layout="constrained")
    axes = ((thermal, thermal[THERMAL].to_numpy(float) / VI * 100, "thermal RMS velocity (% of $V_I$)"),
            (mass, mass[DISORDER].to_numpy(float) * 100, "mass disorder (relative std, %)"))
    panels = ((FRONT, "front speed, fixed gap window (m/s)"),
              (VP, "$V_P$ plateau, converged only (m/s)"), (PEAK, "first peak velocity (m/s)"),
              (ETA, r"wake oscillation energy ratio $\eta$ (magnet 10)"))
    for i, (stats, x, xlabel) in enumerate(axes):
        for j, (name, ylabel) in enumerate(panels):
            a = ax[i, j]
            mean = stats[f"{name}.mean"].to_numpy(float)
            a.errorbar(x, mean, yerr=stats[f"{name}.sem"].to_numpy(float),
                       fmt="o-", ms=4, capsize=3, label="mean ± standard error")
            low = stats[f"{name}.low_coverage"].to_numpy(bool)
            if low.any():  # a mean over some members only
                a.plot(x[low], mean[low], "o", ms=7, mfc="white", mec="C0", zorder=3, label="under 90 % of members")
            run = stats["n"].to_numpy(int) + stats["failed"].to_numpy(int)
            for xi, yi, count, n in zip(x, mean, stats[f"{name}.count"].to_numpy(int), run):
                if np.isfinite(yi):  # the coverage of every point: values used / members run
                    a.annotate(f"{count}/{n}", (xi, yi), textcoords="offset points", xytext=(3, 4), fontsize="xx-small")
                elif n:  # no member has a value there: its place kept, as in the sweeps' figure
                    a.axvline(xi, color="C0", ls=":", lw=0.8)
                    a.annotate(f"0/{n}", (xi, 0.02), xycoords=("data", "axes fraction"), fontsize="xx-small")
            a.axhline(float(quiet[f"{name}.mean"]), color="k", ls=":", lw=1, label="noise-free run")
            if name == PEAK:
                a.axhline(2 * VI, color="C3", ls="--", lw=0.8, label="$2 V_I$")
            a.set(xlabel=xlabel, ylabel=ylabel)
            a.legend(fontsize="x-small")
    return style_figure(fig, f"Long lattice, $V_I$ = {VI:g} m/s ($V_0$ = {v0:.3f} m/s): thermal motion and mass "
                        "disorder", quick=quick)
