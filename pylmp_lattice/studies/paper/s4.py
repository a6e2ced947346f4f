"""Fig. S4: the friction calibration rig (paper Sec. S3): one magnet between two fixed magnets
r1 apart, released at rest 1.8 mm from the left one, oscillates and stops by friction.

Six separations r1 from 249.5 mm to 30.1 mm (the paper's range; the four inner values are ours,
the paper does not list them), mu = 0.285, p = 0.012; the middle magnet's position against time
as in Fig. S4(c-h). Per r1: the final position (at rest once the run is long enough), the number
of half cycles, and the energy check: mechanical energy lost between the release and the end against the friction work
(LAMMPS's f_friction). Quick: the two end separations, 600 ms.

Calibration, as an experimentalist would do it: each trace (every 0.5 ms) gets white noise of
1 % of its range (seed NOISE_SEED), and `measures.fit_friction` fits mu and p to all of them at
once by the paper's procedure (the one-degree-of-freedom equation solved and fitted to the
traces); the JSON and the table "fit" give mu, p with their standard errors against the values
the runs used, and each trace's fitted rest position against the run's; dashed on each panel,
the fitted model.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ... import measures
from ...case import case_from_dict
from ...plots import legend_above_data, pyplot, style_figure
from ...run_folder import RunFolder, simulate
from ..output import StudyResult
from ..scaffold import FRICTION, MASS, PAPER_FORCE, PAPER_LAW

NAME = "s4"
SEPARATIONS = (249.5, 150.0, 90.0, 60.0, 40.0, 30.1)  # mm, r1
RELEASE_GAP = 1.8  # mm, the middle magnet's start from the left magnet
NOISE, NOISE_SEED = 0.01, 4  # the synthetic measurement noise, of each trace's range; its seed
FIT_EVERY = 5  # fit every 5th frame (0.5 ms): the fit's cost is in the model, its precision in the frames


def rig_case(r1: float, duration: float = 2000.0):
    """The rig for separation r1 (mm), run for `duration` ms."""
    return case_from_dict({
        "name": f"rig_r1_{r1:g}mm",
        "chain": {"particles": 3, "mass": MASS, "r0": [RELEASE_GAP, r1 - RELEASE_GAP]},
        "force": dict(PAPER_FORCE),
        "impactor": {"profile": "rest"},
        "friction": {"mu": FRICTION["mu"], "p": FRICTION["p"]},
        "run": {"duration": duration, "dt": 0.002, "output_interval": 0.1},
        "table": {"r_max": r1, "points": 100000},
    })


def run(out: Path, quick: bool = False) -> StudyResult:
    """Run this study into `out` (`quick`: its small version) and return its results; what it
    runs and measures is the module's docstring."""
    separations = (SEPARATIONS[0], SEPARATIONS[-1]) if quick else SEPARATIONS
    duration = 600.0 if quick else 2000.0
    plt = pyplot()
    fig, axes = plt.subplots(2, len(separations) // 2, figsize=(max(7, 4 * len(separations) // 2), 6.5),
                             layout="constrained", sharex=True, squeeze=False)
    rows, traces = [], []
    for r1, ax in zip(separations, axes.flat):
        case = rig_case(r1, duration)
        folder = out / NAME / case.name
        traj = simulate(case, folder, overwrite=True)
        x = traj.x0[1] + traj.u[:, 1]  # mm from the left magnet
        turning = np.flatnonzero(np.diff(np.sign(traj.v[:, 1])) != 0)
        # mechanical energy, mJ (g (m/s)^2 = mJ): the magnet may still move at the end of a short run
        energy = case.force.energy(traj.gaps()).sum(axis=1) + 0.5 * case.chain.masses()[1] * traj.v[:, 1] ** 2
        friction = RunFolder(folder).friction_work()
        lost = energy[0] - energy[-1]
        rows.append((r1, x[-1], len(turning), lost, friction, friction / lost - 1))
        traces.append((traj.t[::FIT_EVERY], x[::FIT_EVERY]))
        ax.plot(traj.t, x, lw=0.8, label="middle magnet")
        ax.axhline(r1 / 2, color="k", ls=":", lw=0.8, label="$r_1/2$")
        ax.set(title=f"$r_1$ = {r1:g} mm", xlabel="t (ms)", ylabel="position from the left magnet (mm)")
    # the legend's entries side by side where a panel is the figure's width (quick), else one a row
    fit, fit_rows = _calibrate(separations, traces, axes.flat, ncol=2 if axes.shape[1] == 1 else 1)
    # the paper's panels (c-h) run from the widest to the narrowest rig (quick: the first two letters)
    style_figure(fig, f"Fig. S4: the friction rig, $\\mu$ = {FRICTION['mu']:g}, p = {FRICTION['p']:g}, {duration:g} ms",
                 quick=quick, letters="cdefgh")
    columns = ("r1_mm", "final_position_mm", "half_cycles", "mechanical_energy_lost_mJ", "friction_work_mJ",
               "energy_balance_relative_error")
    table = {c: [row[k] for row in rows] for k, c in enumerate(columns)}
    numbers = {
        "mu": FRICTION["mu"], "p": FRICTION["p"], "duration_ms": duration,
        "rig": [dict(zip(columns, row)) for row in rows],
        "max_abs_energy_balance_relative_error": float(np.max(np.abs(table["energy_balance_relative_error"]))),
        "calibration": {"noise_of_range": NOISE, "noise_seed": NOISE_SEED, "frame_interval_ms": 0.1 * FIT_EVERY,
                        "mu": fit.mu, "mu_error": fit.mu_error, "mu_relative_error": fit.mu / FRICTION["mu"] - 1,
                        "p": fit.p, "p_error": fit.p_error, "p_relative_error": fit.p / FRICTION["p"] - 1,
                        "correlation": fit.correlation, "reduced_chi2": fit.reduced_chi2,
                        "residual_correlation_time_samples": fit.correlation_time, "traces": fit_rows},
    }
    if quick:
        numbers["quick_cannot_show"] = {"final_position_mm": "the rest position: in 600 ms the magnet has not stopped",
                                        "separations": "the four inner rigs, (d-g)"}
    tables = {"rig": table, "fit": {k: [row[k] for row in fit_rows] for k in fit_rows[0]}}
    return StudyResult(NAME, numbers, tables=tables, figure=fig, quick=quick)


