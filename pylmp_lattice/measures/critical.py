"""The critical impactor velocity V*: the knee of the steady oscillation's energy ratio eta(V_I)
(paper Fig. 4(c,d)), under four definitions, since the paper does not say which it used.

- "threshold": the smallest V_I at which eta reaches `level` (linear interpolation);
- "tangent": where the tangent at the steepest point of eta(V_I) crosses eta = 0 (the
  extrapolated onset, as for a melting or glass transition);
- "two_line": the break of the continuous two-segment least-squares line through the points;
- "kneedle": the point farthest below the chord of eta(V_I) on axes scaled to [0, 1] (Satopaa
  et al. 2011), taken over V_I up to the first maximum of eta.

eta depends on when it is measured (a weak oscillation takes longer to decay), so V* depends
on the run length too; the studies report it for several windows.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..serialize import jsonable
from ._common import NAN

KNEE_METHODS = ("threshold", "tangent", "two_line", "kneedle")


@dataclass(frozen=True)
class CriticalVelocity:
    """V* in m/s by one definition (`method`), NaN with a `reason` when it does not exist."""

    value: float
    method: str
    reason: str | None = None

    def to_dict(self) -> dict:
        """The results as a dict of plain values (JSON), units in the keys."""
        return jsonable({"V_star_m_per_s": self.value, "method": self.method, "reason": self.reason})


def critical_velocity(vi, eta, method: str = "two_line", level: float = 0.1) -> CriticalVelocity:
    """V* from eta measured at impactor velocities vi (m/s); NaN entries of eta are dropped.

    level: eta at the threshold (method "threshold" only).
    """
    if method not in KNEE_METHODS:
        raise ValueError(f"method: got {method!r}; choose one of {', '.join(KNEE_METHODS)}")
    vi, eta = np.asarray(vi, dtype=float), np.asarray(eta, dtype=float)
    if vi.ndim != 1 or vi.shape != eta.shape:
        raise ValueError(f"eta: got shape {eta.shape}; expected {vi.shape}, the shape of vi")
    keep = np.isfinite(vi) & np.isfinite(eta)
    order = np.argsort(vi[keep])
    x, y = vi[keep][order], eta[keep][order]
    if x.size < 4:
        return CriticalVelocity(NAN, method, f"{x.size} finite points; at least 4 are needed")
    value, reason = {"threshold": _threshold, "tangent": _tangent, "two_line": _two_line,
                     "kneedle": _kneedle}[method](x, y, level)
    return CriticalVelocity(float(value), method, reason)


def critical_velocities(vi, eta, level: float = 0.1) -> dict[str, CriticalVelocity]:
    """V* under every definition, {method: CriticalVelocity}."""
    return {m: critical_velocity(vi, eta, m, level) for m in KNEE_METHODS}


def _threshold(x, y, level):
    above = np.flatnonzero(y >= level)
    if above.size == 0:
        return NAN, f"eta stays below {level:g}"
    i = above[0]
    if i == 0:
        return NAN, f"eta is already >= {level:g} at the smallest V_I, {x[0]:g} m/s"
    return x[i - 1] + (level - y[i - 1]) * (x[i] - x[i - 1]) / (y[i] - y[i - 1]), None


def _tangent(x, y, _level):
    slope = np.diff(y) / np.diff(x)
    i = int(np.argmax(slope))
    if slope[i] <= 0:
        return NAN, "eta never increases with V_I"
    # the tangent through the steepest segment, extended to eta = 0
    return x[i] - y[i] / slope[i], None


def _two_line(x, y, _level):
    def misfit(v_star):
        basis = np.column_stack([np.ones_like(x), np.minimum(x - v_star, 0), np.maximum(x - v_star, 0)])
        coef, *_ = np.linalg.lstsq(basis, y, rcond=None)
        return float(np.sum((basis @ coef - y) ** 2)), coef

    candidates = np.linspace(x[1], x[-2], 400)  # a break with at least two points on each side
    errors = [misfit(c)[0] for c in candidates]
    best = candidates[int(np.argmin(errors))]
    coef = misfit(best)[1]
    if not coef[2] > coef[1]:
        return NAN, "no upward break: eta does not rise faster above any V_I"
    return best, None


def _kneedle(x, y, _level):
    top = int(np.argmax(y))
    if top < 2:
        return NAN, "eta is largest at the smallest V_I; no rising curve"
    xs, ys = x[: top + 1], y[: top + 1]
    fine = np.linspace(xs[0], xs[-1], 2000)
    from scipy.interpolate import PchipInterpolator

    curve = PchipInterpolator(xs, ys)(fine)
    xn = (fine - fine[0]) / (fine[-1] - fine[0])
    yn = (curve - curve[0]) / (curve[-1] - curve[0])
    return fine[int(np.argmax(xn - yn))], None
