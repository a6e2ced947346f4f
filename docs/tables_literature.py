"""The tables of docs/literature.md: each function renders one marked table (docs/tables.py)
from the stored study outputs."""

from __future__ import annotations

from tables_format import exp_form, fixed, num, percent, read_csv, read_json, sci, sig, table


def harmonic() -> str:
    """The harmonic chain against its exact solution (docs/literature/harmonic_runs.csv)."""
    rows = []
    for r in read_csv("literature/harmonic_runs.csv"):
        g = lambda k: num(r[k])  # noqa: E731
        rows.append([f"{g('u_p_m_per_s'):g}", f"{g('max_error_magnets_2_31_over_u_p'):.2e}",
                     f"{g('max_error_all_over_u_p'):.2e}", fixed(g("front_speed_V_P_m_per_s"), 4),
                     fixed(g("first_peak_over_u_p_magnet_31"), 5), fixed(g("first_peak_over_u_p_exact_magnet_31"), 5),
                     r["last_magnet_with_first_peak"], fixed(g("first_peak_over_u_p_there"), 5),
                     fixed(g("wake_decay_exponent_magnet_6"), 3), fixed(g("wake_decay_exponent_magnet_6_exact"), 3)])
    return table(["u_p (m/s)", "max \\|v - exact\\| / u_p, magnets 2-31", "same, magnets 1-90", "V_P (m/s)",
                  "first peak / u_p at magnet 31", "exact, same frames", "last magnet with a first peak", "first peak / u_p there",
                  "wake decay exponent, magnet 6", "exact"], rows)


def toda_solitons() -> str:
    """One Toda soliton's speed against sinh(k)/k (docs/literature/toda_solitons.csv)."""
    rows = [[f"{num(r['kappa']):g}", f"{num(r['dt_ms']):g}", fixed(num(r["speed_sites_per_ms"]), 8),
             fixed(num(r["exact_sinh_k_over_k"]), 8), exp_form(num(r["relative_error"]))]
            for r in read_csv("literature/toda_solitons.csv")]
    return table(["k", "dt (ms)", "measured speed (sites per unit time)", "sinh(k)/k", "relative error"], rows)


def toda_pistons() -> str:
    """The Toda piston problem (docs/literature/toda_pistons.csv)."""
    rows = []
    for r in read_csv("literature/toda_pistons.csv"):
        g = lambda k: num(r[k])  # noqa: E731
        rows.append([f"{g('u_p'):g}", fixed(g("mean_r_gaps_1_10"), 5), fixed(g("uniform_wake_r"), 5),
                     exp_form(g("relative_error_exp_minus_r")), fixed(g("mean_v_magnets_2_11"), 4),
                     f"{g('staggered_t_half'):.3g}", f"{g('staggered_t_end'):.3g}",
                     fixed(g("staggered_t_end") / g("staggered_t_half"), 2), fixed(g("front_speed_sites_per_ms"), 4),
                     fixed(g("lead_soliton_speed"), 4), fixed(g("front_height"), 3),
                     fixed(g("lead_soliton_height_sinh2k"), 3)])
    return table(["u_p", "mean r, gaps 1-10, t in [190, 200]", "uniform wake -2 ln(1 + u_p/2)",
                  "relative error of exp(-r)", "mean v, magnets 2-11", "staggered amplitude, t = 100", "t = 200", "ratio",
                  "front speed (sites per unit time)", "lead soliton sinh(k)/k", "front height exp(-r) - 1",
                  "lead soliton sinh^2 k"], rows)


UNITS = {"K": "N mm^3", "b": "mm", "q": "", "A": "N", "B": "/mm", "a": "mm", "epsilon": "mJ", "sigma": "mm", "D": "mJ",
         "alpha": "/mm", "r_e": "mm"}  # the force laws' parameters (forcelaw.py), in the paper's units
LAWS = {"power": "F = K/(r+b)^q", "toda": "F = A (exp(-B (r - a)) - 1)", "lj": "Lennard-Jones", "morse": "Morse"}


