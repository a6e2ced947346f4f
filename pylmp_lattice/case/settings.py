"""How a case runs and what it writes: [run], [table] and [output]."""

from __future__ import annotations

import math
from dataclasses import dataclass, fields

from ..errors import ConfigError
from .checks import MAX_STEPS, _choice, _is_number, _steps

# "chain": the plugin's fix lattice/chain does the whole step (the default, ~10x faster);
# "stock": bonds + table + fix nve + fix move + fix lattice/friction, the cross-check.
ENGINES = ("chain", "stock")
OUTPUT_FORMATS = ("h5md", "text", "none")
COMPRESSIONS = ("lzf", "gzip", "none")


@dataclass(frozen=True)
class RunSettings:
    """[run]: how long and how finely to integrate, ms, and which engine (`ENGINES`)."""

    duration: float  # ms
    dt: float = 0.01  # ms
    output_interval: float = 0.1  # ms between dump frames
    check_interval: float | None = None  # ms between checks for touching magnets (stock engine); default output_interval
    engine: str = "chain"  # see ENGINES; the chain engine checks for contact at every step

    def __post_init__(self):
        _choice("run.engine", self.engine, ENGINES)
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
        _choice("output.format", self.format, OUTPUT_FORMATS)
        if not all(isinstance(n, int) and not isinstance(n, bool) for n in self.fine):
            raise ConfigError("output.fine", f"got {list(self.fine)!r}; expected a list of magnet numbers")
        if len(set(self.fine)) != len(self.fine):
            raise ConfigError("output.fine", f"got {list(self.fine)!r}; expected distinct magnet numbers")
        if self.fine_interval is not None and not (_is_number(self.fine_interval) and math.isfinite(self.fine_interval)
                                                    and self.fine_interval > 0):
            raise ConfigError("output.fine_interval", f"got {self.fine_interval!r} ms; expected > 0")
        _choice("output.compression", self.compression, COMPRESSIONS)
        if not isinstance(self.front, bool):
            raise ConfigError("output.front", f"got {self.front!r}; expected true or false")
