"""Propagation velocity of the front V_P: per gap, centred per particle, fitted over a window,
and its plateau (or drift, for a series that does not settle).

Arrival times in ms and positions/gaps in mm give velocities in mm/ms = m/s. Arrays are
0-based (entry i of V_P is gap i + 1); the magnet and gap numbers in results objects are
1-based and ranges inclusive, as the paper counts (`numbering`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..numbering import entries, number
from ..serialize import jsonable
from ._common import NAN, require_integer

OVER = ("gap", "magnet")  # what a per-entry series is over: entry i is gap i + 1, or magnet i + 1
# A plateau's values scatter by at most this fraction of their mean: V_P per gap scatters by about
# 1 % in a chain with thermal RMS 1 % of V_I, 8.5 % at 10 % (study thermal, quick); from frames
# every 10 ms on the main job (0.3 per gap crossing) by 90 % about a wrong mean.
SCATTER_LIMIT = 0.2


def propagation_velocity(arrival, spacing) -> np.ndarray:
    """Shock propagation velocity over each gap, m/s, shape (N-1,).

    V_P[n] = r0_n / (t_arrival[n+1] - t_arrival[n]) with r0_n the initial gap between particles
    n and n+1 in mm (a scalar or an array of shape (N-1,)), arrival times in ms. NaN where either
    particle was never reached; inf where both arrived at once (e.g. both moving at t[0]).
    R chains at once: arrival (R, N) and spacing (R, N-1) give (R, N-1), row r chain r's.
    """
    arrival = np.asarray(arrival, dtype=float)
    if arrival.ndim == 2:
        _arrival(arrival[0])
    else:
        arrival = _arrival(arrival)
    spacing = np.asarray(spacing, dtype=float)
    gaps = arrival.shape[:-1] + (arrival.shape[-1] - 1,)
    if spacing.ndim != 0 and spacing.shape != gaps:
        raise ValueError(f"spacing: got shape {spacing.shape}; expected () or {gaps}")
    with np.errstate(divide="ignore"):
        return spacing / np.diff(arrival)


def centred_propagation_velocity(arrival, spacing) -> np.ndarray:
    """V_P at each particle from its two neighbours, m/s, shape (N,):

        V_P[n] = (r0_{n-1} + r0_n) / (t_{n+1} - t_{n-1})   (= 2 r0 / (t_{n+1} - t_{n-1}))

    second-order accurate where the per-gap value is first order; NaN at both ends and where
    a neighbour was never reached. spacing: initial gaps, mm, scalar or shape (N-1,).
    """
    arrival = _arrival(arrival)
    gaps = np.broadcast_to(np.asarray(spacing, dtype=float), (arrival.size - 1,))
    out = np.full(arrival.size, NAN)
    with np.errstate(divide="ignore", invalid="ignore"):
        out[1:-1] = (gaps[:-1] + gaps[1:]) / (arrival[2:] - arrival[:-2])
    return out


@dataclass(frozen=True)
class FrontFit:
    """A straight line through the arrival times t_n against the initial positions x_n of
    magnets first_magnet .. last_magnet (1-based, inclusive; see `fit_propagation_velocity`).

    velocity: V_P = 1/slope, m/s; velocity_stderr: its standard error from the fit, m/s;
    residual_rms: rms of t_n about the line, ms (large for a front that accelerates);
    first_magnet, last_magnet: the magnets used; n_points: how many had an arrival time.
    """

    velocity: float
    velocity_stderr: float
    residual_rms: float
    first_magnet: int
    last_magnet: int
    n_points: int


def fit_propagation_velocity(arrival, positions, first_magnet: int = 1, last_magnet: int | None = None) -> FrontFit:
    """V_P fitted over a window of magnets: least squares t_n = t_0 + x_n / V_P over magnets
    first_magnet .. last_magnet (1-based, inclusive; default all) that have an arrival (ms),
    x_n their initial positions (mm); arrival and positions of shape (N,), entry i magnet i + 1."""
    arrival = _arrival(arrival)
    positions = np.asarray(positions, dtype=float)
    if positions.shape != arrival.shape:
        raise ValueError(f"positions: got shape {positions.shape}; expected {arrival.shape}")
    last_magnet = arrival.size if last_magnet is None else last_magnet
    require_integer(first_magnet=first_magnet, last_magnet=last_magnet)
    if not 1 <= first_magnet <= last_magnet <= arrival.size:
        raise ValueError(f"first_magnet, last_magnet: got {first_magnet}, {last_magnet}; "
                         f"expected 1 <= first_magnet <= last_magnet <= {arrival.size}")
    window = entries(first_magnet, last_magnet)
    t, x = arrival[window], positions[window]
    keep = np.isfinite(t)
    if keep.sum() < 3:
        return FrontFit(NAN, NAN, NAN, first_magnet, last_magnet, int(keep.sum()))
    (velocity,), (stderr,), residual = _front_lines(x[keep][None], t[keep][None])
    return FrontFit(
        velocity=float(velocity),
        velocity_stderr=float(stderr),
        residual_rms=float(np.sqrt(np.mean(residual**2))),
        first_magnet=first_magnet,
        last_magnet=last_magnet,
        n_points=int(keep.sum()),
    )


def fit_front_speeds(arrival, positions, first_magnet: int, last_magnet: int) -> tuple[np.ndarray, np.ndarray]:
    """`fit_propagation_velocity` of R chains at once over one window of magnets, first_magnet
    .. last_magnet (1-based, inclusive), with no plateau criterion: arrival (R, N) ms and
    positions (R, N) mm give V_P (R,) m/s and its standard error (R,). NaN for a chain where any
    magnet of the window has no arrival: a front that did not cross the whole window has no speed
    over it (`fit_propagation_velocity` fits the magnets that have one)."""
    arrival = np.atleast_2d(np.asarray(arrival, dtype=float))
    positions = np.broadcast_to(np.asarray(positions, dtype=float), arrival.shape)
    require_integer(first_magnet=first_magnet, last_magnet=last_magnet)
    if not 1 <= first_magnet < last_magnet - 1 < arrival.shape[1]:
        raise ValueError(f"first_magnet, last_magnet: got {first_magnet}, {last_magnet}; "
                         f"expected 1 <= first_magnet, first_magnet + 2 <= last_magnet <= {arrival.shape[1]}")
    window = entries(first_magnet, last_magnet)
    velocity, stderr, _ = _front_lines(positions[:, window], arrival[:, window])
    return velocity, stderr


def _front_lines(x, t) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Least squares t = t_0 + x / V of each row of x (R, k) mm and t (R, k) ms, k >= 3, in
    closed form (scipy.stats.linregress's numbers to 1e-12 of V, without its ~0.3 s import): V (R,)
    m/s, its standard error (R,) from the residuals (k - 2 degrees of freedom), and the
    residuals of t (R, k), ms. NaN in a row where any t is."""
    dx = x - x.mean(axis=1, keepdims=True)
    dt = t - t.mean(axis=1, keepdims=True)
    with np.errstate(invalid="ignore", divide="ignore"):
        slope = np.sum(dx * dt, axis=1) / np.sum(dx * dx, axis=1)  # ms per mm
        residual = dt - slope[:, None] * dx
        slope_stderr = np.sqrt(np.sum(residual**2, axis=1) / (t.shape[1] - 2) / np.sum(dx * dx, axis=1))
        return 1.0 / slope, slope_stderr / slope**2, residual


