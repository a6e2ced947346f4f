r"""Dispersive-shock theory of a nearest-neighbour chain pushed by a piston: closed-form
predictions of the front speed V_P, the wake and the critical speed V*, in user units.

The chain m u_n'' = F(r_(n-1)) - F(r_n), r_n = x_(n+1) - x_n, any `forcelaw` law, starts at
rest at spacing r0; particle 0 moves into it at V_I from t = 0. Speeds in sites per unit time
(1/ms) are Lagrangian; times r0 they are speeds in the undeformed chain (m/s), the frame in
which the package measures V_P (arrival times against the initial positions).

1. The long-wave limit is a p-system. With r(n, t) and v(n, t) smooth in the site index n,
   r_t = v_n (kinematics) and m v_t = -(F(r))_n, so with the stiffness k(r) = -F'(r) > 0 and

       c(r) = sqrt(k(r) / m)            (sites per ms: N/mm per g is 1/ms^2)

   r_t - v_n = 0 and v_t - c^2 r_n = 0. Adding c times the first to the second gives
   (v + R)_t - c (v + R)_n = 0 with R(r) = int c dr: v + R(r) is carried unchanged along the
   backward characteristics dn/dt = -c, and v - R(r) along the forward ones dn/dt = +c.

2. The wake (`wake_gap`). The piston launches a forward wave into the chain at rest, so the
   backward characteristics all come from the undisturbed chain, v + R(r) = R(r0). Behind
   the wave the particles move with the piston (v = V_I) at the spacing r1 with

       V_I = int_{r1}^{r0} c(r) dr.                                              (1)

   Eq. (1) holds across a dispersive shock as across a simple wave: in the Whitham
   modulation system of a convex (genuinely nonlinear) chain a forward DSW is a simple wave
   of the modulation equations, and the backward Riemann invariant passes through it
   unchanged (El 2005; El & Hoefer 2016, Sec. 4). It is not the Rankine-Hugoniot condition:
   the expanding oscillatory zone carries mass and momentum (compare `exact.jump`). For the
   Toda lattice (m = A = B = 1) c = exp(-r/2) and Eq. (1) gives exp(-r1/2) = 1 + V_I/2,
   the exact wake (`exact.toda_piston_wake`). Mean force on the piston: F(r1).

3. Linear waves about a uniform state r (Lagrangian frame, so no Doppler shift from the
   mean flow): u_n ~ exp(i (k n - omega t)) with m omega^2 = 4 k(r) sin^2(k/2),

       omega0(k, r) = 2 c(r) sin(k/2),   0 <= k <= pi (k in radians per site),

   and the conjugate (solitary-wave tail) branch omega~(k~, r) = -i omega0(i k~, r)
   = 2 c(r) sinh(k~/2).

4. El's DSW fitting (El, Chaos 15, 037103 (2005); El & Hoefer, Physica D 333, 11 (2016),
   Sec. 6). For a DSW joining the wake r1 (behind, harmonic edge) to the chain at rest r0
   (ahead, soliton edge) along the forward family, with characteristic speed V(r) = c(r):
   - harmonic edge: dk/dr = (d omega0/dr) / (V - d omega0/dk), k(r0) = 0, integrated to r1;
   - soliton edge: dk~/dr = (d omega~/dr) / (V - d omega~/dk~), k~(r1) = 0, integrated to r0;
   - edge speeds s- = d omega0/dk at (k(r1), r1); s+ = omega~(k~(r0), r0) / k~(r0).
   With the lattice dispersion both integrate in closed form, for any law:
     harmonic: dk/dr = 2 c' sin(k/2) / (c (1 - cos(k/2))) = 2 (ln c)' cot(k/4), so
               d ln cos^-2(k/4) = d ln c and, with rho = c(r1)/c(r0) > 1,
                   cos^2(k-/4) = 1/rho,      s- = c(r1) cos(k-/2) = 2 c(r0) - c(r1);  (2)
     soliton:  dk~/dr = -2 (ln c)' coth(k~/4), so cosh^2(k~/4) = c(r1)/c(r) and at r0
                   cosh(k~+/2) = 2 rho - 1,  s+ = 2 c(r0) sinh(k~+/2) / k~+.         (3)
   lead_speed = r0 s+ and trailing_speed = r0 s- (m/s). Only rho enters: the law matters
   through c(r1)/c(r0), which Eq. (1) ties to V_I.
   Checks (tests/test_theory.py): for Toda (c = exp(-r/2)), rho = 1 + V_I/2 and Eq. (3) is
   the exact lead soliton cosh(kappa) = 1 + V_I, speed sinh(kappa)/kappa, kappa = k~+/2
   (`exact.toda_lead_soliton`). For weak shocks, rho - 1 ~ (-c'/c^2)(r0) V_I and sinh x / x
   ~ 1 + x^2/6 give s+ ~ c0 + (2/3)(c(r1) - c0): V_P ~ V0 + (4/3) s V_I with the weak-shock
   s = r0 F''/(4 k) (`exact.weak_shock`), the KdV lead soliton; for F = K/(r + b)^q,
   V0 + (q + 1) r0 V_I / (3 (r0 + b)).

5. The critical speed (`critical_velocity`). The harmonic edge reaches k- = pi, where its
   group velocity s- vanishes, when rho = 2 (Eq. 2): the stiffness of the wake is four
   times that of the chain at rest, k(r*) = 4 k(r0), and

       V* = int_{r*}^{r0} c(r) dr.                                                 (4)

   Below V* the trailing edge leaves the piston (s- > 0) and the wake next to it becomes
   uniform: the oscillation there decays (eta -> 0). Above V* the edge would move backwards
   (s- < 0) and stays at the piston, which then drives a period-two (binary) oscillation
   that persists. For Toda V* = 2 sqrt(A/(m B)) exactly (`exact.toda_critical_piston_speed`).
   Above V* the uniform wake, its frequency and Eq. (3) lose their derivation; the numbers
   are still returned, with `wake_persists` True, for comparison.

6. The wake frequency. At a fixed particle, late times select the waves of zero group
   velocity, the band edge k = pi of the wake state: f = omega0(pi, r1)/(2 pi) = c(r1)/pi,
   the linear frequency f0 of the paper evaluated at r1 instead of r0
   (`measures.linear_frequency`).

The Rankine-Hugoniot values (`exact.jump`, `exact.weak_shock`) are returned beside these for
comparison: the jump from rest to a uniform state moving at V_I, and the weak-shock line
c0 + s V_I.

`first_peak_limit` extrapolates first peaks measured along a finite chain to n -> infinity
by A - C/n (scipy.optimize.curve_fit, with standard errors).

Assumptions: the law is convex on [r1, r0] (c grows monotonically under compression),
checked on a grid; a sampled law goes through its spline's derivative. Integrals by
scipy.integrate.quad (relative error ~1e-12); roots by brentq.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np

from .exact import jump, weak_shock
from .forcelaw import SampledLaw
from .measures import linear_frequency, linear_wave_speed
from .measures._common import require_positive
from .serialize import jsonable

_CONVEXITY_SAMPLES = 65  # grid on [r1, r0] where c must grow under compression


@dataclass(frozen=True)
class Prediction:
    """The DSW-fitting predictions for one V_I (user units; see the module docstring).

    V_I, V0: the piston and linear wave speeds, m/s; wake_gap: r1, mm (Eq. 1);
    piston_force: F(r1), N; wake_frequency: c(r1)/pi, Hz; lead_speed, trailing_speed: the
    soliton and harmonic edges in the undeformed chain, m/s (Eqs. 3, 2; the trailing edge
    clipped at 0 above V*, where it sits at the piston); trailing_wavenumber: k- (rad per
    site, > pi above V*); lead_decay: k~+ (1 per site, the lead soliton's tail exp(-k~+ n));
    stiffness_ratio: k(r1)/k(r0) = rho^2 (4 at V*); critical_velocity: V*, m/s (Eq. 4);
    wake_persists: V_I > V*; in_domain: V_I <= V*, where the derivation holds. Outside it
    (in_domain False) the numbers are returned for comparison but run ahead of the simulations:
    on the paper's chain the extrapolated V_P falls below the lead speed by 0.72, 0.93, 1.33 and
    2.27 % at 1.1, 1.25, 1.5 and 2 V* (the wake frequency differs by +0.08, -0.36, -1.62 and
    -5.13 %), against 0.06-0.47 % for V_P and at most 0.21 % for the frequency below V* (study dsw,
    docs/literature.md; 0.05-0.54 % and 0.24 % over the four magnet laws);
    rankine_hugoniot_speed, rankine_hugoniot_gap: the jump from rest to a uniform state moving
    at V_I, m/s and mm (`exact.jump`); weak_shock_speed: c0 + s V_I, m/s (`exact.weak_shock`).
    """

    V_I: float
    V0: float
    wake_gap: float
    piston_force: float
    wake_frequency: float
    lead_speed: float
    trailing_speed: float
    trailing_wavenumber: float
    lead_decay: float
    stiffness_ratio: float
    critical_velocity: float
    wake_persists: bool
    in_domain: bool
    rankine_hugoniot_speed: float
    rankine_hugoniot_gap: float
    weak_shock_speed: float

    def to_dict(self) -> dict:
        """As JSON-able numbers with the units in the keys."""
        units = {"V_I": "m_per_s", "V0": "m_per_s", "wake_gap": "mm", "piston_force": "N",
                 "wake_frequency": "Hz", "lead_speed": "m_per_s", "trailing_speed": "m_per_s",
                 "trailing_wavenumber": "rad_per_site", "lead_decay": "per_site",
                 "critical_velocity": "m_per_s", "rankine_hugoniot_speed": "m_per_s",
                 "rankine_hugoniot_gap": "mm", "weak_shock_speed": "m_per_s"}
        return jsonable({f"{k}_{units[k]}" if k in units else k: v for k, v in asdict(self).items()})


def wave_speed(law, mass: float, r) -> np.ndarray:
    """c(r) = sqrt(-F'(r)/m), sites per ms (r in mm, mass in g); NaN where the law softens to
    negative stiffness."""
    k = np.asarray(law.stiffness(r), float)
    return np.sqrt(np.where(k > 0, k, np.nan) / mass)


def riemann_drop(law, mass: float, r0: float, r1: float) -> float:
    """int_{r1}^{r0} c(r) dr, m/s: the piston speed that holds the wake at spacing r1 (Eq. 1)."""
    from scipy.integrate import quad

    # a spline's stiffness is only piecewise smooth: integrate between its knots
    knots = [x for x in law.r if r1 < x < r0] if isinstance(law, SampledLaw) else []
    value, _ = quad(lambda r: float(wave_speed(law, mass, r)), r1, r0, epsabs=0.0, epsrel=1e-12,
                    limit=200 + 2 * len(knots), points=knots or None)
    return float(value)


def wake_gap(law, mass: float, r0: float, V_I: float) -> float:
    """r1, mm, solving V_I = int_{r1}^{r0} c dr (Eq. 1)."""
    _check(law, mass, r0, V_I=V_I)
    return _compressed_root(lambda r: riemann_drop(law, mass, r0, r) - V_I, law, r0,
                            f"V_I: got {V_I:g} m/s; the wake would close the gap before contact")


def critical_velocity(law, mass: float, r0: float) -> float:
    """V*, m/s (Eq. 4): the piston speed at which the wake's stiffness is 4 k(r0), so the
    DSW's harmonic edge reaches wavenumber pi at the piston; above it the wake persists.
    inf when the stiffness never reaches 4 k(r0) inside the law's domain (no V* before contact)."""
    _check(law, mass, r0)
    k0 = float(law.stiffness(r0))
    try:
        r_star = _compressed_root(lambda r: float(law.stiffness(r)) - 4 * k0, law, r0, "no V*")
    except ValueError:
        return math.inf
    return riemann_drop(law, mass, r0, r_star)


def predict(law, mass: float, r0: float, V_I: float) -> Prediction:
    """The theory's numbers for `law` (a forcelaw object) at spacing r0 (mm), mass (g) and
    piston speed V_I (m/s). Raises ValueError where the theory does not apply: V_I <= 0, a
    wake that would reach contact, or a law that is not convex on [r1, r0]."""
    r1 = wake_gap(law, mass, r0, V_I)
    grid = np.linspace(r1, r0, _CONVEXITY_SAMPLES)
    c = wave_speed(law, mass, grid)
    if not np.all(np.diff(c) < 0):
        raise ValueError(f"law: c(r) must grow under compression on [{r1:.6g}, {r0:.6g}] mm (a convex law) "
                         "for a compressive dispersive shock")
    c0, c1 = float(c[-1]), float(c[0])
    rho = c1 / c0
    k_minus = 4 * float(np.arccos(1 / np.sqrt(rho)))
    k_plus = 2 * float(np.arccosh(2 * rho - 1))
    v_star = critical_velocity(law, mass, r0)
    # the jump's u_p is 0/0 at r0 itself: its limit there is 0
    rh_gap = _compressed_root(lambda r: (float(jump(law, r0, mass, r).u_p) if r < r0 else 0.0) - V_I, law, r0,
                              f"V_I: got {V_I:g} m/s; no uniform Rankine-Hugoniot state before contact")
    ws = weak_shock(law, r0, mass)
    return Prediction(
        V_I=float(V_I), V0=float(linear_wave_speed(float(law.stiffness(r0)), mass, r0)),
        wake_gap=r1, piston_force=float(law.force(r1)),
        wake_frequency=float(linear_frequency(float(law.stiffness(r1)), mass)),
        lead_speed=r0 * 2 * c0 * float(np.sinh(k_plus / 2)) / k_plus,
        trailing_speed=r0 * max(2 * c0 - c1, 0.0),
        trailing_wavenumber=k_minus, lead_decay=k_plus, stiffness_ratio=rho**2,
        critical_velocity=v_star, wake_persists=bool(V_I > v_star), in_domain=bool(V_I <= v_star),
        rankine_hugoniot_speed=float(jump(law, r0, mass, rh_gap).D), rankine_hugoniot_gap=rh_gap,
        weak_shock_speed=ws.c0 + ws.s * V_I,
    )


@dataclass(frozen=True)
class FirstPeakLimit:
    """The fit first_peak(n) = A - C/n: A (the limit n -> infinity) and C with their standard
    errors (from the fit's covariance, scaled by the residuals), in the units of the peaks;
    rms_residual; n_min, n_max and points: the particles used."""

    A: float
    A_error: float
    C: float
    C_error: float
    rms_residual: float
    n_min: int
    n_max: int
    points: int

    def to_dict(self) -> dict:
        """The results as a dict of plain values (JSON), units in the keys."""
        return jsonable(asdict(self))


def first_peak_limit(n, first_peaks) -> FirstPeakLimit:
    """Fit A - C/n to first peaks (any unit, e.g. m/s or V_I) of particles n (>= 1); NaN
    peaks are dropped. Needs at least 3 points."""
    from scipy.optimize import curve_fit

    n, y = np.asarray(n, float), np.asarray(first_peaks, float)
    if n.shape != y.shape or n.ndim != 1:
        raise ValueError(f"first_peaks: got shape {y.shape}; expected {n.shape}, the shape of n")
    keep = np.isfinite(n) & np.isfinite(y)
    n, y = n[keep], y[keep]
    if n.size < 3:
        raise ValueError(f"first_peaks: got {n.size} finite points; expected at least 3")
    if np.any(n <= 0):
        raise ValueError(f"n: got {n.min():g}; expected particle numbers >= 1")
    (A, C), cov = curve_fit(lambda x, a, c: a - c / x, n, y, p0=(y[-1], 0.0))
    err = np.sqrt(np.diag(cov))
    resid = y - (A - C / n)
    return FirstPeakLimit(float(A), float(err[0]), float(C), float(err[1]), float(np.sqrt(np.mean(resid**2))),
                          int(n.min()), int(n.max()), int(n.size))


def _compressed_root(g, law, r0: float, message: str) -> float:
    """The r in (lower end of the law's domain, r0) where g changes sign, g(r0) < 0 < g(r) for
    r below the root (g grows under compression). The bracket halves the distance to the
    domain's end until g turns positive; ValueError(message) if it never does."""
    from scipy.optimize import brentq

    lo = float(law.domain()[0])
    for j in range(1, 60):
        r = lo + (r0 - lo) * 0.5**j
        value = g(r)
        if np.isfinite(value) and value > 0:
            return float(brentq(g, r, r0 if j == 1 else lo + (r0 - lo) * 0.5 ** (j - 1), xtol=1e-14, rtol=1e-15))
        if not np.isfinite(value):
            break
    raise ValueError(message)


def _check(law, mass: float, r0: float, **speeds):
    if not all(callable(getattr(law, name, None)) for name in ("force", "stiffness", "domain")):
        raise TypeError(f"law: got {type(law).__name__}; expected a force law (`forcelaw`), e.g. a case's "
                        "`case.force` or forcelaw.PowerLaw(K=413.8, b=3.917, q=3.0)")
    require_positive(mass=mass, r0=r0, **speeds)