def _calibrate(separations, traces, axes, ncol: int):
    """mu and p fitted to the traces with NOISE added; the fitted model drawn on `axes`, each
    legend in `ncol` columns."""
    rng = np.random.default_rng(NOISE_SEED)
    noisy = [x + rng.normal(0.0, NOISE * np.ptp(x), x.size) for _, x in traces]
    times = [t for t, _ in traces]
    fit = measures.fit_friction(times, noisy, list(separations), PAPER_LAW, MASS, FRICTION["g"], start=RELEASE_GAP)
    rows = []
    for r1, (t, x), y, rest, err, ax in zip(separations, traces, noisy, fit.rest_position, fit.rest_position_error,
                                            axes):
        model = measures.rig_motion(t, r1, fit.mu, fit.p, PAPER_LAW, MASS, FRICTION["g"], RELEASE_GAP)
        ax.plot(t, y, ",", color="0.6", label=f"with {NOISE:.0%} noise")
        ax.plot(t, model.x, "--", lw=0.8, label=f"fit: $\\mu$ = {fit.mu:.4f}, p = {fit.p:.5f}")
        legend_above_data(ax, ncol)  # the traces run from edge to edge: a legend inside hid turning points
        rows.append({"r1_mm": r1, "fitted_rest_position_mm": rest, "fitted_rest_position_error_mm": err,
                     "run_final_position_mm": float(x[-1]), "model_rest_time_ms": model.rest_time})
    return fit, rows
