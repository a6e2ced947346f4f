"""Hugoniots of four chains: U_s against u_p, the jump conditions, and the wake's "temperature".

Chains (studies.scaffold.CHAINS): the magnets (600 ms), the Toda lattice m = A = B = 1 at
r0 = a = 10 mm (100 ms), Lennard-Jones m = epsilon = sigma = 1 at its minimum r0 = 2^(1/6) mm
and Morse with alpha r_e = 6 at r_e = r0 (30 ms, dt = 0.002 ms); each a long lattice pushed at
u_p = V_I. Per run:
- U_s: the front speed V_P (the u_p/2 crossing, the package's default front; the paper does
  not state its threshold), against u_p with a
  linear fit; against the weak-shock theory c0 + s u_p, s = r0 F''/(4 |F'|)
  (`exact.weak_shock`), and against c0 + (4/3) s u_p, the leading edge of a weak dispersive
  shock (the KdV limit: the lead soliton is twice the mean jump high, and a KdV soliton's speed
  excess is twice its height's share; the Rankine-Hugoniot speed has the mean jump's);
- the mean state behind (`measures.wake_state`, gaps from a tenth to a third of the way to the
  front, last quarter of the run): the Rankine-Hugoniot speed D and particle velocity from its
  mean compression and mean force (`exact.jump`), against u_p and U_s;
- the wake's oscillation energy per particle (kinetic + potential about the mean state),
  against the energy jump condition: the work per particle minus the mean flow's kinetic and
  the mean state's potential energy (`exact.wake_energy`).
The Toda front is also compared with its exact lead soliton, r0 sinh(k)/k, cosh k = 1 + u_p.
Each point's `units` says what its columns (named in m/s, mm, N, mJ) hold: the model chains'
are their reduced units (`units`).
Quick: the magnet and Toda chains at two u_p each, shorter runs.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from ...exact import jump, toda_lead_soliton, wake_energy, weak_shock
from ...measures import wake_state
from ...plots import pyplot, style_figure
from ..output import StudyResult
from ..scaffold import CHAINS, chain_case, run_cases

NAME = "hugoniot"
# chain -> (u_p values in m/s, duration ms, dt ms, output interval ms)
RUNS = {
    "magnet": ((0.05, 0.1, 0.2, 0.35, 0.5, 0.75, 1.0, 1.5, 2.0), 600.0, 0.01, 0.5),
    "toda": ((0.1, 0.2, 0.5, 1.0, 1.5, 2.0, 3.0), 100.0, 0.01, 0.1),
    "lj": ((0.1, 0.25, 0.5, 1.0, 2.0, 3.0), 30.0, 0.002, 0.02),
    "morse": ((0.1, 0.25, 0.5, 1.0, 2.0, 3.0), 30.0, 0.002, 0.02),
}
# The model chains' reduced units (their user units are mm, g, N, so a speed is numerically in m/s).
REDUCED = {"toda": "m = A = B = 1", "lj": r"m = $\epsilon$ = $\sigma$ = 1", "morse": r"m = D = 1, $\alpha r_e$ = 6"}
# The units of a points row whose chain is not in REDUCED: the ones its columns are named in.
NAMED_UNITS = "m/s, mm, N, mJ"
QUICK = {"magnet": ((0.1, 1.0), 300.0), "toda": ((0.5, 1.0), 50.0)}


def measure(chain: str, u_p: float, case, summary: dict, traj) -> dict:
    """One Hugoniot point: front speed, mean state behind, jump conditions, wake energy."""
    force, r0, mass, _ = CHAINS[chain]
    law = case.force
    reached = summary["particles_reached_by_front"]
    gaps = (max(1, reached // 10) + 1, max(reached // 3, 3))  # first and last gap (1-based, inclusive)
    duration = case.run.duration
    state = wake_state(traj.t, traj.v, traj.gaps(), law, mass, gaps, (0.75 * duration, duration))
    rh = jump(law, r0, mass, state.mean_gap, state.mean_force)
    vp = summary["shock_velocity_plateau_m_per_s"]
    row = {
        "chain": chain, "units": units(chain),
        "u_p_m_per_s": u_p, "U_s_m_per_s": vp["mean"], "U_s_converged": vp["converged"],
        "first_peak_over_u_p": summary["first_peak_velocity_over_V_I"],
        "particles_reached": reached, "wake_gaps": [state.first_gap, state.last_gap],
        "mean_gap_mm": state.mean_gap, "mean_force_N": state.mean_force, "mean_velocity_m_per_s": state.mean_velocity,
        "rankine_hugoniot_D_m_per_s": float(rh.D), "rankine_hugoniot_u_p_m_per_s": float(rh.u_p),
        "wake_kinetic_mJ": state.kinetic, "wake_oscillation_energy_mJ": state.oscillation_energy,
        "energy_jump_mJ": float(wake_energy(law, r0, mass, u_p, state.mean_gap, state.mean_force)),
    }
    if chain == "toda":
        row["lead_soliton_speed_m_per_s"] = float(r0 * toda_lead_soliton(u_p)[1])
    return row


def units(chain: str) -> str:
    """The units of a chain's points row: the magnets' are the columns' (`NAMED_UNITS`); a model
    chain's are its reduced units ("reduced, m = A = B = 1"), whose scales (1 mm, 1 g, 1 ms)
    make its numbers the same as in the columns' units."""
    if chain not in REDUCED:
        return NAMED_UNITS
    return "reduced, " + re.sub(r"[$\\]", "", REDUCED[chain])  # the figure's TeX as plain text


