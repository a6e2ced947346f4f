"""Checks before a run starts: its output size, memory and time against this machine, the
number of MPI ranks, and a time step that is stable but coarse.

The estimates are linear models calibrated on this project's 2-core machine with the main case
(301 magnets, 60 000 steps) at two output intervals (6001 and 601 frames), a 200 000-magnet
chain and a 40-magnet chain in which every magnet moves (see README, "A run you can trust").
They lean high, and are meant to catch runs that are off by orders of magnitude, not to
predict to the second.
"""

from __future__ import annotations

import logging
import math
import os
import shutil
from dataclasses import dataclass
from pathlib import Path

from .case import Case
from .errors import ConfigError
from .summary import linear_chain

log = logging.getLogger(__name__)

# The text dump (`dump custom ... %.12g`, 12 columns), headers included: 63.5 bytes per atom and
# frame when every magnet moves (40 magnets struck at 2 m/s); a chain mostly at rest writes less
# ("0" for each still value; the main case 50.5), so this is an upper estimate.
DUMP_BYTES_PER_ATOM_FRAME = 64.0
# LAMMPS's per-rank memory for a bonded chain ("Per MPI rank memory": 61 MB at 2e5 atoms), rounded up.
ENGINE_BYTES_PER_ATOM = 400
# Reading the text dump back holds the text, its lines and the arrays: 3.1 bytes per dump byte.
READ_BYTES_PER_DUMP_BYTE = 3.1
# Python, numpy, LAMMPS and matplotlib loaded: 151 MB.
BASE_MEMORY_BYTES = 151e6
# Engine: 5.3e-8 s per atom-step; each dumped atom-frame costs 2.1e-6 s to write and 1.2e-6 s
# to read back and measure; plus 1.2 s of start-up, measures and figure.
SECONDS_PER_ATOM_STEP = 5.3e-8
SECONDS_PER_ATOM_FRAME = 3.3e-6
BASE_SECONDS = 1.2
# Runs estimated to take longer need an explicit yes.
LONG_RUN_SECONDS = 3600.0
# dt above this fraction of the linear period 1/f0 is coarse.
COARSE_DT_FRACTION = 1 / 50


@dataclass(frozen=True)
class Estimate:
    """What a run will need: output on disk (bytes), peak memory (bytes) and wall time (s)."""

    frames: int
    output_bytes: float
    memory_bytes: float
    seconds: float

    def __str__(self) -> str:
        return (f"{self.frames} frames, output {_size(self.output_bytes)}, memory {_size(self.memory_bytes)}, "
                f"time {_duration(self.seconds)}")


def output_bytes(case: Case) -> float:
    """Bytes of trajectory output the case's output settings produce (the one place that knows the format)."""
    return DUMP_BYTES_PER_ATOM_FRAME * case.chain.particles * frames(case)


def frames(case: Case) -> int:
    """Trajectory frames written, the first (t = 0) included."""
    return case.run.steps() // case.run.steps("output_interval") + 1


def estimate(case: Case, nprocs: int = 1) -> Estimate:
    n, steps = case.chain.particles, case.run.steps()
    out = output_bytes(case)
    memory = BASE_MEMORY_BYTES + ENGINE_BYTES_PER_ATOM * n + READ_BYTES_PER_DUMP_BYTE * out
    seconds = BASE_SECONDS + SECONDS_PER_ATOM_STEP * n * steps / max(1, min(nprocs, os.cpu_count() or 1))
    seconds += SECONDS_PER_ATOM_FRAME * n * frames(case)
    return Estimate(frames(case), out, memory, seconds)


def check(case: Case, folder: str | Path, nprocs: int = 1, yes: bool = False) -> Estimate:
    """Refuse (ConfigError) a run that cannot fit this machine or, without `yes`, takes over an hour;
    warn about many ranks and a coarse time step. Returns the estimate."""
    if not (isinstance(nprocs, int) and nprocs >= 1):
        raise ConfigError("--np", f"got {nprocs!r}; expected an integer >= 1")
    cores = os.cpu_count() or 1
    if nprocs > cores:
        log.warning("--np %d is more than the %d cores of this machine: ranks will share cores and run slower",
                    nprocs, cores)
    coarse_dt_warning(case)
    est = estimate(case, nprocs)
    disk, memory = free_disk(folder), available_memory()
    if est.output_bytes > disk or (memory is not None and est.memory_bytes > memory):
        free = f"{_size(disk)} free on disk" + (f", {_size(memory)} memory available" if memory is not None else "")
        raise ConfigError("run", f"too large for this machine: {est}; {free} "
                                 "(fewer particles, a shorter run or a longer run.output_interval)")
    if est.seconds > LONG_RUN_SECONDS and not yes:
        raise ConfigError("run", f"estimated {est}; pass --yes (yes=True) to start a run this long")
    return est


def coarse_dt_warning(case: Case) -> str | None:
    """Warn (and return the text) when dt is stable but above 1/50 of the linear period 1/f0.

    Velocity Verlet advances a linear mode of angular frequency w with a phase error of
    (w dt)^2 / 24 per period, here at f0 (the top of the linear band, the summary's f0).
    Behind a shock the chain is compressed and stiffer, so shock measures err more: for the
    paper's long lattice at dt = 0.4 ms, V_P by +0.20 % and the first peak by -0.68 %.
    """
    f0 = linear_chain(case)[1]  # Hz
    period = 1e3 / f0  # ms
    if case.run.dt <= COARSE_DT_FRACTION * period:
        return None
    error = (2 * math.pi * f0 * case.run.dt * 1e-3) ** 2 / 24
    text = (f"run.dt: {case.run.dt:g} ms is stable but coarse, more than 1/50 of the linear period "
            f"1/f0 = {period:.4g} ms; expected phase error of linear waves {100 * error:.2g} %, "
            f"more behind a shock; use dt <= {COARSE_DT_FRACTION * period:.3g} ms")
    log.warning(text)
    return text


def free_disk(folder: str | Path) -> float:
    """Free bytes on the file system that holds (or will hold) `folder`."""
    path = Path(folder).resolve()
    while not path.exists():
        path = path.parent
    return float(shutil.disk_usage(path).free)


def available_memory() -> float | None:
    """Bytes of memory available to a new process (Linux MemAvailable), None where unknown."""
    try:
        for line in Path("/proc/meminfo").read_text().splitlines():
            if line.startswith("MemAvailable:"):
                return float(line.split()[1]) * 1024
    except OSError:
        pass
    return None


def _size(n: float) -> str:
    units = ("B", "kB", "MB", "GB", "TB", "PB", "EB")
    k = 0
    while abs(n) >= 1000 and k < len(units) - 1:
        n, k = n / 1000, k + 1
    return f"{n:.3g} {units[k]}"


def _duration(seconds: float) -> str:
    if seconds < 120:
        return f"{seconds:.2g} s"
    if seconds < 7200:
        return f"{seconds / 60:.3g} min"
    return f"{seconds / 3600:.3g} h"
