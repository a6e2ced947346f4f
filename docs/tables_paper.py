"""The tables of docs/reproduction.md and the README's main job: each function renders one
marked table (docs/tables.py) from the stored study outputs."""

from __future__ import annotations

import math
import re

from tables_format import COMPARE, fixed, num, percent, read_csv, read_json, sci, sig, table


def fig1() -> str:
    """Fig. 1: rise times and the front speed (docs/reproduction/fig1.json, fig1_magnets.csv)."""
    data = read_json("reproduction/fig1.json")
    paper, rise1, rise6 = data["paper"], data["rise_time_n1_ms"], data["rise_time_n6_ms"]
    start = num(read_csv("reproduction/fig1_magnets.csv")[0]["start_time_ms"])
    window = "n=2..12"
    gap = data["V_P_fit_by_arrival_definition_and_magnets"]["velocity_peak"][window]
    lab = data["V_P_lab_frame_m_per_s"][window]
    r0 = data["pitch_r0_plus_L_mm"] - data["magnet_length_mm"]
    return table(COMPARE, [
        ["rise time, n = 1", f"{paper['rise_time_n1_ms']:g} ms", f"{fixed(rise1, 2)} ms",
         percent(rise1 / paper["rise_time_n1_ms"] - 1, 1),
         f"by construction of the stand-in pulse; we count from v = 0.01 V_I, reached {fixed(start, 2)} ms after the start"],
        ["rise time, n = 6", f"{paper['rise_time_n6_ms']:g} ms", f"{fixed(rise6, 2)} ms",
         percent(rise6 / paper["rise_time_n6_ms"] - 1, 1),
         f"the stand-in pulse is not the measured impact; the steepening itself ({fixed(rise1, 1)} -> "
         f"{fixed(rise6, 1)} ms by n = 6, ratio {fixed(rise6 / rise1, 2)} against the paper's "
         f"{fixed(paper['rise_time_n6_ms'] / paper['rise_time_n1_ms'], 2)}) is reproduced"],
        ["front speed V_P (x-t diagram)", f"{paper['V_P_m_per_s']:g} m/s",
         f"{fixed(lab, 2)} m/s in the lab frame over magnets {gap['first_magnet']}-{gap['last_magnet']} "
         f"({fixed(gap['velocity'], 2)} m/s in the model's gap frame)", percent(lab / paper["V_P_m_per_s"] - 1, 1),
         f"the paper reads V_P off an x-t image of the magnets, whose centres are r0 + L = "
         f"{data['pitch_r0_plus_L_mm']:g} mm apart; its model's speeds, and ours, count the gap r0 = {r0:g} mm only "
         "(\"the length of the magnet is not considered\"). See below"],
    ])


def fig2() -> str:
    """Fig. 2: the power-law fit to noisy samples of the paper's law (docs/reproduction/fig2.json)."""
    data = read_json("reproduction/fig2.json")
    law, fit, err = data["law"], data["fit"], data["fit_relative_error"]
    noise = f"{100 * data['noise_relative']:g} % noise on {data['samples']} samples"
    v, a = data["peak_velocity_m_per_s"], data["peak_acceleration_m_per_s2"]
    magnets = " and ".join(k[2:] for k in v)
    return table(["quantity", "paper", "ours (fit)", "difference", "why"], [
        ["K", f"{law['K_N_mm3']:g} N mm^3", f"{fixed(fit['K_N_mm3'], 1)} N mm^3", percent(err["K"], 1), noise],
        ["b", f"{law['b_mm']:g} mm", f"{fixed(fit['b_mm'], 3)} mm", percent(err["b"], 1), "same"],
        ["q", f"{law['q']:g}", fixed(fit["q"], 4), percent(err["q"]), "same"],
        [f"F(r0), -dF/dr(r0) at r0 = {data['r0_mm']:g} mm", "-",
         f"{sig(data['force_at_r0_N'], 4)} N, {sig(data['stiffness_at_r0_N_per_mm'], 4)} N/mm", "-", "from the law"],
        [f"(b-d) v and a of magnets {magnets}", "experiment vs model curves",
         f"model only: peak v {' and '.join(fixed(x, 2) for x in v.values())} m/s, "
         f"peak a {' and '.join(fixed(x, 0) for x in a.values())} m/s^2", "-", "the experimental curves are not published"],
    ])


