"""The case: its sections together, with the checks that need more than one of them (the
table against the gaps, the time step against the stiffest spring, a long lattice's N)."""

from __future__ import annotations

import logging
import math
import sys
from dataclasses import dataclass, replace
from functools import cached_property, lru_cache

import numpy as np

from ..errors import ConfigError
from ..exact import weak_shock
from ..forcelaw import ForceLaw
from ..impactor import Impactor
from .chain import CHUNK, KEPT_DRAWS, Chain
from .checks import MAX_PARTICLES, _steps, check_name
from .model import Friction, SecondNeighbour
from .settings import OutputSettings, RunSettings, TableSettings

logger = logging.getLogger(__name__)

# Extra particles beyond the front's reach in a long lattice: the dispersive precursor ahead
# of the front decays over a few particles, so 20 keep the held end unperturbed.
LONG_LATTICE_MARGIN = 20
# How finely the positions (doubles) must resolve the smallest gap at the chain's far end.
GAP_DIGITS = 1e-6
# The keys of the cases whose extremes passed `Case._check_extremes` (bounded: cleared when full).
_CHECKED: set[tuple] = set()


@dataclass(frozen=True)
class Case:
    """One simulation, checked when built (ConfigError naming the field); with a disordered
    chain of many magnets, the checks that need every draw wait for the preflight (`_extremes`)."""

    chain: Chain
    force: ForceLaw
    impactor: Impactor
    run: RunSettings
    table: TableSettings = TableSettings()
    friction: Friction | None = None  # None: frictionless
    output: OutputSettings = OutputSettings()
    second_neighbour: SecondNeighbour | None = None  # None: nearest neighbours only
    name: str = "case"

    def __post_init__(self):
        check_name(self.name)
        _check_rest_stiffness(self.chain, self.force)  # before V0 sizes a long lattice
        if self.chain.particles is None:
            n = long_lattice_particles(self.chain, self.force, self.impactor, self.run.duration)
            object.__setattr__(self, "chain", replace(self.chain, particles=n))
            self._drop_fine_beyond_chain()
        # the chain engine's fix handles nearest neighbours only
        if self.second_neighbour is not None and self.run.engine != "stock":
            raise ConfigError("run.engine", f"got {self.run.engine!r}; second neighbours need run.engine = 'stock'")
        if getattr(self.impactor, "after", None) == "stop" and self.run.duration > self.impactor.duration():
            raise ConfigError("run.duration", f"got {self.run.duration} ms; the measured impactor data end at "
                              f"{self.impactor.duration()} ms (impactor.after = 'stop')")
        n = self.chain.particles
        if any(not 1 <= k <= n for k in self.output.fine):
            raise ConfigError("output.fine", f"got {list(self.output.fine)}; expected magnet numbers in [1, {n}]")
        if self.output.fine:
            _steps("output.fine_interval", self.fine_interval(), self.run.dt)
        if self.chain.draws() <= CHUNK:  # else at first use, after the preflight has seen N (see _extremes)
            self.check_draws()

    def check_draws(self) -> None:
        """Refuse (ConfigError) a case whose drawn masses or gaps do not fit it (see `_extremes`);
        run once, when the case is built or at the first need of its table range."""
        self._extremes

    @cached_property
    def _extremes(self) -> tuple[float, float, float]:
        """The smallest and widest initial gap (mm) and the smallest mass (g), with the checks
        that need them: every mass and gap > 0, a table that covers every gap within the law's
        range, and dt below the stability limit of the lightest magnet.

        With mass or gap disorder they take a draw per magnet. Up to CHUNK draws (a few ms),
        they run when the case is built; beyond, at their first use: `preflight.check` after it
        has refused from N a case this machine cannot run, and `table_range`, which every deck
        needs, so that no deck is written and no run starts without them."""
        lightest = self.chain.mass_range[0]
        smallest, widest = self.chain.gap_range
        # the checks below depend on these alone: a sweep's replicas without disorder pass them once
        key = (self.force, self.table, self.second_neighbour, self.run.dt, self.chain.particles, smallest, widest,
               lightest, self.chain.thermal_velocity)
        try:
            if key in _CHECKED:
                return smallest, widest, lightest
        except TypeError:  # a law with unhashable parameters: checked each time
            key = None
        self._check_extremes(smallest, widest, lightest)
        if key is not None:
            if len(_CHECKED) >= KEPT_DRAWS:
                _CHECKED.clear()
            _CHECKED.add(key)
        return smallest, widest, lightest

    def _check_extremes(self, smallest: float, widest: float, lightest: float) -> None:
        lo, hi = self.table_range(widest)
        if not math.isfinite((self.chain.particles - 1) * widest * 3):  # positions and table in doubles
            raise ConfigError("chain.r0", f"got gaps up to {widest:g} mm; expected a chain whose length is finite")
        # positions in doubles: the chain's far end must still resolve its smallest gap (a 2^63 mm
        # defect gap left the gaps beyond it 0, "touched at t = 0")
        longest = smallest * GAP_DIGITS / sys.float_info.epsilon / (self.chain.particles - 1)
        if widest > longest:
            field = "chain.defect_r0" if widest == float(self.chain.defect_r0 or 0) else "chain.r0"
            raise ConfigError(field, f"got {widest:g} mm; expected at most {longest:.4g} mm (a chain of "
                              f"{self.chain.particles} magnets with gaps up to that keeps its smallest gap, "
                              f"{smallest:g} mm, to {GAP_DIGITS:g} of itself in double precision)")
        if not math.isfinite(hi):
            raise ConfigError("table.r_max", f"got {hi} mm; expected a finite table range")
        if self.second_neighbour is not None:
            self._check_second_neighbour(lo, hi)
        d = self.force.domain()
        if not hi > lo:
            raise ConfigError("table.r_max", f"got {hi} mm; expected > {lo} mm (the table's start)")
        if lo < d[0] or lo > smallest:
            raise ConfigError("table.r_min", f"got {lo} mm; expected in [{d[0]}, {smallest}] mm "
                              f"(the law's range starts at {d[0]} mm; the smallest gap)")
        if not _finite_at(self.force, lo, hi):
            raise ConfigError("table.r_min", f"got {lo} mm; the {self.force.law} law is not finite there; expected > {lo} mm")
        if not hi > widest:
            raise ConfigError("table.r_max", f"got {hi:g} mm; expected > {widest:g} mm, the widest initial gap "
                                             "(the table must cover every separation of the run)")
        if d[1] < hi:
            raise ConfigError("table.r_max", f"table [{lo}, {hi}] mm and gaps must lie in the law's range [{d[0]}, {d[1]}] mm")
        v_t = self.chain.thermal_velocity
        if v_t and not v_t * self.run.dt < smallest:  # mm/ms = m/s; v^2 overflows beyond 1e154 m/s
            raise ConfigError("chain.thermal_velocity", f"got {v_t:g} m/s; expected >= 0 and < {smallest / self.run.dt:.4g} "
                              f"m/s (the smallest gap {smallest:g} mm / run.dt {self.run.dt:g} ms: an RMS speed that "
                              "crosses a gap in one step)")
        dt_max = self._stability_limit(lo, hi, lightest)
        if self.run.dt >= dt_max:
            raise ConfigError("run.dt", f"got {self.run.dt} ms; expected < {dt_max:.4g} ms (stability limit of the stiffest spring)")

    def _drop_fine_beyond_chain(self):
        """A long lattice's N follows from run.duration: a shorter run makes a shorter chain, and
        the output.fine magnets beyond it are dropped, with a warning."""
        n = self.chain.particles
        beyond = [k for k in self.output.fine if isinstance(k, int) and k > n]
        if beyond:
            logger.warning("output.fine: magnets %s are beyond this long lattice's N = %d (set by run.duration = %g ms); "
                           "dropped", beyond, n, self.run.duration)
            kept = tuple(k for k in self.output.fine if k not in beyond)
            object.__setattr__(self, "output", replace(self.output, fine=kept))

    def fine_interval(self) -> float:
        """Interval of the fine output, ms (default: every time step)."""
        return self.output.fine_interval if self.output.fine_interval is not None else self.run.dt

    def table_range(self, widest: float | None = None) -> tuple[float, float]:
        """Separations covered by the potential table, mm: table.r_min (default: the start of the
        law's range) to table.r_max (default: 3 times the widest initial gap). `widest`: the
        widest gap (mm) to size the table for instead of the chain's, which are drawn and
        checked first (see `_extremes`); the preflight passes a sample's."""
        if widest is None:
            widest = self._extremes[1]
        r_min = self.table.r_min if self.table.r_min is not None else self.force.domain()[0]
        r_max = self.table.r_max if self.table.r_max is not None else 3 * widest
        return r_min, r_max

    def _check_second_neighbour(self, lo: float, hi: float):
        lo2, hi2 = self.second_table_range((lo, hi))
        law = self.second_neighbour.law
        d = law.domain()
        finite = _finite_at(law, lo2, hi2)
        if lo2 < d[0] or hi2 > d[1] or not finite:
            raise ConfigError("second_neighbour", f"the law must be finite on [{lo2}, {hi2}] mm (twice the nearest "
                              f"table's range); its range is [{d[0]}, {d[1]}] mm")

    def second_table_range(self, nearest: tuple[float, float] | None = None) -> tuple[float, float]:
        """Separations d = x_(n+2) - x_n covered by the second-neighbour table, mm: twice the
        nearest table's range (both gaps within it); `nearest`: that range (default: table_range())."""
        lo, hi = nearest or self.table_range()
        return 2 * lo, 2 * hi

    def held(self) -> list[int]:
        """0-based indices of the magnets held at the far end: the last one; for a long lattice
        with second neighbours the last two, so that every free magnet starts in balance (a
        magnet next to a single held one would feel its second neighbour on one side only)."""
        n = self.chain.particles
        if self.second_neighbour is not None and self.chain.far_end == "long":
            return [n - 2, n - 1]
        return [n - 1]

    def stability_limit(self) -> float:
        """Largest stable velocity-Verlet time step, ms.

        The highest normal-mode frequency of a chain with springs of stiffness <= k_max and
        masses >= m_min is below 2 sqrt(k_max/m_min); Verlet is stable for omega dt < 2, so
        dt < sqrt(m_min/k_max). k_max is the largest stiffness over the table's range
        (for the paper's law at contact, r = 0: 0.4535 ms). sqrt(g / (N/mm)) is exactly 1 ms.
        With second neighbours of stiffness |k2| <= k2_max (Gershgorin: omega^2 <= 4 (k_max +
        k2_max)/m), k_max + k2_max takes the place of k_max.
        """
        return self._stability_limit(*self.table_range(), self._extremes[2])

    def _stability_limit(self, lo: float, hi: float, lightest: float) -> float:
        with np.errstate(all="ignore"):  # extreme parameters: judged by the result below
            k_max = _max_stiffness(self.force, lo, hi)
            if self.second_neighbour is not None:
                r2 = np.linspace(*self.second_table_range((lo, hi)), 20001)
                k_max += float(np.max(np.abs(self.second_neighbour.stiffness(r2))))
        if not (0 < k_max < math.inf):
            raise ConfigError("force", f"largest stiffness {k_max:g} N/mm on the table [{lo:g}, {hi:g}] mm; "
                                       "expected finite and > 0 (a chain that carries waves)")
        return math.sqrt(lightest / k_max)


