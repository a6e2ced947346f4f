"""The measures and figure of a constant drive on the long lattice: Fig. 3's panels, shared by
`fig3` (the magnet chain) and `s5` (the linear lattice).

(a) a typical velocity profile; (b) propagation velocity V_P along the chain (per gap and
centred); (c) first peak velocity and acceleration; (d) velocity maxima and minima against time
for several particles; (e) the oscillation frequency from them; and (f, ours) the width of the
disordered transition zone against time. Magnets and gaps are numbered from 1, as the paper
counts (`numbering`); arrays are 0-based (column n - 1 is magnet n).
"""

from __future__ import annotations

import numpy as np

from .. import measures
from ..numbering import number
from ..plots import pyplot, separate, style_figure, twin_axis
from .output import StudyResult
from .scaffold import linear_constants, pick

TRACKED = (2, 5, 10, 25, 50, 100, 150)  # magnets whose extrema are drawn
STEADY = (5, 10, 20)  # magnets well behind the front at the end
# how close (in V_I) a magnet's extrema must stay to magnet 10's steady ones to count as
# settled: the zone's growth rate depends on it, so it is reported for each
TOLERANCES = (0.2, 0.1, 0.05, 0.02)
TOLERANCE = 0.1  # the one drawn and tabled


def analyse(name, what, traj, case, vi, duration, quick, zone=True) -> StudyResult:
    """Fig. 3's measures and figure for a constant-drive run (also the linear lattice's, S5);
    `zone`: measure the transition zone (settling into magnet 10's steady oscillation)."""
    v0, f0 = linear_constants(case)
    t, v, a = traj.t, traj.v, traj.a
    gaps = case.chain.gaps()
    front = measures.front(t, v, a, vi, gaps)
    reached = measures.particles_reached(front.arrival)
    centred = measures.centred_propagation_velocity(front.arrival, gaps)
    plateau = measures.trailing_plateau(front.accepted_velocity)
    # gaps first .. last lie between magnets first .. last + 1
    fit = measures.fit_propagation_velocity(front.arrival, case.chain.positions(), plateau.first, plateau.last + 1)
    peaks = front.peaks
    first_peak = measures.trailing_plateau(peaks.driven_peak_velocity, over="magnet")
    window = (0.8 * duration, duration)
    steady = {n: measures.steady_oscillation(t, v[:, n - 1], vi, window) for n in STEADY}
    tracked = pick(TRACKED, reached)
    osc = {n: measures.oscillations(t, v[:, n - 1], vi) for n in tracked}

    # transition zone: settled = within a tolerance of magnet 10's steady maxima and minima
    ref = steady[10]
    zones = {}
    if zone and ref.measured:
        # up to 0.9 T: a particle settling later cannot show the extrema that confirm it
        times = np.arange(0.1 * duration, 0.9 * duration + 1e-9, duration / 20)
        for tol in TOLERANCES:
            onset = measures.steady_onset_times(t, v[:, :reached], vi, (ref.max_velocity, ref.min_velocity), tol)
            zones[tol] = measures.transition_zone(times, front.arrival[:reached], onset)
    zone = zones.get(TOLERANCE)

    numbers = {
        "V_I_m_per_s": vi,
        "duration_ms": duration,
        "particles": case.chain.particles,
        "particles_reached": reached,
        "V0_m_per_s": v0,
        "f0_Hz": f0,
        "V_P_plateau_m_per_s": plateau,
        "V_P_fitted_over_plateau_window": fit,
        "V_P_max_m_per_s": float(np.nanmax(front.accepted_velocity)),  # the front's: no drive gap, no flagged gap
        "first_peak_max_m_per_s": float(np.nanmax(peaks.peak_velocity[1:])),
        "first_peak_plateau_m_per_s": first_peak,
        "first_peak_plateau_over_V_I": first_peak.mean / vi,
        "first_particle_with_first_peak_at_least_3.87_m_per_s": _first_at_least(peaks.driven_peak_velocity, 3.87),
        "first_peak_acceleration_max_m_per_s2": float(np.nanmax(peaks.peak_acceleration[1:])),
        "steady_oscillation_window_ms": list(window),
        "steady_oscillation": {f"n={n}": s.to_dict() | {"f_over_f0": s.frequency / f0} for n, s in steady.items()},
        "transition_zone_tolerance_over_V_I": TOLERANCE,
        "transition_zone": zone,
        "transition_zone_growth_particles_per_ms": _growth(zone),
        "transition_zone_growth_by_tolerance_particles_per_ms": {f"{tol:g}": _growth(z) for tol, z in zones.items()},
    }
    tables = {
        "particles": {
            "n": np.arange(1, v.shape[1] + 1),
            "arrival_ms": front.arrival,
            "V_P_gap_n_to_n+1_m_per_s": np.append(front.propagation_velocity, np.nan),
            "V_P_centred_m_per_s": centred,
            "first_peak_velocity_m_per_s": peaks.peak_velocity,
            "first_peak_acceleration_m_per_s2": peaks.peak_acceleration,
            "rise_time_ms": peaks.rise_time,
        },
        "extrema": _extrema_table(osc),
    }
    if zone is not None:
        tables["transition_zone"] = zone.to_dict()
    fig = figure(traj, vi, v0, f0, front, centred, osc, zones, reached, what, quick)
    return StudyResult(name, numbers, tables=tables, figure=fig, quick=quick)