def fig3() -> str:
    """Fig. 3: the long lattice at V_I = 2 m/s (docs/reproduction/fig3.json)."""
    d = read_json("reproduction/fig3.json")
    paper, vi, v0 = d["paper"], d["V_I_m_per_s"], d["V0_m_per_s"]
    p, fit, peak = d["V_P_plateau_m_per_s"], d["V_P_fitted_over_plateau_window"], d["first_peak_plateau_m_per_s"]
    steady = d["steady_oscillation"]
    ns = ", ".join(k[2:] for k in steady)
    s10 = steady["n=10"]
    zone = d["transition_zone"]
    first, last = zone["width_magnets"][0], zone["width_magnets"][-1]
    rates = d["transition_zone_growth_by_tolerance_particles_per_ms"]
    at = d["first_particle_with_first_peak_at_least_3.87_m_per_s"]
    return table(COMPARE, [
        ["linear wave speed V0", f"{paper['V0_m_per_s']:g} m/s", f"{fixed(v0, 3)} m/s", percent(v0 / paper["V0_m_per_s"] - 1, 1),
         f"V0 = r0 sqrt(q K/(r0+b)^(q+1)/m) from the paper's rounded K, b, q gives {fixed(v0, 3)}; the paper's "
         f"{paper['V0_m_per_s']:g} is not consistent with its own parameters to better than 1 %"],
        ["V_P plateau (Fig. 3(b))", f"{paper['V_P_m_per_s']:g} m/s",
         f"{fixed(p['mean'], 3)} m/s (gaps {p['first_gap']}-{p['last_gap']}, drift {percent(p['relative_drift'])}, "
         f"{'converged' if p['converged'] else 'not converged'}); fitted {fixed(fit['velocity'], 4)} +- "
         f"{sig(fit['velocity_stderr'], 1)}", percent(p["mean"] / paper["V_P_m_per_s"] - 1),
         f"still rising by ~{100 * p['relative_drift']:.2f} % over the window"],
        ["first peak of a \"typical\" magnet (Fig. 3(a))", f"{paper['first_peak_m_per_s']:g} m/s",
         f"the first peak passes {paper['first_peak_m_per_s']:g} m/s at magnet {at} and saturates at "
         f"{fixed(peak['mean'], 3)} m/s", "-",
         f"the paper does not say which magnet; {paper['first_peak_m_per_s']:g} m/s lies on our curve"],
        ["saturated first peak (Fig. 3(c))", f"{paper['saturated_first_peak_over_V_I']:g} V_I",
         f"{fixed(d['first_peak_plateau_over_V_I'], 3)} V_I",
         percent(d["first_peak_plateau_over_V_I"] / paper["saturated_first_peak_over_V_I"] - 1, 1), ""],
        ["first peak acceleration", "grows and saturates",
         f"grows to {fixed(d['first_peak_acceleration_max_m_per_s2'], 0)} m/s^2 and saturates", "-", ""],
        ["steady oscillation (Fig. 3(d,e))", "same amplitude and period for n >= 5",
         f"n = {ns}: f = {fixed(s10['frequency_Hz'], 2)} Hz (f/f0 = {fixed(s10['f_over_f0'], 3)}), amplitude "
         + " / ".join(fixed(s["amplitude_m_per_s"], 3) for s in steady.values()) + " m/s, eta "
         + " / ".join(fixed(s["energy_ratio_eta"], 3) for s in steady.values()), "-",
         f"its mean is {fixed(s10['mean_velocity_m_per_s'], 6)} m/s = V_I: the momentum balance behind the front "
         "(an independent check)"],
        ["transition zone (Fig. 3(d), Movie S2)", "expands indefinitely",
         "grows linearly; its rate depends on how close a magnet must come to magnet 10's steady oscillation to count "
         "as settled: " + ", ".join(fixed(r, 3) for r in rates.values()) + " magnets/ms for a settling tolerance of "
         + ", ".join(rates) + f" V_I (at {d['transition_zone_tolerance_over_V_I']:g} V_I: {first:g} magnets wide at "
         f"{zone['time_ms'][0]:g} ms, {last:g} at {zone['time_ms'][-1]:g} ms)", "-",
         "the deepest magnet the front reached minus the deepest magnet whose extrema stay within the tolerance of "
         "magnet 10's steady maxima and minima (`measures.transition`); no tolerance is singled out by the physics, "
         "so the rate is a range, not one number (`transition_zone_growth_by_tolerance_particles_per_ms` in "
         "`fig3.json`)"],
    ])


