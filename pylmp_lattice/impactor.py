"""Prescribed motion of the impactor (particle 1): velocity, displacement and acceleration of t.

User units: t in ms, velocity in m/s, displacement in mm (1 m/s * 1 ms = 1 mm), acceleration
in m/s^2. Each profile also renders its motion in the deck (`fix move`, or the plugin's
`fix lattice/impactor` for measured data), where position and velocity are set together every
step, so they are always consistent.

One word, impactor, names magnet 1 and its drive throughout the package and the plugin (`fix
lattice/impactor`; decks of 0.1.0 and before say `lattice/piston`, which the plugin still
registers under that name). "Piston" elsewhere
(`exact.harmonic_piston_velocity`, the Toda study) is the literature's piston problem.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Protocol

import numpy as np

from .errors import ConfigError
from .units import acceleration


# A measured drive has come to rest (a pulse, `Measured.is_pulse`) where its mean velocity over the
# last REST_TAIL of its record is at most REST_FRACTION of its peak: a mean over a span, not the
# spline's slope at the last sample, which one noisy sample can swing (the experiment's half-sine
# as u samples every 0.1 ms with 10 um of noise: the end slope called it a push in half the draws)
REST_FRACTION, REST_TAIL = 0.1, 0.05


class Profile(Protocol):
    """What every impactor profile gives (user units: t in ms); each profile below is one."""

    profile: str  # its name in a case's [impactor] section

    def velocity_at(self, t):
        """The impactor's velocity at times t, m/s."""

    def displacement_at(self, t):
        """Its displacement from where it starts, mm."""

    def acceleration_at(self, t):
        """Its acceleration, m/s^2 (the force on it in a dump is the chain's push, not m a)."""

    def peak_velocity(self) -> float:
        """Its largest velocity, m/s: V_I, against which the front's levels are set."""

    def is_pulse(self) -> bool:
        """Whether the drive comes back to rest by itself (a pulse, not a push): its front
        arrivals are then each magnet's first velocity peak (`measures.default_arrival_method`)."""
        return False


@dataclass(frozen=True)
class Constant(Profile):
    """u1(t) = V_I t: the paper's constant impactor velocity (Fig. 3)."""

    velocity: float  # m/s

    profile = "constant"

    def __post_init__(self):
        _check_drive(self.velocity)

    def velocity_at(self, t):
        return np.full_like(np.asarray(t, float), self.velocity)

    def displacement_at(self, t):
        return self.velocity * np.asarray(t, float)

    def acceleration_at(self, t):
        return np.zeros_like(np.asarray(t, float))

    def peak_velocity(self) -> float:
        return self.velocity


@dataclass(frozen=True)
class Rest(Profile):
    """The first magnet held at rest, like the last (the friction calibration rig, Fig. S4b)."""

    profile = "rest"

    def velocity_at(self, t):
        return np.zeros_like(np.asarray(t, float))

    displacement_at = acceleration_at = velocity_at

    def peak_velocity(self) -> float:
        return 0.0


@dataclass(frozen=True)
class Ramp(Profile):
    """Linear ramp from rest to V_I over T_r, then constant (paper Fig. S7a)."""

    velocity: float  # m/s
    ramp_time: float  # ms

    profile = "ramp"

    def __post_init__(self):
        _check_drive(self.velocity, ramp_time=self.ramp_time)

    def velocity_at(self, t):
        t = np.asarray(t, float)
        return self.velocity * np.minimum(t / self.ramp_time, 1.0)

    def displacement_at(self, t):
        t, tr = np.asarray(t, float), self.ramp_time
        return self.velocity * np.where(t < tr, t**2 / (2 * tr), t - tr / 2)

    def acceleration_at(self, t):
        return np.where(np.asarray(t, float) < self.ramp_time, acceleration(self.velocity / self.ramp_time), 0.0)

    def peak_velocity(self) -> float:
        return self.velocity


@dataclass(frozen=True)
class SinePulse(Profile):
    """Half-sine velocity pulse V_I sin(pi t / T_s) for 0 <= t <= T_s, then at rest (Fig. S8a)."""

    velocity: float  # m/s, peak
    duration: float  # ms, T_s

    profile = "sine"

    def __post_init__(self):
        _check_drive(self.velocity, duration=self.duration)

    def velocity_at(self, t):
        t = np.asarray(t, float)
        return np.where(t < self.duration, self.velocity * np.sin(np.pi * t / self.duration), 0.0)

    def displacement_at(self, t):
        t, ts = np.asarray(t, float), self.duration
        amplitude = self.velocity * ts / np.pi  # mm
        return amplitude * (1 - np.cos(np.pi * np.minimum(t, ts) / ts))

    def acceleration_at(self, t):
        t, ts = np.asarray(t, float), self.duration
        return np.where(t < ts, acceleration(self.velocity * np.pi / ts * np.cos(np.pi * t / ts)), 0.0)

    def peak_velocity(self) -> float:
        return self.velocity

    def is_pulse(self) -> bool:
        return True