@dataclass(frozen=True)
class Plateau:
    """Level of a per-gap or per-magnet series over its trailing window (see `trailing_plateau`).

    mean, std: of the finite values in the window; drift: the relative change across the window
    of the least-squares line through them, slope * (last - first) / mean; drift_stderr: its
    standard error from the scatter of the values (0 for values on a line, NaN for 2 values);
    over: "gap" or "magnet", what the series' entries are; first, last: the window, as the
    1-based, inclusive numbers of its first and last gap (or magnet), e.g. gaps 145 .. 193 =
    values[144:193] (`to_dict` names them first_gap, last_gap or first_magnet, last_magnet).
    The numbers NaN, and first, last None, when there are too few finite values. A series
    whose drift exceeds the tolerance and three standard errors, or whose values scatter by
    more than SCATTER_LIMIT of their mean, is not a plateau: `converged()` is False, and
    `to_dict` reports it with `converged: false` beside its drift.
    """

    mean: float
    std: float
    drift: float
    first: int | None
    last: int | None
    drift_stderr: float = 0.0
    over: str = "gap"

    def converged(self, rtol: float = 0.01) -> bool:
        """True if the values scatter by at most SCATTER_LIMIT of their mean and the series changes
        by at most rtol (relative) across the window, or by no more than three standard errors of
        its drift: a noisy series (e.g. V_P in a thermal chain, which scatters by about 1 % per
        gap) is not called drifting for a trend its scatter makes (three: a steady series with
        Gaussian scatter is called drifting 0.3 % of the time), but a series that scatters by
        about its mean has no level, whatever its drift (e.g. arrival times read from frames far
        coarser than a gap's crossing; `Front.resolution` says when they are)."""
        return bool(_converged(self.mean, self.std, self.drift, self.drift_stderr, rtol))

    def to_dict(self, rtol: float = 0.01) -> dict:
        """The plateau as a dict of plain values (JSON), with `converged(rtol)`."""
        return jsonable({"mean": self.mean, "std": self.std, "relative_drift": self.drift,
                         "relative_drift_stderr": self.drift_stderr, f"first_{self.over}": self.first,
                         f"last_{self.over}": self.last, "converged": self.converged(rtol), "converged_rtol": rtol})


