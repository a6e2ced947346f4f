"""The short summary of a run: the paper's headline shock measures, with units in the keys.

Magnets and gaps are numbered as the paper counts (`numbering`): magnet 1 is the impactor, gap
n lies between magnets n and n+1, and ranges are inclusive (first_gap 145, last_gap 193: gaps
145 through 193). particles_reached_by_front is the number of the farthest magnet with an
arrival: the front reached magnets 1 through it (`measures.particles_reached`; the driven
magnet 1 is among them also before a pulse's peak marks its own arrival; 0 while no magnet
has an arrival)."""

from __future__ import annotations

import logging
import math
import warnings
from itertools import islice, repeat
from operator import is_, itemgetter

import numpy as np

from . import measures
from .case import Case
from .case_measures import ChainDraws, chain_draws, linear_constants_at
from .columnar import columns, repeated, rows
from .measures.front import LINEAR_LAG
from .numbering import number

log = logging.getLogger(__name__)
# A long lattice is valid while the last free particle stays (nearly) at rest.
QUIET_FRACTION = 1e-3
# Each number keeps its decimals, and at least this many significant figures when it is small.
SIGNIFICANT = 3
# 10**k, k = -30 .. 30, raised by far more than math.log10's error (`_round`)
_PLAIN = {k: 10.0**k * (1 + 1e-9) for k in range(-30, 31)}


def summary_of(case: Case, front: measures.Front | None, max_speed: np.ndarray | None = None) -> dict:
    """Linear wave speed and frequency, shock velocity plateau, first peaks (user units).

    front: the run's front measures (`RunFolder.measures`); None without a drive.
    max_speed: each magnet's largest |v| in the run, m/s, to check that a long lattice's far
    end stayed at rest."""
    if front is None:  # no drive, no shock (e.g. the friction calibration rig)
        return {key: column[0] for key, column in _linear_part([case], chain_draws([case])).items()}
    return summaries([case], measures.stack_fronts([front]), None if max_speed is None else np.asarray(max_speed)[None])[0]


def summaries(cases, front: measures.Front, max_speed: np.ndarray | None = None,
              draws: ChainDraws | None = None, points: list | None = None) -> list[dict]:
    """`summary_of` for each of R cases of one drive (a batch), from their fronts as one Front of R
    chains (`measures.stack_fronts`) and max_speed (R, N): each the summary of the case alone,
    bit for bit (`summary_of` is a batch of one); draws: the cases' `chain_draws`, if drawn.
    points: a key per case, equal for cases that differ at most in chain.seed (a sweep's
    `Member.point`): what depends on a case but not on its draws (the fit windows) is worked
    out once per key (default: per case); V0 and f0 once per mean gap and mass."""
    return rows(summary_columns(cases, front, max_speed, draws, points))


def summary_columns(cases, front: measures.Front, max_speed: np.ndarray | None = None,
                    draws: ChainDraws | None = None, points: list | None = None, same: dict | None = None) -> dict:
    """`summaries` as columns (`columnar.columns` of them), made a key at a time: no dict per
    member (a batch's members.json and table take them so). same: as `columnar.columns`'."""
    draws = draws or chain_draws(cases)
    points = _points(range(len(cases)) if points is None else points)
    vi = cases[0].impactor.peak_velocity()
    vp = front.accepted_velocity  # gaps out of order or below the linear speed are flagged, not averaged
    speeds = measures.trailing_plateaus(vp)
    first_peaks = measures.trailing_plateaus(front.peaks.driven_peak_velocity, over="magnet")
    reached = measures.particles_reached(front.arrival).tolist()
    positions = draws.positions
    resolutions, resolved = _resolutions(front.resolution_columns(), same)
    over_vi = _rounds(first_peaks.mean / vi, 4)
    cols = {key: columns(column, same) for key, column in _linear_part(cases, draws, points).items()}
    cols |= dict(zip(_FRONT_KEYS, (columns(reached, same), _plateaus(speeds, resolved, same),
                                   _front_speeds(cases, points, front.arrival, positions, same), _maxima(vp, same),
                                   _plateaus(first_peaks, resolved, same), columns(over_vi, same),
                                   _flags(front.flag_columns(), same), resolutions)))
    n = len(cases)
    labs, lab = _lab_speeds(cases, points, front.arrival, positions, same)
    quiet = _far_end_quiet(cases, points, front, max_speed, vi)
    if labs == n:
        cols["front_speed_lab_m_per_s"] = lab
    if len(quiet) == n:
        cols["far_end_quiet"] = columns([quiet[r] for r in range(n)], same)
    if labs in (0, n) and len(quiet) in (0, n):
        return {"cols": cols}
    out = rows({"cols": cols})  # summaries of unequal keys (points with and without L, or a long far end)
    for row, value in zip(out, rows(lab)) if 0 < labs < n else ():
        if value is not None:
            row["front_speed_lab_m_per_s"] = value
    for r, value in quiet.items() if 0 < len(quiet) < n else ():
        out[r]["far_end_quiet"] = value
    return columns(out, same)