def _check_rest_stiffness(chain: Chain, law: ForceLaw) -> None:
    """Refuse (ConfigError naming chain.r0 or chain.defect_r0) nominal gaps where the law's stiffness k = -dF/dr is
    not a finite normal number > 0: a chain at rest there carries no waves (V0 = r0 sqrt(k/m) is
    0 or imaginary: unstable), so there is no shock to simulate, and V0 and the weak-shock
    coefficient (`exact.weak_shock`), which size a long lattice and check the units, are undefined.
    For the paper's law k evaluates to 0 beyond r0 = 1.158e77 mm, where (r0 + b)^4 overflows; a
    Lennard-Jones or Morse chain stretched past its inflection point has k < 0. Gaps below the
    smallest normal double (2.2e-308 mm) have too few digits to take a difference of (the weak
    shock's F'')."""
    tiny = sys.float_info.min
    # each gap given, and their mean: what the long lattice's size and the unit check use (plain
    # floats: a sweep builds a case per member); the defect's gap too (1e300 mm: k = 0, no V0)
    gaps = [float(chain.r0)] if np.isscalar(chain.r0) else [*map(float, chain.r0), float(np.mean(chain.r0))]
    named = [("chain.r0", r) for r in gaps]
    if chain.defect_r0 is not None:
        named.append(("chain.defect_r0", float(chain.defect_r0)))
    for field, r in named:
        if r < tiny:
            raise ConfigError(field, f"got {r:g} mm; expected >= {tiny:.4g} mm (the smallest normal double: below "
                                     "it a gap has too few significant digits)")
    with np.errstate(all="ignore"):
        k = law.stiffness([r for _, r in named]).tolist()
    bad = [(field, r, kr) for (field, r), kr in zip(named, k) if not tiny <= kr < math.inf]
    if not bad:
        return
    field, r, kr = bad[0]
    where = _rest_range(law, r)
    raise ConfigError(field, f"got {r:g} mm, where the {law.law} law's stiffness -dF/dr is {kr:g} N/mm; expected "
                      "a gap where it is finite and > 0 (a chain at rest that carries waves)"
                      + (f": {where} mm for this law" if where else "; no gap has it for this law's parameters"))


