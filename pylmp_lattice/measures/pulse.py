"""Pulses on a chain's gaps: a solitary pulse's speed, the leading pulse of a piston problem,
and the period-two (staggered) pattern behind it. Pure functions of arrays.

A pulse is given as a positive amplitude per gap, w (n_frames, N-1): for the Toda lattice
w = exp(-r) - 1 (r = gap - a, its force in units of A), for a power law the force. t in ms (or
the chain's time unit), speeds in sites per unit time. Gaps are numbered from 1 (gap n between
magnets n and n+1, `numbering`); column i of w is gap i + 1.
"""

from __future__ import annotations

import numpy as np

from ..numbering import entries


def centroid_speed(t, w, gaps: tuple[int, int]) -> float:
    """Sites per unit time from the time centroids of w at gaps gaps[0] .. gaps[1] (1-based,
    inclusive): for a pulse of constant shape, the centroid moves at the pulse's speed exactly."""
    idx = np.arange(gaps[0], gaps[1] + 1)
    w = np.asarray(w, float)[:, entries(*gaps)]
    arrival = (np.asarray(t, float)[:, None] * w).sum(axis=0) / w.sum(axis=0)
    return float(1.0 / np.polyfit(idx, arrival, 1)[0])


def lead_pulse(t, w, skip: int = 21, settle: float = 5.0) -> tuple[float, float]:
    """Speed (sites per unit time) and height (of w) of the leading pulse: the time of the
    largest w at each gap after the first `skip` (refined by a parabola through three frames), fitted
    over the later half of the gaps it has passed `settle` time units before the run's end
    (and reached: a peak above 5 % of the largest); height: the mean peak over the last five of
    those gaps."""
    t, w = np.asarray(t, float), np.asarray(w, float)
    peak = np.argmax(w, axis=0)
    passed = peak < np.searchsorted(t, t[-1] - settle)
    reached = w.max(axis=0) > 0.05 * w.max()  # not round-off ahead of the front
    n = np.flatnonzero((np.arange(w.shape[1]) >= skip) & (peak > 0) & passed & reached)
    i = peak[n]
    y0, y1, y2 = w[i - 1, n], w[i, n], w[i + 1, n]
    tp = t[i] + (t[1] - t[0]) * 0.5 * (y0 - y2) / (y0 - 2 * y1 + y2)
    half = len(n) // 2
    return float(1.0 / np.polyfit(n[half:], tp[half:], 1)[0]), float(np.mean(y1[-5:]))


def staggered_amplitude(t, r, t_end: float, gaps: int = 6, span: float = 10.0) -> float:
    """Largest |r_(n+1) - r_n| over the first `gaps` gaps in the `span` time units before
    t_end: the period-two component next to the piston (r: gaps or strains, (n_frames, N-1))."""
    t = np.asarray(t, float)
    sel = (t > t_end - span) & (t <= t_end)
    return float(np.max(np.abs(np.diff(np.asarray(r, float)[sel, :gaps], axis=1))))