def _far_end_quiet(cases, points: list[list[int]], front: measures.Front, max_speed, vi: float) -> dict[int, bool]:
    """`far_end_quiet` of each case of a long lattice (with max_speed), by row: whether its last
    free magnet stayed below the noise level (a warning where it did not)."""
    out = {}
    loud: list[tuple[int, float]] = []  # (magnet, speed) of each case whose last free magnet moved
    for rows_ in points:  # (a point's cases share their far end)
        case = cases[rows_[0]]
        if case.chain.far_end != "long" or max_speed is None:
            continue
        last_free = min(case.held()) - 1  # 0-based
        noises = np.broadcast_to(front.noise, len(cases))
        for r in rows_:
            last = float(max_speed[r, last_free])
            out[r] = bool(last <= measures.levels.level(QUIET_FRACTION, vi, float(noises[r])))
            if not out[r]:
                loud.append((number(last_free), last))
    if len(cases) == 1 and loud:
        log.warning("long lattice too short: magnet %d moved at %.3g m/s; results may include a reflection", *loud[0])
    elif loud:  # a batch: one line for all (far_end_quiet in each member's row)
        log.warning("long lattice too short in %d of %d chains: magnet %s moved at up to %.3g m/s; their results may "
                    "include a reflection (far_end_quiet false in their rows)", len(loud), len(cases),
                    "/".join(map(str, sorted({m for m, _ in loud}))), max(s for _, s in loud))
    return out


# A summary's front measures, in its order; shock_velocity_max_m_per_s: with friction V_P peaks
# early and decays (Fig. S6), where and how high
_FRONT_KEYS = ("particles_reached_by_front", "shock_velocity_plateau_m_per_s", "front_speed_m_per_s",
               "shock_velocity_max_m_per_s", "first_peak_velocity_plateau_m_per_s", "first_peak_velocity_over_V_I",
               "front_flags", "front_resolution")


def front_window(case: Case) -> tuple[int, int] | None:
    """The gaps (first, last; 1-based, inclusive) over which `front_speed_m_per_s` is fitted,
    from the case alone, so that every member of an ensemble point shares them: the second half
    of the gaps that a wave at (1 - LINEAR_LAG) times the nominal linear speed V0 crosses in the
    run, from gap 2 (gap 1 is the drive's rise) to the last gap between free magnets. A front
    is never slower than linear waves, so any front that keeps going crosses the whole window.
    None when the window would hold fewer than 2 gaps."""
    r0 = float(np.mean(case.chain.r0))
    v0 = linear_constants_at(case.force, r0, float(np.mean(case.chain.mass)))[0]
    last = min(int((1 - LINEAR_LAG) * v0 * case.run.duration / r0), min(case.held()) - 1)
    first = max(2, math.ceil(last / 2))
    return (first, last) if last > first else None


def _points(keys) -> list[list[int]]:
    """The rows of the cases grouped by their point keys, in order of first appearance."""
    keys = list(keys)
    if keys and keys.count(keys[0]) == len(keys):  # one point (a sweep's task): at C speed
        return [list(range(len(keys)))]
    groups: dict = {}
    for r, key in enumerate(keys):
        groups.setdefault(key, []).append(r)
    return list(groups.values())


def _front_speeds(cases, points: list[list[int]], arrival: np.ndarray, positions: np.ndarray,
                  same: dict | None = None) -> dict:
    """`front_speed_m_per_s` of each case, as columns: V_P from the slope of the arrival times
    against the initial positions (R, N) over `front_window` (no plateau criterion, so defined for
    every chain whose front crossed the window; value null where it did not), with its standard
    error and window; null for a case without a window."""
    arrival = np.atleast_2d(arrival)
    by_window: dict[tuple[int, int], list[int]] = {}
    for rows_ in points:
        window = front_window(cases[rows_[0]])
        if window is not None:
            by_window.setdefault(window, []).extend(rows_)
    fits = {}
    for (first, last), rows_ in by_window.items():
        speed, stderr = measures.fit_front_speeds(arrival[rows_], positions[rows_], first, last + 1)
        fits[first, last] = rows_, _fitted(speed.tolist()), _fitted(stderr.tolist())
    if len(fits) == 1 and len(next(iter(fits.values()))[0]) == len(cases):  # one window for all (a sweep's task)
        [((first, last), (rows_, speeds, errors))] = fits.items()
        order = np.argsort(rows_, kind="stable").tolist() if rows_ != sorted(rows_) else None
        if order is not None:
            speeds, errors = [speeds[k] for k in order], [errors[k] for k in order]
        n = len(cases)
        return {"cols": {"value": columns(speeds, same), "stderr": columns(errors, same),
                         "first_gap": repeated(first, n, same), "last_gap": repeated(last, n, same)}}
    out: list[dict | None] = [None] * len(cases)
    for (first, last), (rows_, speeds, errors) in fits.items():
        for r, v, e in zip(rows_, speeds, errors):
            out[r] = {"value": v, "stderr": e, "first_gap": first, "last_gap": last}
    return columns(out, same)