def figure(traj, vi, v0, f0, front, centred, osc, zones, reached, what, quick):
    """Panels (a-c) on the top row, (d-f) below, lettered in reading order."""
    plt = pyplot()
    fig, ax = plt.subplots(2, 3, figsize=(15, 8.5), layout="constrained")
    typical = min(49, reached // 2)  # magnet 50 as in the paper, or one the front passed long ago
    ax[0, 0].plot(traj.t, traj.v[:, typical], lw=0.7, label=f"magnet {typical + 1}")
    ax[0, 0].axhline(vi, color="k", ls=":", lw=0.8, label=f"$V_I$ = {vi:g} m/s")
    ax[0, 0].set(title="velocity profile", xlabel="t (ms)", ylabel="v (m/s)")
    ax[0, 0].legend(fontsize="small", loc="upper left")
    n = np.arange(1, len(front.arrival) + 1)
    ax[0, 1].plot(n[:-1] + 0.5, front.accepted_velocity, ".", ms=3, label="per gap")
    ax[0, 1].plot(n, centred, "-", lw=0.8, label="centred")
    ax[0, 1].axhline(v0, color="k", ls=":", lw=1, label=f"$V_0$ = {v0:.3f} m/s")
    ax[0, 1].set(title="propagation velocity", xlabel="magnet n (gap n at n + 1/2)", ylabel="$V_P$ (m/s)", xlim=(0, reached + 1))
    ax[0, 1].legend(fontsize="small")
    peaks = front.peaks
    left = ax[0, 2].plot(n, peaks.peak_velocity, "o", ms=2.5, color="C0", label="velocity (left)")
    ax[0, 2].set(title="first peaks", xlabel="magnet n", ylabel="first peak velocity (m/s)", xlim=(0, reached + 1))
    right = twin_axis(ax[0, 2], "first peak acceleration (m/s$^2$)")
    left += right.plot(n, peaks.peak_acceleration, "s", ms=2, mfc="none", color="C3", label="acceleration (right)")
    separate(ax[0, 2], right, peaks.peak_velocity, peaks.peak_acceleration)
    ax[0, 2].legend(handles=left, fontsize="small", loc="center right")
    for k, (p, o) in enumerate(osc.items()):  # a magnet without extrema yet (a short run) has no entry
        if len(o.max_time) or len(o.min_time):
            ax[1, 0].plot(o.max_time, o.max_velocity, "^", ms=2.5, color=f"C{k}", label=f"n = {p}")
            ax[1, 0].plot(o.min_time, o.min_velocity, "v", ms=2.5, color=f"C{k}")
        if len(o.frequency_time):
            ax[1, 1].plot(o.frequency_time, o.frequency / f0, ".-", ms=2.5, lw=0.6, color=f"C{k}", label=f"n = {p}")
    ax[1, 0].plot([], [], "^", color="0.4", label="maxima")
    ax[1, 0].plot([], [], "v", color="0.4", label="minima")
    ax[1, 0].set(title="velocity maxima and minima", xlabel="t (ms)", ylabel="peak velocity (m/s)")
    ax[1, 0].legend(fontsize="x-small", ncol=2)
    ax[1, 1].set(title="oscillation frequency", xlabel="t (ms)", ylabel="$f/f_0$")
    ax[1, 1].legend(fontsize="x-small", ncol=2)
    if zones:
        zone = zones[TOLERANCE]
        ax[1, 2].plot(zone.time, zone.front_magnet, label="front")
        ax[1, 2].plot(zone.time, zone.settled_magnet, label=f"settled (within {TOLERANCE:g} $V_I$)")
        ax[1, 2].plot(zone.time, zone.width, label=f"width (settled within {TOLERANCE:g} $V_I$)")
        for k, (tol, other) in enumerate((t, z) for t, z in zones.items() if t != TOLERANCE):
            # a colour and a marker each: told apart in print and in grey
            ax[1, 2].plot(other.time, other.width, "--" + "osd"[k], ms=3, lw=0.9, color=f"C{3 + k}",
                          label=f"width (within {tol:g} $V_I$)")
        ax[1, 2].legend(fontsize="x-small")
    ax[1, 2].set(title="transition zone", xlabel="t (ms)", ylabel="magnet n, or width (magnets)")
    return style_figure(fig, what, quick=quick)


def _first_at_least(values, level):
    """The number of the first magnet whose value reaches `level` (None if none)."""
    hit = np.flatnonzero(values >= level)
    return number(hit[0]) if hit.size else None


def _growth(zone):
    """Least-squares slope of the transition zone's width against time, particles/ms."""
    if zone is None:
        return None
    ok = np.isfinite(zone.width)
    return float(np.polyfit(zone.time[ok], zone.width[ok], 1)[0]) if ok.sum() >= 3 else None


def _extrema_table(osc):
    rows = [(p, kind, tt, vv) for p, o in osc.items()
            for kind, ts, vs in (("max", o.max_time, o.max_velocity), ("min", o.min_time, o.min_velocity))
            for tt, vv in zip(ts, vs)]
    rows.sort(key=lambda r: (r[0], r[2]))
    return {"n": [r[0] for r in rows], "kind": [r[1] for r in rows], "time_ms": [r[2] for r in rows],
            "velocity_m_per_s": [r[3] for r in rows]}
