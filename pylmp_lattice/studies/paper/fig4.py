"""Fig. 4 (a-d): the stabilized shock against the impactor velocity V_I (long lattice, constant
drive, no friction), every run through the sweep layer.

(a) V_P (plateau of the last quarter of the gaps crossed); (b) f/f0 and (c) eta of the steady
oscillation of magnet 10 at the end of the run (window: the last fifth, at least 3.5 periods
1/f0); V* the knee of eta(V_I), under the four definitions of `measures.critical`, and how it
moves with the run length (eta at the end of the first half, three quarters and all of the
run); V*/V0 (paper: ~0.5). The largest V_I before magnets touch is bracketed by the runs that
stopped on contact, then refined by a second sweep inside the bracket.
(d) V* against q, holding K and b fixed, or holding F(r0) and dF/dr(r0) fixed (K and b
adjusted for each q). V_I runs over the same fractions of each law's own V0, each run lasting
the same number of its law's periods 1/f0. Members whose magnets touch are listed (`touched`
per q, and the table `q_runs`), never dropped silently; the knee of every q is taken over one
common range, the fractions of V0 at which every law ran without contact.

eta here is measured down to 1e-3 V_I prominence, so a weak oscillation still has a (small)
eta; where no oscillation is found at all it is NaN with the reason in the JSON. The table
`V_star` puts the paper's V*, the knees of both sweeps and their V*/V0 side by side.
Full: 27 + 6 values of V_I over 300 ms, q in 2.5, 3, 4, 5 with 12 V_I each over 12 periods;
quick: 8 values over 150 ms, q in 2.5 and 5 with QUICK_FRACTIONS over 12 periods: fewer
points, the same trends (tested: V*/V0 falls with q for K, b fixed); panel (c)'s knees and
their run-length dependence are rough with 8 points (said in `quick_cannot_show`).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ... import measures, theory
from ...case import case_from_dict
from ...forcelaw import PowerLaw
from ...plots import pyplot, style_figure
from ...units import period
from ..output import StudyResult
from ..scaffold import MASS, PAPER_FORCE, PAPER_LAW, R0, linear_constants, paper_case, paper_dict, sweep_runs

NAME = "fig4"
MAGNET = 10
PROMINENCE = 1e-3  # of V_I, for eta: follows weak oscillations too
WINDOW_PERIODS = 3.5  # the steady window spans at least this many linear periods 1/f0
PAPER = {"V_star_over_V0": 0.5}
CONVENTIONS = ("fixed K, b", "fixed F(r0), dF/dr(r0)")
KNEE = "two_line"  # the knee drawn in (d)
QUICK_FRACTIONS = (0.05, 0.2, 0.3, 0.4, 0.5, 0.6, 0.8, 1.0)  # of V0


def run(out: Path, quick: bool = False) -> StudyResult:
    """Run this study into `out` (`quick`: its small version) and return its results; what it
    runs and measures is the module's docstring."""
    root = out / NAME
    if quick:
        velocities, duration = [0.01, 0.1, 0.5, 1.0, 1.5, 2.0, 3.0, 4.0], 150.0
        qs, fractions, q_periods = [2.5, 5.0], list(QUICK_FRACTIONS), 12.0
    else:
        velocities = sorted(set(np.round(np.geomspace(0.01, 0.3, 8), 4)) | set(np.round(np.linspace(0.4, 4.0, 19), 4)))
        duration = 300.0
        qs, fractions, q_periods = [2.5, 3.0, 4.0, 5.0], list(np.geomspace(0.02, 1.5, 12)), 12.0

    base = paper_dict("fig4", {"profile": "constant", "velocity": 1.0}, duration)
    v0, f0 = linear_constants(case_from_dict(base))
    runs = sweep_runs(base, root / "velocity", grid={"impactor.velocity": [float(v) for v in velocities]})
    limit = _contact_bracket(runs)
    if not quick and limit["largest_without_contact_m_per_s"] is not None and limit["smallest_with_contact_m_per_s"]:
        lo, hi = limit["largest_without_contact_m_per_s"], limit["smallest_with_contact_m_per_s"]
        refine = [float(v) for v in np.round(np.linspace(lo, hi, 8)[1:-1], 4)]
        runs += sweep_runs(base, root / "limit", grid={"impactor.velocity": refine})
        limit = _contact_bracket(runs)
    runs.sort(key=lambda r: r.member.params["impactor.velocity"])
    ends = (duration / 2, 3 * duration / 4, duration)
    rows = [_measure(r, ends) for r in runs]
    ok = [row for row in rows if row["status"] == "done"]
    vi = np.array([row["V_I_m_per_s"] for row in ok])
    eta = {end: np.array([row["eta_by_run_length"][f"{end:g}"] for row in ok]) for end in ends}
    v_star = {f"{end:g}": measures.critical_velocities(vi, eta[end]) for end in ends}
    final = v_star[f"{duration:g}"]

    by_q, q_rows, common = _against_q(root / "q", qs, fractions, q_periods, f0)
    table = _v_star_table(v0, final, by_q)
    numbers = {
        "duration_ms": duration, "particle": MAGNET, "eta_prominence_over_V_I": PROMINENCE,
        "V_I_values": len(rows), "V0_m_per_s": v0, "f0_Hz": f0,
        "contact_limit": limit,
        "runs": rows,
        "V_star_by_run_length_ms": v_star,
        "V_star_over_V0": {k: c.value / v0 for k, c in final.items()},
        "V_star_dsw_m_per_s": (dsw := _dsw_critical_velocity(PAPER_FORCE)), "V_star_dsw_over_V0": dsw / v0,
        "V_star_against_q": by_q,
        "q_sweep_common_fraction_range_of_V0": common,
        "q_sweep_run_length_periods": q_periods,
        "paper": PAPER,
    }
    if quick:
        numbers["quick_cannot_show"] = {
            "V_star_by_run_length_ms": "with 8 values of V_I the knees, and how they move with the run length, "
                                       "are rough"}
    velocity = {key: [row.get(key) for row in rows] for key in
                ("V_I_m_per_s", "status", "V_P_m_per_s", "V_P_converged", "f_Hz", "f_over_f0", "eta")}
    velocity["eta"] = [np.nan if e is None else e for e in velocity["eta"]]
    fig = _figure(rows, v0, final, dsw, by_q, common, duration, quick)
    return StudyResult(NAME, numbers, tables={"velocity": velocity, "q_runs": q_rows, "V_star": table}, figure=fig,
                       quick=quick)