def lab_window(case: Case) -> tuple[int, int] | None:
    """The magnets (first, last; 1-based, inclusive) over which `front_speed_lab_m_per_s` is
    fitted: from magnet 2 (magnet 1's arrival is the drive's) over the first half of the gaps,
    where an x-t image's arrow drawn from the impacted end spans (Fig. 1(b): magnets 2-12 of 21).
    None when that holds fewer than 3 magnets (a chain of under 5), too few for a slope and its error."""
    last = 2 + (case.chain.particles - 1) // 2
    return (2, last) if last >= 4 else None


def _lab_speeds(cases, points: list[list[int]], arrival: np.ndarray, positions: np.ndarray,
                same: dict | None = None) -> tuple[int, dict]:
    """`front_speed_lab_m_per_s` of each case that gives chain.magnet_length L: the front speed
    over magnet centres, as an x-t image of the magnets shows it (pitch r0 + L, where the model's
    r0 is the gap between faces), fitted over `lab_window`, with the gap-frame speed over the
    same magnets beside it (value null where the front did not cross the window); None without L.
    positions (R, N): the initial positions, x_1 = 0, the gaps between faces. Returns how many
    cases have one, and the column of all (`columnar.columns`)."""
    arrival = np.atleast_2d(arrival)
    parts = []
    for rows_ in points:
        case = cases[rows_[0]]
        length, window = case.chain.magnet_length, lab_window(case)
        if length is None or window is None:
            continue
        first, last = window
        x = positions[rows_]
        centres = x + length * np.arange(x.shape[1])
        # the centres' fits and the gaps' in one call (each row is fitted alone)
        speed, error = measures.fit_front_speeds(np.concatenate([arrival[rows_]] * 2), np.concatenate([centres, x]),
                                                 first, last)
        k = len(rows_)
        pitch = np.mean(np.diff(centres, axis=1), axis=1)
        parts.append((rows_, [first, last], (_fitted(speed[:k].tolist()), _fitted(error[:k].tolist()),
                                             _fitted(speed[k:].tolist()), _rounds(pitch.tolist(), 6))))
    n = len(cases)
    if len(parts) == 1 and parts[0][0] == list(range(n)):  # one point, all of the cases (a sweep's task)
        [(_, magnets, (lab, e, gap, p))] = parts
        return n, {"cols": {"value": columns(lab, same), "stderr": columns(e, same),
                            "gap_frame_m_per_s": columns(gap, same), "magnets": repeated(magnets, n, same),
                            "pitch_mm": columns(p, same)}}
    out: list[dict | None] = [None] * n
    for rows_, magnets, values in parts:
        for r, lab, e, gap, p in zip(rows_, *values):
            out[r] = {"value": lab, "stderr": e, "gap_frame_m_per_s": gap, "magnets": list(magnets), "pitch_mm": p}
    return sum(len(part[0]) for part in parts), columns(out, same)


def _linear_part(cases, draws: ChainDraws, points: list[list[int]] | None = None) -> dict[str, list]:
    """The part of each summary without a front, as columns (key: a value per case): the case,
    N, V_I and the linear V0 and f0 (computed once for chains of equal mean gap and mass);
    points: the rows grouped by `_points` (cases that differ at most in chain.seed share all
    but V0 and f0's means)."""
    n = len(cases)
    out: dict[str, list] = {key: [None] * n for key in _LINEAR_KEYS}
    r0s, masses = np.mean(draws.gaps, axis=1).tolist(), np.mean(draws.masses, axis=1).tolist()
    for rows_ in points or _points(range(n)):
        case = cases[rows_[0]]
        keys = list(zip(map(r0s.__getitem__, rows_), map(masses.__getitem__, rows_)))
        done = {key: linear_constants_at(case.force, *key) for key in dict.fromkeys(keys)}
        done = {key: (_round(v0, 6), _round(f0, 4)) for key, (v0, f0) in done.items()}
        constants = list(map(done.__getitem__, keys))
        parts = (repeat(case.name), repeat(case.chain.particles), repeat(case.impactor.peak_velocity()),
                 map(itemgetter(0), constants), map(itemgetter(1), constants))
        whole = rows_ == list(range(n))  # one point (a sweep's task): whole columns
        for key, values in zip(_LINEAR_KEYS, parts):
            if whole:
                out[key] = list(islice(values, n))
            else:
                for r, value in zip(rows_, values):
                    out[key][r] = value
    return out