def _rest_range(law: ForceLaw, r: float) -> str | None:
    """The gaps (mm, normal doubles) nearest `r` where `law`'s stiffness is finite and > 0, as
    text ("a to b", "up to b"), found on a grid of 10 points a decade refined to 4 digits; None if none."""
    tiny = sys.float_info.min

    def ok(x):
        with np.errstate(all="ignore"):
            k = law.stiffness(x)
        return (k >= tiny) & (k < math.inf)

    grid = np.geomspace(tiny, 1e308, 6160)  # 10 a decade
    good = ok(grid)
    if not good.any():
        return None
    nearest = int(np.flatnonzero(good)[np.argmin(np.abs(np.log(grid[good]) - math.log(max(r, tiny))))])
    edges = np.flatnonzero(np.diff(good.astype(int)))  # the last index before each change
    below, above = edges[edges < nearest], edges[edges >= nearest]

    def edge(i):  # the boundary between grid[i] and grid[i + 1], to 1e-4 of a decade
        fine = np.geomspace(grid[i], grid[i + 1], 1001)
        hits = np.flatnonzero(ok(fine) == good[i + 1])
        return float(fine[hits[0]] if good[i + 1] else fine[hits[0] - 1])

    low = edge(below[-1]) if len(below) else None
    high = edge(above[0]) if len(above) else None
    if low is None:
        return f"up to {high:.4g}" if high is not None else "any"
    return f"{low:.4g} to {high:.4g}" if high is not None else f"from {low:.4g}"