def _converged(mean, std, drift, drift_stderr, rtol: float):
    """`Plateau.converged` of values or of arrays of them (`Plateaus.converged`)."""
    noisy = np.where(np.isfinite(drift_stderr), 3.0 * np.asarray(drift_stderr, dtype=float), 0.0)
    return (np.abs(drift) <= np.maximum(rtol, noisy)) & (std <= SCATTER_LIMIT * np.abs(mean))


@dataclass(frozen=True)
class Plateaus:
    """The `Plateau`s of R series (`trailing_plateaus`) as columns: mean, std, drift,
    drift_stderr arrays (R,); first, last lists of R numbers (None where undefined); over. A
    sequence of Plateau (len, index, iterate); `converged` of all at once."""

    mean: np.ndarray
    std: np.ndarray
    drift: np.ndarray
    drift_stderr: np.ndarray
    first: list
    last: list
    over: str = "gap"

    @classmethod
    def of(cls, plateaus) -> Plateaus:
        """Plateaus of one `over` as columns."""
        plateaus = list(plateaus)
        column = lambda name: np.array([getattr(p, name) for p in plateaus], dtype=float)  # noqa: E731
        return cls(column("mean"), column("std"), column("drift"), column("drift_stderr"), [p.first for p in plateaus],
                   [p.last for p in plateaus], plateaus[0].over if plateaus else "gap")

    def __len__(self) -> int:
        return len(self.first)

    def __getitem__(self, r: int) -> Plateau:
        return Plateau(float(self.mean[r]), float(self.std[r]), float(self.drift[r]), self.first[r], self.last[r],
                       float(self.drift_stderr[r]), self.over)

    def __iter__(self):
        return map(self.__getitem__, range(len(self)))

    def converged(self, rtol: float = 0.01) -> np.ndarray:
        """`Plateau.converged` of each, (R,) bool."""
        return _converged(self.mean, self.std, self.drift, self.drift_stderr, rtol)


def trailing_plateau(values, fraction: float = 0.25, min_points: int = 3, over: str = "gap") -> Plateau:
    """Plateau of a per-gap series (e.g. V_P, shape (N-1,), entry i gap i + 1) or, with
    over="magnet", a per-magnet one (shape (N,), entry i magnet i + 1), over its last entries
    that have a value: the last ceil(fraction * n_finite) finite entries (at least min_points),
    where n_finite counts finite entries. For V_P, the last quarter of the gaps the front
    crossed. Leave out an entry (the impactor's, say) by making it NaN: the numbers stay
    the magnets'. The drift is the slope of the least-squares line through the window's
    values against their entry numbers (closed form).
    """
    values = np.asarray(values, dtype=float)
    if values.ndim != 1:
        raise ValueError(f"values: got shape {values.shape}; expected (N,)")
    return trailing_plateaus(values[None], fraction, min_points, over)[0]