_LINEAR_KEYS = ("case", "particles", "impactor_peak_velocity_m_per_s", "linear_wave_speed_V0_m_per_s",
                "linear_frequency_f0_Hz")


def _maxima(vp: np.ndarray, same: dict | None = None) -> dict:
    """Largest V_P of each chain, vp (R, N-1), and the gap where it occurs (gap n between magnets
    n and n+1); None for a chain without any. As columns (`columnar.columns`)."""
    found = np.isfinite(vp).any(axis=1)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # all-NaN rows: no maximum (None)
        top, where = np.nanmax(vp, axis=1).tolist(), np.nanargmax(np.where(found[:, None], vp, 0.0), axis=1).tolist()
    if found.all():
        return {"cols": {"value": columns(_rounds(top, 5), same), "gap": columns(list(map(number, where)), same)}}
    return columns([{"value": v, "gap": number(i)} if ok else None
                    for v, i, ok in zip(_rounds(top, 5), where, found.tolist())], same)


def _flags(flags: dict[str, list], same: dict | None = None) -> dict:
    """The flagged gaps of each chain (`Front.flag_columns`: out of order, below the slowest
    linear speed), as counts and gap numbers; as columns (`columnar.columns`)."""
    counts = {"out_of_order": columns(list(map(len, flags["out_of_order_gaps"])), same),
              "below_linear_speed": columns(list(map(len, flags["below_linear_speed_gaps"])), same)}
    return {"cols": counts | _floats_rounded(flags, 6, same)}


def _resolutions(resolutions: dict[str, list], same: dict | None = None) -> tuple[dict, list[bool]]:
    """`Front.resolution_columns`, rounded, with each chain's `source`: "engine record" (the
    engine's arrivals of every step, sample_interval_ms 0) or "frames" (read from frames
    sample_interval_ms apart), and a warning when the frames are too coarse for the gaps. As
    columns (`columnar.columns`), and whether each chain's arrivals are resolved."""
    resolved = resolutions["resolved"]
    for r in [r for r, ok in enumerate(resolved) if not ok] if not all(resolved) else ():
        log.warning("arrival times from frames every %.3g ms, %.2g per gap crossing (%.3g ms): V_P and the first "
                    "peaks are not resolved and not reported as converged; set run.output_interval <= %.3g ms "
                    "or output.front = true (the engine's record of every step)",
                    *(resolutions[key][r] for key in ("sample_interval_ms", "frames_per_gap", "gap_crossing_time_ms",
                                                      "max_sample_interval_ms")))
    sources = ["engine record" if interval == 0 else "frames" for interval in resolutions["sample_interval_ms"]]
    return {"cols": _floats_rounded(resolutions, 6, same) | {"source": columns(sources, same)}}, resolved


def _floats_rounded(cols: dict[str, list], decimals: int, same: dict | None = None) -> dict:
    """Columns (a list per key) with their floats `_round`ed, their other values as they are, a
    column at a time (`_rounds`; a column of one value n times rounded once), each as
    `columnar.columns`."""
    out = {}
    for key, values in cols.items():
        first = values[0] if values else None
        if values and all(map(is_, values, repeat(first))):
            out[key] = repeated(_round(first, decimals) if isinstance(first, float) else first, len(values), same)
            continue
        floats = [issubclass(kind, float) for kind in set(map(type, values))]
        out[key] = columns(_rounds(values, decimals) if all(floats) else values if not any(floats)
                           else [_round(v, decimals) if isinstance(v, float) else v for v in values], same)
    return out