def hugoniot_chains() -> str:
    """The four chains of the Hugoniot study (docs/literature/hugoniot.json)."""
    rows = []
    for chain, c in read_json("literature/hugoniot.json")["chains"].items():
        force = dict(c["force"])
        law = force.pop("law")
        params = ", ".join(f"{k} = {sig(v, 4) if k == 'alpha' else f'{v:g}'}{' ' + UNITS[k] if UNITS[k] else ''}"
                           for k, v in force.items())
        rows.append([chain, f"{LAWS[law]}, {params}", f"{c['r0_mm']:.5g} mm", f"{c['mass_g']:g} g",
                     f"{c['duration_ms']:g} ms, dt {c['dt_ms']:g} ms"])
    return table(["chain", "law", "r0", "m", "run"], rows)


def hugoniot_fits() -> str:
    """Each chain's c0 and weak-shock s beside the fitted U_s(u_p) lines, in the units of the
    chain's points (the model chains' reduced units; docs/literature/hugoniot.json)."""
    data = read_json("literature/hugoniot.json")
    units = {p["chain"]: p["units"] for p in data["points"]}
    rows = []
    for chain, t in data["theory_and_fits"].items():
        a, h = t["fit_all"], t["fit_lower_half"]
        rows.append([chain, units[chain], fixed(t["c0_m_per_s"], 4), fixed(t["s_weak_shock"], 4),
                     fixed(t["s_kdv_leading_edge"], 4), f"{fixed(a['c0_m_per_s'], 4)} + {fixed(a['s'], 4)} u_p",
                     f"{fixed(h['c0_m_per_s'], 4)} + {fixed(h['s'], 4)} u_p (u_p <= {h['u_p_max_m_per_s']:g})"])
    return table(["chain", "units", "c0", "s (weak shock)", "4s/3", "fit, all u_p", "fit, lower half"], rows)


def hugoniot_points() -> str:
    """U_s, the mean state's jump conditions and the wake energy per run, in each row's units
    (docs/literature/hugoniot.json)."""
    data = read_json("literature/hugoniot.json")
    rows = []
    for p in data["points"]:
        t = data["theory_and_fits"][p["chain"]]
        c0, s, up, us = t["c0_m_per_s"], t["s_weak_shock"], p["u_p_m_per_s"], p["U_s_m_per_s"]
        lead = p.get("lead_soliton_speed_m_per_s")
        d = p["rankine_hugoniot_D_m_per_s"]
        rows.append([p["chain"], p["units"], f"{up:g}", fixed(us, 4) + (f" (lead soliton {fixed(lead, 4)})" if lead else ""),
                     fixed(c0 + s * up, 4), fixed(c0 + 4 / 3 * s * up, 4), fixed(d, 4),
                     fixed(p["rankine_hugoniot_u_p_m_per_s"], 4), fixed((us - c0) / (d - c0), 2),
                     fixed(p["first_peak_over_u_p"], 3), f"{p['wake_oscillation_energy_mJ']:.3e}",
                     f"{p['energy_jump_mJ']:.3e}", fixed(p["wake_oscillation_energy_mJ"] / p["energy_jump_mJ"], 3)])
    return table(["chain", "units", "u_p", "U_s", "c0 + s u_p", "c0 + (4/3) s u_p", "R-H D of the mean state",
                  "R-H u_p", "(U_s - c0)/(D - c0)", "first peak / u_p", "wake oscillation energy",
                  "energy jump", "ratio"], rows)