def trailing_plateaus(values, fraction: float = 0.25, min_points: int = 3, over: str = "gap") -> Plateaus:
    """`trailing_plateau` of each row of values (R, M), e.g. the V_P of R chains, as columns
    (`Plateaus`): row by row the plateau of the row alone, bit for bit (the windows of equal
    length are gathered into a C-ordered array, whose rows numpy reduces as it reduces a 1-D
    array)."""
    values = np.ascontiguousarray(values, dtype=float)
    if values.ndim != 2:
        raise ValueError(f"values: got shape {values.shape}; expected (R, N)")
    if over not in OVER:
        raise ValueError(f"over: got {over!r}; choose one of {', '.join(OVER)}")
    if not 0 < fraction <= 1:
        raise ValueError(f"fraction: got {fraction}; expected in (0, 1]")
    if min_points < 2:
        raise ValueError(f"min_points: got {min_points}; expected >= 2 (a line is fitted)")
    finite = np.isfinite(values)
    n_finite = finite.sum(axis=1)
    count = np.maximum(np.ceil(fraction * n_finite).astype(int), min_points)
    # rank of each finite entry from the row's end (1: its last finite entry)
    rank = np.cumsum(finite[:, ::-1], axis=1)[:, ::-1]
    r = len(values)
    out = Plateaus(np.full(r, NAN), np.full(r, NAN), np.full(r, NAN), np.full(r, NAN), [None] * r, [None] * r, over)
    for c, tail in set(zip(count.tolist(), np.minimum(2 * count, n_finite).tolist())):
        rows = np.flatnonzero((count == c) & (np.minimum(2 * count, n_finite) == tail) & (n_finite >= c))
        if rows.size == 0:
            continue
        index = np.nonzero(finite[rows] & (rank[rows] <= c))[1].reshape(rows.size, c)
        window = values[rows[:, None], index]
        tails = values[rows[:, None], np.nonzero(finite[rows] & (rank[rows] <= tail))[1].reshape(rows.size, tail)]
        out.mean[rows], out.std[rows], out.drift[rows], out.drift_stderr[rows] = _plateaus(window, index, tails)
        for k, first, last in zip(rows.tolist(), map(number, index[:, 0].tolist()), map(number, index[:, -1].tolist())):
            out.first[k], out.last[k] = first, last
    return out


def _plateaus(window, index, tail) -> tuple[np.ndarray, ...]:
    """mean, std, drift and drift_stderr (R,) of windows (R, c) of values at entries index
    (R, c), with the tails (R, <= 2 c) the scatter is estimated from (see trailing_plateau)."""
    count = window.shape[1]
    mean = window.mean(axis=1)
    x = index.astype(float)
    dx = x - x.mean(axis=1, keepdims=True)
    slope = np.sum(dx * (window - mean[:, None]), axis=1) / np.sum(dx * dx, axis=1)
    drift = slope * (index[:, -1] - index[:, 0]) / mean
    # The drift's standard error if each value scatters independently by s, estimated from the
    # second differences (variance 6 s^2) of the window and as many values before it; a smooth
    # series (any noise-free one) has s, hence the error, near 0.
    scatter = np.sqrt(np.mean(np.diff(tail, 2) ** 2, axis=1) / 6) if tail.shape[1] > 2 else np.full(len(window), NAN)
    stderr = scatter / np.abs(mean) * (count - 1) * np.sqrt(12 / (count * (count**2 - 1)))
    return mean, window.std(axis=1), drift, stderr


def _arrival(arrival):
    arrival = np.asarray(arrival, dtype=float)
    if arrival.ndim != 1 or arrival.size < 2:
        raise ValueError(f"arrival: got shape {arrival.shape}; expected (N,) with N >= 2")
    return arrival
