"""Fig. 4 (a-d): the stabilized shock against the impactor velocity V_I (long lattice, constant
drive, no friction), every run through the sweep layer.

(a) V_P (plateau of the last quarter of the gaps crossed); (b) f/f0 and (c) eta of the steady
oscillation of magnet 10 at the end of the run (window: the last fifth, at least 3.5 periods
1/f0); V* the knee of eta(V_I), under the four definitions of `measures.critical`, and how it
moves with the run length (eta at the end of the first half, three quarters and all of the
run); V*/V0 (paper: ~0.5).
(d) V* against q, holding K and b fixed, or holding F(r0) and dF/dr(r0) fixed (K and b
adjusted for each q). The largest V_I before magnets touch is bracketed by the runs that
stopped on contact, then refined by a second sweep inside the bracket.

eta here is measured down to 1e-3 V_I prominence, so a weak oscillation still has a (small)
eta; where no oscillation is found at all it is NaN with the reason in the JSON.
For (d) V_I runs over the same fractions of each law's own V0, each run lasting the same number
of its law's periods 1/f0. Full: 27 + 6 values of V_I over 300 ms, q in 2.5, 3, 4, 5 with 12
V_I each over 12 periods; quick: 8 values over 150 ms, q in 2.5 and 4 with 5 V_I each over 6
periods.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ... import measures
from ...case import case_from_dict
from ...plots import pyplot
from ..output import StudyResult
from ..scaffold import PAPER_LAW, R0, linear_constants, paper_case, paper_dict, sweep_runs

NAME = "fig4"
PARTICLE = 9  # 0-based: magnet 10
PROMINENCE = 1e-3  # of V_I, for eta: follows weak oscillations too
WINDOW_PERIODS = 3.5  # the steady window spans at least this many linear periods 1/f0
PAPER = {"V_star_over_V0": 0.5}


def run(out: Path, quick: bool = False) -> StudyResult:
    root = out / NAME
    if quick:
        velocities, duration = [0.01, 0.1, 0.5, 1.0, 1.5, 2.0, 3.0, 4.0], 150.0
        qs, fractions, q_periods = [2.5, 4.0], [0.05, 0.2, 0.4, 0.7, 1.0], 6.0
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
    v_star = {f"{end:g}": {k: c for k, c in measures.critical_velocities(vi, eta[end]).items()} for end in ends}
    final = v_star[f"{duration:g}"]

    # (d): one sweep over (law, V_I) pairs; V_I as fractions of each law's V0
    conventions = ("fixed K, b", "fixed F(r0), dF/dr(r0)")
    f0_paper = f0
    points = [(c, q, _law(q, c)) for c in conventions for q in qs]
    # and the run lasts q_periods linear periods 1/f0 of its law (with K, b fixed, f0 falls 12x
    # from q = 2.5 to 5)
    q_base = paper_dict("fig4_q", {"profile": "constant", "velocity": 1.0}, 100.0)
    scale = {(c, q): _linear_constants(force) for c, q, force in points}
    # dt and the output interval scale with the period too (the paper's law: 0.01 and 0.1 ms
    # for 23.5 ms), so every law gets the same resolution; dt stays far below Verlet's limit
    slow = {key: max(1.0, float(np.round(f0_paper / f0))) for key, (_, f0) in scale.items()}
    length = {key: float(np.round(q_periods * 1e3 / f0 / (0.1 * slow[key])) * 0.1 * slow[key])
              for key, (_, f0) in scale.items()}
    pairs = [(force, float(np.round(x * scale[(c, q)][0], 5)), length[(c, q)], slow[(c, q)])
             for c, q, force in points for x in fractions]
    q_runs = sweep_runs(q_base, root / "q", zip={
        "force": [p[0] for p in pairs], "impactor.velocity": [p[1] for p in pairs], "run.duration": [p[2] for p in pairs],
        "run.dt": [0.01 * p[3] for p in pairs], "run.output_interval": [0.1 * p[3] for p in pairs]})
    by_q = {c: {} for c in conventions}
    for c, q, force in points:
        mine = [r for r in q_runs if r.member.params["force"] == force]
        end = length[(c, q)]
        done = [m for m in (_measure(r, (end,)) for r in mine) if m["status"] == "done"]
        x = np.array([row["V_I_m_per_s"] for row in done])
        y = np.array([row["eta_by_run_length"][f"{end:g}"] for row in done])
        knee = measures.critical_velocity(x, y, "two_line")
        v0q = scale[(c, q)][0]
        by_q[c][f"{q:g}"] = {"force": force, "V0_m_per_s": v0q, "duration_ms": end, "V_star": knee,
                             "V_star_over_V0": knee.value / v0q, "runs": len(mine), "done": len(done),
                             "V_I_m_per_s": x, "eta": y}

    numbers = {
        "duration_ms": duration, "particle": PARTICLE + 1, "eta_prominence_over_V_I": PROMINENCE,
        "V0_m_per_s": v0, "f0_Hz": f0,
        "contact_limit": limit,
        "runs": rows,
        "V_star_by_run_length_ms": v_star,
        "V_star_over_V0": {k: c.value / v0 for k, c in final.items()},
        "V_star_against_q": by_q,
        "q_sweep_run_length_periods": q_periods,
        "paper": PAPER,
    }
    table = {key: [row.get(key) for row in rows] for key in
             ("V_I_m_per_s", "status", "V_P_m_per_s", "V_P_converged", "f_Hz", "f_over_f0", "eta")}
    table["eta"] = [np.nan if e is None else e for e in table["eta"]]
    return StudyResult(NAME, numbers, tables={"velocity": table}, figure=_figure(rows, v0, final, by_q),
                       quick=quick)


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
    span = max(0.2 * ends[-1], WINDOW_PERIODS * 1e3 / f0)  # ms: enough for weak oscillations near f0
    steady = {end: measures.steady_oscillation(traj.t, traj.v[:, PARTICLE], vi, (end - span, end), prominence=PROMINENCE)
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


def _figure(rows, v0, v_star, by_q):
    plt = pyplot()
    fig, ax = plt.subplots(2, 2, figsize=(11, 8), layout="constrained")
    done = [r for r in rows if r["status"] == "done"]
    vi = np.array([r["V_I_m_per_s"] for r in done])
    get = lambda key: np.array([np.nan if r[key] is None else r[key] for r in done], float)  # noqa: E731
    ax[0, 0].plot(vi, get("V_P_m_per_s"), "o-", ms=3)
    ax[0, 0].axhline(v0, color="k", ls=":", lw=1, label=f"$V_0$ = {v0:.3f} m/s")
    ax[0, 0].set(title="(a) propagation velocity", xlabel="$V_I$ (m/s)", ylabel="$V_P$ (m/s)")
    ax[0, 0].legend(fontsize="small")
    ax[0, 1].plot(vi, get("f_over_f0"), "o-", ms=3)
    ax[0, 1].set(title="(b) steady oscillation frequency", xlabel="$V_I$ (m/s)", ylabel="$f/f_0$")
    ax[1, 0].plot(vi, get("eta"), "o-", ms=3)
    for k, (method, c) in enumerate(v_star.items()):
        if np.isfinite(c.value):
            ax[1, 0].axvline(c.value, color=f"C{k + 1}", ls="--", lw=0.8, label=f"$V^*$ {method}: {c.value:.2f} m/s")
    ax[1, 0].set(title="(c) oscillation energy ratio", xlabel="$V_I$ (m/s)", ylabel=r"$\eta$")
    ax[1, 0].legend(fontsize="x-small")
    for convention, per_q in by_q.items():
        q = [float(k) for k in per_q]
        ax[1, 1].plot(q, [per_q[k]["V_star_over_V0"] for k in per_q], "o-", label=convention)
    ax[1, 1].set(title="(d) critical velocity against q", xlabel="q", ylabel="$V^*/V_0$ (two-line knee)")
    ax[1, 1].legend(fontsize="small")
    return fig