def run(out: Path, quick: bool = False) -> StudyResult:
    """Run this study into `out` (`quick`: its small version) and return its results; what it
    runs and measures is the module's docstring."""
    plans = {c: (QUICK[c][0], QUICK[c][1], *RUNS[c][2:]) for c in QUICK} if quick else RUNS
    rows, theory = [], {}
    for chain, (speeds, duration, dt, output) in plans.items():
        force, r0, mass, _ = CHAINS[chain]
        cases = [chain_case(chain, f"{chain}_up{u:g}", {"velocity": u}, duration, dt=dt, output=output) for u in speeds]
        for u, case, (summary, traj) in zip(speeds, cases, run_cases(cases, out / NAME / chain)):
            rows.append(measure(chain, u, case, summary, traj))
        ws = weak_shock(cases[0].force, r0, mass)
        mine = [r for r in rows if r["chain"] == chain]
        u = np.array([r["u_p_m_per_s"] for r in mine])
        us = np.array([r["U_s_m_per_s"] for r in mine])
        small = u <= np.median(u)
        fit = np.polyfit(u, us, 1) if len(u) >= 2 else (np.nan, np.nan)
        fit_small = np.polyfit(u[small], us[small], 1) if small.sum() >= 2 else (np.nan, np.nan)
        theory[chain] = {
            "c0_m_per_s": ws.c0, "s_weak_shock": ws.s, "s_kdv_leading_edge": 4 * ws.s / 3,
            "fit_all": {"c0_m_per_s": float(fit[1]), "s": float(fit[0])},
            "fit_lower_half": {"c0_m_per_s": float(fit_small[1]), "s": float(fit_small[0]),
                               "u_p_max_m_per_s": float(u[small].max())},
        }
    fig = style_figure(_figure(rows, theory), "Hugoniots: long lattices pushed at $u_p$ ($U_s$, jump conditions, "
                       "wake energy)", quick=quick)
    table = {key: [r.get(key) for r in rows] for key in rows[0] if key != "wake_gaps"}
    table["lead_soliton_speed_m_per_s"] = [r.get("lead_soliton_speed_m_per_s") for r in rows]
    numbers = {
        "chains": {c: {"force": CHAINS[c][0], "r0_mm": CHAINS[c][1], "mass_g": CHAINS[c][2],
                       "duration_ms": plans[c][1], "dt_ms": plans[c][2]} for c in plans},
        "theory_and_fits": theory, "points": rows,
    }
    if quick:
        numbers["quick_cannot_show"] = {"chains": "the Lennard-Jones and Morse chains (full study only)"}
    return StudyResult(NAME, numbers, tables={"points": table}, figure=fig, quick=quick)


def _figure(rows, theory):
    from matplotlib.ticker import NullFormatter

    plt = pyplot()
    chains = list(theory)
    fig, axes = plt.subplots(2, len(chains), figsize=(4.2 * len(chains), 7.5), layout="constrained", squeeze=False)
    for k, chain in enumerate(chains):
        mine = [r for r in rows if r["chain"] == chain]
        u = np.array([r["u_p_m_per_s"] for r in mine])
        line = np.linspace(0.0, u.max() * 1.05, 100)
        th = theory[chain]
        ax = axes[0, k]
        ax.plot(u, [r["U_s_m_per_s"] for r in mine], "o", label="front speed $U_s$ (LAMMPS)")
        ax.plot(u, [r["rankine_hugoniot_D_m_per_s"] for r in mine], "s", mfc="none", label="R-H speed of the mean state")
        ax.plot(line, th["c0_m_per_s"] + th["s_weak_shock"] * line, "k-", lw=0.8, label=f"weak shock, s = {th['s_weak_shock']:.3f}")
        ax.plot(line, th["c0_m_per_s"] + th["s_kdv_leading_edge"] * line, "k--", lw=0.8, label="KdV leading edge, 4s/3")
        ax.plot(line, th["fit_all"]["c0_m_per_s"] + th["fit_all"]["s"] * line, ":", color="C0",
                label=f"fit: {th['fit_all']['c0_m_per_s']:.3f} + {th['fit_all']['s']:.3f} $u_p$")
        if chain == "toda":
            ax.plot(line[1:], CHAINS["toda"][1] * toda_lead_soliton(line[1:])[1], "r-", lw=0.8, label="exact lead soliton")
        # the model chains are in reduced units: numerically m/s and mJ (mm, g, N), but not the magnets'
        speed, energy = ("m/s", "mJ") if chain not in REDUCED else ("reduced units",) * 2
        # two-line titles: centred one-liners ran into the panel letter and off a narrow panel
        name = chain if chain not in REDUCED else f"{chain} ({REDUCED[chain]})"
        ax.set(xlabel=f"$u_p$ ({speed})", ylabel=f"speed ({speed})", title=f"{name}\nfront and jump speeds")
        ax.legend(fontsize="x-small")
        ax = axes[1, k]
        ax.loglog(u, [r["wake_oscillation_energy_mJ"] for r in mine], "o", label="wake oscillation energy")
        ax.loglog(u, [max(r["energy_jump_mJ"], 1e-12) for r in mine], "k^", mfc="none", label="energy jump condition")
        ax.set(xlabel=f"$u_p$ ({speed})", ylabel=f"energy per particle ({energy})", title=f"{name}\nthe wake's energy")
        ax.xaxis.set_minor_formatter(NullFormatter())  # crowded minor labels on a short log axis
        ax.legend(fontsize="x-small")
    return fig
