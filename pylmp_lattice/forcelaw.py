"""Force laws between nearest neighbours: repulsive force F(r) of the separation r.

Units (user): r in mm, F in N, energy U in mJ (= N mm), stiffness -dF/dr in N/mm.
Every law gives F, the potential U with F = -dU/dr, and the stiffness k = -dF/dr.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.interpolate import CubicSpline
from scipy.optimize import curve_fit

from .errors import ConfigError


@dataclass(frozen=True)
class PowerLaw:
    """The magnets' law F = K / (r + b)^q (paper: K = 413.8 N mm^3, b = 3.917 mm, q = 3)."""

    K: float = 413.8  # N mm^q
    b: float = 3.917  # mm
    q: float = 3.0

    law = "power"

    def __post_init__(self):
        _positive("force.K", self.K, "N mm^q")
        _positive("force.b", self.b, "mm")
        if not self.q > 1:
            raise ConfigError("force.q", f"got {self.q}; expected > 1 (finite potential energy)")

    def force(self, r):
        return self.K / (np.asarray(r, float) + self.b) ** self.q

    def energy(self, r):
        return self.K / ((self.q - 1) * (np.asarray(r, float) + self.b) ** (self.q - 1))

    def stiffness(self, r):
        return self.q * self.K / (np.asarray(r, float) + self.b) ** (self.q + 1)

    def domain(self) -> tuple[float, float]:
        """Separations where the law is defined, mm: from contact (r = 0) upward."""
        return 0.0, np.inf


@dataclass(frozen=True)
class LinearSpring:
    """Linear spring F = k (r_free - r): repulsive for r < r_free, stiffness k everywhere.

    The paper's Fig. S5 writes "F = k r" with r counted as compression; with the repulsive
    sign convention of Eq. (1) that is dF/dr = -k, so V0 = r0 sqrt(k/m) as in the paper.
    """

    k: float  # N/mm
    r_free: float  # mm

    law = "linear"

    def __post_init__(self):
        _positive("force.k", self.k, "N/mm")
        _positive("force.r_free", self.r_free, "mm")

    def force(self, r):
        return self.k * (self.r_free - np.asarray(r, float))

    def energy(self, r):
        return 0.5 * self.k * (self.r_free - np.asarray(r, float)) ** 2

    def stiffness(self, r):
        return np.full_like(np.asarray(r, float), self.k)

    def domain(self) -> tuple[float, float]:
        return 0.0, np.inf


@dataclass(frozen=True)
class SampledLaw:
    """A law given as measured samples (r_i, F_i), interpolated by a not-a-knot cubic spline.

    U(r) is the spline's exact integral, so F = -dU/dr holds to round-off; the law is only
    defined inside the sampled range.
    """

    r: tuple[float, ...]  # mm, increasing
    F: tuple[float, ...]  # N
    _spline: CubicSpline = field(init=False, repr=False, compare=False)
    _integral: object = field(init=False, repr=False, compare=False)

    law = "sampled"

    def __post_init__(self):
        r, F = np.asarray(self.r, float), np.asarray(self.F, float)
        if r.ndim != 1 or r.shape != F.shape or len(r) < 4:
            raise ConfigError("force.r", f"got {r.shape} r and {F.shape} F samples; expected two equal lists of >= 4")
        if np.any(np.diff(r) <= 0):
            raise ConfigError("force.r", "samples must be strictly increasing")
        if r[0] < 0:
            raise ConfigError("force.r", f"got r = {r[0]} mm; expected >= 0")
        spline = CubicSpline(r, F)
        object.__setattr__(self, "_spline", spline)
        object.__setattr__(self, "_integral", spline.antiderivative())

    def force(self, r):
        return self._spline(r)

    def energy(self, r):
        # U(r) = integral_r^{r_max} F dr', zero at the last sample.
        return self._integral(self.r[-1]) - self._integral(r)

    def stiffness(self, r):
        return -self._spline(r, 1)

    def domain(self) -> tuple[float, float]:
        return self.r[0], self.r[-1]


ForceLaw = PowerLaw | LinearSpring | SampledLaw


@dataclass(frozen=True)
class PowerLawFit:
    law: PowerLaw
    rms_relative_error: float  # sqrt(mean(((F_fit - F) / F)^2))
    max_relative_error: float


def fit_power_law(r, F, guess: PowerLaw | None = None) -> PowerLawFit:
    """Fit F = K/(r+b)^q to samples (r in mm, F in N > 0) by least squares on log F.

    Log space weighs every sample by its relative error, as a force law spanning decades needs.
    """
    r, F = np.asarray(r, float), np.asarray(F, float)
    guess = guess or PowerLaw()
    if np.any(F <= 0):
        raise ConfigError("force.F", "a power-law fit needs F > 0 at every sample")

    def log_model(x, logK, b, q):
        return logK - q * np.log(x + b)

    b_min = max(1e-9, 1e-9 - r.min())
    (logK, b, q), _ = curve_fit(
        log_model, r, np.log(F), p0=(np.log(guess.K), guess.b, guess.q),
        bounds=([-np.inf, b_min, 1.0 + 1e-9], [np.inf, np.inf, np.inf]),
    )
    law = PowerLaw(K=float(np.exp(logK)), b=float(b), q=float(q))
    rel = law.force(r) / F - 1
    return PowerLawFit(law, float(np.sqrt(np.mean(rel**2))), float(np.max(np.abs(rel))))


def _positive(name: str, value: float, unit: str):
    if not (np.isfinite(value) and value > 0):
        raise ConfigError(name, f"got {value} {unit}; expected > 0")
