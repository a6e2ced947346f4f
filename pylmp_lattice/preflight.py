"""Checks before a run starts: its output size, memory and time against this machine, the
number of MPI ranks, and a time step that is stable but coarse.

The estimates are linear models calibrated on this project's 2-core machine with the main case
(301 magnets, 60 000 steps) at two output intervals (6001 and 601 frames), a 200 000-magnet
chain and a 40-magnet chain in which every magnet moves (see README, "A run you can trust").
They lean high, and are meant to catch runs that are off by orders of magnitude, not to
predict to the second. `output_bytes` is the one place that knows what each output format
costs on disk.
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

# Bytes on disk per atom and frame, at the peak of a run, by output.format:
# - text: LAMMPS's text dump (12 columns, %.12g), headers included: 63.5 when every magnet moves
#   (40 magnets struck at 2 m/s), less for a chain mostly at rest ("0" for each still value;
#   the main case 50.5);
# - h5md: the binary dump (id x vx fx, 4 doubles) plus, while it is converted, the H5MD file
#   (x, v, f, 3 doubles before compression; the main case compresses to 8.4).
DISK_BYTES_PER_ATOM_FRAME = {"text": 64.0, "h5md": 32.0 + 24.0, "none": 0.0}
# LAMMPS's per-rank memory for a bonded chain ("Per MPI rank memory": 61 MB at 2e5 atoms), rounded up.
ENGINE_BYTES_PER_ATOM = 400
# Reading a text dump back (the figure reads it) holds the text, its lines and the arrays:
# 3.1 bytes per dump byte. H5MD is converted in blocks and read by columns: BLOCK_BYTES.
READ_BYTES_PER_DUMP_BYTE = 3.1
BLOCK_BYTES = 64e6
# Without the engine's front record the whole trajectory is read to measure: t, u, v, a.
TRAJECTORY_BYTES_PER_ATOM_FRAME = 4 * 8.0
# Python, numpy, LAMMPS and matplotlib loaded: 151 MB.
BASE_MEMORY_BYTES = 151e6
# Engine 1.3e-7 s per atom-step (the front record included; under load); each written
# atom-frame costs 3.3e-6 s as text (writing, reading back) and 5e-7 s as H5MD (conversion);
# plus 1.2 s of start-up, measures and figure.
SECONDS_PER_ATOM_STEP = 1.3e-7
SECONDS_PER_ATOM_FRAME = {"text": 3.3e-6, "h5md": 5e-7, "none": 0.0}
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


def atom_frames(case: Case) -> int:
    """Atom-frames the run writes: every magnet each output_interval, the fine ones each fine_interval."""
    if case.output.format == "none":
        return 0
    fine = len(case.output.fine) * (case.run.steps() // round(case.fine_interval() / case.run.dt) + 1)
    return case.chain.particles * frames(case) + fine


def output_bytes(case: Case) -> float:
    """Peak bytes on disk of the run's per-frame output."""
    return DISK_BYTES_PER_ATOM_FRAME[case.output.format] * atom_frames(case)


def frames(case: Case) -> int:
    """Frames of the whole chain written, the first (t = 0) included; 0 without output."""
    return 0 if case.output.format == "none" else case.run.steps() // case.run.steps("output_interval") + 1


def estimate(case: Case, nprocs: int = 1) -> Estimate:
    n, steps, fmt = case.chain.particles, case.run.steps(), case.output.format
    out = output_bytes(case)
    memory = BASE_MEMORY_BYTES + ENGINE_BYTES_PER_ATOM * n
    memory += READ_BYTES_PER_DUMP_BYTE * out if fmt == "text" else BLOCK_BYTES if fmt == "h5md" else 0.0
    if not case.output.front:
        memory += TRAJECTORY_BYTES_PER_ATOM_FRAME * atom_frames(case)
    seconds = BASE_SECONDS + SECONDS_PER_ATOM_STEP * n * steps / max(1, min(nprocs, os.cpu_count() or 1))
    seconds += SECONDS_PER_ATOM_FRAME[fmt] * atom_frames(case)
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
