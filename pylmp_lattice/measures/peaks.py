"""First peaks: the first velocity maximum behind the front, the largest acceleration on the
way to it, and the rise time (paper Figs. 1(c), 3(c))."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..serialize import jsonable
from ._common import (check_history, check_noise, first_confirmed_maximum, first_crossing, refine_maxima,
                      require_positive, window_argmax)
from .levels import FRONT_FRACTION, PROMINENCE, START_FRACTION, front_levels

_BLOCK_ELEMENTS = 1 << 22  # first_peaks works on column blocks of about this many samples


@dataclass(frozen=True)
class FirstPeaks:
    """First velocity peak of each particle, arrays of shape (N,) (see `first_peaks`).

    start_time: start of motion, ms; peak_time, peak_velocity: the first velocity peak, ms and
    m/s; peak_acceleration: largest acceleration from the start of motion to that peak, m/s^2.
    NaN where the particle never moved or no first peak was confirmed.
    """

    start_time: np.ndarray
    peak_time: np.ndarray
    peak_velocity: np.ndarray
    peak_acceleration: np.ndarray

    @property
    def driven_peak_velocity(self) -> np.ndarray:
        """peak_velocity with magnet 1's left out (NaN): magnet 1 is the impactor, whose motion
        is the drive, not the chain's response (plateaus of it keep the magnets' numbers)."""
        driven = np.array(self.peak_velocity, dtype=float)  # a copy (of each chain's, for R chains)
        driven[..., 0] = np.nan
        return driven

    @property
    def rise_time(self) -> np.ndarray:
        """Duration from the start of motion to the first velocity peak, ms."""
        return self.peak_time - self.start_time

    def to_dict(self) -> dict:
        """The results as a dict of plain values (JSON), units in the keys."""
        return jsonable({"start_time_ms": self.start_time, "peak_time_ms": self.peak_time,
                         "peak_velocity_m_per_s": self.peak_velocity, "peak_acceleration_m_per_s2": self.peak_acceleration,
                         "rise_time_ms": self.rise_time})


def first_peaks(
    t,
    v,
    a,
    drive_velocity: float,
    start_fraction: float = START_FRACTION,
    front_fraction: float = FRONT_FRACTION,
    prominence: float = PROMINENCE,
    noise: float = 0.0,
) -> FirstPeaks:
    """First velocity peak, first peak acceleration and start of motion of every particle.

    - Start of motion: first time v_n reaches start_fraction * V_I (interpolated, as in
      `arrival_times`).
    - First peak: the first local maximum of v_n at or after the front (the first sample with
      v_n >= front_fraction * V_I) after which v_n falls by at least prominence * V_I before
      exceeding it, i.e. the first maximum behind the front with prominence >= prominence * V_I
      in the sense of scipy.signal.find_peaks; this ignores wiggles from sampling noise. Its time
      and value are the vertex of the parabola through the discrete maximum and its two
      neighbours. NaN if no such peak is confirmed within the record.
    - First peak acceleration: max of a_n over the samples from the start of motion to the
      discrete first peak, refined by the same parabola when the largest sample has both
      neighbours inside that window.
    - Rise time (`FirstPeaks.rise_time`): peak time minus start of motion, the paper's "duration
      from zero velocity to first peak velocity" (Fig. 1(c)); zero velocity is taken as
      start_fraction * V_I so that a numerically tiny precursor does not count.

    noise: the chain's noise velocity sigma, m/s (`levels`): the start and front levels are at
    least 5 sigma, the confirming fall at least 3 sigma, so thermal motion is not a start. One
    value, or one per column (shape (N,)); for one column (n_frames, 1), any number (C,): the
    measures of that one signal against each, shape (C,) (a drive shared by C chains).
    """
    t, v = check_history(t, v)
    a = np.asarray(a, dtype=float)
    if a.shape != v.shape:
        raise ValueError(f"a: got shape {a.shape}; expected {v.shape}, the shape of v")
    require_positive(drive_velocity=drive_velocity, start_fraction=start_fraction, prominence=prominence)
    if not start_fraction <= front_fraction:
        raise ValueError(f"front_fraction: got {front_fraction}; expected >= start_fraction = {start_fraction}")
    lv = front_levels(drive_velocity, check_noise(noise, v.shape[1]), start_fraction, front_fraction, prominence)
    if v.shape[1] == 1:  # one signal, against one or many noise velocities (see check_noise)
        return FirstPeaks(*_first_peaks_block(t, v, a, lv.start, lv.front, lv.drop))
    levels = [np.broadcast_to(x, v.shape[1:]) for x in (lv.start, lv.front, lv.drop)]
    width = max(1, _BLOCK_ELEMENTS // len(t))  # bounds the temporaries for long chains
    blocks = [
        _first_peaks_block(t, v[:, j : j + width], a[:, j : j + width], *(x[j : j + width] for x in levels))
        for j in range(0, v.shape[1], width)
    ]
    return FirstPeaks(*(np.concatenate(column) for column in zip(*blocks)))


def _first_peaks_block(t, v, a, start_level, front_level, drop):
    i_start, t_start = first_crossing(t, v, start_level)
    i_front, _ = first_crossing(t, v, front_level)
    i_peak, confirmed = first_confirmed_maximum(v, i_front, drop)
    cols = np.arange(v.shape[1])
    t_peak, v_peak = refine_maxima(t, v, i_peak, cols)
    i_acc = window_argmax(a, i_start, i_peak)
    # Refine only a maximum inside the window, where both neighbours belong to the rise.
    inside = (i_acc > i_start) & (i_acc < i_peak)
    a_peak = np.where(inside, refine_maxima(t, a, i_acc, cols)[1], a[i_acc, cols])
    return (
        t_start,
        np.where(confirmed, t_peak, np.nan),
        np.where(confirmed, v_peak, np.nan),
        np.where(confirmed, a_peak, np.nan),
    )
