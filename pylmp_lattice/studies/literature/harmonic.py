"""The harmonic chain driven by a piston, against its exact solution (Schroedinger 1914).

The linear lattice of the paper's Fig. S5 (which gives no k; here the magnets' stiffness at r0,
k = 3 K / (r0 + b)^4 = 0.01934 N/mm, m = 1.084 g,
r0 = 12 mm; w = sqrt(k/m) = 0.1336 rad/ms, c0 = r0 w = 1.603 m/s), 120 magnets with a held
far end, magnet 1 pushed at u_p for 600 ms (the front reaches magnet ~80). Point by point
against v_n(t) = u_p [J_2n(2 w t) + 2 sum_{k>n} J_2k(2 w t)], n the site index from 0 (magnet
n + 1; magnets are numbered from 1 wherever a number is shown, `numbering`); the front speed
(V_P, the u_p/2 crossing) against c0 at every u_p; the first peak against its far-field limit
1.2744 u_p (`exact.harmonic_overshoot_limit`); the wake at magnet 6 decaying as t^(-3/2) (by the
Bessel recurrence, J_0 + 2 sum_{0<k<n} J_2k + J_2n = (2/x) sum_{k<n} (2k+1) J_(2k+1)(x), each
term O(x^(-3/2)), x = 2 w t), and the local exponent over the run's window compared with the
exact solution's over the same window. Quick: two u_p, 300 ms.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ...exact import harmonic_overshoot_limit, harmonic_piston_velocity
from ...numbering import number
from ...plots import pyplot, style_figure
from ..output import StudyResult
from ..scaffold import MAGNET_STIFFNESS, chain_case, run_cases
from ..scaffold import MASS as MAGNET_MASS
from ..scaffold import R0 as MAGNET_R0

NAME = "harmonic"
VELOCITIES = (0.05, 0.1, 0.2, 0.4)  # m/s; the chain has no contact, and at u_p / c0 = 0.25 gaps shrink by ~30 %
QUICK = ((VELOCITIES[0], VELOCITIES[-1]), 300.0)  # u_p values (m/s), run length (ms)
PARTICLES = 120
WAKE_PARTICLE = 5  # site index: magnet 6


def _decay_exponent(t, dv, t_range):
    """Slope of log max|dv| against log t over windows of one oscillation period in t_range."""
    omega = np.sqrt(MAGNET_STIFFNESS / MAGNET_MASS)
    period = np.pi / omega  # the wake oscillates at the band edge, 2 w
    edges = np.arange(t_range[0], t_range[1], period)
    mids, amps = [], []
    for a, b in zip(edges[:-1], edges[1:]):
        sel = (t >= a) & (t < b)
        mids.append(0.5 * (a + b))
        amps.append(np.max(np.abs(dv[sel])))
    return float(np.polyfit(np.log(mids), np.log(amps), 1)[0]), np.array(mids), np.array(amps)


def run(out: Path, quick: bool = False) -> StudyResult:
    """Run this study into `out` (`quick`: its small version) and return its results; what it
    runs and measures is the module's docstring."""
    velocities, duration = QUICK if quick else (VELOCITIES, 600.0)
    omega = np.sqrt(MAGNET_STIFFNESS / MAGNET_MASS)
    c0 = MAGNET_R0 * omega
    limit = harmonic_overshoot_limit()
    plt = pyplot()
    fig, axes = plt.subplots(2, 2, figsize=(10, 7.5), layout="constrained")
    rows = []
    cases = [chain_case("harmonic", f"harmonic_up{u_p:g}", {"velocity": u_p}, duration, particles=PARTICLES,
                        output=0.5) for u_p in velocities]
    for u_p, (summary, traj) in zip(velocities, run_cases(cases, out / NAME)):
        n = np.arange(PARTICLES - 30)  # far from the held end's reflection
        exact = harmonic_piston_velocity(n, traj.t, u_p, omega)
        err = np.abs(traj.v[:, n] - exact) / u_p
        peaks = traj.v.max(axis=0) / u_p
        # a first peak counts once it is 10 ms behind the run's end (it has passed)
        passed = np.flatnonzero((np.argmax(traj.v, axis=0) < len(traj.t) - 1 - round(10.0 / (traj.t[1] - traj.t[0])))
                                & (peaks > 1.0))
        last = int(passed[passed < len(n)][-1])
        window = (0.3 * duration, duration)
        exponent, mids, amps = _decay_exponent(traj.t, traj.v[:, WAKE_PARTICLE] - u_p, window)
        exponent_exact = _decay_exponent(traj.t, exact[:, WAKE_PARTICLE] - u_p, window)[0]
        rows.append({
            "u_p_m_per_s": u_p,
            "max_error_magnets_2_31_over_u_p": float(err[:, 1:31].max()),
            "max_error_all_over_u_p": float(err.max()),
            "front_speed_V_P_m_per_s": summary["shock_velocity_plateau_m_per_s"]["mean"],
            "first_peak_over_u_p_magnet_31": float(peaks[30]),
            "first_peak_over_u_p_exact_magnet_31": float(exact[:, 30].max() / u_p),
            "last_magnet_with_first_peak": number(last),
            "first_peak_over_u_p_there": float(peaks[last]),
            "first_peak_over_u_p_exact_there": float(exact[:, last].max() / u_p),
            "wake_decay_exponent_magnet_6": exponent,
            "wake_decay_exponent_magnet_6_exact": exponent_exact,
        })
        axes[0, 1].semilogy(traj.t, np.maximum(err.max(axis=1), 1e-12), lw=0.8, label=f"$u_p$ = {u_p:g} m/s")
        axes[1, 0].plot(passed[1:] + 1, peaks[passed[1:]], ".", ms=3, label=f"$u_p$ = {u_p:g}")
        axes[1, 1].loglog(mids, amps / u_p, "o", ms=3, label=f"$u_p$ = {u_p:g}")
    # (a) the last run, point by point
    for k in (1, 10, 30, 60):
        if k < len(n):
            axes[0, 0].plot(traj.t, traj.v[:, k] / u_p, ".", ms=1.5, label=f"magnet {k + 1} (LAMMPS)")
            axes[0, 0].plot(traj.t, exact[:, k] / u_p, "k-", lw=0.5, label="exact" if k == 1 else None)
    axes[0, 0].set(xlabel="t (ms)", ylabel="$v_n / u_p$", title=f"against the exact chain, $u_p$ = {u_p:g} m/s")
    axes[0, 0].legend(fontsize="x-small", markerscale=4)
    axes[0, 1].set(xlabel="t (ms)", ylabel="max$_n$ |v - exact| / $u_p$", title=f"error over magnets 1-{PARTICLES - 30}")
    axes[0, 1].legend(fontsize="small")
    n_line = np.arange(1, 90)
    t_long = np.linspace(0.0, 3 * n_line[-1] / omega, 6001)
    axes[1, 0].plot(n_line + 1, harmonic_piston_velocity(n_line, t_long, 1.0, omega).max(axis=0), "k-", lw=0.8,
                    label="exact")
    axes[1, 0].axhline(limit, color="k", ls=":", label=f"far-field limit {limit:.4f}")
    axes[1, 0].set(xlabel="magnet n", ylabel="first peak velocity / $u_p$", title="overshoot (same for every $u_p$)")
    axes[1, 0].legend(fontsize="small")
    tt = np.array([mids[0], mids[-1]])
    axes[1, 1].loglog(tt, amps[0] / velocities[-1] * (tt / tt[0]) ** -1.5, "k--", label="$t^{-3/2}$")
    axes[1, 1].set(xlabel="t (ms)", ylabel="max |$v - u_p$| / $u_p$ per period", title="the wake at magnet 6 decays")
    axes[1, 1].legend(fontsize="small")
    style_figure(fig, f"Harmonic chain (the paper's linear lattice), {PARTICLES} magnets, far end held, "
                 f"piston $u_p$, {duration:g} ms", quick=quick)
    numbers = {
        "chain": {"k_N_per_mm": MAGNET_STIFFNESS, "mass_g": MAGNET_MASS, "r0_mm": MAGNET_R0, "particles": PARTICLES,
                  "omega_rad_per_ms": omega, "duration_ms": duration, "dt_ms": 0.01},
        "c0_m_per_s": c0,
        "first_peak_far_field_limit_over_u_p": limit,
        "runs": rows,
        "max_error_magnets_2_31_over_u_p": max(r["max_error_magnets_2_31_over_u_p"] for r in rows),
    }
    table = {key: [r[key] for r in rows] for key in rows[0]}
    return StudyResult(NAME, numbers, tables={"runs": table}, figure=fig, quick=quick)
