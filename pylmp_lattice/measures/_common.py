"""Helpers shared by the measures: input checks, level crossings, first maxima, refinement."""

from __future__ import annotations

import numbers

import numpy as np

from ..units import PER_MS_IN_HZ as HZ_PER_INV_MS

NAN = float("nan")


def check_history(t, v, single=False):
    """t as (n_frames,) strictly increasing; v as (n_frames, N), or (n_frames,) if single."""
    t = np.asarray(t, dtype=float)
    v = np.asarray(v, dtype=float)
    if t.ndim != 1 or t.size < 2:
        raise ValueError(f"t: got shape {t.shape}; expected (n_frames,) with n_frames >= 2")
    if np.any(np.diff(t) <= 0):
        raise ValueError("t: got non-increasing times; expected strictly increasing")
    if v.shape[:1] != (t.size,) or v.ndim != (1 if single else 2):
        expected = f"({t.size},)" if single else f"({t.size}, N)"
        raise ValueError(f"v: got shape {v.shape}; expected {expected}, with n_frames = len(t) first")
    return t, v


def check_noise(noise, columns: int):
    """The noise velocity sigma (m/s) as one value, or as one per column of a history (N,);
    with one column, any number of them (C,): that signal's measures against each."""
    if np.ndim(noise) == 0:
        return noise
    noise = np.asarray(noise, dtype=float)
    if noise.ndim != 1 or (columns != 1 and noise.shape != (columns,)):
        raise ValueError(f"noise: got shape {noise.shape}; expected one value or ({columns},), one per column")
    return noise


def require_positive(**values):
    """ValueError naming the first value that is not > 0 (or not finite); TypeError for one that
    is no single real number (a str, None, a bool or an array of several values). The rule of
    every physical parameter of the measures and of `theory`."""
    for name, value in values.items():
        if np.ndim(value) != 0:
            raise TypeError(f"{name}: got an array of shape {np.shape(value)}; expected one number")
        if isinstance(value, (bool, np.bool_)) or not (isinstance(value, numbers.Real) or (
                isinstance(value, np.ndarray) and value.dtype.kind in "iuf")):
            raise TypeError(f"{name}: got {value!r} ({type(value).__name__}); expected a number")
        if not (np.isfinite(value) and value > 0):
            raise ValueError(f"{name}: got {value}; expected > 0")


def require_integer(**values):
    """TypeError naming the first value that is no integer (a magnet or gap number: 10, not 10.0)."""
    for name, value in values.items():
        if isinstance(value, (bool, np.bool_)) or not isinstance(value, (numbers.Integral, np.integer)):
            raise TypeError(f"{name}: got {value!r} ({type(value).__name__}); expected an integer")


def require_window(window) -> tuple[float, float]:
    """A time window (start, end) as two floats; TypeError unless it is two numbers."""
    try:
        t_a, t_b = (float(x) for x in window)
    except (TypeError, ValueError):
        raise TypeError(f"window: got {window!r}; expected (start, end) in ms, two numbers") from None
    return t_a, t_b


def first_crossing(t, v, level):
    """Per column of v (n_frames, N), level scalar or (N,): index of the first sample with
    v >= level (len(t) if none) and the crossing time, linearly interpolated from the previous
    sample (NaN if none). One column (n_frames, 1) against levels (C,): per level, shape (C,)."""
    level = np.asarray(level, dtype=float)
    if _one_signal(v):
        # the first sample >= level is the first where the running maximum is (same index)
        i = np.searchsorted(np.maximum.accumulate(v[:, 0]), np.atleast_1d(level), side="left")
        reached = i < len(t)
        i, cols = np.where(reached, i, 0), 0
    else:
        above = v >= level
        cols = np.arange(v.shape[1])
        i = np.argmax(above, axis=0)
        reached = above[i, np.arange(above.shape[1])]
    before = np.maximum(i - 1, 0)
    v0, v1 = v[before, cols], v[i, cols]
    with np.errstate(divide="ignore", invalid="ignore"):
        # v0 < level <= v1 where i > 0, so the division is safe where it is used.
        time = t[before] + (level - v0) / (v1 - v0) * (t[i] - t[before])
    time = np.where(i == 0, t[0], time)
    return np.where(reached, i, len(t)), np.where(reached, time, np.nan)


def first_confirmed_maximum(y, i_from, drop, relative=False, floor=0.0):
    """Per column of y (n_frames, N): the first maximum at or after sample i_from[col] that is
    confirmed by a later fall of `drop` below it (absolute, or `drop` times the maximum if
    `relative`, but at least `floor`) before y exceeds it. Returns (index, confirmed): the index
    of the largest sample between i_from and the confirming fall, and whether a fall was found.
    One column (n_frames, 1) against C sets of i_from, drop, floor (arrays (C,)): per set."""
    if not _one_signal(y):
        return _confirmed(y, i_from, drop, relative, floor)[:2]
    i_from, drop, floor = np.broadcast_arrays(i_from, drop, floor)
    index, confirmed = np.zeros(i_from.shape, int), np.zeros(i_from.shape, bool)
    for start in np.unique(i_from):
        # A larger fall is confirmed no earlier: the group's smallest confirms at i_drop, and a
        # set whose own fall is also reached there has the group's maximum; the others alone.
        group = np.flatnonzero(i_from == start)
        i_max, found, i_drop, running_max = _confirmed(y, start, drop[group].min(), relative, floor[group].min())
        if not found[0]:  # no fall at all: none of the group is confirmed (index 0, as below)
            continue
        peak, top = y[i_drop[0], 0], running_max[i_drop[0], 0]
        fall = np.maximum(drop[group] * np.abs(top), floor[group]) if relative else drop[group]
        same = peak <= top - fall
        index[group[same]], confirmed[group[same]] = i_max[0], True
        for k in group[~same]:
            index[k], confirmed[k] = (x[0] for x in _confirmed(y, start, drop[k], relative, floor[k])[:2])
    return index, confirmed