def long_lattice_particles(chain: Chain, force: ForceLaw, impactor: Impactor, duration: float) -> int:
    """N for a long lattice: the front must not reach the held end within `duration`.

    The front speed is bounded by V_bound = V0 + 2 max(1, s) V_peak (V0 the linear wave speed
    at r0, V_peak the impactor's peak velocity, s the weak-shock coefficient r0 F''/(4 |F'|),
    `exact.weak_shock`): behind the front particles move at up to 2 V_I (the paper's saturated
    first peak), and the front outruns linear waves by at most that for the magnets (s = 0.75);
    a stiffer law's lead soliton outruns them by about (4/3) s u_p (Toda s = B r0 / 4,
    Lennard-Jones 5.25, Morse 3 alpha r0 / 4). For the paper's case V_bound = 5.6 m/s against
    the measured 3.92 m/s. A heuristic, not a theorem: near a sonic vacuum (FPUT with k = 0.001,
    beta = 1, V_I = 0.1 m/s) a front ran at 4.3 m/s against a bound of 0.58 (docs/engine.md).
    Runs check it afterwards: the last free particle must have stayed at rest (`far_end_quiet`).
    """
    if not impactor.peak_velocity() > 0:
        raise ConfigError("chain.far_end", "a long lattice needs a moving impactor; use far_end = 'fixed'")
    r0, m = float(chain.r0), float(chain.mass)
    shock = weak_shock(force, r0, m)  # c0 = V0 in mm/ms = m/s
    v_bound = shock.c0 + 2 * max(1.0, shock.s) * impactor.peak_velocity()
    n = v_bound * duration / r0 + LONG_LATTICE_MARGIN
    if not n <= MAX_PARTICLES:
        raise ConfigError("run.duration", f"got {duration} ms; a long lattice would need {n:.3g} magnets, "
                                          f"expected at most {MAX_PARTICLES}")
    return math.ceil(v_bound * duration / r0) + LONG_LATTICE_MARGIN


def _max_stiffness(law, lo: float, hi: float) -> float:
    """Largest stiffness of `law` on [lo, hi] mm, N/mm: at lo for a law that softens (`Law.softens`,
    what sampling finds there, its first sample); else sampled. Cached: sweeps ask it per member,
    and under gap disorder each replica has its own hi (3 times its widest gap), which took 0.12
    ms a replica to sample."""
    return _stiffness_at(law, lo) if law.softens else _sampled_max_stiffness(law, lo, hi)


@lru_cache(maxsize=64)
def _stiffness_at(law, r: float) -> float:
    return float(law.stiffness(np.array([r]))[0])


@lru_cache(maxsize=64)
def _sampled_max_stiffness(law, lo: float, hi: float) -> float:
    return float(np.max(law.stiffness(np.linspace(lo, hi, 20001))))


def _finite_at(law: ForceLaw, lo: float, hi: float) -> bool:
    """Whether `law`'s force, energy and stiffness are finite at both ends of [lo, hi] mm."""
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        return bool(np.all(np.isfinite([f(np.array([lo, hi])) for f in (law.force, law.energy, law.stiffness)])))
