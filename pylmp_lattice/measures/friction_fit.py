"""Friction calibration from the Fig. S4 rig: mu and p of the paper's law (Eq. S1) fitted to
measured traces of the middle magnet, by the paper's procedure (Sec. S3).

The rig: two magnets held `separation` = r1 apart, a third released at rest `start` from the
left one. Its position x (mm from the left magnet) obeys the one-degree-of-freedom equation

    m x'' = F(x) - F(r1 - x) - sign(x') mu (m g + p (F(x) + F(r1 - x))),

and while it rests it sticks as long as |F(x) - F(r1 - x)| <= mu (m g + p (F(x) + F(r1 - x))).
Between two turning points sign(x') is fixed, so each half cycle is smooth: `rig_motion`
integrates it half cycle by half cycle (scipy DOP853, an event at x' = 0), deciding at each
turning point whether the magnet sticks (then it rests there for good) or slides back.

`fit_friction` solves that equation for trial (mu, p) and fits its x(t) to the measured traces
by weighted least squares (scipy.optimize.least_squares), all traces at once, as the paper
fits its six separations 249.5 ... 30.1 mm together. Each trace is weighted by its noise,
estimated from its second differences (robust: the median absolute deviation). A fit of a
trace with many oscillations from a poor start can lock onto the wrong number of cycles, so
the fit grows its time window: the first 1/16 of each trace's motion, then 1/8, 1/4, 1/2 and
all of it, each stage starting from the last. Uncertainties are the standard errors of the
linearised fit (covariance (J^T J)^-1 times the reduced chi^2), times the residuals' integrated
autocorrelation time (in samples: 1 for independent noise; noise correlated from sample to
sample, a filtered or smoothed measurement's, counts fewer independent samples, and without
it the errors came out 8 times too small for noise smoothed over 20 samples: tests/
test_friction_fit.py); the rest position of each trace is that of the fitted model, with its
error propagated from the covariance.

Units (user): t in ms, x, start and separation in mm, mass in g, g in m/s^2 (converted to a
weight in N through `units`), F in N.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from ..serialize import jsonable
from ..units import to_engine

_STAGES = (1 / 16, 1 / 8, 1 / 4, 1 / 2, 1.0)  # fractions of each trace's motion fitted in turn
_GRID = 2000  # angle steps per half cycle (midpoint rule: times to ~1e-7 relative)
_MAX_HALF_CYCLES = 100_000


@dataclass(frozen=True)
class RigMotion:
    """x (mm) at the requested times; rest_position (mm) where the magnet comes to rest and
    rest_time (ms) when (found also beyond the last requested time); turning: the turning
    points (mm), the release first."""

    x: np.ndarray
    rest_position: float
    rest_time: float
    turning: tuple[float, ...]


def rig_motion(t, separation: float, mu: float, p: float, law, mass: float, g: float = 9.81,
               start: float = 1.8) -> RigMotion:
    """The middle magnet's motion (see the module docstring) at times t (ms, increasing, from
    the release at t = 0), for friction mu and p, a `forcelaw` law, mass (g) and g (m/s^2)."""
    from scipy.optimize import brentq  # here: scipy's submodules slow every start

    t = np.asarray(t, float)
    r1 = float(separation)
    weight = float(to_engine(mass, "mass")) * g  # N: kg times m/s^2

    def net(x):
        return float(law.force(x) - law.force(r1 - x))

    def limit(x):
        return mu * (weight + p * float(law.force(x) + law.force(r1 - x)))

    def potential(x, s):
        """W_s(x), mJ: U(x) + U(r1 - x) + s mu (m g x - p U(x) + p U(r1 - x)); m x'' = -W_s'(x)."""
        u_left, u_right = law.energy(x), law.energy(r1 - x)
        return u_left + u_right + s * mu * (weight * x - p * u_left + p * u_right)

    x_out = np.full(t.shape, np.nan)
    x, now, turning = float(start), 0.0, [float(start)]
    theta = (np.arange(_GRID) + 0.5) * (np.pi / _GRID)  # midpoints of the half cycle's angle grid
    for _ in range(_MAX_HALF_CYCLES):
        if abs(net(x)) <= limit(x):  # sticks here for good
            x_out[t >= now] = x
            return RigMotion(x_out, x, now, tuple(turning))
        s = float(np.sign(net(x)))
        wall = r1 if s > 0 else 0.0  # contact with the magnet it moves towards
        bottom = brentq(lambda y: net(y) - s * limit(y), x, wall)  # W_s is convex: its minimum
        level = potential(x, s)
        if potential(wall, s) <= level:
            raise ValueError(f"mu: got {mu}, p: got {p}; the magnet would reach the fixed one at {wall:g} mm")
        x_next = brentq(lambda y: potential(y, s) - level, bottom, wall, xtol=1e-13, rtol=1e-15)
        # x = x + (x_next - x)(1 - cos theta)/2 removes the 1/sqrt singularities at both turning
        # points: dt/dtheta is smooth, and the midpoint rule sums it to second order
        half = 0.5 * (x_next - x)
        y = x + half * (1 - np.cos(theta))
        speed = np.sqrt(np.maximum(2 * (level - potential(y, s)) / mass, 0.0))
        dt_dtheta = np.abs(half) * np.sin(theta) / speed
        t_grid = now + np.concatenate(([0.0], np.cumsum(dt_dtheta) * (np.pi / _GRID)))
        inside = (t >= now) & (t <= t_grid[-1])
        if inside.any():
            angle = np.interp(t[inside], t_grid, np.linspace(0.0, np.pi, _GRID + 1))
            x_out[inside] = x + half * (1 - np.cos(angle))
        x, now = x_next, float(t_grid[-1])
        turning.append(x)
    raise RuntimeError(f"rig_motion: more than {_MAX_HALF_CYCLES} half cycles")