def dsw_chains() -> str:
    """The DSW theory's V* beside the knees, per chain (docs/literature/dsw_chains.csv; the
    runs whose wake was unclear from dsw_runs.csv)."""
    unclear: dict[str, list[dict]] = {}
    for run in read_csv("literature/dsw_runs.csv"):
        if run["wake"] == "unclear":
            unclear.setdefault(run["chain"], []).append(run)
    rows = []
    for c in read_csv("literature/dsw_chains.csv"):
        persists = sig(num(c["smallest_persisting_V_I_m_per_s"]), 4)
        notes = [f"{sig(num(r['V_I_m_per_s']), 3)} unclear: ratio {fixed(num(r['eta_ratio']), 2)}"
                 for r in unclear.get(c["chain"], [])]
        rows.append([c["chain"], sig(num(c["V0_m_per_s"]), 5), sig(num(c["V_star_theory_m_per_s"]), 4),
                     fixed(num(c["V_star_over_V0"]), 3), sig(num(c["largest_decaying_V_I_m_per_s"]), 4),
                     persists + (f" ({'; '.join(notes)})" if notes else "")]
                    + [sig(num(c[f"knee_{m}_m_per_s"]), 4) for m in ("two_line", "kneedle", "tangent", "threshold")])
    return table(["chain", "V0 (m/s)", "V* theory (m/s)", "V*/V0", "largest V_I that decays (m/s)",
                  "smallest that persists (m/s)", "knee: two-line (m/s)", "kneedle (m/s)", "tangent (m/s)",
                  "eta = 0.1 (m/s)"], rows)


def dsw_lengths() -> str:
    """The paper's law: the V_P and first-peak limits against the run length (docs/literature/dsw.json)."""
    data = read_json("literature/dsw.json")["run_length"]
    runs, periods = data["runs"], data["periods_T0"]
    seconds = {p: next(r["duration_ms"] for r in runs if r["periods_T0"] == p) / 1e3 for p in periods}
    rows = []
    for vi in dict.fromkeys(r["V_I_m_per_s"] for r in runs):
        mine = {r["periods_T0"]: r for r in runs if r["V_I_m_per_s"] == vi}
        cells = [f"{mine[periods[0]]['V_I_over_V_star']:.3g}", sig(vi, 4)]
        for key, digits in (("V_P_limit_m_per_s", 6), ("first_peak_limit_over_V_I", 5)):
            values = [mine[p][key] if mine[p]["status"] == "done" else None for p in periods]
            cells += [sig(v, digits) for v in values]
            ok = [v for v in values if v is not None]
            cells.append(sci((max(ok) - min(ok)) / (sum(ok) / len(ok))) if len(ok) == len(values) else "-")
        rows.append(cells)
    at = [f"{seconds[p]:.2g} s" for p in periods]
    return table(["V_I/V*", "V_I (m/s)"] + [f"V_P limit, {t}" for t in at] + ["relative change"]
                 + [f"first peak limit / V_I, {t}" for t in at] + ["relative change"], rows)


def dsw_paper_law() -> str:
    """The paper's law run by run against the theory (docs/literature/dsw_runs.csv, magnet q=3)."""
    rows = []
    for r in read_csv("literature/dsw_runs.csv"):
        if r["chain"] != "magnet q=3" or r["status"] != "done":
            continue
        g = lambda k: num(r[k])  # noqa: E731
        rows.append([f"{g('V_I_over_V_star'):.3g}", sig(g("V_I_m_per_s"), 4), sig(g("V_P_limit_m_per_s"), 5),
                     sig(g("lead_speed_m_per_s"), 5), percent(g("V_P_limit_vs_lead")), percent(g("V_P_plateau_vs_lead")),
                     sig(g("rankine_hugoniot_speed_m_per_s"), 5), fixed(g("f_Hz"), 3), fixed(g("wake_frequency_Hz"), 3),
                     percent(g("f_vs_theory")), f"{g('eta'):.1e}" if g("eta") < 0.1 else fixed(g("eta"), 3),
                     fixed(g("eta_ratio"), 2), fixed(g("mean_gap_mm"), 4), fixed(g("wake_gap_mm"), 4),
                     percent(g("mean_force_vs_theory")),
                     f"{fixed(g('first_peak_limit_over_V_I'), 4)} ({g('first_peak_limit_error'):.0e})"])
    return table(["V_I/V*", "V_I", "V_P limit", "lead speed", "error", "plateau error", "R-H speed", "f", "c(r1)/pi",
                  "error", "eta", "eta(T)/eta(T/2)", "mean gap", "r1", "force error", "first peak limit / V_I"], rows)
