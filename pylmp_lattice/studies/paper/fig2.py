"""Fig. 2: (a) the nearest-neighbour force and the instantaneous stiffness against separation,
and the fit that gives K, b, q; (b-d) velocities and accelerations of magnets 2 and 8 in the
experiment model (`scaffold.experiment_case`, as in `fig1`; the paper's experimental curves are not published, so
only the model's side is shown).

`fit_power_law` is checked on samples of the law with 2 % multiplicative noise (seeded), over
the separations of the paper's force measurement (about 2 to 40 mm): it must recover K, b, q.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ...forcelaw import fit_power_law
from ...plots import pyplot, separate, style_figure, twin_axis
from ...run_folder import simulate
from ..output import StudyResult
from ..scaffold import EXPERIMENT_STAND_IN as STAND_IN
from ..scaffold import PAPER_LAW, R0, experiment_case

NAME = "fig2"
NOISE = 0.02  # relative, 1 sigma
SHOWN = (1, 7)  # 0-based: magnets n = 2 and 8, as in the paper


def run(out: Path, quick: bool = False) -> StudyResult:
    """Run this study into `out` (`quick`: its small version) and return its results; what it
    runs and measures is the module's docstring."""
    law = PAPER_LAW
    r = np.linspace(2.0, 40.0, 60)
    rng = np.random.default_rng(2020)
    samples = law.force(r) * (1 + NOISE * rng.standard_normal(r.size))
    fit = fit_power_law(r, samples)
    case = experiment_case()
    traj = simulate(case, out / NAME / case.name, overwrite=True)
    numbers = {
        "law": {"K_N_mm3": law.K, "b_mm": law.b, "q": law.q},
        "noise_relative": NOISE, "samples": int(r.size), "sample_range_mm": [float(r[0]), float(r[-1])],
        "fit": {"K_N_mm3": fit.law.K, "b_mm": fit.law.b, "q": fit.law.q,
                "rms_relative_error": fit.rms_relative_error, "max_relative_error": fit.max_relative_error},
        "fit_relative_error": {"K": fit.law.K / law.K - 1, "b": fit.law.b / law.b - 1, "q": fit.law.q / law.q - 1},
        "r0_mm": R0, "force_at_r0_N": float(law.force(R0)),
        "stiffness_at_r0_N_per_mm": float(law.stiffness(R0)),
        "peak_velocity_m_per_s": {f"n={n + 1}": float(traj.v[:, n].max()) for n in SHOWN},
        "peak_acceleration_m_per_s2": {f"n={n + 1}": float(traj.a[:, n].max()) for n in SHOWN},
    }
    grid = np.linspace(0.0, 40.0, 401)
    tables = {"law": {"r_mm": grid, "F_N": law.force(grid), "stiffness_N_per_mm": law.stiffness(grid)},
              "samples": {"r_mm": r, "F_noisy_N": samples, "F_fit_N": fit.law.force(r)}}
    plt = pyplot()
    fig, ax = plt.subplots(1, 3, figsize=(15, 4.5), layout="constrained")
    handles = ax[0].semilogy(r, samples, ".", ms=4, label=f"F: samples ({NOISE:.0%} noise)")
    handles += ax[0].semilogy(grid, law.force(grid), "k-", lw=1, label="F = K/(r+b)$^q$ (left)")
    handles += ax[0].semilogy(grid, fit.law.force(grid), "C1--", lw=1, label=f"fit: q = {fit.law.q:.3f}")
    ax[0].set(title="force and stiffness", xlabel="separation r (mm)", ylabel="F (N)")
    right = twin_axis(ax[0], "stiffness $-dF/dr$ (N/mm)")
    handles += right.semilogy(grid, law.stiffness(grid), "C3-.", lw=1.2, label="stiffness $-dF/dr$ (right)")
    separate(ax[0], right, np.append(samples, law.force(grid)), law.stiffness(grid))
    ax[0].legend(handles=handles, fontsize="small", loc="center left")
    for n in SHOWN:
        ax[1].plot(traj.t, traj.v[:, n], lw=0.8, label=f"n = {n + 1}")
        ax[2].plot(traj.t, traj.a[:, n], lw=0.8, label=f"n = {n + 1}")
    ax[1].set(title="velocity (model; the paper's (b, c))", xlabel="t (ms)", ylabel="v (m/s)")
    ax[2].set(title="acceleration (model; the paper's (d))", xlabel="t (ms)", ylabel="a (m/s$^2$)")
    ax[1].legend(fontsize="small")
    ax[2].legend(fontsize="small")
    style_figure(fig, "Fig. 2: the force law; magnets 2 and 8 of the 21-magnet experiment (model)", quick=quick,
                 stand_in=STAND_IN)
    return StudyResult(NAME, numbers | {"stand_in_impact": STAND_IN}, tables=tables, figure=fig, quick=quick)
