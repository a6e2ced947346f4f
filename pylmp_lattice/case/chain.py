"""The chain: its magnets, gaps, initial velocities and ensembles (disorder, defect, thermal)."""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from ..errors import ConfigError
from .checks import MAX_PARTICLES, _choice, _is_number, _show, brief

FAR_ENDS = ("fixed", "long")
DISORDER = ("normal", "uniform")
# Draws at a time when only the extremes of the masses or gaps are needed: memory stays bounded
# at any N (8 MB a chunk), and the numbers are those of masses() and gaps().
CHUNK = 1 << 20
# A chain of at most this many magnets keeps its masses, gaps and velocities once drawn: a
# sweep's batched member asks for them again in its deck, levels, front record and summary (each
# draw sets up three random streams, ~0.1 ms). Larger chains draw on each call (bounded memory).
KEPT_DRAWS = 4096
# The seed's independent streams: masses, gaps, velocities (`Chain._stream`)
MASS_STREAM, GAP_STREAM, VELOCITY_STREAM = 0, 1, 2


def check_seed(seed) -> None:
    """chain.seed's rule, for a chain and for a sweep's reseeded replica: an integer in [0, 2^63)."""
    if not (isinstance(seed, int) and not isinstance(seed, bool) and 0 <= seed < 2**63):
        raise ConfigError("chain.seed", f"got {seed!r}; expected an integer in [0, 2**63 - 1]")


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

    magnet_length: each magnet's length along the rod, mm (the paper's: 6.35, two 3.175 mm
    rings). It changes no force: the gaps r are between faces. It gives the lab frame, magnet
    centres a pitch r0 + L apart, in which the paper reads its front speed off Fig. 1(b)
    (`summary`'s front_speed_lab_m_per_s).
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
    magnet_length: float | None = None  # mm, along the rod; the lab frame's pitch is r0 + magnet_length

    def __post_init__(self):
        _choice("chain.far_end", self.far_end, FAR_ENDS)
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
        length = self.magnet_length
        if length is not None and not (_is_number(length) and math.isfinite(length) and 0 <= length <= 1e6):
            raise ConfigError("chain.magnet_length", f"got {brief(length)} mm; expected a number in [0, 1e6]")
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
        if self.disorder is not None:
            _choice("chain.disorder", self.disorder, DISORDER)
        if self.disorder == "uniform":
            for name in ("mass_disorder", "r0_disorder"):
                if (getattr(self, name) or 0) >= 1 / math.sqrt(3):
                    raise ConfigError(f"chain.{name}", f"got {getattr(self, name)}; expected < 0.5774 "
                                      "(uniform disorder of relative std w spans 1 +- sqrt(3) w)")
        if self.seed is not None:
            check_seed(self.seed)
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
                part *= 1 + width * self._noise(rng, np.empty(len(part)))
            yield self._with_defect(part, defect, start)

    def _noise(self, rng: np.random.Generator, out: np.ndarray) -> np.ndarray:
        """The disorder's relative noise (unit variance) drawn into `out`: uniform or normal."""
        if self.disorder == "uniform":
            out[:] = rng.uniform(-math.sqrt(3), math.sqrt(3), len(out))
        else:
            rng.standard_normal(out=out)
        return out

    def _with_defect(self, part: np.ndarray, defect: float | None, start: int = 0) -> np.ndarray:
        """`part` (values start, start + 1, ... of a series) with the defect's value in its place."""
        if defect is not None and 0 <= self.defect_index - 1 - start < part.shape[-1]:
            part[..., self.defect_index - 1 - start] = defect
        return part

    def _masses(self, chunk: int) -> Iterator[np.ndarray]:
        return self._series(self.mass, self.particles, self.mass_disorder, MASS_STREAM, self.defect_mass, chunk)

    def _gaps(self, chunk: int) -> Iterator[np.ndarray]:
        return self._series(self.r0, self.particles - 1, self.r0_disorder, GAP_STREAM, self.defect_r0, chunk)

    def masses(self, first: int | None = None) -> np.ndarray:
        """Mass of each particle, g, shape (N,), with disorder and defect; of particles 1 ..
        `first` only if given (the same numbers, drawn for those alone: a sample of any N)."""
        if first is not None:
            return next(self._masses(first))
        return self._kept("masses", lambda: next(self._masses(self.particles)))

    def gaps(self, first: int | None = None) -> np.ndarray:
        """Initial separations, mm, shape (N-1,), with disorder and defect; of gaps 1 .. `first`
        only if given (the same numbers, drawn for those alone: a sample of any N)."""
        if first is not None:
            return next(self._gaps(first))
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
        return self._range("mass_disorder", self.mass, self.defect_mass, self._masses, self.masses)

    @cached_property
    def gap_range(self) -> tuple[float, float]:
        """Smallest and largest initial separation, mm, in bounded memory at any N; ConfigError
        naming chain.r0_disorder if a draw gave a gap <= 0."""
        return self._range("r0_disorder", self.r0, self.defect_r0, self._gaps, self.gaps)

    def _range(self, name: str, nominal, defect, chunks, kept) -> tuple[float, float]:
        width = getattr(self, name)
        if not width and np.isscalar(nominal):  # no draws: the value and the defect (N >= 3 keeps one of each)
            values = [float(nominal)] + ([float(defect)] if defect is not None else [])  # an int may pass 2^53
            return min(values), max(values)
        # drawn in chunks, the numbers of masses() and gaps(); a chain that keeps its draws draws
        # them once, here, for the deck and the measures too (a replica under disorder drew them twice)
        low, high = _extremes(iter([kept()]) if self.particles <= KEPT_DRAWS else chunks(CHUNK))
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
        v[1:-1] = thermal_velocities(self.masses()[1:-1], [self.thermal_velocity], self.thermal_normals()[None])[0]
        return v

    def thermal_normals(self) -> np.ndarray:
        """The standard normal draws, shape (N-2,), that `thermal_velocities` makes the free
        magnets' thermal velocities of (from the seed's velocity stream; of many chains at once:
        `thermal_normals`)."""
        return self._stream(VELOCITY_STREAM).standard_normal(self.particles - 2)

    def positions(self) -> np.ndarray:
        """Initial positions x_n, mm, with x_1 = 0."""
        return np.concatenate([[0.0], np.cumsum(self.gaps())])


def replica_draws(chain: Chain, seeds) -> tuple[np.ndarray, np.ndarray]:
    """The masses (R, N) and gaps (R, N - 1) of `chain` with each of R seeds (a sweep's replicas
    of a point under disorder), drawn together, each row the bits of `replace(chain, seed=seed)`'s
    own masses() and gaps(): one generator re-seeded per seed (`seeding.stream_draws`) instead of
    a SeedSequence and a generator per replica and stream."""
    from .seeding import stream_draws

    def series(nominal, count, width, stream, defect):
        base = np.broadcast_to(np.asarray(nominal, float), (len(seeds), count)).copy()
        if width:
            base *= 1 + width * stream_draws(seeds, stream, count, chain._noise)
        return chain._with_defect(base, defect)

    n = chain.particles
    return (series(chain.mass, n, chain.mass_disorder, MASS_STREAM, chain.defect_mass),
            series(chain.r0, n - 1, chain.r0_disorder, GAP_STREAM, chain.defect_r0))


def thermal_normals(chains) -> np.ndarray:
    """`Chain.thermal_normals` of chains of equal N, shape (R, N-2), bit for bit, drawn together
    from one generator re-seeded per chain (`seeding.stream_normals`)."""
    from .seeding import stream_normals

    return stream_normals([chain.seed or 0 for chain in chains], VELOCITY_STREAM, chains[0].particles - 2)


def thermal_velocities(m: np.ndarray, thermal, z: np.ndarray) -> np.ndarray:
    """The free magnets' thermal velocities (`Chain.velocities`) of R chains with free masses m,
    g, the same (n,) or each chain's (R, n): RMS `thermal` (R,) m/s, from standard normal draws
    z (R, n); (R, n). Each row has the bits of its chain alone (the sums run along a row, the
    same operations in the same order)."""
    m = np.asarray(m, float)
    n, total = m.shape[-1], np.sum(m, axis=-1)
    c = np.sqrt(n / (n - 2 + n * np.sum(m**2, axis=-1) / total**2))
    free = (c * np.asarray(thermal, float))[:, None] * z
    return free - (np.sum(m * free, axis=1) / total)[..., None]


def _extremes(chunks: Iterator[np.ndarray]) -> tuple[float, float]:
    low, high = math.inf, -math.inf
    for part in chunks:
        low, high = min(low, float(part.min())), max(high, float(part.max()))
    return low, high
