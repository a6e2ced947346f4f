"""Oscillations behind the front: the sequence of velocity maxima and minima, the frequency
from it (paper Figs. 3(d,e), S5(d,e)), and the steady oscillation in a stated time window
(f, eta and amplitude, Fig. 4(b,c))."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..serialize import jsonable
from ._common import (
    HZ_PER_INV_MS, NAN, check_history, first_crossing, prominent_maxima, refine_maxima, require_positive, require_window,
)
from .levels import FRONT_FRACTION, NOISE_FALL, PROMINENCE, level


@dataclass(frozen=True)
class Oscillations:
    """Velocity extrema of one particle behind the front (see `oscillations`).

    max_time, max_velocity: local maxima, ms and m/s; min_time, min_velocity: local minima.
    """

    max_time: np.ndarray
    max_velocity: np.ndarray
    min_time: np.ndarray
    min_velocity: np.ndarray

    @property
    def frequency_time(self) -> np.ndarray:
        """Midpoints between successive maxima, ms: where `frequency` applies."""
        return 0.5 * (self.max_time[1:] + self.max_time[:-1])

    @property
    def frequency(self) -> np.ndarray:
        """Instantaneous oscillation frequency 1 / (t_max[k+1] - t_max[k]), Hz."""
        return HZ_PER_INV_MS / np.diff(self.max_time)

    def to_dict(self) -> dict:
        """The results as a dict of plain values (JSON), units in the keys."""
        return jsonable({"max_time_ms": self.max_time, "max_velocity_m_per_s": self.max_velocity,
                         "min_time_ms": self.min_time, "min_velocity_m_per_s": self.min_velocity,
                         "frequency_time_ms": self.frequency_time, "frequency_Hz": self.frequency})


def oscillations(
    t, v, drive_velocity: float, front_fraction: float = FRONT_FRACTION, prominence: float = PROMINENCE,
    noise: float = 0.0,
) -> Oscillations:
    """Local maxima and minima of one particle's velocity v(t), shape (n_frames,), behind the front.

    Extrema are the peaks of v (maxima) and -v (minima) with prominence >= prominence * V_I, as
    scipy.signal.find_peaks finds them (`_common.prominent_maxima`), kept from the front on (the
    first sample with v >= front_fraction * V_I), each refined to the vertex of the parabola
    through it and its two neighbours. With the same arguments the first maximum is the first
    peak of `first_peaks`. Empty if the front never arrived. noise: the chain's noise velocity
    sigma, m/s: the front level is at least 5 sigma and the prominence at least 3 sigma (`levels`).
    """
    t, v = check_history(t, v, single=True)
    require_positive(drive_velocity=drive_velocity, front_fraction=front_fraction, prominence=prominence)
    i_front = first_crossing(t, v[:, None], level(front_fraction, drive_velocity, noise))[0][0]
    extrema = []
    for sign in (1.0, -1.0):
        i = prominent_maxima(sign * v, level(prominence, drive_velocity, noise, NOISE_FALL))
        i = i[i >= i_front]
        t_ext, v_ext = refine_maxima(t, sign * v[:, None], i, cols=0)
        extrema += [t_ext, sign * v_ext]
    return Oscillations(*extrema)


@dataclass(frozen=True)
class SteadyOscillation:
    """Oscillation of one particle over the whole periods inside a time window (see
    `steady_oscillation`).

    frequency: f = 1/T, Hz, T the mean period; energy_ratio: eta; max_velocity, min_velocity:
    the mean of the maxima and of the minima, m/s; amplitude: half their difference, m/s
    (for a non-harmonic oscillation the two differ from mean_velocity +- amplitude);
    mean_velocity: mean of v over the
    periods, m/s; period_spread: std / mean of the individual periods (0 for a periodic motion);
    start, end: first and last maximum used, ms; window: the window, ms (clipped to the record);
    n_periods:
    how many periods were used. When nothing can be measured the numbers are NaN, n_periods is
    0 and `reason` says why (None when measured).
    """

    frequency: float
    energy_ratio: float
    max_velocity: float
    min_velocity: float
    mean_velocity: float
    period_spread: float
    start: float
    end: float
    window: tuple[float, float]
    n_periods: int
    reason: str | None = None

    @property
    def amplitude(self) -> float:
        """Half the peak-to-peak velocity, m/s."""
        return 0.5 * (self.max_velocity - self.min_velocity)

    @property
    def measured(self) -> bool:
        """Whether the oscillation was measured (`reason` says why not)."""
        return self.reason is None

    def to_dict(self) -> dict:
        """The results as a dict of plain values (JSON), units in the keys."""
        return jsonable({"frequency_Hz": self.frequency, "energy_ratio_eta": self.energy_ratio,
                         "max_velocity_m_per_s": self.max_velocity, "min_velocity_m_per_s": self.min_velocity,
                         "amplitude_m_per_s": self.amplitude, "mean_velocity_m_per_s": self.mean_velocity,
                         "period_spread": self.period_spread, "start_ms": self.start, "end_ms": self.end,
                         "window_ms": list(self.window), "n_periods": self.n_periods, "reason": self.reason})


def steady_oscillation(
    t,
    v,
    drive_velocity: float,
    window: tuple[float, float],
    front_fraction: float = FRONT_FRACTION,
    prominence: float = PROMINENCE,
    noise: float = 0.0,
) -> SteadyOscillation:
    """Steady oscillation of one particle, v shape (n_frames,), in the time window (t_a, t_b), ms.

    The periods used run from the first to the last velocity maximum of `oscillations` inside
    the window (whole periods only). T is their mean period, f = 1/T and
        eta = 1/(t1 - t0) * int_{t0}^{t1} (v(t)/V_I - 1)^2 dt,
    the paper's (1/T) int_{t0}^{t0+T} averaged over those periods; v is linearly interpolated
    between samples. eta = A^2/2 for v = V_I (1 + A sin(2 pi f t)), i.e. 0.5 for A = 1.

    Fewer than two maxima in the window gives NaN numbers and a `reason`: the front had not
    arrived, the oscillation has decayed below prominence * V_I (its remaining size is stated),
    or the window is shorter than a period. It never falls back to maxima outside the window.
    noise: the chain's noise velocity sigma, m/s, as in `oscillations`.
    """
    t, v = check_history(t, v, single=True)
    t_a, t_b = require_window(window)
    if not t_a < t_b:
        raise ValueError(f"window: got ({t_a}, {t_b}) ms; expected start < end")
    if t_b <= t[0] or t_a >= t[-1]:
        raise ValueError(f"window: got ({t_a}, {t_b}) ms; expected to overlap the record [{t[0]}, {t[-1]}] ms")
    t_a, t_b = max(t_a, float(t[0])), min(t_b, float(t[-1]))  # the part of the window recorded
    osc = oscillations(t, v, drive_velocity, front_fraction, prominence, noise)
    inside = (osc.max_time >= t_a) & (osc.max_time <= t_b)
    k = int(inside.sum()) - 1
    if k < 1:
        return SteadyOscillation(NAN, NAN, NAN, NAN, NAN, NAN, NAN, NAN, (t_a, t_b), 0,
                                 _no_oscillation(t, v, drive_velocity, (t_a, t_b), front_fraction, prominence, noise,
                                                 k + 1))
    max_time, max_velocity = osc.max_time[inside], osc.max_velocity[inside]
    t0, t1 = max_time[0], max_time[-1]
    periods = np.diff(max_time)
    tt = np.concatenate(([t0], t[(t > t0) & (t < t1)], [t1]))
    vv = np.interp(tt, t, v)
    y = (vv / drive_velocity - 1.0) ** 2
    eta = _trapezoid(y, tt) / (t1 - t0)
    minima = (osc.min_time > t0) & (osc.min_time < t1)
    return SteadyOscillation(
        frequency=float(HZ_PER_INV_MS / periods.mean()),
        energy_ratio=float(eta),
        max_velocity=float(max_velocity.mean()),
        min_velocity=float(osc.min_velocity[minima].mean()),
        mean_velocity=float(_trapezoid(vv, tt) / (t1 - t0)),
        period_spread=float(periods.std() / periods.mean()),
        start=float(t0),
        end=float(t1),
        window=(t_a, t_b),
        n_periods=k,
    )


def _no_oscillation(t, v, vi, window, front_fraction, prominence, noise, n_maxima) -> str:
    t_a, t_b = window
    front, least = level(front_fraction, vi, noise), level(prominence, vi, noise, NOISE_FALL)
    arrived = np.flatnonzero(v >= front)
    if arrived.size == 0 or t[arrived[0]] > t_b:
        return f"the front (v >= {front:.3g} m/s) had not arrived by the end of the window, {t_b:g} ms"
    part = v[(t >= t_a) & (t <= t_b)]
    swing = float(part.max() - part.min()) if part.size else 0.0
    if swing < least:
        return (f"no oscillation left in [{t_a:g}, {t_b:g}] ms: v varies by {swing:.3g} m/s there, "
                f"below the prominence threshold {least:.3g} m/s ({prominence:g} V_I)")
    return f"{n_maxima} velocity maxima in [{t_a:g}, {t_b:g}] ms; at least two are needed for a period"


def _trapezoid(y, x) -> float:
    return float(np.sum(0.5 * (y[1:] + y[:-1]) * np.diff(x)))