@dataclass(frozen=True)
class FrictionFit:
    """The fitted friction law (see `fit_friction`).

    mu, p and their standard errors; correlation: of the two estimates; rest_position,
    rest_position_error (mm, one per trace): where the fitted model comes to rest;
    rms_residual, noise (mm, per trace): of the fit, and the noise estimated from the trace;
    reduced_chi2: of the weighted fit (~1 when the model explains the trace to its noise; the
    noise is estimated from second differences, blind to slow noise, which raises it);
    correlation_time: the residuals' integrated autocorrelation time, samples (~1 for white
    noise), which widens the errors;
    stages: the time windows fitted in turn (fractions of each trace's motion); nfev: model
    evaluations.
    """

    mu: float
    mu_error: float
    p: float
    p_error: float
    correlation: float
    rest_position: tuple[float, ...]
    rest_position_error: tuple[float, ...]
    rms_residual: tuple[float, ...]
    noise: tuple[float, ...]
    reduced_chi2: float
    correlation_time: float
    stages: tuple[float, ...]
    nfev: int

    def to_dict(self) -> dict:
        """The results as a dict of plain values (JSON), units in the keys."""
        return jsonable(asdict(self))


def fit_friction(t, x, separation, law, mass: float, g: float = 9.81, start=1.8,
                 guess: tuple[float, float] = (0.2, 0.005)) -> FrictionFit:
    """Fit mu and p to measured traces x(t) of the rig (see the module docstring).

    t, x: one trace (arrays, ms and mm from the left magnet, t = 0 at the release) or a list
    of traces; separation: r1 (mm), one per trace; start: the release position(s), mm;
    law: the magnets' `forcelaw` law; mass in g; g in m/s^2; guess: (mu, p) to start from.
    """
    from scipy.optimize import least_squares

    traces = _traces(t, x, separation, start)
    noise = [_noise(xi) for _, xi, _, _ in traces]
    motion_end = [_motion_end(ti, xi, s) for (ti, xi, _, _), s in zip(traces, noise)]
    nfev = 0

    def residuals(params, fraction):
        mu, p = params
        out = []
        for (ti, xi, r1, x0), sigma, end in zip(traces, noise, motion_end):
            keep = ti <= fraction * end if fraction < 1 else slice(None)
            out.append((rig_motion(ti[keep], r1, mu, p, law, mass, g, x0).x - xi[keep]) / sigma)
        return np.concatenate(out)

    params = np.asarray(guess, float)
    for fraction in _STAGES:
        fit = least_squares(residuals, params, args=(fraction,), bounds=([0.0, 0.0], [np.inf, np.inf]),
                            x_scale="jac", diff_step=1e-5)
        params, nfev = fit.x, nfev + fit.nfev
    dof = max(fit.fun.size - params.size, 1)
    chi2 = float(np.sum(fit.fun**2) / dof)
    sizes = [ti.size for ti, _, _, _ in traces]  # (the last stage fits every sample)
    tau = float(np.average([_correlation_time(r) for r in np.split(fit.fun, np.cumsum(sizes)[:-1])], weights=sizes))
    cov = np.linalg.inv(fit.jac.T @ fit.jac) * chi2 * tau
    err = np.sqrt(np.diag(cov))
    rest, rest_err, rms = [], [], []
    for (ti, xi, r1, x0) in traces:
        def rest_at(q, r1=r1, x0=x0):
            return rig_motion(ti[-1:], r1, q[0], q[1], law, mass, g, x0).rest_position
        base = rest_at(params)
        grad = np.array([(rest_at(params + h * e) - base) / h
                         for h, e in zip(1e-5 * np.maximum(np.abs(params), 1e-3), np.eye(2))])
        rest.append(base)
        rest_err.append(float(np.sqrt(grad @ cov @ grad)))
        rms.append(float(np.sqrt(np.mean((rig_motion(ti, r1, *params, law, mass, g, x0).x - xi) ** 2))))
    return FrictionFit(
        mu=float(params[0]), mu_error=float(err[0]), p=float(params[1]), p_error=float(err[1]),
        correlation=float(cov[0, 1] / (err[0] * err[1])), rest_position=tuple(rest), rest_position_error=tuple(rest_err),
        rms_residual=tuple(rms), noise=tuple(noise), reduced_chi2=chi2, correlation_time=tau, stages=_STAGES, nfev=nfev,
    )