def s3() -> str:
    """Fig. S3: second neighbours (docs/reproduction/s3.json)."""
    d = read_json("reproduction/s3.json")
    ratio, theory = d["V_I_0.01_m_per_s"]["V_P_ratio_attractive_over_nearest"], d["V_I_0.01_m_per_s"]["V0_ratio_linear_theory"]
    runs = d["V_I_2_m_per_s"]
    base, att, rep = runs["nearest only"], runs["attractive 5 %"], runs["repulsive 5 %"]

    def change(key, change_key):
        return (f"{fixed(base[key]['mean'], 3)} -> {fixed(att[key]['mean'], 3)} m/s (attractive, "
                f"{percent(att[change_key], 1)}); {fixed(rep[key]['mean'], 3)} m/s (repulsive, {percent(rep[change_key], 1)})")
    return table(COMPARE, [
        ["linear front speed with / without (V_I = 0.01 m/s)", "-", fixed(ratio, 4),
         f"theory sqrt((k1 + 4 k2)/k1) = {fixed(theory, 4)}: {percent(ratio / theory - 1)}",
         "the check of the second-neighbour bonds against linear theory"],
        [f"V_P at V_I = 2 m/s, {d['duration_ms']:g} ms", "\"second-order effect\"",
         change("V_P_plateau_m_per_s", "V_P_change_vs_nearest_only"), "-",
         f"a {100 * d['fraction_of_nearest_force_at_r0']:g} % attraction is not negligible for V_P"],
        ["saturated first peak", "-", change("first_peak_plateau_m_per_s", "first_peak_change_vs_nearest_only")
         .replace(" (attractive, ", " (").replace(" (repulsive, ", " ("), "-", ""],
    ])


def s4() -> str:
    """Fig. S4: the friction rig (docs/reproduction/s4.json)."""
    d = read_json("reproduction/s4.json")
    fit, rig = d["calibration"], d["rig"]
    ends = [rig[0], rig[-1]]
    return table(COMPARE, [
        ["mu, p", f"{d['mu']:g}, {d['p']:g} (fitted to experiments)",
         f"used in the runs; refitted (`measures.fit_friction`) to the {len(rig)} runs' traces with white noise of "
         f"{100 * fit['noise_of_range']:g} % of each range: mu = {fixed(fit['mu'], 6)} +- {sig(fit['mu_error'], 1)}, "
         f"p = {fixed(fit['p'], 7)} +- {sig(fit['p_error'], 1)}",
         f"{percent(fit['mu_relative_error'], 4)}, {percent(fit['p_relative_error'], 4)}",
         "the experimental traces are not published; the paper's fitting procedure is checked on synthetic traces "
         "of known mu and p instead"],
        ["energy balance: mechanical energy lost = friction work", "-",
         f"agree to {sci(d['max_abs_energy_balance_relative_error'])} (all {len(rig)} r1)", "-",
         "an independent check of the friction fix"],
        [f"r1 = {ends[0]['r1_mm']:g} and {ends[1]['r1_mm']:g} mm: half cycles before rest", "Fig. S4(c, h)",
         f"{ends[0]['half_cycles']} and {ends[1]['half_cycles']}", "-", ""],
    ])