def _against_q(root, qs, fractions, periods, f0_paper):
    """(d): one sweep over (law, V_I) pairs, V_I as fractions of each law's V0; the knee of
    each law over the fractions at which every law ran without contact."""
    points = [(c, q, _law(q, c)) for c in CONVENTIONS for q in qs]
    scale = {(c, q): _linear_constants(force) for c, q, force in points}
    # dt and the output interval scale with the period (the paper's law: 0.01 and 0.1 ms for
    # 23.5 ms), so every law gets the same resolution; dt stays far below Verlet's limit; the
    # run lasts `periods` linear periods 1/f0 of its law (with K, b fixed, f0 falls 12x from
    # q = 2.5 to 5)
    slow = {key: max(1.0, float(np.round(f0_paper / f0))) for key, (_, f0) in scale.items()}
    length = {key: float(np.round(periods * period(f0) / (0.1 * slow[key])) * 0.1 * slow[key])
              for key, (_, f0) in scale.items()}
    pairs = [(c, q, force, x) for c, q, force in points for x in fractions]
    q_base = paper_dict("fig4_q", {"profile": "constant", "velocity": 1.0}, 100.0)
    q_runs = sweep_runs(q_base, root, zip={
        "force": [p[2] for p in pairs],
        "impactor.velocity": [float(np.round(p[3] * scale[p[:2]][0], 5)) for p in pairs],
        "run.duration": [length[p[:2]] for p in pairs],
        "run.dt": [0.01 * slow[p[:2]] for p in pairs], "run.output_interval": [0.1 * slow[p[:2]] for p in pairs]})
    measured = [(c, q, x, _measure(r, (length[(c, q)],))) for (c, q, _, x), r in zip(pairs, q_runs)]
    # the common range: fractions at which no law's member touched (or failed)
    common = [x for x in fractions if all(m["status"] == "done" for _, _, xx, m in measured if xx == x)]
    by_q = {c: {} for c in CONVENTIONS}
    for c, q, force in points:
        end = length[(c, q)]
        mine = [(x, m) for cc, qq, x, m in measured if (cc, qq) == (c, q)]
        used = [(x, m) for x, m in mine if x in common]
        x = np.array([m["V_I_m_per_s"] for _, m in used])
        y = np.array([m["eta_by_run_length"][f"{end:g}"] for _, m in used])
        knees = measures.critical_velocities(x, y)
        v0q = scale[(c, q)][0]
        dsw = _dsw_critical_velocity(force)
        by_q[c][f"{q:g}"] = {
            "force": force, "V0_m_per_s": v0q, "duration_ms": end, "V_star": knees[KNEE], "V_star_all": knees,
            "V_star_over_V0": knees[KNEE].value / v0q, "V_star_dsw_m_per_s": dsw, "V_star_dsw_over_V0": dsw / v0q,
            "runs": len(mine), "used": len(used),
            "touched": [{"V_I_m_per_s": m["V_I_m_per_s"], "error": m["error"]}
                        for _, m in mine if m["status"] != "done"],
            "V_I_m_per_s": x, "eta": y}
    q_rows = {"convention": [c for c, *_ in measured], "q": [q for _, q, *_ in measured],
              "V_I_over_V0": [x for _, _, x, _ in measured],
              "V_I_m_per_s": [m["V_I_m_per_s"] for *_, m in measured], "status": [m["status"] for *_, m in measured],
              "in_common_range": [x in common for _, _, x, _ in measured],
              "eta": [m.get("eta", np.nan) if m.get("eta") is not None else np.nan for *_, m in measured]}
    return by_q, q_rows, common


