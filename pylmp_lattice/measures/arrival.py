"""Front arrival: when the front reaches each particle, by one of three definitions.

- "level" (the default for a sustained drive: constant velocity, ramp, a measured motion still
  moving forward at the end of its record, `Profile.is_pulse`): the
  first time v_n reaches fraction * V_I (V_I/2 by default), linearly interpolated. It is this
  package's front for a constant drive (the paper does not say which point of the rise it
  times; its V_P of 3.92 m/s is matched to 0.2 %: docs/reproduction.md) and is insensitive to
  how the peak is shaped.
- "velocity_peak" (the default for a pulse, `default_arrival_method(pulse=True)`: a half-sine,
  or a measured motion at rest, or recoiling, by the end of its record): the time
  of the first velocity maximum, parabola-refined. A short pulse spreads and weakens as it
  travels, so far particles may never reach V_I/2; their first maximum still marks the pulse.
- "acceleration_peak": the time of the first acceleration maximum, parabola-refined; the
  steepest point of the rise, closest to the shock front in a strongly nonlinear chain.

A peak counts only when it is confirmed by a later fall of `drop` times its own height before
the signal exceeds it, searched from the start of motion (v_n >= start_fraction * V_I); this
ignores wiggles on the rise and works whatever the pulse's amplitude.

In a noisy chain (noise velocity sigma > 0, see `levels`) every velocity level is at least
5 sigma and every velocity fall at least 3 sigma; the acceleration peak's relative fall has no
noise floor (its start of motion has).
"""

from __future__ import annotations

import numpy as np

from ._common import check_history, check_noise, first_confirmed_maximum, first_crossing, refine_maxima, require_positive
from .levels import FRONT_FRACTION, PULSE_DROP, START_FRACTION, front_levels

ARRIVAL_METHODS = ("level", "velocity_peak", "acceleration_peak")


def default_arrival_method(pulse: bool) -> str:
    """"velocity_peak" for a pulse (a drive that returns to rest), else "level"."""
    return "velocity_peak" if pulse else "level"


def arrival_times(
    t,
    v,
    drive_velocity: float,
    fraction: float = FRONT_FRACTION,
    *,
    method: str = "level",
    a=None,
    start_fraction: float = START_FRACTION,
    drop: float = PULSE_DROP,
    noise: float = 0.0,
) -> np.ndarray:
    """Front arrival time of each particle, ms, shape (N,); NaN where it never arrived.

    t (n_frames,) ms; v, a (n_frames, N) in m/s and m/s^2 (a only for "acceleration_peak").
    method "level": first time v_n >= fraction * V_I (t[0] if already there);
    "velocity_peak" / "acceleration_peak": time of the first confirmed maximum of v_n / a_n
    after the start of motion (see the module docstring).
    noise: the chain's noise velocity sigma, m/s (`levels.noise_velocity`; 0 for a chain at rest),
    or one per column (shape (N,)); for one column, any number (C,): arrival times against each, (C,).
    """
    t, v = check_history(t, v)
    require_positive(drive_velocity=drive_velocity, fraction=fraction, start_fraction=start_fraction, drop=drop)
    levels = front_levels(drive_velocity, check_noise(noise, v.shape[1]), start_fraction, fraction, pulse_drop=drop)
    if method == "level":
        return first_crossing(t, v, levels.front)[1]
    if method not in ARRIVAL_METHODS:
        raise ValueError(f"method: got {method!r}; choose one of {', '.join(ARRIVAL_METHODS)}")
    y = v
    if method == "acceleration_peak":
        if a is None:
            raise ValueError("a: got None; method 'acceleration_peak' needs the accelerations")
        y = np.asarray(a, dtype=float)
        if y.shape != v.shape:
            raise ValueError(f"a: got shape {y.shape}; expected {v.shape}, the shape of v")
    i_start, _ = first_crossing(t, v, levels.start)
    floor = levels.pulse_floor if method == "velocity_peak" else 0.0
    i_peak, confirmed = first_confirmed_maximum(y, i_start, drop, relative=True, floor=floor)
    t_peak, _ = refine_maxima(t, y, i_peak, np.arange(v.shape[1]))
    return np.where(confirmed & (i_start < len(t)), t_peak, np.nan)


def particles_reached(arrival) -> np.ndarray | int:
    """The number of the farthest magnet with an arrival (1-based; 0 if none), along the last
    axis of arrival (ms, NaN where none): the front reached magnets 1 .. it. Magnet 1, the
    driven one, is among them also while its own arrival, a pulse's peak (T_s/2), is still NaN."""
    finite = np.isfinite(np.asarray(arrival, dtype=float))
    last = finite.shape[-1] - np.argmax(finite[..., ::-1], axis=-1)
    out = np.where(finite.any(axis=-1), last, 0)
    return int(out) if out.ndim == 0 else out