def s5() -> str:
    """Fig. S5: the linear lattice (docs/reproduction/s5.json; the Airy limit from
    docs/literature/harmonic.json)."""
    d = read_json("reproduction/s5.json")
    p, v0, peak = d["V_P_plateau_m_per_s"], d["V0_m_per_s"], d["first_peak_plateau_m_per_s"]
    n = round((p["first_gap"] + p["last_gap"]) / 2)
    eta, mid = d["decay_eta"], d["decay_window_mid_ms"]
    steady = d["steady_oscillation"]["n=10"]
    airy = read_json("literature/harmonic.json")["first_peak_far_field_limit_over_u_p"]
    return table(COMPARE, [
        ["V_P -> V0 (Fig. S5(b))", "approaches V0", f"{fixed(p['mean'], 4)} m/s at gaps {p['first_gap']}-{p['last_gap']} "
         f"against V0 = {fixed(v0, 4)} m/s", percent(p["mean"] / v0 - 1),
         f"the front's Airy deficit 0.068 n^(-2/3) = {100 * 0.068 * n ** (-2 / 3):.1f} % at n = {n}, vanishing as n "
         "grows (tested against the exact chain in `tests/test_measures.py`)"],
        ["the oscillation decays completely (Fig. S5(d))", "yes",
         f"eta of magnet {d['decay_particle']}: {sci(eta[0])} at {mid[0]:.0f} ms, {sci(eta[-1])} at {mid[-1]:.0f} ms; at "
         f"{steady['window_ms'][0]:g}-{steady['window_ms'][1]:g} ms nothing above 0.05 V_I is left (NaN with the reason "
         "in `s5.json`)", "-", ""],
        ["against the exact semi-infinite chain", "-",
         f"velocity of magnet {d['decay_particle']} to {sci(d['max_velocity_error_vs_exact_over_V_I'])} V_I, eta to "
         f"{sci(d['decay_eta_relative_difference_max'])}", "-", "`exact.harmonic_piston_velocity`"],
        ["first peak velocity grows, acceleration falls with n (Fig. S5(c))", "yes",
         f"{'yes' if d['first_peak_acceleration_falls_with_n'] else 'no'}; first peak "
         f"{fixed(d['first_peak_plateau_over_V_I'], 3)} V_I by n = {peak['last_magnet']} (Airy limit {fixed(airy, 3)} V_I)",
         "-", ""],
    ])