def _dsw_critical_velocity(force: dict) -> float:
    """The dispersive-shock theory's V* (`theory.critical_velocity`), m/s, for a power law."""
    return theory.critical_velocity(PowerLaw(force["K"], force["b"], force["q"]), MASS, R0)


def _v_star_table(v0, final, by_q) -> dict:
    """The paper's V*, the knees of the V_I sweep (q = 3) and of the q sweep, and the DSW
    theory's V* (the wake's harmonic edge reaches wavenumber pi at the piston), side by side."""
    dsw = _dsw_critical_velocity(PAPER_FORCE)
    rows = [("paper", "~0.5 V0 (Fig. 4(c))", 3.0, "paper's law", PAPER["V_star_over_V0"] * v0, PAPER["V_star_over_V0"]),
            ("DSW theory", "harmonic edge at k = pi", 3.0, "paper's law", dsw, dsw / v0)]
    rows += [("V_I sweep", f"knee: {m}", 3.0, "paper's law", c.value, c.value / v0) for m, c in final.items()]
    for conv, per_q in by_q.items():
        for q, d in per_q.items():
            rows += [("q sweep", f"knee: {m}", float(q), conv, c.value, c.value / d["V0_m_per_s"])
                     for m, c in d["V_star_all"].items()]
            rows.append(("DSW theory", "harmonic edge at k = pi", float(q), conv, d["V_star_dsw_m_per_s"],
                         d["V_star_dsw_over_V0"]))
    columns = ("source", "definition", "q", "law", "V_star_m_per_s", "V_star_over_V0")
    return {name: [row[k] for row in rows] for k, name in enumerate(columns)}


def _linear_constants(force: dict) -> tuple[float, float]:
    return linear_constants(paper_case("v0", {"profile": "constant", "velocity": 1.0}, 1.0, force=force))


def _law(q: float, convention: str) -> dict:
    """The magnet law with power q: same K and b, or same F(r0) and dF/dr(r0) as the paper's."""
    K, b, q0 = PAPER_LAW.K, PAPER_LAW.b, PAPER_LAW.q
    if convention.startswith("fixed K"):
        return {"law": "power", "K": K, "b": b, "q": q}
    f0, k0 = K / (R0 + b) ** q0, q0 * K / (R0 + b) ** (q0 + 1)
    # F = K'/(r0 + b')^q and k = q K'/(r0 + b')^(q+1) give r0 + b' = q F/k
    span = q * f0 / k0
    return {"law": "power", "K": f0 * span**q, "b": span - R0, "q": q}


