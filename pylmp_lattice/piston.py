"""Prescribed motion of the impactor (particle 1): velocity, displacement and acceleration of t.

User units: t in ms, velocity in m/s, displacement in mm (1 m/s * 1 ms = 1 mm), acceleration
in m/s^2. Each profile also renders its motion as LAMMPS `fix move` (in `deck`), where
position and velocity are set together every step, so they are always consistent.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .errors import ConfigError


@dataclass(frozen=True)
class Constant:
    """u1(t) = V_I t: the paper's constant impactor velocity (Fig. 3)."""

    velocity: float  # m/s

    profile = "constant"

    def __post_init__(self):
        _check_velocity(self.velocity)

    def velocity_at(self, t):
        return np.full_like(np.asarray(t, float), self.velocity)

    def displacement_at(self, t):
        return self.velocity * np.asarray(t, float)

    def acceleration_at(self, t):
        return np.zeros_like(np.asarray(t, float))

    def peak_velocity(self) -> float:
        return self.velocity


@dataclass(frozen=True)
class Ramp:
    """Linear ramp from rest to V_I over T_r, then constant (paper Fig. S7a)."""

    velocity: float  # m/s
    ramp_time: float  # ms

    profile = "ramp"

    def __post_init__(self):
        _check_velocity(self.velocity)
        if not self.ramp_time > 0:
            raise ConfigError("impactor.ramp_time", f"got {self.ramp_time} ms; expected > 0")

    def velocity_at(self, t):
        t = np.asarray(t, float)
        return self.velocity * np.minimum(t / self.ramp_time, 1.0)

    def displacement_at(self, t):
        t, tr = np.asarray(t, float), self.ramp_time
        return self.velocity * np.where(t < tr, t**2 / (2 * tr), t - tr / 2)

    def acceleration_at(self, t):
        # m/s per ms = 1e3 m/s^2
        return np.where(np.asarray(t, float) < self.ramp_time, 1e3 * self.velocity / self.ramp_time, 0.0)

    def peak_velocity(self) -> float:
        return self.velocity


@dataclass(frozen=True)
class SinePulse:
    """Half-sine velocity pulse V_I sin(pi t / T_s) for 0 <= t <= T_s, then at rest (Fig. S8a)."""

    velocity: float  # m/s, peak
    duration: float  # ms, T_s

    profile = "sine"

    def __post_init__(self):
        _check_velocity(self.velocity)
        if not self.duration > 0:
            raise ConfigError("impactor.duration", f"got {self.duration} ms; expected > 0")

    def velocity_at(self, t):
        t = np.asarray(t, float)
        return np.where(t < self.duration, self.velocity * np.sin(np.pi * t / self.duration), 0.0)

    def displacement_at(self, t):
        t, ts = np.asarray(t, float), self.duration
        amplitude = self.velocity * ts / np.pi  # mm
        return amplitude * (1 - np.cos(np.pi * np.minimum(t, ts) / ts))

    def acceleration_at(self, t):
        t, ts = np.asarray(t, float), self.duration
        return np.where(t < ts, 1e3 * self.velocity * np.pi / ts * np.cos(np.pi * t / ts), 0.0)

    def peak_velocity(self) -> float:
        return self.velocity


Impactor = Constant | Ramp | SinePulse
PROFILES = {cls.profile: cls for cls in (Constant, Ramp, SinePulse)}


def _check_velocity(v: float):
    if not (np.isfinite(v) and v > 0):
        raise ConfigError("impactor.velocity", f"got {v} m/s; expected > 0")
