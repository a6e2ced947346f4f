"""Dispersive-shock theory (`pylmp_lattice.theory`) against the simulations, against V_I.

Chains: the magnet law F = K/(r + b)^q with K, b fixed and q = 2, 3 (the paper's), 4, 5
(m = 1.084 g, r0 = 12 mm); the Toda lattice (m = A = B = 1, r0 = a = 10 mm) and the
Lennard-Jones chain (m = epsilon = sigma = 1 at its minimum), each a long lattice pushed at
constant V_I = x V* for x in FRACTIONS, V* the theory's critical speed of that chain.
Every chain runs for PERIODS of its own linear period T0 = 1/f0, with dt = 0.01 ms T0/PAPER_T0
(T0/2353), frames of the chain every 100 steps and of magnets 1-12 every 10, so every run has
the same number of steps and frames.

Per run, measured against the theory's `predict`:
- V_P: the summary's plateau (the last quarter of the gaps crossed), and its limit n -> oo from
  the fit A - C/n of the per-gap V_P over the later three quarters (`theory.first_peak_limit`);
  against the lead (soliton-edge) speed, the Rankine-Hugoniot speed and the weak-shock line;
- the wake frequency f and eta of magnet 10 (`measures.steady_oscillation`, prominence
  1e-3 V_I, as Fig. 4) in the window ending at T, against the band edge c(r1)/pi; eta also at
  T/2: the wake "decays" where eta(T)/eta(T/2) < DECAYS, "persists" where it is > PERSISTS;
- the mean gap and mean force next to the piston (gaps 2-11, the last fifth of the run,
  `measures.wake_state`) against r1 and F(r1);
- the first-peak limit A (with its standard error) of A - C/n over the same particles.
Per chain: the predicted V* beside the knees of eta(V_I) (`measures.critical_velocities`)
and the bracket [largest V_I that decays, smallest that persists]; the largest deviations of
V_P's limit and of the wake frequency from the theory below and above V*. Above V* the theory
is outside its domain (`Prediction.in_domain`): the study warns, and the figure shades that
side of every panel, where the measured deviations are drawn against numbers kept for
comparison only.
Run length (the paper's law only): the same V_I run for LENGTHS periods (0.94, 1.5 and 3.0 s;
the first is the runs above), and the V_P and first-peak limits of each, with their largest
relative change between lengths per V_I: the table "lengths" (does the first peak's limit sit
below 2 V_I, or do longer runs close the gap?).
Quick: the paper's law only, at x = 0.5 and 1.5, 17 periods (400 ms), and 34 periods for the
run length; its figure and JSON say quick. Members that fail (magnets touching) are reported in the table with their error.
"""

from __future__ import annotations

import logging
from pathlib import Path

import numpy as np

from ... import measures, theory
from ...case import FORCE_LAWS
from ...plots import pyplot, style_figure
from ...run_folder import RunFolder
from ...units import period
from .. import STUDIES
from ..output import StudyResult
from ..scaffold import CHAINS as LITERATURE_CHAINS
from ..scaffold import MASS, PAPER_FORCE, R0, done_runs, sweep_runs

log = logging.getLogger(__name__)
NAME = "dsw"
# chain -> (force, spacing r0 in mm, mass in g, table settings)
CHAINS = {f"magnet q={q:g}": (PAPER_FORCE | {"q": q}, R0, MASS, {}) for q in (2.0, 3.0, 4.0, 5.0)}
CHAINS |= {name: LITERATURE_CHAINS[name] for name in ("toda", "lj")}
FRACTIONS = (0.25, 0.5, 0.75, 0.9, 1.1, 1.25, 1.5, 2.0)  # V_I / V*
PERIODS = 40.0  # run length in linear periods T0 = 1/f0
LENGTHS = (40.0, 64.0, 128.0)  # run lengths compared, periods T0 (the first is PERIODS)
LENGTH_CHAIN = "magnet q=3"  # the chain whose limits are compared across run lengths
QUICK = {"chains": ("magnet q=3",), "fractions": (0.5, 1.5), "periods": 17.0, "lengths": (17.0, 34.0)}
PAPER_T0 = 23.53  # ms, about 1/f0 of the paper's chain (23.520): the time step scales from it
MAGNET = 10  # where eta and f are measured (as Fig. 4)
FINE = tuple(range(1, 13))  # magnets written at the fine interval: the piston's neighbours
WAKE_GAPS = (2, 11)  # gaps 2-11 (inclusive), next to the piston
PROMINENCE = 1e-3  # of V_I, for eta and f: follows weak oscillations too
WINDOW_PERIODS = 3.5  # the steady window spans at least this many T0
DECAYS, PERSISTS = 0.25, 0.5  # eta(T)/eta(T/2): below, the wake decays; above, it persists