def _measure(run, ends) -> dict:
    row = run.row("V_I_m_per_s", "impactor.velocity")
    if not run.done:
        return row
    vi = row["V_I_m_per_s"]
    traj = run.trajectory()
    plateau = run.summary["shock_velocity_plateau_m_per_s"]
    f0 = run.summary["linear_frequency_f0_Hz"]
    span = max(0.2 * ends[-1], WINDOW_PERIODS * period(f0))  # ms: enough for weak oscillations near f0
    steady = {end: measures.steady_oscillation(traj.t, traj.v[:, MAGNET - 1], vi, (end - span, end), prominence=PROMINENCE)
              for end in ends}
    last = steady[ends[-1]]
    return row | {
        "V_P_m_per_s": plateau["mean"], "V_P_converged": plateau["converged"],
        "f_Hz": last.frequency, "f_over_f0": last.frequency / f0, "eta": last.energy_ratio,
        "steady_oscillation": last,
        "eta_by_run_length": {f"{end:g}": s.energy_ratio for end, s in steady.items()},
    }


def _contact_bracket(runs) -> dict:
    ok = [r.member.params["impactor.velocity"] for r in runs if r.done]
    touched = [(r.member.params["impactor.velocity"], r.error) for r in runs
               if not r.done and r.error and "touched" in r.error]
    hi = min(touched, default=(None, None))
    return {"largest_without_contact_m_per_s": max(ok, default=None), "smallest_with_contact_m_per_s": hi[0],
            "first_contact": hi[1]}


def _figure(rows, v0, v_star, dsw, by_q, common, duration, quick):
    plt = pyplot()
    fig, ax = plt.subplots(2, 2, figsize=(11, 8), layout="constrained")
    done = [r for r in rows if r["status"] == "done"]
    vi = np.array([r["V_I_m_per_s"] for r in done])
    get = lambda key: np.array([np.nan if r[key] is None else r[key] for r in done], float)  # noqa: E731
    ax[0, 0].plot(vi, get("V_P_m_per_s"), "o-", ms=3, label="$V_P$ (plateau)")
    ax[0, 0].axhline(v0, color="k", ls=":", lw=1, label=f"$V_0$ = {v0:.3f} m/s")
    touched = [r["V_I_m_per_s"] for r in rows if r["status"] != "done"]
    for k, x in enumerate(touched):
        label = f"magnets touched ({len(touched)} run{'s' if len(touched) > 1 else ''})"
        ax[0, 0].axvline(x, color="C3", ls="--", lw=0.6, label=label if k == 0 else None)
    ax[0, 0].set(title="propagation velocity", xlabel="$V_I$ (m/s)", ylabel="$V_P$ (m/s)")
    ax[0, 0].legend(fontsize="small")
    ax[0, 1].plot(vi, get("f_over_f0"), "o-", ms=3)
    ax[0, 1].set(title="steady oscillation frequency", xlabel="$V_I$ (m/s)", ylabel="$f/f_0$")
    ax[1, 0].plot(vi, get("eta"), "o-", ms=3, label=r"$\eta$ of magnet 10")
    for k, (method, c) in enumerate(v_star.items()):
        if np.isfinite(c.value):
            ax[1, 0].axvline(c.value, color=f"C{k + 1}", ls="--", lw=0.8, label=f"$V^*$ {method}: {c.value:.2f} m/s")
    ax[1, 0].axvline(dsw, color="k", ls="-", lw=0.8, label=f"$V^*$ DSW theory: {dsw:.2f} m/s")
    ax[1, 0].set(title="oscillation energy ratio", xlabel="$V_I$ (m/s)", ylabel=r"$\eta$")
    ax[1, 0].legend(fontsize="x-small")
    for k, (convention, per_q) in enumerate(by_q.items()):
        q = [float(x) for x in per_q]
        touched = sum(len(d["touched"]) for d in per_q.values())
        ax[1, 1].plot(q, [per_q[x]["V_star_over_V0"] for x in per_q], "o-", color=f"C{k}",
                      label=f"{convention}: {KNEE.replace('_', '-')} knee ({touched} touched)")
        ax[1, 1].plot(q, [per_q[x]["V_star_dsw_over_V0"] for x in per_q], "s--", mfc="none", color=f"C{k}",
                      label=f"{convention}: DSW theory")
    span = f"{min(common):.2g}-{max(common):.2g} $V_0$" if common else "none"
    ax[1, 1].axhline(PAPER["V_star_over_V0"], color="k", ls=":", lw=0.8, label="paper, q = 3: ~0.5")
    ax[1, 1].set(title=f"critical velocity against q ($V_I$ in {span})", xlabel="q",
                 ylabel="$V^*/V_0$")
    ax[1, 1].legend(fontsize="x-small", loc="best")
    return style_figure(fig, f"Fig. 4: long lattice, constant drive, no friction, {duration:g} ms", quick=quick)