def _plateaus(plateaus: measures.Plateaus, resolved: list[bool], same: dict | None = None) -> dict:
    """Each plateau as JSON (its chain's arrival times `resolved` or not), its window as
    first_gap, last_gap (or first_magnet, last_magnet). trend: "steady" when converged (drift
    within 1 %, or 3 standard errors, and a scatter within 20 % of the mean), else "decaying"
    (e.g. V_P with friction) or "growing": a drifting mean is not a plateau; "unresolved" (never
    converged) when the arrival times come from frames too coarse for the gaps (`resolved`
    False; see `front_resolution`). Null, like the numbers, when the series has too few values.
    As columns (`columnar.columns`), the numbers rounded and convergence judged a column at a time."""
    numbers = [_rounds(getattr(plateaus, f), 5) for f in ("mean", "std", "drift", "drift_stderr")]
    defined = np.isfinite(plateaus.mean)
    converged = (defined & np.asarray(resolved, dtype=bool) & plateaus.converged()).tolist()
    falling = (plateaus.drift < 0).tolist()
    trends = [None if not known else "unresolved" if not ok else "steady" if steady else "decaying" if down else "growing"
              for ok, known, steady, down in zip(resolved, defined.tolist(), converged, falling)]
    keys = ("mean", "std", "relative_drift", "relative_drift_stderr", "converged", "trend", f"first_{plateaus.over}",
            f"last_{plateaus.over}")
    return {"cols": {key: columns(list(values), same)
                     for key, values in zip(keys, (*numbers, converged, trends, plateaus.first, plateaus.last))}}


def _fitted(xs: list[float]) -> list[float | None]:
    """Fitted front speeds or their errors, m/s, to 5 decimals; None (JSON null, as summary.json
    reads back) where the front did not cross the window."""
    out = _rounds(xs, 5)
    missing = ~np.isfinite(np.asarray(xs, dtype=float))
    for k in np.flatnonzero(missing).tolist() if missing.any() else ():
        out[k] = None
    return out


def _rounds(xs: list[float], decimals: int) -> list[float]:
    """`_round` of each of some floats (a batch's column): `rounds` where `decimals` keeps enough
    figures, `_round` for the small ones."""
    a = np.asarray(xs, dtype=float)
    with np.errstate(invalid="ignore"):
        small = ~((np.abs(a) > _PLAIN.get(SIGNIFICANT - 1 - decimals, math.inf)) | (a == 0) | ~np.isfinite(a))
    out = rounds(a, decimals)
    for k in np.flatnonzero(small).tolist():
        out[k] = _round(xs[k], decimals)
    return out


def rounds(xs, decimals: int) -> list[float]:
    """round(float(x), decimals) of each x (a list or array of numbers), bit for bit, with array
    operations where they give its bits (`_decimals_rounded`), `round` for the rest."""
    a = np.asarray(xs, dtype=float)
    out, exact = _decimals_rounded(a, decimals)
    out = out.tolist()
    for k in np.flatnonzero(~exact).tolist():
        out[k] = round(float(a[k]), decimals)
    return out


def _decimals_rounded(a: np.ndarray, decimals: int) -> tuple[np.ndarray, np.ndarray]:
    """round(x, decimals) of each x in `a` where `exact` says so, at C speed: rint(x 10^d) / 10^d.
    Python's round is the double nearest to R 10^-d, R the exact x 10^d rounded half to even;
    for d <= 22 (10^d exact) and |x 10^d| < 2^52, rint of the product (within |y| 2^-53 of x 10^d)
    is R wherever the product lies farther than that from a half, and the division of the
    exact R by the exact 10^d is the nearest double: the same bits. Elsewhere (ties, near-ties,
    non-finite or huge products) `exact` is False."""
    if not 0 <= decimals <= 22:
        return a, np.zeros(a.shape, bool)
    scale = 10.0**decimals
    with np.errstate(invalid="ignore", over="ignore"):
        y = a * scale
        exact = (np.abs(y) < 2.0**52) & (np.abs(y - np.floor(y) - 0.5) > np.abs(y) * 2.0**-51)
    return np.rint(y) / scale, exact


def _round(x: float, decimals: int, significant: int = SIGNIFICANT) -> float:
    """x to `decimals` decimals, or more where that would keep fewer than `significant` figures:
    a small number (a drift's standard error of 1e-6) stays a number, not 0."""
    x = float(x)  # numpy's round of an np.float64 multiplies by 10**n: a subnormal becomes NaN
    # math, not numpy: a summary rounds some 20 numbers per member. Where |x| is above 10**k
    # (k = significant - 1 - decimals) by more than log10's error, `decimals` keeps enough figures:
    # as below, without the logarithm (inf too)
    if abs(x) > _PLAIN.get(significant - 1 - decimals, math.inf) or x == 0 or not math.isfinite(x):
        return round(x, decimals)
    digits = significant - 1 - math.floor(math.log10(abs(x)))
    return round(x, digits if digits > decimals else decimals)
