"""The per-particle front measures of a run, computed once for the summary and the figure, and
the gaps whose V_P cannot be a front's: flagged, not averaged.

Gap 1 (impactor to magnet 2) carries a front speed only with "level" arrivals. Magnet 1 is the
drive: its arrival is a time of the prescribed profile, not of a wave. With a level it is the
moment the drive's rise passes V_I/2 (t = 0 for a constant piston), and for a fast rise magnet
2 crosses the same level when that rise reaches it: gap 1's V_P continues the next gaps' (the
long lattice at V_I = 2 m/s, a constant drive and ramps of 1 and 10 ms: 2.61-2.62, then
3.06-3.16 and 3.37-3.54 m/s; the exact harmonic piston: 0.903 V0, then 0.923 and 0.953 V0).
A slow rise does not form a front at once: ramps of T_r = 25, 50 and 100 ms (same lattice,
magnet 1 at V_I/2 at T_r/2) gave 4.11, 3.06 and 3.86 m/s over gap 1 beside 2.82, 2.64 and
4.04 over gap 2, and gaps 3 (50 ms) and 6 and 10 (100 ms) out of order, flagged (study s7);
gap 1 is kept there (it is no time of the profile alone) but is no steady front's speed, which
the plateau over the last gaps is. With peak arrivals (a pulse's default) magnet
1's arrival is the drive's own maximum (T_s/2 for a half-sine), set by the profile, while
magnet 2's first maximum is the chain's response, from 10 ms before to 8 ms after the drive's
(the paper's experiment, V_I = 0.3-2.81 m/s, T_s = 30 and 47.8 ms): gap 1 gave up to 116 m/s,
or magnet 2 first (out of order) in 3 of these 8 runs, beside 1.7-4.3 m/s over gaps 2-4; no
wave of the chain exceeds 26.5 m/s (its linear speed at contact). So with peak arrivals gap 1
is `drive_gap`: left out, neither averaged nor flagged (the engine's record keeps the raw
arrivals; this is where both are interpreted)."""

from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np

from ._common import NAN
from .arrival import arrival_times
from .peaks import FirstPeaks, first_peaks
from .propagation import propagation_velocity

# A linear front's half-level crossing lags its sound speed by a little (an Airy front: V_P =
# V0 (1 - 0.068 n^(-2/3)) at gap n, 6.8 % at the first, see study s5); slower than the slowest
# linear speed by more than this fraction, a gap was not crossed by the front.
LINEAR_LAG = 0.1
# Arrival times read from frames resolve a gap's crossing only with at least this many frames per
# crossing (main job, 3.07 ms per gap: frames every 1 ms give V_P within 0.02 % and 0.7 % scatter,
# every 2 ms 12 % scatter, every 10 ms a plateau at 7.2 m/s for 3.9).
MIN_FRAMES_PER_GAP = 2.0


