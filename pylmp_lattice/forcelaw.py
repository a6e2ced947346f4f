"""Force laws between nearest neighbours: repulsive force F(r) of the separation r.

Units (user): r in mm, F in N, energy U in mJ (= N mm), stiffness -dF/dr in N/mm.
Every law gives F, the potential U with F = -dU/dr, and the stiffness k = -dF/dr.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import ClassVar, Protocol

import numpy as np

from .errors import ConfigError


class Law(Protocol):
    """What every law gives (user units); each law below is one."""

    law: str  # its name in a case's [force] section
    # its parameters that must be finite and > 0, name -> unit, checked when it is made
    positive: ClassVar[dict[str, str]] = {}
    # whether its stiffness never grows with r on its domain (every parameter allowed): the
    # stiffest separation of a range is then its start (the stability limit's k_max)
    softens: ClassVar[bool] = False

    def __post_init__(self):
        for name, unit in self.positive.items():
            _positive(f"force.{name}", getattr(self, name), unit)

    def force(self, r):
        """F(r), N: the repulsive force at separations r (mm, any shape)."""

    def energy(self, r):
        """U(r), mJ, with F = -dU/dr."""

    def stiffness(self, r):
        """k(r) = -dF/dr, N/mm."""

    def domain(self) -> tuple[float, float]:
        """The separations where the law is defined, mm (open at a divergence)."""


@dataclass(frozen=True)
class PowerLaw(Law):
    """The magnets' law F = K / (r + b)^q (paper: K = 413.8 N mm^3, b = 3.917 mm, q = 3)."""

    K: float = 413.8  # N mm^q
    b: float = 3.917  # mm
    q: float = 3.0

    law = "power"
    positive = {"K": "N mm^q", "b": "mm"}
    softens = True  # q K / (r + b)^(q + 1), K > 0, q > 1

    def __post_init__(self):
        super().__post_init__()
        _number("force.q", self.q)
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
class LinearSpring(Law):
    """Linear spring F = k (r_free - r): repulsive for r < r_free, stiffness k everywhere.

    The paper's Fig. S5 writes "F = k r" with r counted as compression; with the repulsive
    sign convention of Eq. (1) that is dF/dr = -k, so V0 = r0 sqrt(k/m) as in the paper.
    """

    k: float  # N/mm
    r_free: float  # mm

    law = "linear"
    positive = {"k": "N/mm", "r_free": "mm"}
    softens = True  # k everywhere

    def force(self, r):
        return self.k * (self.r_free - np.asarray(r, float))

    def energy(self, r):
        return 0.5 * self.k * (self.r_free - np.asarray(r, float)) ** 2

    def stiffness(self, r):
        return np.full_like(np.asarray(r, float), self.k)

    def domain(self) -> tuple[float, float]:
        return 0.0, np.inf


@dataclass(frozen=True)
class SampledLaw(Law):
    """A law given as measured samples (r_i, F_i), interpolated by a not-a-knot cubic spline.

    U(r) is the spline's exact integral, so F = -dU/dr holds to round-off; the law is only
    defined inside the sampled range.
    """

    r: tuple[float, ...]  # mm, increasing
    F: tuple[float, ...]  # N
    _spline: scipy.interpolate.CubicSpline = field(init=False, repr=False, compare=False)
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
        from scipy.interpolate import CubicSpline  # here, not at the top: scipy's submodules cost a CLI start more than most runs

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


@dataclass(frozen=True)
class Toda(Law):
    """The Toda law F = A (exp(-B (r - a)) - 1), zero at r = a (Toda 1967).

    U = (A/B) (exp(-B (r - a)) - 1) + A (r - a), zero and minimal at r = a. With m = A = B = 1
    (g, N, 1/mm: time in ms) it is the dimensionless Toda lattice, r - a its relative
    displacement. F stays finite at contact, but the stiffness A B exp(-B (r - a)) grows fast
    below a, so for B a >> 1 start the table nearer a (`table.r_min`).
    """

    A: float  # N
    B: float  # 1/mm
    a: float  # mm, the separation where F = 0

    law = "toda"
    positive = {"A": "N", "B": "1/mm", "a": "mm"}
    softens = True  # A B exp(-B (r - a)), A, B > 0

    def force(self, r):
        return self.A * np.expm1(-self.B * (np.asarray(r, float) - self.a))

    def energy(self, r):
        x = np.asarray(r, float) - self.a
        return self.A / self.B * np.expm1(-self.B * x) + self.A * x

    def stiffness(self, r):
        return self.A * self.B * np.exp(-self.B * (np.asarray(r, float) - self.a))

    def domain(self) -> tuple[float, float]:
        return 0.0, np.inf


