"""Shock measures on particle histories: pure functions of arrays, no I/O and no LAMMPS.

Conventions (user units, see `units`): time t in ms, particle velocity v in m/s (= mm/ms),
acceleration a in m/s^2, lengths in mm, mass in g, stiffness in N/mm, frequency in Hz.
A history has shape (n_frames, N): particles in chain order, particle 0 the impactor. The
shock runs towards increasing index and drives particles with positive velocities; the drive
(impactor) velocity V_I > 0 sets the scale of every threshold, given as a fraction of V_I.
A measure that does not exist for a particle (the front never reached it, no confirmed peak)
is NaN, not an exception; arrays of the wrong shape raise ValueError.

Typical use on a `Trajectory` `tr` with drive velocity `vi`:

    t_front = arrival_times(tr.t, tr.v, vi)
    vp = propagation_velocity(t_front, np.diff(tr.x0))
    speed = trailing_plateau(vp)             # speed.mean, speed.std, speed.converged()
    peaks = first_peaks(tr.t, tr.v, tr.a, vi)
    steady = steady_oscillation(tr.t, tr.v[:, 50], vi)
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.signal import find_peaks

from .units import TO_SI

_HZ_PER_INV_MS = 1.0 / TO_SI["time"]  # 1/ms -> Hz
# Default levels, as fractions of V_I: the start of motion, the front, and the drop that confirms
# a peak. The engine's on-the-fly record (fix lattice/front, see `deck`) uses the same ones.
START_FRACTION = 0.01
FRONT_FRACTION = 0.5
PROMINENCE = 0.05
_BLOCK_ELEMENTS = 1 << 22  # first_peaks works on column blocks of about this many samples


# ---------------------------------------------------------------------------------------------
# Linear chain
# ---------------------------------------------------------------------------------------------


def linear_wave_speed(stiffness: float, mass: float, spacing: float) -> float:
    """Speed of small-amplitude waves, V0 = r0 sqrt(k/m), in m/s.

    stiffness: k = -dF/dr at r = r0, N/mm; mass: m, g; spacing: r0, mm.
    In user units N/mm per g is 1/ms^2 (= 1e6 1/s^2), so r0 sqrt(k/m) is in mm/ms = m/s.
    """
    _require_positive(stiffness=stiffness, mass=mass, spacing=spacing)
    return spacing * np.sqrt(stiffness / mass)


def linear_frequency(stiffness: float, mass: float) -> float:
    """Linear oscillation frequency f0 = (1/pi) sqrt(k/m), in Hz.

    The top of the harmonic chain's band, omega_max = 2 sqrt(k/m), as a frequency; units as
    in `linear_wave_speed` (sqrt(k/m) in 1/ms, converted to Hz).
    """
    _require_positive(stiffness=stiffness, mass=mass)
    return np.sqrt(stiffness / mass) / np.pi * _HZ_PER_INV_MS


# ---------------------------------------------------------------------------------------------
# Front arrival and propagation velocity
# ---------------------------------------------------------------------------------------------


def arrival_times(t, v, drive_velocity: float, fraction: float = FRONT_FRACTION) -> np.ndarray:
    """Front arrival time of each particle, ms, shape (N,).

    The first time v_n(t) reaches fraction * V_I, linearly interpolated between the last sample
    below and the first sample at or above that level (t[0] if the first sample is already
    there); NaN for a particle that never reaches it.
    """
    t, v = _check_history(t, v)
    _require_positive(drive_velocity=drive_velocity, fraction=fraction)
    return _first_crossing(t, v, fraction * drive_velocity)[1]


def propagation_velocity(arrival, spacing) -> np.ndarray:
    """Shock propagation velocity over each gap, m/s, shape (N-1,).

    V_P[n] = r0_n / (t_arrival[n+1] - t_arrival[n]) with r0_n the initial gap between particles
    n and n+1 in mm (a scalar or an array of shape (N-1,)), arrival times in ms. NaN where either
    particle was never reached; inf where both arrived at once (e.g. both moving at t[0]).
    """
    arrival = np.asarray(arrival, dtype=float)
    if arrival.ndim != 1 or arrival.size < 2:
        raise ValueError(f"arrival: got shape {arrival.shape}; expected (N,) with N >= 2")
    spacing = np.asarray(spacing, dtype=float)
    if spacing.ndim != 0 and spacing.shape != (arrival.size - 1,):
        raise ValueError(f"spacing: got shape {spacing.shape}; expected () or ({arrival.size - 1},)")
    with np.errstate(divide="ignore"):
        return spacing / np.diff(arrival)


@dataclass(frozen=True)
class Plateau:
    """Level of a per-particle series over its trailing window (see `trailing_plateau`).

    mean, std: of the finite values in the window; drift: the relative change across the window
    of the least-squares line through them, slope * (stop - 1 - start) / mean; values[start:stop]
    is the window. All NaN (and start == stop) when there are too few finite values.
    """

    mean: float
    std: float
    drift: float
    start: int
    stop: int

    def converged(self, rtol: float = 0.01) -> bool:
        """True if the series changes by at most rtol (relative) across the window."""
        return bool(abs(self.drift) <= rtol)


def trailing_plateau(values, fraction: float = 0.25, min_points: int = 3) -> Plateau:
    """Plateau of a per-particle series (e.g. V_P) over the last particles that have a value.

    The window is the last ceil(fraction * n_finite) finite entries (at least min_points), where
    n_finite counts finite entries: for V_P, the last quarter of the gaps the front crossed.
    """
    values = np.asarray(values, dtype=float)
    if values.ndim != 1:
        raise ValueError(f"values: got shape {values.shape}; expected (N,)")
    if not 0 < fraction <= 1:
        raise ValueError(f"fraction: got {fraction}; expected in (0, 1]")
    if min_points < 2:
        raise ValueError(f"min_points: got {min_points}; expected >= 2 (a line is fitted)")
    finite = np.flatnonzero(np.isfinite(values))
    count = max(int(np.ceil(fraction * finite.size)), min_points)
    if finite.size < count:
        nan = float("nan")
        return Plateau(nan, nan, nan, values.size, values.size)
    index = finite[-count:]
    window = values[index]
    mean = float(window.mean())
    slope = np.polyfit(index, window, 1)[0]
    drift = float(slope * (index[-1] - index[0]) / mean)
    return Plateau(mean, float(window.std()), drift, int(index[0]), int(index[-1]) + 1)


# ---------------------------------------------------------------------------------------------
# First peak and rise time
# ---------------------------------------------------------------------------------------------


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
    def rise_time(self) -> np.ndarray:
        """Duration from the start of motion to the first velocity peak, ms."""
        return self.peak_time - self.start_time


def first_peaks(
    t,
    v,
    a,
    drive_velocity: float,
    start_fraction: float = START_FRACTION,
    front_fraction: float = FRONT_FRACTION,
    prominence: float = PROMINENCE,
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
    """
    t, v = _check_history(t, v)
    a = np.asarray(a, dtype=float)
    if a.shape != v.shape:
        raise ValueError(f"a: got shape {a.shape}; expected {v.shape}, the shape of v")
    _require_positive(drive_velocity=drive_velocity, start_fraction=start_fraction, prominence=prominence)
    if not start_fraction <= front_fraction:
        raise ValueError(f"front_fraction: got {front_fraction}; expected >= start_fraction = {start_fraction}")
    levels = (start_fraction * drive_velocity, front_fraction * drive_velocity, prominence * drive_velocity)
    width = max(1, _BLOCK_ELEMENTS // len(t))  # bounds the temporaries for long chains
    blocks = [
        _first_peaks_block(t, v[:, j : j + width], a[:, j : j + width], *levels)
        for j in range(0, v.shape[1], width)
    ]
    return FirstPeaks(*(np.concatenate(column) for column in zip(*blocks)))


def _first_peaks_block(t, v, a, start_level, front_level, drop):
    rows = np.arange(len(t))[:, None]
    i_start, t_start = _first_crossing(t, v, start_level)
    i_front, _ = _first_crossing(t, v, front_level)
    behind = np.where(rows >= i_front, v, -np.inf)
    running_max = np.maximum.accumulate(behind, axis=0)  # -inf before the front
    dropped = v <= running_max - drop
    confirmed = dropped.any(axis=0)
    i_drop = np.argmax(dropped, axis=0)
    # The peak is the largest sample between the front and the first confirming drop.
    i_peak = np.argmax(np.where(rows < i_drop, behind, -np.inf), axis=0)
    cols = np.arange(v.shape[1])
    t_peak, v_peak = _refine_maxima(t, v, i_peak, cols)
    i_acc = np.argmax(np.where((rows >= i_start) & (rows <= i_peak), a, -np.inf), axis=0)
    # Refine only a maximum inside the window, where both neighbours belong to the rise.
    inside = (i_acc > i_start) & (i_acc < i_peak)
    a_peak = np.where(inside, _refine_maxima(t, a, i_acc, cols)[1], a[i_acc, cols])
    return (
        t_start,
        np.where(confirmed, t_peak, np.nan),
        np.where(confirmed, v_peak, np.nan),
        np.where(confirmed, a_peak, np.nan),
    )


@dataclass(frozen=True)
class Front:
    """The per-particle front measures of one run, computed once (see `front`)."""

    arrival: np.ndarray  # (N,) ms, `arrival_times`
    propagation_velocity: np.ndarray  # (N-1,) m/s, `propagation_velocity`
    peaks: FirstPeaks  # `first_peaks`


def front(t, v, a, drive_velocity: float, spacing) -> Front:
    """Arrival times, propagation velocity and first peaks with their default definitions."""
    arrival = arrival_times(t, v, drive_velocity)
    return Front(arrival, propagation_velocity(arrival, spacing), first_peaks(t, v, a, drive_velocity))


# ---------------------------------------------------------------------------------------------
# Oscillations behind the front
# ---------------------------------------------------------------------------------------------


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
        return _HZ_PER_INV_MS / np.diff(self.max_time)


def oscillations(
    t, v, drive_velocity: float, front_fraction: float = FRONT_FRACTION, prominence: float = PROMINENCE
) -> Oscillations:
    """Local maxima and minima of one particle's velocity v(t), shape (n_frames,), behind the front.

    Extrema are those of scipy.signal.find_peaks on v (maxima) and -v (minima) with prominence
    >= prominence * V_I, kept from the front on (the first sample with v >= front_fraction * V_I),
    each refined to the vertex of the parabola through it and its two neighbours. With the same
    arguments the first maximum is the first peak of `first_peaks`. Empty if the front never
    arrived.
    """
    t, v = _check_history(t, v, single=True)
    _require_positive(drive_velocity=drive_velocity, front_fraction=front_fraction, prominence=prominence)
    i_front = _first_crossing(t, v[:, None], front_fraction * drive_velocity)[0][0]
    extrema = []
    for sign in (1.0, -1.0):
        i = find_peaks(sign * v, prominence=prominence * drive_velocity)[0]
        i = i[i >= i_front]
        t_ext, v_ext = _refine_maxima(t, sign * v[:, None], i, cols=0)
        extrema += [t_ext, sign * v_ext]
    return Oscillations(*extrema)


@dataclass(frozen=True)
class SteadyOscillation:
    """Oscillation of one particle over its last full periods (see `steady_oscillation`).

    frequency: f = 1/T, Hz, with T the mean period; energy_ratio: eta; amplitude: half the
    difference of the mean maximum and mean minimum velocity, m/s; period_spread: std / mean of
    the individual periods (0 for a periodic motion); start, end: the window, ms; n_periods: the
    number of periods in it (0, and NaN measures, if fewer than two maxima were found).
    """

    frequency: float
    energy_ratio: float
    amplitude: float
    period_spread: float
    start: float
    end: float
    n_periods: int


def steady_oscillation(
    t,
    v,
    drive_velocity: float,
    n_periods: int = 3,
    front_fraction: float = FRONT_FRACTION,
    prominence: float = PROMINENCE,
) -> SteadyOscillation:
    """Stabilized oscillation frequency f and energy ratio eta of one particle, v shape (n_frames,).

    The window spans the last n_periods full periods available: from the maximum n_periods
    before the last one (fewer if fewer were found) to the last maximum of `oscillations`.
    T is the mean period over it and
        eta = 1/(t1 - t0) * int_{t0}^{t1} (v(t)/V_I - 1)^2 dt,
    the paper's (1/T) int_{t0}^{t0+T} averaged over those periods; v is linearly interpolated
    between samples. eta = A^2/2 for v = V_I (1 + A sin(2 pi f t)), i.e. 0.5 for A = 1.
    """
    if int(n_periods) < 1:
        raise ValueError(f"n_periods: got {n_periods}; expected >= 1")
    osc = oscillations(t, v, drive_velocity, front_fraction, prominence)
    t, v = np.asarray(t, dtype=float), np.asarray(v, dtype=float)
    k = min(int(n_periods), osc.max_time.size - 1)
    if k < 1:
        nan = float("nan")
        return SteadyOscillation(nan, nan, nan, nan, nan, nan, 0)
    t0, t1 = osc.max_time[-k - 1], osc.max_time[-1]
    periods = np.diff(osc.max_time[-k - 1 :])
    tt = np.concatenate(([t0], t[(t > t0) & (t < t1)], [t1]))
    y = (np.interp(tt, t, v) / drive_velocity - 1.0) ** 2
    eta = np.sum(0.5 * (y[1:] + y[:-1]) * np.diff(tt)) / (t1 - t0)
    in_window = (osc.min_time > t0) & (osc.min_time < t1)
    amplitude = 0.5 * (osc.max_velocity[-k - 1 :].mean() - osc.min_velocity[in_window].mean())
    return SteadyOscillation(
        frequency=float(_HZ_PER_INV_MS / periods.mean()),
        energy_ratio=float(eta),
        amplitude=float(amplitude),
        period_spread=float(periods.std() / periods.mean()),
        start=float(t0),
        end=float(t1),
        n_periods=k,
    )


# ---------------------------------------------------------------------------------------------
# Helpers
# ---------------------------------------------------------------------------------------------


def _check_history(t, v, single=False):
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


def _require_positive(**values):
    for name, value in values.items():
        if not value > 0:
            raise ValueError(f"{name}: got {value}; expected > 0")


def _first_crossing(t, v, level):
    """Per column of v: index of the first sample with v >= level (len(t) if none) and the
    crossing time, linearly interpolated from the previous sample (NaN if none)."""
    above = v >= level
    cols = np.arange(v.shape[1])
    i = np.argmax(above, axis=0)
    reached = above[i, cols]
    before = np.maximum(i - 1, 0)
    v0, v1 = v[before, cols], v[i, cols]
    with np.errstate(divide="ignore", invalid="ignore"):
        # v0 < level <= v1 where i > 0, so the division is safe where it is used.
        time = t[before] + (level - v0) / (v1 - v0) * (t[i] - t[before])
    time = np.where(i == 0, t[0], time)
    return np.where(reached, i, len(t)), np.where(reached, time, np.nan)


def _refine_maxima(t, y, i, cols):
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