@dataclass(frozen=True)
class Front:
    """arrival (N,) ms by `arrival_method`; propagation_velocity (N-1,) m/s over each gap, as
    measured; peaks; noise: the noise velocity sigma the levels were set against, m/s;
    slowest_linear_speed: the chain's slowest linear wave speed, m/s (NaN: not checked);
    sample_interval: the time between the frames the arrival times were read from, ms (0: every
    step, the engine's record).

    Gap 1 is `drive_gap` (not a front's transit, see the module docstring) unless the arrivals
    are "level" ones. Any other gap is flagged when the front crossed it out of order
    (`out_of_order`: magnet n+1 reached no later than magnet n) or slower than any linear wave
    of the chain can travel (`below_linear_speed`: below (1 - LINEAR_LAG) times the slowest
    linear speed);
    `accepted_velocity` is V_P with the drive gap and flagged gaps NaN, what plateaus and
    maxima average.

    The fronts of R chains (a batch, `stack_fronts`) have arrays with a leading axis R (noise
    and slowest_linear_speed (R,)); their properties are those of each chain, row by row, and
    `resolutions`, `all_flags` and `row` give each chain's."""

    arrival: np.ndarray
    propagation_velocity: np.ndarray
    peaks: FirstPeaks
    arrival_method: str = "level"
    noise: float | np.ndarray = 0.0
    slowest_linear_speed: float | np.ndarray = NAN
    sample_interval: float = 0.0

    @property
    def drive_gap(self) -> np.ndarray:
        """True at gap 1 when magnet 1's arrival is the drive's own peak, not a front's (any
        arrivals but "level"), shape of propagation_velocity."""
        gap = np.zeros(np.shape(self.propagation_velocity), dtype=bool)
        gap[..., 0] = self.arrival_method != "level"
        return gap

    @property
    def out_of_order(self) -> np.ndarray:
        """Gaps whose far magnet's arrival is not later than the near one's (not the drive's gap 1)."""
        with np.errstate(invalid="ignore"):
            return ~self.drive_gap & (np.diff(self.arrival) <= 0)

    @property
    def below_linear_speed(self) -> np.ndarray:
        """Gaps (in order) whose V_P is below the chain's slowest linear speed, by more than LINEAR_LAG."""
        slowest = np.asarray(self.slowest_linear_speed)[..., None]  # a chain's, against its gaps
        with np.errstate(invalid="ignore"):
            return ~self.drive_gap & ~self.out_of_order & (self.propagation_velocity < (1 - LINEAR_LAG) * slowest)

    @property
    def accepted_velocity(self) -> np.ndarray:
        """V_P per gap, NaN where flagged (the drive's gap, out of order, below the linear speed)."""
        return np.where(self.drive_gap | self.out_of_order | self.below_linear_speed, NAN, self.propagation_velocity)

    def resolution(self) -> dict:
        """Whether the arrival times resolve each gap's crossing: the front's mean time per gap
        over the magnets it reached (ms; from magnet 2 where gap 1 is `drive_gap`: magnet 1's
        arrival is then the drive's), how many frames fall in it, and the longest frame interval
        that resolves it (ms); `resolved` is False below MIN_FRAMES_PER_GAP frames per gap,
        where V_P per gap and the first peaks are sampling artefacts; `arrival_method`, how the
        arrivals were taken (`arrival`)."""
        return self.resolutions()[0]

    def resolutions(self) -> list[dict]:
        """`resolution` of each chain (one for a single front)."""
        return _rows(self.resolution_columns())

    def resolution_columns(self) -> dict[str, list]:
        """`resolutions` as columns: each key's values, one a chain."""
        arrival = np.atleast_2d(self.arrival)
        reached = np.isfinite(arrival)
        reached[:, 0] &= ~np.atleast_2d(self.drive_gap)[:, 0]  # the drive's arrival is no front's: from magnet 2
        first, last = np.argmax(reached, axis=1), arrival.shape[1] - 1 - np.argmax(reached[:, ::-1], axis=1)
        rows = np.arange(len(arrival))
        with np.errstate(invalid="ignore", divide="ignore"):
            crossing = np.where((reached.sum(axis=1) > 1) & (last > first),
                                (arrival[rows, last] - arrival[rows, first]) / (last - first), NAN)
        n = len(crossing)
        if self.sample_interval > 0:
            frames = crossing / self.sample_interval
            per_gap, resolved = frames.tolist(), (frames >= MIN_FRAMES_PER_GAP).tolist()
        else:  # the engine's record of every step
            per_gap, resolved = [None] * n, [True] * n
        return {"arrival_method": [self.arrival_method] * n, "sample_interval_ms": [self.sample_interval] * n,
                "gap_crossing_time_ms": crossing.tolist(),
                "frames_per_gap": per_gap, "max_sample_interval_ms": (crossing / MIN_FRAMES_PER_GAP).tolist(),
                "resolved": resolved}

    def flags(self) -> dict:
        """The flagged gaps (1-based, gap n between magnets n and n+1) and what they were set against."""
        return self.all_flags()[0]

    def all_flags(self) -> list[dict]:
        """`flags` of each chain (one for a single front)."""
        return _rows(self.flag_columns())

    def flag_columns(self) -> dict[str, list]:
        """`all_flags` as columns: each key's values, one a chain."""
        late, slow = np.atleast_2d(self.out_of_order), np.atleast_2d(self.below_linear_speed)
        slowest, noise = (np.broadcast_to(x, len(late)).tolist() for x in (self.slowest_linear_speed, self.noise))
        return {"out_of_order_gaps": _gap_numbers(late), "below_linear_speed_gaps": _gap_numbers(slow),
                "slowest_linear_speed_m_per_s": slowest, "noise_velocity_m_per_s": noise}

    def row(self, r: int) -> Front:
        """Chain r's front, of the fronts of R chains."""
        pick = lambda x: float(x[r]) if np.ndim(x) else x  # noqa: E731
        return Front(self.arrival[r], self.propagation_velocity[r],
                     FirstPeaks(*(getattr(self.peaks, f.name)[r] for f in fields(FirstPeaks))), self.arrival_method,
                     pick(self.noise), pick(self.slowest_linear_speed), self.sample_interval)


def _gap_numbers(flagged: np.ndarray) -> list[list[int]]:
    """The flagged gaps (1-based) of each row of `flagged` (R, N-1); rows without any, most of a
    batch's, take no search."""
    out: list[list[int]] = [[] for _ in range(len(flagged))]
    for r in np.flatnonzero(flagged.any(axis=1)).tolist():
        out[r] = (np.flatnonzero(flagged[r]) + 1).tolist()
    return out


def _rows(columns: dict[str, list]) -> list[dict]:
    """Columns (a list per key) as a dict per row."""
    return [dict(zip(columns, values)) for values in zip(*columns.values())]


def stack_fronts(fronts) -> Front:
    """The fronts of R chains (equal N, method and sample interval) as one Front (see `Front`)."""
    first = fronts[0]
    odd = next((f for f in fronts if f.arrival_method != first.arrival_method
                or not np.array_equal(f.sample_interval, first.sample_interval, equal_nan=True)), None)
    if odd is not None:
        raise ValueError(f"fronts: method {odd.arrival_method!r} every {odd.sample_interval} ms beside "
                         f"{first.arrival_method!r} every {first.sample_interval} ms; a stack needs one of each")
    stack = lambda name: np.stack([getattr(f, name) for f in fronts])  # noqa: E731
    return Front(stack("arrival"), stack("propagation_velocity"),
                 FirstPeaks(*(np.stack([getattr(f.peaks, g.name) for f in fronts]) for g in fields(FirstPeaks))),
                 first.arrival_method, np.array([f.noise for f in fronts], dtype=float),
                 np.array([f.slowest_linear_speed for f in fronts], dtype=float), first.sample_interval)


def front(t, v, a, drive_velocity: float, spacing, arrival_method: str = "level", noise: float = 0.0,
          slowest_linear_speed: float = NAN) -> Front:
    """Arrival times (by `arrival_method`, see `arrival`), propagation velocity and first peaks,
    with levels set against V_I and the noise velocity sigma (m/s; see `levels`), read from
    frames at times t (ms; their largest spacing is the Front's sample_interval)."""
    arrival = arrival_times(t, v, drive_velocity, method=arrival_method, a=a, noise=noise)
    interval = float(np.max(np.diff(t))) if len(t) > 1 else NAN
    return Front(arrival, propagation_velocity(arrival, spacing), first_peaks(t, v, a, drive_velocity, noise=noise),
                 arrival_method, noise, slowest_linear_speed, interval)