def _confirmed(y, i_from, drop, relative, floor):
    """first_confirmed_maximum column by column; also the confirming fall's index and the running maximum."""
    rows = np.arange(y.shape[0])[:, None]
    behind = np.where(rows >= i_from, y, -np.inf)
    running_max = np.maximum.accumulate(behind, axis=0)  # -inf before i_from
    fall = np.maximum(drop * np.abs(running_max), floor) if relative else drop
    dropped = (y <= running_max - fall) & np.isfinite(running_max)
    confirmed = dropped.any(axis=0)
    i_drop = np.argmax(dropped, axis=0)
    return np.argmax(np.where(rows < i_drop, behind, -np.inf), axis=0), confirmed, i_drop, running_max


def window_argmax(y, lo, hi):
    """Per column of y (n_frames, N): the index of the largest sample from lo to hi (inclusive;
    0 for an empty window), lo and hi arrays (N,). One column (n_frames, 1) against windows (C,):
    per window."""
    if not _one_signal(y):
        rows = np.arange(y.shape[0])[:, None]
        return np.argmax(np.where((rows >= lo) & (rows <= hi), y, -np.inf), axis=0)
    lo, hi = np.broadcast_arrays(lo, hi)
    out = np.zeros(lo.shape, int)
    for a, b in set(zip(lo.tolist(), hi.tolist())):
        window = y[a:b + 1, 0]
        if window.size and window.max() > -np.inf:  # else all -inf, as outside: index 0
            out[(lo == a) & (hi == b)] = a + np.argmax(window)  # the first of equal maxima
    return out


def _one_signal(v) -> bool:
    """Whether v is one column without NaN (whose levels may be many: see first_crossing)."""
    return v.shape[1] == 1 and not np.isnan(v).any()


def prominent_maxima(y, min_prominence):
    """Indices of the local maxima of y (n,) with prominence >= min_prominence: the same as
    scipy.signal.find_peaks(y, prominence=min_prominence)[0] (a flat maximum counts once, at its
    middle sample; the prominence is the height above the higher of the lowest samples on each
    side before a higher one). Written here because importing scipy.signal (1.17) takes longer
    than a run of the paper's long lattice; tests/test_measures.py holds it to scipy's answer."""
    y = np.asarray(y, dtype=float)
    starts = np.flatnonzero(np.r_[True, y[1:] != y[:-1]])  # the runs of equal samples
    ends = np.r_[starts[1:] - 1, len(y) - 1]
    z = y[starts]
    k = np.flatnonzero((z[1:-1] > z[:-2]) & (z[1:-1] > z[2:])) + 1
    peaks = (starts[k] + ends[k]) // 2
    heights = y[peaks] - np.array([max(_base(y, i, -1), _base(y, i, 1)) for i in peaks])
    keep = heights >= min_prominence
    return peaks[keep]


def _base(y, i, side):
    """The lowest sample from y[i] towards `side` (-1 left, +1 right) before the first one higher
    than y[i] (or the end), searched in widening windows: a peak's base is usually near it."""
    width = 64
    while True:
        lo, hi = (max(0, i - width), i + 1) if side < 0 else (i, min(len(y), i + 1 + width))
        segment = y[lo:hi]
        higher = np.flatnonzero(segment > y[i])
        if higher.size:
            return segment[higher[-1] + 1 :].min() if side < 0 else segment[: higher[0]].min()
        if (side < 0 and lo == 0) or (side > 0 and hi == len(y)):
            return segment.min()
        width *= 4


def refine_maxima(t, y, i, cols):
    """Time and value of the maximum of y[:, cols] near sample i (arrays broadcast together):
    the vertex of the parabola through samples i-1, i, i+1 (the sample itself at either end of
    the record, or where the three samples are not concave)."""
    last = len(t) - 1
    i_prev, i_next = np.clip(i - 1, 0, last), np.clip(i + 1, 0, last)
    h1, h2 = t[i] - t[i_prev], t[i_next] - t[i]
    y0, y1, y2 = y[i_prev, cols], y[i, cols], y[i_next, cols]
    with np.errstate(divide="ignore", invalid="ignore"):
        # y = y1 + b s + c s^2 with s = time - t[i], through the three samples.
        c = ((y0 - y1) / h1 + (y2 - y1) / h2) / (h1 + h2)
        b = (y2 - y1) / h2 - c * h2
        refine = (i > 0) & (i < last) & (c < 0)
        return (
            np.where(refine, t[i] - b / (2 * c), t[i]),
            np.where(refine, y1 - b * b / (4 * c), y1),
        )
