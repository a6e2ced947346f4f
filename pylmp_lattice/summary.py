"""The short summary of a run: the paper's headline shock measures, with units in the keys.

Magnets and gaps are numbered as the paper counts (`numbering`): magnet 1 is the impactor, gap
n lies between magnets n and n+1, and ranges are inclusive (first_gap 145, last_gap 193: gaps
145 through 193)."""

from __future__ import annotations

import logging

import numpy as np

from . import measures
from .case import Case
from .numbering import number

log = logging.getLogger(__name__)
# A long lattice is valid while the last free particle stays (nearly) at rest.
QUIET_FRACTION = 1e-3


def summarize(case: Case, front: measures.Front | None, max_speed: np.ndarray | None = None) -> dict:
    """Linear wave speed and frequency, shock velocity plateau, first peaks (user units).

    front: the run's front measures (`RunFolder.measures`); None without a drive.
    max_speed: each magnet's largest |v| in the run, m/s, to check that a long lattice's far
    end stayed at rest."""
    chain, vi = case.chain, case.impactor.peak_velocity()
    v0, f0 = linear_chain(case)
    out = {
        "case": case.name,
        "particles": chain.particles,
        "impactor_peak_velocity_m_per_s": vi,
        "linear_wave_speed_V0_m_per_s": round(v0, 6),
        "linear_frequency_f0_Hz": round(f0, 4),
    }
    if front is None:  # no drive, no shock (e.g. the friction calibration rig)
        return out
    vp = front.accepted_velocity  # gaps out of order or below the linear speed are flagged, not averaged
    speed = measures.trailing_plateau(vp)
    first_peak = measures.trailing_plateau(front.peaks.driven_peak_velocity, over="magnet")
    resolution = _resolution(front)
    out |= {
        "particles_reached_by_front": int(np.sum(np.isfinite(front.arrival))),
        "shock_velocity_plateau_m_per_s": _plateau(speed, resolution["resolved"]),
        # with friction V_P peaks early and decays (Fig. S6): where and how high
        "shock_velocity_max_m_per_s": _maximum(vp),
        "first_peak_velocity_plateau_m_per_s": _plateau(first_peak, resolution["resolved"]),
        "first_peak_velocity_over_V_I": round(first_peak.mean / vi, 4),
        "front_flags": _flags(front),
        "front_resolution": resolution,
    }
    if chain.far_end == "long" and max_speed is not None:
        last_free = min(case.held()) - 1  # 0-based
        last = float(max_speed[last_free])
        out["far_end_quiet"] = bool(last <= measures.levels.level(QUIET_FRACTION, vi, front.noise))
        if not out["far_end_quiet"]:
            log.warning("long lattice too short: magnet %d moved at %.3g m/s; results may include a reflection",
                        number(last_free), last)
    return out


def linear_chain(case: Case) -> tuple[float, float]:
    """Linear wave speed V0 (m/s) and frequency f0 (Hz) at the mean gap and mass."""
    r0 = float(np.mean(case.chain.gaps()))
    k0 = float(case.force.stiffness(r0))
    m = float(np.mean(case.chain.masses()))
    return float(measures.linear_wave_speed(k0, m, r0)), float(measures.linear_frequency(k0, m))


def _maximum(vp: np.ndarray) -> dict | None:
    """Largest V_P and the gap where it occurs (gap n between magnets n and n+1)."""
    if not np.any(np.isfinite(vp)):
        return None
    return {"value": round(float(np.nanmax(vp)), 5), "gap": number(np.nanargmax(vp))}


def _flags(front: measures.Front) -> dict:
    """The gaps flagged (out of order, below the slowest linear speed), as counts and gap numbers."""
    flags = front.flags()
    return {"out_of_order": len(flags["out_of_order_gaps"]), "below_linear_speed": len(flags["below_linear_speed_gaps"]),
            **{k: round(v, 6) if isinstance(v, float) else v for k, v in flags.items()}}


def _resolution(front: measures.Front) -> dict:
    """`Front.resolution`, rounded, with a warning when the frames are too coarse for the gaps."""
    res = front.resolution()
    if not res["resolved"]:
        log.warning("arrival times from frames every %.3g ms, %.2g per gap crossing (%.3g ms): V_P and the first "
                    "peaks are not resolved and not reported as converged; set run.output_interval <= %.3g ms "
                    "or output.front = true (the engine's record of every step)", res["sample_interval_ms"],
                    res["frames_per_gap"], res["gap_crossing_time_ms"], res["max_sample_interval_ms"])
    return {k: round(v, 6) if isinstance(v, float) else v for k, v in res.items()}


def _plateau(p: measures.Plateau, resolved: bool = True) -> dict:
    """A plateau as JSON, its window as first_gap, last_gap (or first_magnet, last_magnet).
    trend: "steady" when converged (drift within 1 %, or 3 standard errors, and a scatter within
    20 % of the mean), else "decaying" (e.g. V_P with friction) or "growing": a drifting
    mean is not a plateau; "unresolved" (never converged) when the arrival times come from
    frames too coarse for the gaps (`resolved` False; see `front_resolution`). Null, like the
    numbers, when the series has too few values."""
    defined = bool(np.isfinite(p.mean))
    converged = defined and resolved and p.converged()
    trend = (None if not defined else "unresolved" if not resolved else "steady" if converged
             else "decaying" if p.drift < 0 else "growing")
    return {
        "mean": round(p.mean, 5),
        "std": round(p.std, 5),
        "relative_drift": round(p.drift, 5),
        "relative_drift_stderr": round(p.drift_stderr, 5),
        "converged": converged,
        "trend": trend,
        f"first_{p.over}": p.first,
        f"last_{p.over}": p.last,
    }
