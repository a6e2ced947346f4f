"""The disordered transition zone behind a strong shock (paper Fig. 3(d), Movie S2): between the
front and the magnets that have settled into the steady oscillation. Its width, the deepest
magnet the front reached minus the deepest settled magnet, grows with time. Magnets are
numbered from 1 (the impactor), as the paper counts (`numbering`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..serialize import jsonable
from ._common import NAN, check_history, require_positive
from .levels import PROMINENCE
from .oscillation import oscillations


def steady_onset_times(
    t,
    v,
    drive_velocity: float,
    reference: tuple[float, float],
    tolerance: float = 0.1,
    min_extrema: int = 4,
    prominence: float = PROMINENCE,
) -> np.ndarray:
    """Time each particle settles into the steady oscillation, ms, shape (N,).

    reference: (v_max, v_min), the steady oscillation's mean maximum and minimum velocity, m/s
    (e.g. from `steady_oscillation` of a particle well behind the front; for an oscillation
    that decays to rest behind the front, (V_I, V_I)). A particle has settled at the first
    velocity extremum (of `oscillations`) from which every later maximum is within
    tolerance * V_I of v_max and every later minimum within tolerance * V_I of v_min, and at
    least min_extrema extrema follow; NaN if it never settled within the record.
    """
    t, v = check_history(t, v)
    require_positive(drive_velocity=drive_velocity, tolerance=tolerance)
    v_max, v_min = reference
    onset = np.full(v.shape[1], NAN)
    for n in range(v.shape[1]):
        osc = oscillations(t, v[:, n], drive_velocity, prominence=prominence)
        times = np.concatenate((osc.max_time, osc.min_time))
        off = np.concatenate((np.abs(osc.max_velocity - v_max), np.abs(osc.min_velocity - v_min)))
        order = np.argsort(times)
        times, bad = times[order], off[order] > tolerance * drive_velocity
        if times.size == 0 or bad[-1]:
            continue
        first_good = np.flatnonzero(bad)[-1] + 1 if bad.any() else 0
        if times.size - first_good >= min_extrema:
            onset[n] = times[first_good]
    return onset


@dataclass(frozen=True)
class TransitionZone:
    """The front and the settled magnets against time (see `transition_zone`); arrays of shape
    (n_times,). time: ms; front_magnet: the deepest magnet the front reached (1-based magnet
    number, as every magnet number here; NaN before it reached any); settled_magnet: the deepest
    magnet settled by then (NaN while none has); width: their difference, magnets."""

    time: np.ndarray
    front_magnet: np.ndarray
    settled_magnet: np.ndarray

    @property
    def width(self) -> np.ndarray:
        """The transition zone's width in magnets: front magnet minus settled magnet."""
        return self.front_magnet - self.settled_magnet

    def to_dict(self) -> dict:
        """The results as a dict of plain values (JSON), units in the keys."""
        return jsonable({"time_ms": self.time, "front_magnet": self.front_magnet, "settled_magnet": self.settled_magnet,
                         "width_magnets": self.width})


def transition_zone(times, arrival, onset) -> TransitionZone:
    """Transition-zone width at the given times (ms) from the magnets' front arrival times and
    steady onset times (both ms, shape (N,), entry i magnet i + 1, NaN where never)."""
    times = np.asarray(times, dtype=float)
    arrival, onset = np.asarray(arrival, dtype=float), np.asarray(onset, dtype=float)
    if arrival.shape != onset.shape or arrival.ndim != 1:
        raise ValueError(f"onset: got shape {onset.shape}; expected {arrival.shape}, the shape of arrival")
    magnet = np.arange(1, arrival.size + 1, dtype=float)

    def deepest(event):
        with np.errstate(invalid="ignore"):
            done = event[None, :] <= times[:, None]  # NaN compares False
        return np.where(done.any(axis=1), np.max(np.where(done, magnet, 0.0), axis=1), NAN)

    return TransitionZone(times, deepest(arrival), deepest(onset))