def fig4() -> str:
    """Fig. 4: V_P, f and eta against V_I, V* and its dependence on q (docs/reproduction/fig4.json)."""
    d = read_json("reproduction/fig4.json")
    v0, runs = d["V0_m_per_s"], d["runs"]
    done = [r for r in runs if r["status"] == "done"]
    at = lambda vi: min(done, key=lambda r: abs(r["V_I_m_per_s"] - vi))  # noqa: E731
    low, high, two = done[0], done[-1], at(2.0)
    contact = d["contact_limit"]
    touched = [r for r in runs if r["status"] != "done"]
    first, last = _contact(touched[0]["error"]), _contact(touched[-1]["error"])
    knees, paper = d["V_star_over_V0"], d["paper"]["V_star_over_V0"]
    names = {"two_line": "two-line break", "tangent": "tangent", "kneedle": "kneedle", "threshold": "eta = 0.1"}
    theory = d["V_star_dsw_over_V0"]
    spread = [knees[m] / paper - 1 for m in names]
    lengths = d["V_star_by_run_length_ms"]
    eta_1 = at(1.0)["eta_by_run_length"]
    q = d["V_star_against_q"]
    kb, ff = q["fixed K, b"], q["fixed F(r0), dF/dr(r0)"]
    qs = ", ".join(f"{float(k):g}" for k in kb)

    def knee_list(conv, key=lambda c: c["V_star"]["V_star_m_per_s"], digits=3):
        return ", ".join(fixed(key(c), digits) for c in conv.values())

    over = lambda c: c["V_star_over_V0"]  # noqa: E731
    dsw = lambda c: c["V_star_dsw_over_V0"]  # noqa: E731
    others = max(abs(c["V_star_all"][m]["V_star_m_per_s"] - c["V_star"]["V_star_m_per_s"]) / c["V0_m_per_s"]
                 for conv in q.values() for c in conv.values() for m in ("tangent", "kneedle"))
    to_theory = max(abs(dsw(c) - over(c)) for conv in q.values() for c in conv.values())
    fractions = d["q_sweep_common_fraction_range_of_V0"]
    any_run = next(iter(kb.values()))
    touched_q = [(conv, k) for conv, cs in q.items() for k, c in cs.items() if c["touched"]]
    top = max(t["V_I_m_per_s"] for conv, k in touched_q for t in q[conv][k]["touched"]) if touched_q else None
    top_fraction = top / q[touched_q[0][0]][touched_q[0][1]]["V0_m_per_s"] if touched_q else None
    return table(COMPARE, [
        ["V_P against V_I (Fig. 4(a))", "nearly linear, like a Hugoniot",
         f"{fixed(low['V_P_m_per_s'], 3)} m/s at {low['V_I_m_per_s']:g} m/s (V0 = {fixed(v0, 3)} m/s) to "
         f"{fixed(high['V_P_m_per_s'], 3)} m/s at {high['V_I_m_per_s']:g} m/s; linear above ~0.5 m/s", "-",
         "numbers for the paper's curve are not given"],
        ["f/f0 against V_I (Fig. 4(b))", "grows with V_I",
         f"{fixed(low['f_over_f0'], 3)} at {low['V_I_m_per_s']:g} m/s (-> 1, the band edge, in the linear limit), "
         f"{fixed(two['f_over_f0'], 2)} at {two['V_I_m_per_s']:g} m/s, {fixed(high['f_over_f0'], 2)} at "
         f"{high['V_I_m_per_s']:g} m/s", "-", ""],
        ["largest V_I before magnets touch", "-",
         f"between {contact['largest_without_contact_m_per_s']:g} and {contact['smallest_with_contact_m_per_s']:g} m/s "
         f"({d['duration_ms']:g} ms): at {touched[0]['V_I_m_per_s']:g} m/s magnets {first[0]} and {first[1]} touch at "
         f"{first[2]:.0f} ms, in the transition zone; at {touched[-1]['V_I_m_per_s']:g} m/s magnets {last[0]} and "
         f"{last[1]} touch at {last[2]:.0f} ms", "-",
         "the limit depends on the run length, since the contact happens in the growing transition zone"],
        ["V*/V0 (Fig. 4(c))", f"~{paper:g}",
         ", ".join(f"{fixed(knees[m], 2)} ({n})" for m, n in names.items())
         + f"; the dispersive-shock theory (`theory.critical_velocity`, the wake's harmonic edge reaching wavenumber "
         f"pi): {fixed(theory, 3)} ({fixed(d['V_star_dsw_m_per_s'], 3)} m/s)",
         f"{percent(min(spread), 0)} to {percent(max(spread), 0)}",
         f"the paper does not define its knee; the three knee definitions give "
         f"{fixed(min(knees[m] for m in ('two_line', 'tangent', 'kneedle')), 2)}-"
         f"{fixed(max(knees[m] for m in ('two_line', 'tangent', 'kneedle')), 2)}, bracketing {paper:g}; the theory's V* "
         f"lies among the knees (tangent {fixed(abs(knees['tangent'] - theory), 3)} V0 and kneedle "
         f"{fixed(abs(knees['kneedle'] - theory), 3)} V0 from it)"],
        ["V* against run length", "-",
         f"two-line knee {', '.join(fixed(v['two_line']['V_star_m_per_s'], 2) for v in lengths.values())} m/s for eta "
         f"measured at {', '.join(lengths)} ms; tangent "
         f"{', '.join(fixed(v['tangent']['V_star_m_per_s'], 2) for v in lengths.values())}", "-",
         f"weak oscillations keep decaying (eta at 1 m/s: {', '.join(fixed(v, 3) for v in eta_1.values())}), so V* rises "
         f"with the run length and has no long-time limit within {d['duration_ms']:g} ms"],
        ["V* against q (Fig. 4(d))", "a stiffer law reaches the strong regime at a lower V_I",
         f"K, b fixed: V* = {knee_list(kb)} m/s for q = {qs} (V*/V0 = {knee_list(kb, over)}); F(r0), dF/dr(r0) fixed: "
         f"V* = {knee_list(ff)} m/s (V*/V0 = {knee_list(ff, over)}) (two-line knee; the tangent and kneedle knees move "
         f"the same way, within {fixed(others, 3)} V0). The DSW theory's V*/V0: "
         f"{knee_list(kb, dsw)} (K, b fixed) and {knee_list(ff, dsw)} (F, dF/dr fixed), within "
         f"{fixed(to_theory, 3)} V0 of the two-line knees, and with the same trends under both "
         "conventions (`fig4_V_star.csv` lists every knee and the theory side by side)", "-",
         f"reproduced with K and b fixed; with F and dF/dr at r0 fixed the trend reverses. Runs last "
         f"{d['q_sweep_run_length_periods']:g} periods 1/f0 of each law (dt and output scaled with the period), "
         f"{any_run['runs']} V_I from {fixed(fractions[0], 2)} to {sig(top_fraction, 2)} V0"
         + (f"; at {sig(top_fraction, 2)} V0 the magnets of q = {' and '.join(f'{float(k):g}' for _, k in touched_q)} "
            f"with {'F, dF/dr' if touched_q[0][0].startswith('fixed F') else 'K, b'} fixed touch, so every law's knee "
            f"is taken over the {len(fractions)} fractions {fixed(fractions[0], 2)}-{fixed(fractions[-1], 2)} V0 that "
            "all ran (the members that touched are listed in `fig4.json`, `touched`, and in `fig4_q_runs.csv`)"
            if touched_q else "")],
    ])