@dataclass(frozen=True)
class LennardJones(Law):
    """The Lennard-Jones law between nearest neighbours, U = 4 epsilon ((sigma/r)^12 - (sigma/r)^6).

    F = (24 epsilon / r) (2 (sigma/r)^12 - (sigma/r)^6), zero at r = 2^(1/6) sigma; U -> 0 far
    apart. F diverges at contact, so a case must start its table at some r > 0
    (`table.r_min`), which also sets the stiffest spring and so the stability limit.
    """

    epsilon: float  # mJ, depth of the well
    sigma: float  # mm, where U = 0

    law = "lj"
    positive = {"epsilon": "mJ", "sigma": "mm"}

    def _s6(self, r):
        return (self.sigma / np.asarray(r, float)) ** 6

    def force(self, r):
        s6 = self._s6(r)
        return 24 * self.epsilon / np.asarray(r, float) * (2 * s6**2 - s6)

    def energy(self, r):
        s6 = self._s6(r)
        return 4 * self.epsilon * (s6**2 - s6)

    def stiffness(self, r):
        s6 = self._s6(r)
        return 24 * self.epsilon / np.asarray(r, float) ** 2 * (26 * s6**2 - 7 * s6)

    def domain(self) -> tuple[float, float]:
        """Open at r = 0, where F diverges."""
        return 0.0, np.inf


@dataclass(frozen=True)
class Morse(Law):
    """The Morse law U = D (exp(-2 alpha (r - r_e)) - 2 exp(-alpha (r - r_e))), as LAMMPS's morse.

    F = 2 alpha D (exp(-2 alpha (r - r_e)) - exp(-alpha (r - r_e))), zero at r = r_e, where
    U = -D; U -> 0 far apart.
    """

    D: float  # mJ, depth of the well
    alpha: float  # 1/mm
    r_e: float  # mm, the separation where F = 0

    law = "morse"
    positive = {"D": "mJ", "alpha": "1/mm", "r_e": "mm"}

    def _e(self, r):
        return np.exp(-self.alpha * (np.asarray(r, float) - self.r_e))

    def force(self, r):
        e = self._e(r)
        return 2 * self.alpha * self.D * (e**2 - e)

    def energy(self, r):
        e = self._e(r)
        return self.D * (e**2 - 2 * e)

    def stiffness(self, r):
        e = self._e(r)
        return 2 * self.alpha**2 * self.D * (2 * e**2 - e)

    def domain(self) -> tuple[float, float]:
        return 0.0, np.inf


@dataclass(frozen=True)
class FPUT(Law):
    """The Fermi-Pasta-Ulam-Tsingou law: U = k x^2/2 + alpha x^3/3 + beta x^4/4, x = r - a the stretch.

    F = -(k x + alpha x^2 + beta x^3) (repulsive when compressed, x < 0), stiffness
    k + 2 alpha x + 3 beta x^2. With alpha = beta = 0 it is the linear spring (r_free = a).
    alpha > 0 softens compression (as in FPUT's alpha chain); the stiffness turns negative
    at large compression when alpha^2 > 3 k beta, which the table range must avoid.
    """

    k: float  # N/mm
    a: float  # mm, rest separation
    alpha: float = 0.0  # N/mm^2
    beta: float = 0.0  # N/mm^3

    law = "fput"
    positive = {"k": "N/mm", "a": "mm"}

    def __post_init__(self):
        super().__post_init__()
        for name, unit in (("alpha", "N/mm^2"), ("beta", "N/mm^3")):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and np.isfinite(value)):
                raise ConfigError(f"force.{name}", f"got {value!r} {unit}; expected a finite number")

    def force(self, r):
        x = np.asarray(r, float) - self.a
        return -(self.k * x + self.alpha * x**2 + self.beta * x**3)

    def energy(self, r):
        x = np.asarray(r, float) - self.a
        return self.k * x**2 / 2 + self.alpha * x**3 / 3 + self.beta * x**4 / 4

    def stiffness(self, r):
        x = np.asarray(r, float) - self.a
        return self.k + 2 * self.alpha * x + 3 * self.beta * x**2

    def domain(self) -> tuple[float, float]:
        return 0.0, np.inf


ForceLaw = PowerLaw | LinearSpring | SampledLaw | Toda | LennardJones | Morse | FPUT


@dataclass(frozen=True)
class PowerLawFit:
    """`fit_power_law`'s result: the law, and its relative error against the samples of F."""

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

    from scipy.optimize import curve_fit  # here, not at the top: scipy's submodules cost a CLI start more than most runs

    b_min = max(1e-9, 1e-9 - r.min())
    (logK, b, q), _ = curve_fit(
        log_model, r, np.log(F), p0=(np.log(guess.K), guess.b, guess.q),
        bounds=([-np.inf, b_min, 1.0 + 1e-9], [np.inf, np.inf, np.inf]),
    )
    law = PowerLaw(K=float(np.exp(logK)), b=float(b), q=float(q))
    rel = law.force(r) / F - 1
    return PowerLawFit(law, float(np.sqrt(np.mean(rel**2))), float(np.max(np.abs(rel))))


def _positive(name: str, value: float, unit: str):
    _number(name, value)
    if not (np.isfinite(value) and value > 0):
        raise ConfigError(name, f"got {value} {unit}; expected > 0")


def _number(name: str, value) -> None:
    """ConfigError naming the parameter unless `value` is one real number (not a str, None, a
    bool or an array of several)."""
    if np.ndim(value) != 0 or np.asarray(value).dtype.kind not in "iuf":
        raise ConfigError(name, f"got {value!r} ({type(value).__name__}); expected a number")