def _correlation_time(r: np.ndarray) -> float:
    """The integrated autocorrelation time of residuals r, in samples: 1 + 2 times the sum of their
    autocorrelation over the lags before it first falls to 0 or below (1 for independent ones)."""
    r = r - r.mean()
    f = np.fft.rfft(r, 2 * r.size)
    acf = np.fft.irfft(f * np.conj(f))[:r.size]
    if acf[0] <= 0:
        return 1.0
    acf = acf[1:] / acf[0]
    end = np.flatnonzero(acf <= 0)
    return float(max(1.0, 1.0 + 2.0 * acf[:end[0] if end.size else acf.size].sum()))


def _traces(t, x, separation, start):
    """[(t, x, r1, start)] from one trace or lists of them, validated."""
    single = np.ndim(separation) == 0
    ts, xs = ([t], [x]) if single else (list(t), list(x))
    r1s = [separation] if single else list(separation)
    starts = [start] * len(r1s) if np.ndim(start) == 0 else list(start)
    if not len(ts) == len(xs) == len(r1s) == len(starts):
        raise ValueError(f"separation: got {len(r1s)} values for {len(ts)} time and {len(xs)} position traces "
                         f"and {len(starts)} starts; expected one per trace")
    out = []
    for k, (ti, xi, r1, x0) in enumerate(zip(ts, xs, r1s, starts)):
        ti, xi = np.asarray(ti, float), np.asarray(xi, float)
        if ti.ndim != 1 or ti.shape != xi.shape or ti.size < 10:
            raise ValueError(f"x[{k}]: got shape {xi.shape} for t of shape {ti.shape}; expected two equal 1D arrays "
                             "of >= 10 samples")
        if np.any(np.diff(ti) <= 0) or ti[0] < 0:
            raise ValueError(f"t[{k}]: expected increasing times >= 0 ms (0 at the release)")
        if not 0 < x0 < r1:
            raise ValueError(f"start[{k}]: got {x0} mm; expected between 0 and the separation {r1} mm")
        out.append((ti, xi, float(r1), float(x0)))
    return out


def _noise(x) -> float:
    """The noise of a trace, mm: the median absolute second difference, scaled to a standard
    deviation (white noise of std s gives second differences of std s sqrt(6))."""
    d2 = np.abs(np.diff(x, 2))
    return float(max(np.median(d2) / (0.6745 * np.sqrt(6)), 1e-12))


def _motion_end(t, x, sigma) -> float:
    """The last time the trace is more than 5 noise widths from its final position (its
    motion's end, ms), from the median of the last tenth of the trace."""
    rest = np.median(x[-max(len(x) // 10, 1):])
    moving = np.flatnonzero(np.abs(x - rest) > 5 * sigma)
    return float(t[moving[-1]]) if moving.size else float(t[-1])