def _contact(error: str) -> tuple[int, int, float]:
    """The magnets that touched and when (ms), from a member's error line."""
    m = re.search(r"magnets (\d+) and (\d+) touched .* at t = ([0-9.]+) ms", error)
    return int(m[1]), int(m[2]), float(m[3])



def fig1_front() -> str:
    """Fig. 1: the front speed in the gap and lab frames per window (docs/reproduction/fig1.json)."""
    data = read_json("reproduction/fig1.json")
    gap = data["V_P_fit_by_arrival_definition_and_magnets"]["velocity_peak"]
    paper = data["paper"]["V_P_m_per_s"]
    rows = []
    for window, lab in data["V_P_lab_frame_m_per_s"].items():
        fit = gap[window]
        rows.append([f"magnets {fit['first_magnet']}-{fit['last_magnet']}", f"{fixed(fit['velocity'], 3)} m/s",
                     f"{fixed(lab, 3)} m/s", f"{paper:g} m/s", percent(lab / paper - 1, 1)])
    return table(["window", "gap frame (the model's)", f"lab frame (centres, pitch {data['pitch_r0_plus_L_mm']:g} mm)",
                  "paper", "lab frame vs paper"], rows)


def s6() -> str:
    """Fig. S6: V_P against mu (docs/reproduction/s6.json)."""
    rows = []
    for run in read_json("reproduction/s6.json")["runs"]:
        q = run["V_P_last_quarter"]
        rows.append([f"{run['mu']:g}", f"{fixed(run['V_P_max_m_per_s'], 3)} m/s ({run['V_P_max_gap']})",
                     f"{fixed(run['V_P_last_m_per_s'], 3)} m/s (gap {run['gaps_crossed']})",
                     f"{fixed(q['mean'], 3)} m/s, {percent(q['relative_drift'])}", "yes" if q["converged"] else "no"])
    return table(["mu", "V_P max (gap)", "V_P at the last gap crossed", "last quarter: mean, drift",
                  "converged (1 %)"], rows)


