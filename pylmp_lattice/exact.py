"""Exact and asymptotic results for 1D lattices, as pure functions of arrays.

Each function states its units. The harmonic chain is in user units (t in ms, omega in
rad/ms, velocities in m/s). The Toda results are in the lattice's dimensionless units
(m = A = B = 1): with the package's Toda law F = A (exp(-B (r - a)) - 1) and mass m, time is
measured in sqrt(m / (A B)), lengths in 1/B and velocities in sqrt(A / (m B)); `toda_scales`
gives these in user units, and with A = 1 N, B = 1/mm, m = 1 g they are exactly ms, mm, m/s.
r below is then the dimensionless relative displacement B (gap - a).

The weak-shock and jump-condition functions take any force law of `forcelaw` (user units).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


# ----------------------------------------------------------------------------- harmonic chain

def harmonic_piston_velocity(n, t, u_p: float, omega: float):
    """Velocity (m/s) of particle n at time t (ms) in a semi-infinite harmonic chain at rest,
    whose particle 0 is pushed at constant speed u_p (m/s) from t = 0; omega = sqrt(k/m) (rad/ms).

    v_n(t) = u_p [J_2n(2 w t) + 2 sum_{k>n} J_2k(2 w t)] (Schroedinger 1914; Holian & Straub
    1978), n = 0 the piston itself (v_0 = u_p). The tail is summed through the identity
    J_0 + 2 sum_{k>=1} J_2k = 1, so v_n = u_p [1 - J_0 - 2 sum_{k=1}^{n-1} J_2k - J_2n] exactly
    (absolute error ~1e-16 u_p). n: integers >= 0; t: array; returns shape (len(t), len(n)).
    """
    from scipy.special import jv  # here: scipy.special slows every start, most never need it

    n = np.atleast_1d(np.asarray(n, int))
    x = 2 * omega * np.atleast_1d(np.asarray(t, float))[:, None]
    if np.any(n < 0):
        raise ValueError(f"n: got {n.min()}; expected particle indices >= 0")
    orders = np.arange(0, n.max() + 1)
    j = jv(2 * orders[None, :], x)  # (len(t), n_max + 1): J_0, J_2, ..., J_2 n_max
    # partial[:, m] = J_0 + 2 sum_{k=1}^{m} J_2k
    partial = j[:, :1] + 2 * np.cumsum(np.concatenate([np.zeros_like(x), j[:, 1:]], axis=1), axis=1)
    below = np.where(n > 0, partial[:, np.maximum(n - 1, 0)], 0.0)  # J_0 + 2 sum_{k=1}^{n-1} J_2k
    return u_p * np.where(n > 0, 1 - below - j[:, n], 1.0)


def harmonic_overshoot_limit() -> float:
    """The first peak of v_n / u_p far from the piston in the harmonic chain: 1.27435.

    Near the front, with x = 2 w t, J_nu(x) ~ (2/x)^(1/3) Ai((2/x)^(1/3) (nu - x)), so the sum
    of J_2k over k >= n becomes v_n / u_p -> integral_z^inf Ai(s) ds, z = (2/x)^(1/3) (2n - x):
    a front of fixed shape that widens as t^(1/3). Its maximum, at the first zero a1 of Ai, is
    1/3 + integral_0^|a1| Ai(-s) ds, the same for every u_p."""
    from scipy.special import ai_zeros, itairy  # here: scipy.special slows every start, most never need it

    a1 = float(ai_zeros(1)[0][0])
    return 1.0 / 3.0 + float(itairy(-a1)[2])


# ----------------------------------------------------------------------------- Toda lattice

@dataclass(frozen=True)
class TodaScales:
    """The Toda lattice's natural units in user units: time (ms), length (mm), velocity (m/s)."""

    time: float
    length: float
    velocity: float


def toda_scales(A: float, B: float, m: float) -> TodaScales:
    """A in N, B in 1/mm, m in g: t0 = sqrt(m/(A B)) ms, l0 = 1/B mm, v0 = l0/t0 m/s."""
    t0 = np.sqrt(m / (A * B))
    return TodaScales(time=float(t0), length=1.0 / B, velocity=float(1.0 / (B * t0)))


def toda_soliton(n, t, kappa: float, n0: float = 0.0):
    """The Toda one-soliton moving toward larger n (dimensionless units), centred on gap n0 at t = 0.

    With z_n = kappa (n - n0) - t sinh(kappa) and tau_n = 1 + exp(2 z_n), the displacement is
    x_n = ln(tau_(n-1) / tau_n) (0 far behind the soliton, -2 kappa far ahead), so the gap
    n .. n+1 obeys exp(-r_n) - 1 = sinh(kappa)^2 sech(z_n)^2. The soliton moves at
    sinh(kappa)/kappa sites per unit time.
    Returns (x, v, r), each of shape (len(t), len(n)): displacement, velocity, relative
    displacement r_n = x_(n+1) - x_n of the gap that follows particle n.
    """
    from scipy.special import expit  # here: scipy.special slows every start, most never need it

    n = np.atleast_1d(np.asarray(n, float))[None, :]
    t = np.atleast_1d(np.asarray(t, float))[:, None]
    beta = np.sinh(kappa)
    z = kappa * (n - n0) - beta * t
    x = np.logaddexp(0.0, 2 * (z - kappa)) - np.logaddexp(0.0, 2 * z)
    v = 2 * beta * (expit(2 * z) - expit(2 * (z - kappa)))
    r = -np.log1p((np.sinh(kappa) / np.cosh(z)) ** 2)
    return x, v, r


