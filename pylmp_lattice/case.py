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
import math
import tomllib
from dataclasses import MISSING, dataclass, fields, replace
from functools import cached_property, lru_cache
from pathlib import Path

import numpy as np
import tomli_w

from .errors import ConfigError
from .exact import weak_shock
from .forcelaw import FPUT, ForceLaw, LennardJones, LinearSpring, Morse, PowerLaw, SampledLaw, Toda
from .piston import PROFILES, Impactor

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

    def __post_init__(self):
        if self.far_end not in FAR_ENDS:
            raise ConfigError("chain.far_end", f"got {self.far_end!r}; choose one of {', '.join(FAR_ENDS)}")
        if self.particles is None and self.far_end == "fixed":
            raise ConfigError("chain.particles", "missing; required when far_end = 'fixed'")
        if self.particles is not None and not (isinstance(self.particles, int) and self.particles >= 3):
            raise ConfigError("chain.particles", f"got {self.particles!r}; expected an integer >= 3")
        for name, unit, values in (("mass", "g", self.mass), ("r0", "mm", self.r0)):
            arr = np.atleast_1d(np.asarray(values, float))
            if not np.all(np.isfinite(arr) & (arr > 0)):
                raise ConfigError(f"chain.{name}", f"got {_show(values)} {unit}; expected > 0")
        n = self.particles
        if n is not None:
            for name, expected in (("mass", n), ("r0", n - 1)):
                values = getattr(self, name)
                if not np.isscalar(values) and len(values) != expected:
                    raise ConfigError(f"chain.{name}", f"got {len(values)} values; expected 1 or {expected}")
        elif not (np.isscalar(self.mass) and np.isscalar(self.r0)):
            raise ConfigError("chain.particles", "needed when mass or r0 is given per particle")
        self._check_ensemble()

    def _check_ensemble(self):
        for name, unit in (("thermal_velocity", " m/s"), ("mass_disorder", ""), ("r0_disorder", "")):
            value = getattr(self, name)
            if value is not None and not (_is_number(value) and math.isfinite(value) and value >= 0):
                raise ConfigError(f"chain.{name}", f"got {value!r}{unit}; expected >= 0")
        if self.disorder is not None and self.disorder not in DISORDER:
            raise ConfigError("chain.disorder", f"got {self.disorder!r}; choose one of {', '.join(DISORDER)}")
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
        for name, values in (("mass_disorder", self.masses()), ("r0_disorder", self.gaps())):
            if not np.all(values > 0):
                raise ConfigError(f"chain.{name}", f"got {getattr(self, name)}; a draw gave a value <= 0, "
                                  "expected a smaller disorder or disorder = 'uniform'")

    def random(self) -> bool:
        """Whether the chain has random fields (thermal velocities or disorder)."""
        return bool(self.thermal_velocity or self.mass_disorder or self.r0_disorder)

    def _streams(self) -> list[np.random.Generator]:
        # Independent streams for masses, gaps and velocities: turning one on does not change
        # the draws of the others.
        return [np.random.default_rng(s) for s in np.random.SeedSequence(self.seed or 0).spawn(3)]

    def _perturbed(self, nominal: np.ndarray, width: float | None, stream: int) -> np.ndarray:
        if not width:
            return nominal
        rng = self._streams()[stream]
        if self.disorder == "uniform":
            noise = rng.uniform(-math.sqrt(3), math.sqrt(3), nominal.shape)
        else:
            noise = rng.standard_normal(nominal.shape)
        return nominal * (1 + width * noise)

    # The draws are made once per chain (a sweep builds thousands of chains): the methods
    # return copies of these cached arrays.
    def masses(self) -> np.ndarray:
        """Mass of each particle, g, shape (N,), with disorder and defect."""
        return self._masses.copy()

    def gaps(self) -> np.ndarray:
        """Initial separations, mm, shape (N-1,), with disorder and defect."""
        return self._gaps.copy()

    def velocities(self) -> np.ndarray:
        """Initial thermal velocities, m/s, shape (N,); zero for the impactor and the held end.

        Free magnets get v = c sigma z (z standard normal) minus the mass-weighted mean, so the
        net momentum is zero. Removing the mean takes a known fraction of the expected v^2;
        c = sqrt(n / (n - 2 + n sum(m^2)/M^2)) (n free magnets of total mass M) restores it,
        so E[mean v^2] = thermal_velocity^2 exactly (c^2 = n/(n-1) for equal masses).
        """
        return self._velocities.copy()

    @cached_property
    def _masses(self) -> np.ndarray:
        nominal = np.broadcast_to(np.asarray(self.mass, float), (self.particles,)).copy()
        m = self._perturbed(nominal, self.mass_disorder, 0)
        if self.defect_mass is not None:
            m[self.defect_index - 1] = self.defect_mass
        return m

    @cached_property
    def _gaps(self) -> np.ndarray:
        nominal = np.broadcast_to(np.asarray(self.r0, float), (self.particles - 1,)).copy()
        r = self._perturbed(nominal, self.r0_disorder, 1)
        if self.defect_r0 is not None:
            r[self.defect_index - 1] = self.defect_r0
        return r

    @cached_property
    def _velocities(self) -> np.ndarray:
        v = np.zeros(self.particles)
        if not self.thermal_velocity:
            return v
        m = self.masses()[1:-1]
        n, total = len(m), float(np.sum(m))
        c = math.sqrt(n / (n - 2 + n * float(np.sum(m**2)) / total**2))
        z = self._streams()[2].standard_normal(n)
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
            raise ConfigError("run.engine", f"got {self.engine!r}; choose one of {', '.join(ENGINES)}")
        if self.check_interval is None:
            object.__setattr__(self, "check_interval", self.output_interval)
        for f in fields(self):
            if f.name == "engine":
                continue
            value = getattr(self, f.name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise ConfigError(f"run.{f.name}", f"got {value!r} ms; expected > 0")
        for name in ("output_interval", "check_interval", "duration"):
            _steps(f"run.{name}", getattr(self, name), self.dt)

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
            raise ConfigError("output.format", f"got {self.format!r}; choose one of {', '.join(OUTPUT_FORMATS)}")
        if not all(isinstance(n, int) and not isinstance(n, bool) for n in self.fine):
            raise ConfigError("output.fine", f"got {list(self.fine)!r}; expected a list of magnet numbers")
        if len(set(self.fine)) != len(self.fine):
            raise ConfigError("output.fine", f"got {list(self.fine)!r}; expected distinct magnet numbers")
        if self.fine_interval is not None and not (_is_number(self.fine_interval) and math.isfinite(self.fine_interval)
                                                    and self.fine_interval > 0):
            raise ConfigError("output.fine_interval", f"got {self.fine_interval!r} ms; expected > 0")
        if self.compression not in COMPRESSIONS:
            raise ConfigError("output.compression", f"got {self.compression!r}; choose one of {', '.join(COMPRESSIONS)}")
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
        if self.chain.particles is None:
            n = long_lattice_particles(self.chain, self.force, self.impactor, self.run.duration)
            object.__setattr__(self, "chain", replace(self.chain, particles=n))
        lo, hi = self.table_range()
        if self.second_neighbour is not None:
            self._check_second_neighbour()
            # the chain engine's fix handles nearest neighbours only
            if self.run.engine != "stock":
                raise ConfigError("run.engine", f"got {self.run.engine!r}; second neighbours need run.engine = 'stock'")
        d = self.force.domain()
        if not hi > lo:
            raise ConfigError("table.r_max", f"got {hi} mm; expected > {lo} mm (the table's start)")
        if lo < d[0] or lo > min(self.chain.gaps()):
            raise ConfigError("table.r_min", f"got {lo} mm; expected in [{d[0]}, {min(self.chain.gaps())}] mm "
                              f"(the law's range starts at {d[0]} mm; the smallest gap)")
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            ends = [f(np.array([lo, hi])) for f in (self.force.force, self.force.energy, self.force.stiffness)]
        if not np.all(np.isfinite(ends)):
            raise ConfigError("table.r_min", f"got {lo} mm; the {self.force.law} law is not finite there; expected > {lo} mm")
        widest = float(np.max(self.chain.gaps()))
        if not hi > widest:
            raise ConfigError("table.r_max", f"got {hi:g} mm; expected > {widest:g} mm, the widest initial gap "
                                             "(the table must cover every separation of the run)")
        if d[1] < hi:
            raise ConfigError("table.r_max", f"table [{lo}, {hi}] mm and gaps must lie in the law's range [{d[0]}, {d[1]}] mm")
        if getattr(self.impactor, "after", None) == "stop" and self.run.duration > self.impactor.duration():
            raise ConfigError("run.duration", f"got {self.run.duration} ms; the measured impactor data end at "
                              f"{self.impactor.duration()} ms (impactor.after = 'stop')")
        n = self.chain.particles
        if any(not 1 <= k <= n for k in self.output.fine):
            raise ConfigError("output.fine", f"got {list(self.output.fine)}; expected magnet numbers in [1, {n}]")
        if self.output.fine:
            _steps("output.fine_interval", self.fine_interval(), self.run.dt)
        dt_max = self.stability_limit()
        if self.run.dt >= dt_max:
            raise ConfigError("run.dt", f"got {self.run.dt} ms; expected < {dt_max:.4g} ms (stability limit of the stiffest spring)")

    def fine_interval(self) -> float:
        """Interval of the fine output, ms (default: every time step)."""
        return self.output.fine_interval if self.output.fine_interval is not None else self.run.dt

    def table_range(self) -> tuple[float, float]:
        """Separations covered by the potential table, mm."""
        r_min = self.table.r_min if self.table.r_min is not None else self.force.domain()[0]
        r_max = self.table.r_max if self.table.r_max is not None else 3 * float(np.max(self.chain.gaps()))
        return r_min, r_max

    def _check_second_neighbour(self):
        lo2, hi2 = self.second_table_range()
        law = self.second_neighbour.law
        d = law.domain()
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            finite = np.all(np.isfinite([f(np.array([lo2, hi2])) for f in (law.force, law.energy, law.stiffness)]))
        if lo2 < d[0] or hi2 > d[1] or not finite:
            raise ConfigError("second_neighbour", f"the law must be finite on [{lo2}, {hi2}] mm (twice the nearest "
                              f"table's range); its range is [{d[0]}, {d[1]}] mm")

    def second_table_range(self) -> tuple[float, float]:
        """Separations d = x_(n+2) - x_n covered by the second-neighbour table, mm: twice the
        nearest table's range (both gaps within it)."""
        lo, hi = self.table_range()
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
        lo, hi = self.table_range()
        k_max = _max_stiffness(self.force, lo, hi)
        if self.second_neighbour is not None:
            k_max += float(np.max(np.abs(self.second_neighbour.stiffness(np.linspace(*self.second_table_range(), 20001)))))
        return math.sqrt(float(np.min(self.chain.masses())) / k_max)


@lru_cache(maxsize=64)
def _max_stiffness(law: ForceLaw, lo: float, hi: float) -> float:
    """Largest stiffness of `law` on [lo, hi] mm, N/mm, sampled (cached: sweeps ask it per member)."""
    return float(np.max(law.stiffness(np.linspace(lo, hi, 20001))))


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
    return math.ceil(v_bound * duration / r0) + LONG_LATTICE_MARGIN


# ----------------------------------------------------------------------------- TOML boundary

def load_case(path: str | Path, overrides: list[str] = ()) -> Case:
    """Read a case from TOML; `overrides` are 'section.key=value' strings (TOML values)."""
    path = Path(path)
    data = read_toml(path, "case")
    for item in overrides:
        apply_override(data, item)
    return case_from_dict(data, base_dir=path.parent)


def read_toml(path: Path, field: str) -> dict:
    """A TOML file as a dict; a missing or malformed file is a ConfigError naming `field`."""
    try:
        return tomllib.loads(Path(path).read_text())
    except FileNotFoundError as err:
        raise ConfigError(field, f"file not found: {path}") from err
    except tomllib.TOMLDecodeError as err:
        raise ConfigError(field, f"{path} is not valid TOML ({err})") from err


def apply_override(data: dict, item: str) -> None:
    """Set data[section][key] from 'section.key=value'; the value is parsed as TOML."""
    key, sep, text = item.partition("=")
    parts = key.strip().split(".")
    if not sep or len(parts) != 2 or not all(parts):
        raise ConfigError("--set", f"got {item!r}; expected SECTION.KEY=VALUE, e.g. impactor.velocity=1.5")
    try:
        value = tomllib.loads(f"v = {text.strip()}")["v"]
    except tomllib.TOMLDecodeError:
        value = text.strip()  # a bare word, e.g. far_end=long
    data.setdefault(parts[0], {})[parts[1]] = value


def case_from_dict(data: dict, base_dir: Path = Path(".")) -> Case:
    data = dict(data)
    name = data.pop("name", "case")
    sections = {"chain", "force", "impactor", "run", "table", "friction", "second_neighbour", "output"}
    for key in data:
        if key not in sections:
            raise ConfigError(key, f"unknown section; expected one of {', '.join(sorted(sections))}")
    for key in ("chain", "force", "impactor", "run"):
        if key not in data:
            raise ConfigError(key, "missing section")

    force = dict(data["force"])
    law = force.pop("law", "power")
    if law not in FORCE_LAWS:
        raise ConfigError("force.law", f"got {law!r}; choose one of {', '.join(FORCE_LAWS)}")
    force_keys = ("file",) if law == "sampled" else ()
    if law == "sampled" and "file" in force:
        force["r"], force["F"] = _read_columns(base_dir / force.pop("file"), "force.file", "r [mm], F [N]")
    impactor = dict(data["impactor"])
    profile = impactor.pop("profile", "constant")
    if profile not in PROFILES:
        raise ConfigError("impactor.profile", f"got {profile!r}; choose one of {', '.join(PROFILES)}")
    impactor_keys = ("file",) if profile == "measured" else ()
    if profile == "measured" and "file" in impactor:
        impactor["t"], impactor["values"] = _read_columns(base_dir / impactor.pop("file"), "impactor.file",
                                                          "t [ms], u [mm] or v [m/s]")

    return Case(
        chain=_build(Chain, "chain", data["chain"]),
        force=_build(FORCE_LAWS[law], "force", force, force_keys),
        impactor=_build(PROFILES[profile], "impactor", impactor, impactor_keys),
        # second neighbours run on the stock deck path: the default engine there
        run=_build(RunSettings, "run", ({"engine": "stock"} if "second_neighbour" in data else {}) | data["run"]),
        table=_build(TableSettings, "table", data.get("table", {})),
        friction=_build(Friction, "friction", data["friction"]) if "friction" in data else None,
        output=_build(OutputSettings, "output", data.get("output", {})),
        second_neighbour=_second_neighbour(data["second_neighbour"]) if "second_neighbour" in data else None,
        name=str(name),
    )


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
    if law not in FORCE_LAWS or law == "sampled":
        allowed = [k for k in FORCE_LAWS if k != "sampled"]
        raise ConfigError("second_neighbour.law", f"got {law!r}; choose one of {', '.join(allowed)}")
    if isinstance(sign, bool) or not isinstance(sign, (int, float)):
        raise ConfigError("second_neighbour.sign", f"got {sign!r}; expected -1 (attractive) or 1 (repulsive)")
    return SecondNeighbour(_build(FORCE_LAWS[law], "second_neighbour", values), float(sign))


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
            raise ConfigError(f"{section}.{key}", f"unknown key; expected one of {', '.join([*other_keys, *known])}")
        expected = known[key].type
        if (isinstance(value, bool) and "bool" not in expected) or (isinstance(value, str) and "str" not in expected):
            raise ConfigError(f"{section}.{key}", f"got {value!r}; expected a number")
        converted[key] = tuple(value) if isinstance(value, list) else value
    missing = [k for k, f in known.items() if k not in values and f.default is MISSING]
    if missing:
        raise ConfigError(f"{section}.{missing[0]}", "missing")
    try:
        return cls(**converted)
    except (TypeError, ValueError) as err:
        if isinstance(err, ConfigError):
            raise
        raise ConfigError(section, f"invalid values ({err})") from err


def _read_columns(path: Path, field: str, columns: str):
    """Two numeric columns of a CSV file ('#' comments) as two tuples."""
    try:
        table = np.loadtxt(path, delimiter=",", comments="#", ndmin=2)
    except FileNotFoundError as err:
        raise ConfigError(field, f"file not found: {path}") from err
    except ValueError as err:
        raise ConfigError(field, f"{path}: expected two numeric columns {columns} ({err})") from err
    if table.shape[1] != 2:
        raise ConfigError(field, f"{path}: got {table.shape[1]} columns; expected 2 ({columns})")
    return tuple(table[:, 0]), tuple(table[:, 1])


def case_id(case: Case) -> str:
    """The case's identity: 16 hex digits of a hash of its resolved form, the name left out (a
    label, not physics). One identity names run folders (`runs/NAME-<first 8>`) and sweep members."""
    return identity_hash({k: v for k, v in case_to_dict(case).items() if k != "name"})


def identity_hash(data: dict) -> str:
    """16 hex digits of a hash of a resolved case dict (keys sorted, so the order never matters;
    numbers normalised, so that 1 and 1.0 are one value)."""
    text = json.dumps(_normalised(data), sort_keys=True, separators=(",", ":"), default=str)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def _normalised(value):
    """A whole float as an int (1.0 -> 1), in nested dicts and lists: one text per number."""
    if isinstance(value, dict):
        return {k: _normalised(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_normalised(v) for v in value]
    if isinstance(value, float) and value.is_integer():
        return int(value)
    return value


def _steps(field: str, interval: float, dt: float) -> int:
    n = round(interval / dt)
    if n < 1 or abs(n * dt - interval) > 1e-9 * interval:
        raise ConfigError(field, f"got {interval} ms; expected a whole multiple of run.dt = {dt} ms")
    return n


def _is_number(value) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def _show(values) -> str:
    arr = np.atleast_1d(np.asarray(values, float))
    return str(values) if arr.size == 1 else f"{arr.min()}..{arr.max()} (min..max)"