def s7() -> str:
    """Fig. S7: the steady state against the ramp time (docs/reproduction/s7.json)."""
    rows = []
    for run in read_json("reproduction/s7.json")["runs"]:
        p, s = run["V_P_plateau"], run["steady_oscillation"]
        rows.append([f"{run['T_r_ms']:g} ms", f"{fixed(p['mean'], 4)} m/s ({percent(p['relative_drift'])})",
                     f"{fixed(s['amplitude_m_per_s'], 4)} m/s", fixed(run["f_over_f0"], 4),
                     fixed(s["energy_ratio_eta"], 4)])
    return table(["T_r", "V_P plateau (drift)", "amplitude", "f/f0", "eta"], rows)


def s8() -> str:
    """Fig. S8: V_P against the pulse duration (docs/reproduction/s8.json)."""
    data = read_json("reproduction/s8.json")
    runs = [r for r in data["runs"] if r["status"] == "done"]
    return table(["T_s / T0"] + [sig(r["T_s_over_T0"], 3) for r in runs],
                 [["V_P (m/s)"] + [fixed(r["V_P_plateau"]["mean"], 3) for r in runs]])

def s8_limits() -> str:
    """Fig. S8: the limits of V_P and the oscillation after a pulse (docs/reproduction/s8.json)."""
    d = read_json("reproduction/s8.json")
    v0, vc = d["V0_m_per_s"], d["V_P_constant_drive_m_per_s"]
    runs = [r for r in d["runs"] if r["status"] == "done"]
    vp = lambda r: r["V_P_plateau"]["mean"]  # noqa: E731
    at = lambda x: min(runs, key=lambda r: abs(math.log(r["T_s_over_T0"] / x)))  # noqa: E731
    short, shorter, longest, one, third = runs[0], runs[1], runs[-1], at(1.0), at(10 ** -0.5)
    osc, vi = d["shown"]["oscillations"], d["V_I_peak_m_per_s"]
    maxima = osc["max_velocity_m_per_s"]
    return table(COMPARE, [
        ["V_P for T_s << T0", "tends to V0 (no number given)",
         f"{fixed(vp(short), 3)} m/s at T_s = {sig(short['T_s_over_T0'], 1)} T0 = {fixed(vp(short) / v0, 3)} V0, falling "
         f"towards V0 as T_s shrinks ({fixed(vp(shorter), 3)} m/s at {sig(shorter['T_s_over_T0'], 2)} T0)",
         "reproduced as stated", "the paper says only that V_P tends to V0 when T_s << T0 (shorter pulses: below)"],
        ["V_P for T_s >> T0", "-> the constant drive's",
         f"{fixed(vp(longest), 3)} m/s at {sig(longest['T_s_over_T0'], 2)} T0 against {fixed(vc, 3)} m/s for the "
         "constant drive", percent(d["V_P_longest_over_constant_drive"] - 1, 1), ""],
        ["V_P drops sharply below T0 (Fig. S8(b))", "yes",
         f"{fixed(vp(one), 3)} m/s at T0, {fixed(vp(third), 3)} m/s at {sig(third['T_s_over_T0'], 2)} T0", "-", ""],
        [f"after the pulse (Fig. S8(c, d), T_s = {d['shown']['T_s_ms']:g} ms)",
         "amplitude and period fall until the oscillation vanishes",
         f"magnet 10's maxima {fixed(maxima[0], 2)} -> {fixed(max(maxima), 2)} m/s, then down to {fixed(maxima[-1], 2)} "
         f"m/s by {osc['max_time_ms'][-1]:.0f} ms; no extremum above 0.05 V_I ({0.05 * vi:g} m/s) after that", "-", ""],
    ])


S9_PAPER = {0.01: "settles at v = V_I", 0.1: "settles at v = V_I", 1.0: "a steady oscillation", 2.0: "a steady oscillation"}