def toda_soliton_speed(kappa):
    """Speed of the Toda soliton of inverse width kappa: sinh(kappa)/kappa sites per unit time."""
    kappa = np.asarray(kappa, float)
    return np.sinh(kappa) / kappa


def toda_critical_piston_speed(A: float = 1.0, B: float = 1.0, m: float = 1.0) -> float:
    """Piston speed above which the Toda wake oscillates with period two: 2 sqrt(A/(m B)).

    In user units (m/s) for A in N, B in 1/mm, m in g; 2 in dimensionless units."""
    return 2.0 * float(np.sqrt(A / (m * B)))


def toda_piston_wake(u_p):
    """Uniform state behind a Toda piston moving at u_p < 2 (dimensionless): the relative
    displacement r with exp(-r) = (1 + u_p/2)^2, particles moving at u_p.

    It follows from the Riemann invariant v - 2 exp(-r/2) of the long-wave Toda equations,
    which the dispersive shock carries unchanged from the state at rest (-2). Above the
    critical speed 2 no uniform state forms: NaN."""
    u_p = np.asarray(u_p, float)
    return np.where(u_p < 2.0, -2.0 * np.log1p(u_p / 2.0), np.nan)


def toda_lead_soliton(u_p):
    """The lead soliton of the Toda piston problem (dimensionless): cosh(kappa) = 1 + u_p.

    Returns (kappa, speed): the speed sinh(kappa)/kappa in sites per unit time. Its height is
    exp(-r) - 1 = sinh^2(kappa) = u_p^2 + 2 u_p and its peak particle velocity
    2 sinh(kappa) tanh(kappa/2) = 2 (cosh(kappa) - 1) = 2 u_p exactly."""
    kappa = np.arccosh(1.0 + np.asarray(u_p, float))
    return kappa, toda_soliton_speed(kappa)


# ----------------------------------------------------------------------------- weak shocks and jumps

@dataclass(frozen=True)
class WeakShock:
    """The weak-shock limit U_s = c0 + s u_p of a chain at spacing r0 (user units).

    c0 = r0 sqrt(k/m) (m/s), k = -F'(r0); s = r0 F''(r0) / (4 k) (dimensionless). For
    F = K/(r+b)^q, s = (q+1) r0 / (4 (r0 + b)).
    """

    c0: float  # m/s
    s: float


def weak_shock(law, r0: float, m: float) -> WeakShock:
    """c0 and s of `law` (a forcelaw object) at spacing r0 (mm) with mass m (g).

    Expands the jump conditions below to second order in the compression: D^2 = c0^2 (1 +
    F'' delta / (2 k)), u_p = D delta / r0, so D = c0 + s u_p. F'' = -dk/dr is taken by a
    central difference of the analytic stiffness (relative error ~1e-9).
    """
    k = float(law.stiffness(r0))
    h = 1e-5 * r0
    f2 = -float(law.stiffness(r0 + h) - law.stiffness(r0 - h)) / (2 * h)
    return WeakShock(c0=r0 * float(np.sqrt(k / m)), s=r0 * f2 / (4 * k))


@dataclass(frozen=True)
class Jump:
    """A steady shock from rest at spacing r0 to mean spacing r1 (user units), by the
    Rankine-Hugoniot relations on a lattice (mass, momentum, energy per particle).

    D: shock speed in the undisturbed chain, m/s (= r0 times sites per ms);
    u_p: particle velocity behind, m/s; e_wake: energy per particle left behind beyond the
    mean flow's kinetic and the mean state's potential energy (mJ), the wake's "heat".
    """

    D: float
    u_p: float
    e_wake: float


def jump(law, r0: float, m: float, r1, F1=None) -> Jump:
    """Jump conditions from rest at spacing r0 (mm) to the mean spacing r1 (mm), mass m (g).

    F1: the mean force behind (N); by default F(r1), the force of a uniform state. With the
    compression delta = r0 - r1 and dF = F1 - F(r0):
      mass       u_p = (D / r0) delta,
      momentum   m (D / r0) u_p = dF          =>  D^2 = r0^2 dF / (m delta),  u_p^2 = dF delta / m,
      energy     the piston's work per particle F1 delta goes into the mean flow (m u_p^2 / 2),
                 the mean state's potential U(r1) - U(r0), and the rest, e_wake (`wake_energy`),
                 which with the momentum relation is (F1 + F(r0)) delta / 2 - (U(r1) - U(r0)):
                 the area between the Rayleigh line and the law, >= 0 for a law convex in r.
    Arrays broadcast.
    """
    r1 = np.asarray(r1, float)
    F1 = law.force(r1) if F1 is None else np.asarray(F1, float)
    delta, dF = r0 - r1, F1 - law.force(r0)
    D = r0 * np.sqrt(dF / (m * delta))
    u_p = np.sqrt(dF * delta / m)
    return Jump(D=D, u_p=u_p, e_wake=wake_energy(law, r0, m, u_p, r1, F1))


def wake_energy(law, r0: float, m: float, u_p, r1, F1):
    """Energy per particle (mJ) left behind a steady front beyond the mean flow and mean state:
    the piston's work per particle F1 (r0 - r1) (mass conservation: each particle's share of
    the piston's travel is its compression), minus m u_p^2 / 2, minus U(r1) - U(r0).
    u_p in m/s, r0 and r1 in mm, F1 the mean force behind (N), m in g."""
    r1 = np.asarray(r1, float)
    return np.asarray(F1) * (r0 - r1) - 0.5 * m * np.asarray(u_p) ** 2 - (law.energy(r1) - law.energy(r0))