def chain_base(chain: str, periods: float) -> tuple[dict, float]:
    """The case dict of `chain` (a long lattice, V_I to be set) for `periods` of its T0; and T0, ms."""
    force, r0, mass, table = CHAINS[chain]
    law = chain_law(chain)
    t0 = period(measures.linear_frequency(float(law.stiffness(r0)), mass))
    dt = 0.01 * t0 / PAPER_T0  # ms; the run and its outputs as whole numbers of steps
    steps = round(periods * PAPER_T0 / 0.01)
    base = {
        "name": f"dsw_{chain.replace(' ', '_').replace('=', '')}",
        "chain": {"mass": mass, "r0": r0, "far_end": "long"}, "force": dict(force),
        "impactor": {"profile": "constant", "velocity": 1.0},
        "run": {"duration": steps * dt, "dt": dt, "output_interval": 100 * dt},
        "output": {"fine": list(FINE), "fine_interval": 10 * dt},
    } | ({"table": dict(table)} if table else {})
    return base, t0


def chain_law(chain: str):
    """The forcelaw object of `chain`."""
    force = dict(CHAINS[chain][0])
    return FORCE_LAWS[force.pop("law")](**force)


def measure(run, t0: float, prediction: theory.Prediction | None) -> dict:
    """One run's measures (see the module docstring) beside the theory's numbers."""
    case, vi = run.member.case, run.member.params["impactor.velocity"]
    law, mass, duration = case.force, float(case.chain.mass), case.run.duration
    front = RunFolder(run.folder).front()
    reached = measures.particles_reached(front.arrival)
    later = np.arange(max(reached // 4, 1), reached - 1)  # gaps (0-based) and particles the front passed
    vp_limit = theory.first_peak_limit(later + 1, front.propagation_velocity[later])
    peak_limit = theory.first_peak_limit(later, front.peaks.peak_velocity[later] / vi)
    fine = RunFolder(run.folder).trajectory("fine")
    steady = {}
    for end in (duration / 2, duration):
        span = max(0.2 * end, WINDOW_PERIODS * t0)
        steady[end] = measures.steady_oscillation(fine.t, fine.v[:, FINE.index(MAGNET)], vi, (end - span, end),
                                                  prominence=PROMINENCE)
    wake = measures.wake_state(fine.t, fine.v, fine.gaps(), law, mass, WAKE_GAPS, (0.8 * duration, duration))
    eta_half, eta_end = steady[duration / 2].energy_ratio, steady[duration].energy_ratio
    ratio = eta_end / eta_half if np.isfinite(eta_half) and eta_half > 0 else np.nan
    trend = "decays" if not np.isfinite(eta_end) or ratio < DECAYS else "persists" if ratio > PERSISTS else "unclear"
    plateau = run.summary["shock_velocity_plateau_m_per_s"]["mean"]
    row = {
        "duration_ms": duration, "particles_reached": reached,
        "V_P_plateau_m_per_s": plateau, "V_P_limit_m_per_s": vp_limit.A, "V_P_limit_error_m_per_s": vp_limit.A_error,
        "first_peak_plateau_over_V_I": run.summary["first_peak_velocity_over_V_I"],
        "first_peak_limit_over_V_I": peak_limit.A, "first_peak_limit_error": peak_limit.A_error,
        "f_Hz": steady[duration].frequency, "eta_half_run": eta_half, "eta": eta_end, "eta_ratio": ratio,
        "wake": trend, "eta_reason": steady[duration].reason,
        "mean_gap_mm": wake.mean_gap, "mean_force_N": wake.mean_force,
    }
    if prediction is None:
        return row
    p = prediction
    return row | {
        "lead_speed_m_per_s": p.lead_speed, "V_P_limit_vs_lead": vp_limit.A / p.lead_speed - 1,
        "V_P_plateau_vs_lead": plateau / p.lead_speed - 1,
        "rankine_hugoniot_speed_m_per_s": p.rankine_hugoniot_speed, "weak_shock_speed_m_per_s": p.weak_shock_speed,
        "wake_frequency_Hz": p.wake_frequency, "f_vs_theory": steady[duration].frequency / p.wake_frequency - 1,
        "wake_gap_mm": p.wake_gap, "mean_gap_vs_theory": wake.mean_gap / p.wake_gap - 1,
        "piston_force_N": p.piston_force, "mean_force_vs_theory": wake.mean_force / p.piston_force - 1,
        "trailing_speed_m_per_s": p.trailing_speed, "wake_persists_theory": p.wake_persists,
        "theory_in_domain": p.in_domain,
    }


def run(out: Path, quick: bool = False) -> StudyResult:
    """Run this study into `out` (`quick`: its small version) and return its results; what it
    runs and measures is the module's docstring."""
    chains = QUICK["chains"] if quick else tuple(CHAINS)
    fractions = QUICK["fractions"] if quick else FRACTIONS
    periods = QUICK["periods"] if quick else PERIODS
    rows, per_chain = [], {}
    for chain in chains:
        force, r0, mass, _ = CHAINS[chain]
        base, t0 = chain_base(chain, periods)
        law = chain_law(chain)
        v_star = theory.critical_velocity(law, mass, r0)
        velocities = [float(np.round(x * v_star, 6)) for x in fractions]
        runs = sweep_runs(base, out / NAME / base["name"], grid={"impactor.velocity": velocities})
        mine = []
        for r, row in done_runs(runs, mine, "V_I_m_per_s", "impactor.velocity"):
            row |= measure(r, t0, _predict(law, mass, r0, row["V_I_m_per_s"]))
        for row in mine:
            row |= {"chain": chain, "V_I_over_V_star": row["V_I_m_per_s"] / v_star}
        rows += mine
        per_chain[chain] = _chain_numbers(law, mass, r0, t0, v_star, mine)
    lengths = _run_lengths(out, rows, fractions, QUICK["lengths"] if quick else LENGTHS, periods)
    outside = [r for r in rows if r["V_I_over_V_star"] > 1]
    if outside:
        log.warning("study dsw: %d of %d runs have V_I above V*, outside the theory's domain: its lead speed and wake "
                    "frequency there are for comparison only (they run ahead of the simulations)", len(outside), len(rows))
    numbers = {
        "title": STUDIES[NAME] + (" (quick version)" if quick else ""),
        "method": "El, Chaos 15, 037103 (2005); El & Hoefer, Physica D 333, 11 (2016); pylmp_lattice.theory",
        "run_length_periods_T0": periods, "particle": MAGNET, "wake_gaps": list(WAKE_GAPS),
        "eta_prominence_over_V_I": PROMINENCE, "eta_ratio_decays_below": DECAYS, "eta_ratio_persists_above": PERSISTS,
        "chains": per_chain, "runs": rows, "run_length": lengths,
    }
    keys = list(dict.fromkeys(k for row in rows for k in row if k != "eta_reason"))
    tables = {"runs": {k: [_cell(row.get(k)) for row in rows] for k in keys},
              "chains": {"chain": list(per_chain)} | {k: [_cell(c[k]) for c in per_chain.values()]
                                                      for k in next(iter(per_chain.values())) if k != "knees"}}
    tables["chains"] |= {f"knee_{m}_m_per_s": [_cell(c["knees"][m].value) for c in per_chain.values()]
                         for m in measures.KNEE_METHODS}
    tables["lengths"] = {k: [_cell(row.get(k)) for row in lengths["runs"]] for k in LENGTH_KEYS}
    return StudyResult(NAME, numbers, tables=tables, figure=_figure(rows, per_chain, quick), quick=quick)


LENGTH_KEYS = ("V_I_m_per_s", "V_I_over_V_star", "periods_T0", "duration_ms", "status", "particles_reached",
               "V_P_limit_m_per_s", "V_P_limit_error_m_per_s", "first_peak_limit_over_V_I", "first_peak_limit_error")


def _run_lengths(out: Path, rows: list[dict], fractions, lengths, periods: float) -> dict:
    """LENGTH_CHAIN's V_P and first-peak limits at each run length (periods T0): the rows of
    `rows` (run for `periods`) and new sweeps for the other lengths; per V_I, the largest
    relative change of each limit between lengths."""
    law, (_, r0, mass, _) = chain_law(LENGTH_CHAIN), CHAINS[LENGTH_CHAIN]
    v_star = theory.critical_velocity(law, mass, r0)
    velocities = [float(np.round(x * v_star, 6)) for x in fractions]
    found = []
    for length in lengths:
        if length == periods:
            mine = [r | {"periods_T0": length} for r in rows if r["chain"] == LENGTH_CHAIN]
        else:
            base, t0 = chain_base(LENGTH_CHAIN, length)
            base["name"] += f"_{length:g}T0"
            mine = []
            for r, row in done_runs(sweep_runs(base, out / NAME / base["name"], grid={"impactor.velocity": velocities}),
                                    mine, "V_I_m_per_s", "impactor.velocity"):
                row |= measure(r, t0, None)
            for row in mine:
                row |= {"chain": LENGTH_CHAIN, "V_I_over_V_star": row["V_I_m_per_s"] / v_star, "periods_T0": length}
        found += [{k: row.get(k) for k in LENGTH_KEYS} for row in mine]
    change = {}
    for key in ("V_P_limit_m_per_s", "first_peak_limit_over_V_I"):
        spans = []
        for vi in velocities:
            values = [r[key] for r in found if r["V_I_m_per_s"] == vi and r["status"] == "done"]
            if len(values) == len(lengths):
                spans.append((max(values) - min(values)) / np.mean(values))
        change[key] = max(spans, default=None)
    return {"chain": LENGTH_CHAIN, "periods_T0": list(lengths), "runs": found,
            "largest_relative_change_V_P_limit": change["V_P_limit_m_per_s"],
            "largest_relative_change_first_peak_limit": change["first_peak_limit_over_V_I"]}


def _predict(law, mass, r0, vi):
    try:
        return theory.predict(law, mass, r0, vi)
    except ValueError:  # beyond the theory (the wake would reach contact): measured only
        return None


def _chain_numbers(law, mass, r0, t0, v_star, rows) -> dict:
    ok = [r for r in rows if r["status"] == "done"]
    vi = np.array([r["V_I_m_per_s"] for r in ok])
    eta = np.array([r["eta"] for r in ok], float)
    decays = [r["V_I_m_per_s"] for r in ok if r["wake"] == "decays"]
    persists = [r["V_I_m_per_s"] for r in ok if r["wake"] == "persists"]
    v0 = measures.linear_wave_speed(float(law.stiffness(r0)), mass, r0)
    deviation = {}
    for key, name in (("V_P_limit_vs_lead", "V_P_limit"), ("f_vs_theory", "wake_frequency")):
        for side, inside in (("below", True), ("above", False)):
            values = [abs(r[key]) for r in ok if r.get(key) is not None and np.isfinite(r[key])
                      and (r["V_I_m_per_s"] <= v_star) == inside]
            deviation[f"largest_{name}_deviation_{side}_V_star"] = max(values, default=None)
    return deviation | {
        "r0_mm": r0, "mass_g": mass, "V0_m_per_s": v0, "T0_ms": t0,
        "V_star_theory_m_per_s": v_star, "V_star_over_V0": v_star / v0,
        "largest_decaying_V_I_m_per_s": max(decays, default=None),
        "smallest_persisting_V_I_m_per_s": min(persists, default=None),
        "runs": len(rows), "failed": len(rows) - len(ok),
        "knees": measures.critical_velocities(vi, eta),
    }


def _cell(x):
    return np.nan if x is None else x


def _figure(rows, per_chain, quick):
    plt = pyplot()
    fig, ax = plt.subplots(2, 3, figsize=(15, 8.5), layout="constrained")
    ok = [r for r in rows if r["status"] == "done"]
    for k, chain in enumerate(per_chain):
        mine = [r for r in ok if r["chain"] == chain]
        if not mine:
            continue
        col, c = f"C{k}", per_chain[chain]
        x = np.array([r["V_I_over_V_star"] for r in mine])
        get = lambda key: np.array([_cell(r.get(key)) for r in mine], float)  # noqa: E731
        v0 = c["V0_m_per_s"]
        ax[0, 0].plot(x, get("V_P_limit_m_per_s") / v0, "o", color=col, ms=4, label=chain)
        line = np.linspace(0.05, max(x.max(), 1.0) * 1.05, 60)
        theory_line = [_predict(chain_law(chain), c["mass_g"], c["r0_mm"], xi * c["V_star_theory_m_per_s"])
                       for xi in line]
        ax[0, 0].plot(line, [np.nan if p is None else p.lead_speed / v0 for p in theory_line], "-", color=col, lw=0.8)
        ax[0, 0].plot(line, [np.nan if p is None else p.rankine_hugoniot_speed / v0 for p in theory_line], ":",
                      color=col, lw=0.8)
        ax[0, 1].plot(x, 100 * get("V_P_limit_vs_lead"), "o-", color=col, ms=4, label=chain)
        ax[0, 1].plot(x, 100 * get("V_P_plateau_vs_lead"), "x", color=col, ms=4)
        ax[0, 2].plot(x, 100 * get("f_vs_theory"), "o-", color=col, ms=4, label=chain)
        ax[1, 0].semilogy(x, get("eta"), "o-", color=col, ms=4, label=chain)
        for m, marker in (("two_line", "v"), ("kneedle", "^")):
            knee = c["knees"][m].value
            if np.isfinite(knee):
                ax[1, 0].plot(knee / c["V_star_theory_m_per_s"], 2e-6, marker, color=col, ms=7)
        ax[1, 1].plot(x, 100 * get("mean_gap_vs_theory"), "o-", color=col, ms=4, label=f"{chain}: gap")
        ax[1, 1].plot(x, 100 * get("mean_force_vs_theory"), "s--", color=col, ms=3, mfc="none")
        ax[1, 2].errorbar(x, get("first_peak_limit_over_V_I"), yerr=get("first_peak_limit_error"), fmt="o", color=col,
                          ms=4, label=chain)
        ax[1, 2].plot(x, get("first_peak_plateau_over_V_I"), "x", color=col, ms=4)
    right = max([r["V_I_over_V_star"] for r in ok], default=1.0)
    for a in ax.flat:
        a.set_xlabel("$V_I / V^*$ ($V^*$ of the theory)")
        a.axvline(1.0, color="k", ls="--", lw=0.8)
        if right > 1:  # the theory's numbers here are for comparison only (Prediction.in_domain)
            a.axvspan(1.0, right * 1.05, color="0.85", alpha=0.5, lw=0, zorder=0)
    for a in ax[0, 1], ax[0, 2]:
        if right > 1:
            a.text(0.99, 0.02, "$V_I > V^*$: outside the theory's domain", transform=a.transAxes, ha="right",
                   va="bottom", fontsize="x-small", color="0.3")
    for a in ax[0, 1], ax[0, 2], ax[1, 1]:
        a.axhline(0, color="k", lw=0.5)
    ax[0, 0].set(title="$V_P$", ylabel="$V_P / V_0$")
    ax[0, 1].set(title="$V_P$ against the lead speed", ylabel="relative error (%)")
    ax[0, 2].set(title="wake frequency", ylabel="relative error against $c(r_1)/\\pi$ (%)")
    ax[1, 0].set(title="$\\eta$ of magnet 10 at the end", ylabel=r"$\eta$")
    ax[1, 1].set(title="wake next to the piston (gaps 2-11)", ylabel="relative error (%)")
    ax[1, 2].axhline(2.0, color="k", ls=":", lw=0.8)
    ax[1, 2].set(title="first peak", ylabel="first peak / $V_I$")
    ax[0, 0].legend(fontsize="x-small", loc="upper left")
    keys = {  # what the markers and lines mean, in black
        (0, 0): [("o", "", "LAMMPS, A - C/n limit"), ("", "-", "lead speed (theory)"), ("", ":", "Rankine-Hugoniot")],
        (0, 1): [("o", "-", "A - C/n limit"), ("x", "", "plateau, last quarter")],
        (1, 0): [("v", "", "two-line knee"), ("^", "", "kneedle knee")],  # those drawn only, below
        (1, 1): [("o", "-", "mean gap against $r_1$"), ("s", "--", "mean force against $F(r_1)$")],
        (1, 2): [("o", "", "A - C/n limit"), ("x", "", "plateau, last quarter")],
    }
    drawn_knees = {m for c in per_chain.values() for m in ("two_line", "kneedle") if np.isfinite(c["knees"][m].value)}
    keys[1, 0] = [e for e, m in zip(keys[1, 0], ("two_line", "kneedle")) if m in drawn_knees]
    for (i, j), entries in keys.items():
        handles = [ax[i, j].plot([], [], marker=m, ls=ls or "none", color="k", ms=4, label=label)[0]
                   for m, ls, label in entries]
        if not handles:
            continue
        if (i, j) == (0, 0):
            ax[i, j].add_artist(ax[i, j].get_legend())
            ax[i, j].legend(handles=handles, fontsize="x-small", loc="lower right")
        else:
            ax[i, j].legend(handles=handles, fontsize="x-small")
    return style_figure(fig, "Dispersive-shock theory (El's DSW fitting) against LAMMPS: $V_P$, the wake, "
                        "$\\eta$ and $V^*$, first peaks", quick=quick)