def s9() -> str:
    """Fig. S9: phase portraits, settling and transition cycles (docs/reproduction/s9.json)."""
    runs = read_json("reproduction/s9.json")["runs"]
    rows = []
    for r in runs:
        vi, s, o = r["V_I_m_per_s"], r["steady_oscillation"], r["orbit_in_window"]
        spread = f"v varies by {100 * (o['velocity_max_m_per_s'] - o['velocity_min_m_per_s']) / vi:.0f} % of V_I"
        orbit = (f"v between {fixed(o['velocity_min_m_per_s'], 3)} and {fixed(o['velocity_max_m_per_s'], 3)} m/s, gap "
                 f"between {fixed(o['gap_min_mm'], 2)} and {fixed(o['gap_max_mm'], 2)} mm")
        why = ""
        if s["energy_ratio_eta"] is None:
            level = re.search(r"\(([0-9.]+) V_I\)", s["reason"])[1]  # the prominence threshold
            ours = f"settles: nothing above {level} V_I left ({spread})"
        elif len(r["eta_by_time_ms"]) > 1:
            eta = {float(t) / 1e3: e for t, e in r["eta_by_time_ms"].items()}
            final = eta[max(eta)]
            settled = min(t for t, e in eta.items() if abs(e / final - 1) < 0.01)
            earlier = ", ".join(f"{fixed(e, 4)} at {t:g} s" for t, e in eta.items() if t in (min(eta), settled) and t != max(eta))
            ours = f"a steady oscillation, reached slowly: eta = {fixed(final, 4)} at {max(eta):g} s ({earlier}), {orbit}"
            why = (f"reproduced; it takes about {settled:g} s to settle (within 1 % of its final eta; at "
                   f"{min(eta) * 1e3:g} ms eta is still {100 * (eta[min(eta)] / final - 1):.0f} % above its final value)")
        else:
            ours = f"steady, eta = {fixed(s['energy_ratio_eta'], 3)}, {orbit}"
        rows.append([f"{vi:g} m/s", S9_PAPER.get(vi, "-"), ours, why])
    cycles = [r for r in runs if r["steady_oscillation"]["energy_ratio_eta"] is not None]
    rows.append(["transition cycles", "fewer at larger V_I",
                 f"{cycles[0]['transition_cycles']} velocity maxima before settling (within 0.1 V_I of the final extrema, "
                 f"{cycles[0]['settling_time_ms']:.0f} ms) at {cycles[0]['V_I_m_per_s']:g} m/s, "
                 + ", ".join(f"{r['transition_cycles']} at {r['V_I_m_per_s']:g} m/s" for r in cycles[1:]), ""])
    return table(["V_I", "paper", "ours", "why they differ"], rows)


def readme_main_job() -> str:
    """The main job against the paper (docs/reproduction/paper_long_lattice_summary.json, the
    summary.json of `pylmp-lattice run inputs/paper_long_lattice.toml`; the paper's numbers from
    fig3.json)."""
    run, paper = read_json("reproduction/paper_long_lattice_summary.json"), read_json("reproduction/fig3.json")["paper"]
    p, peak = run["shock_velocity_plateau_m_per_s"], run["first_peak_velocity_plateau_m_per_s"]
    return table(["quantity", "this package", "paper"], [
        ["linear wave speed V0", f"{fixed(run['linear_wave_speed_V0_m_per_s'], 3)} m/s", f"{paper['V0_m_per_s']:g} m/s"],
        [f"shock velocity plateau V_P (gaps {p['first_gap']}-{p['last_gap']})", f"{fixed(p['mean'], 3)} m/s",
         f"{paper['V_P_m_per_s']:g} m/s"],
        [f"first peak velocity, saturated (magnets {peak['first_magnet']}-{peak['last_magnet']})",
         f"{fixed(peak['mean'], 3)} m/s = {fixed(run['first_peak_velocity_over_V_I'], 3)} V_I",
         f"{paper['saturated_first_peak_over_V_I']:g} V_I"],
    ])