@dataclass(frozen=True)
class Measured(Profile):
    """A measured impactor motion, samples (t_i, u_i) or (t_i, v_i) (paper Sec. S1, Fig. S2).

    Times start at the first sample and displacements at its value (the impactor starts where
    it is). Interpolated by a not-a-knot cubic spline, of u (v its derivative) or of v (u its
    exact integral), as `fix lattice/impactor` does in the engine. After the last sample the
    impactor is held at rest ('hold') or the run must not go on ('stop').
    """

    t: tuple[float, ...]  # ms
    values: tuple[float, ...]  # mm for column 'u', m/s for column 'v'
    column: str = "u"
    after: str = "hold"
    _u: scipy.interpolate.CubicSpline = field(init=False, repr=False, compare=False)

    profile = "measured"

    def __post_init__(self):
        t, y = np.asarray(self.t, float), np.asarray(self.values, float)
        if t.ndim != 1 or t.shape != y.shape or len(t) < 4 or not np.all(np.isfinite(t) & np.isfinite(y)):
            raise ConfigError("impactor.t", f"got {t.shape} times and {y.shape} values; expected two equal lists of >= 4 numbers")
        if np.any(np.diff(t) <= 0):
            k = int(np.flatnonzero(np.diff(t) <= 0)[0]) + 2  # the first sample not after the one before, from 1
            raise ConfigError("impactor.t", f"times must increase strictly; sample {k} (t = {t[k - 1]:g} ms) is not "
                                            f"after sample {k - 1} (t = {t[k - 2]:g} ms)")
        if self.column not in ("u", "v"):
            raise ConfigError("impactor.column", f"got {self.column!r}; choose one of u, v")
        if self.after not in ("hold", "stop"):
            raise ConfigError("impactor.after", f"got {self.after!r}; choose one of hold, stop")
        from scipy.interpolate import CubicSpline  # here, not at the top: scipy's submodules cost a CLI start more than most runs

        spline = CubicSpline(t - t[0], y)
        u = spline if self.column == "u" else spline.antiderivative()
        object.__setattr__(self, "_u", u)
        if not self.peak_velocity() > 0:
            raise ConfigError("impactor.values", "the impactor never moves forward; expected some velocity > 0")

    def duration(self) -> float:
        """Span of the samples, ms."""
        return self.t[-1] - self.t[0]

    def _clipped(self, t):
        return np.clip(np.asarray(t, float), 0.0, self.duration())

    def displacement_at(self, t):
        return self._u(self._clipped(t)) - self._u(0.0)

    def velocity_at(self, t):
        t = np.asarray(t, float)
        return np.where(t <= self.duration(), self._u(self._clipped(t), 1), 0.0)

    def acceleration_at(self, t):
        t = np.asarray(t, float)
        return np.where(t <= self.duration(), acceleration(self._u(self._clipped(t), 2)), 0.0)

    def peak_velocity(self) -> float:
        return float(np.max(self.velocity_at(np.linspace(0.0, self.duration(), 20001))))

    def is_pulse(self) -> bool:
        """A pulse where it has come to rest by the end of its record (see REST_FRACTION: a
        measured impact, as the stand-in half-sine, or one that recoils); still moving forward
        there: a push."""
        end, span = self.duration(), REST_TAIL * self.duration()
        tail = float(self._u(end) - self._u(end - span)) / span  # mm/ms = m/s
        return bool(tail <= REST_FRACTION * self.peak_velocity())


Impactor = Constant | Rest | Ramp | SinePulse | Measured
PROFILES = {cls.profile: cls for cls in (Constant, Rest, Ramp, SinePulse, Measured)}


def _check_drive(velocity: float, **times: float):
    """A drive's peak velocity (m/s) and its times (ms, by field name), each finite and > 0 (an
    infinite pulse duration made the displacement inf * 0 = NaN, and reached the deck as 'inf')."""
    if not (np.isfinite(velocity) and velocity > 0):
        raise ConfigError("impactor.velocity", f"got {velocity} m/s; expected > 0")
    for name, t in times.items():
        if not (np.isfinite(t) and t > 0):
            raise ConfigError(f"impactor.{name}", f"got {t} ms; expected a finite time > 0")
