"""The checks before a run starts: `check` refuses (ConfigError, UsageError) a run that does
not fit this machine (free disk, available memory, a writable folder), that would take over an
hour without `yes`, or whose long lattice a unit slip has made huge; it warns about many MPI
ranks and a time step that is stable but coarse (`coarse_dt_warning`). The sizes and times it
weighs are `estimate`'s.
"""

from __future__ import annotations

import logging
import math
import shutil
import tempfile
from pathlib import Path

from ..case import Case, unit_warnings
from ..errors import ConfigError, UsageError
from ..formats.files import free_bytes
from ..ranks import rank_warnings
from ..units import period
from .estimate import Estimate, _size, estimate

log = logging.getLogger(__name__)

# Runs estimated to take longer need an explicit yes.
LONG_RUN_SECONDS = 3600.0
# dt above this fraction of the linear period 1/f0 is coarse.
COARSE_DT_FRACTION = 1 / 50


def check(case: Case, folder: str | Path, nprocs: int = 1, yes: bool = False) -> Estimate:
    """Refuse (ConfigError) a run that cannot fit this machine or, without `yes`, takes over an hour;
    warn about many ranks and a coarse time step. Returns the estimate."""
    if not (isinstance(nprocs, int) and nprocs >= 1):
        raise UsageError("--np", f"got {nprocs!r}; expected an integer >= 1")
    for line in rank_warnings(case.chain.particles, nprocs):  # --np tells the truth
        log.warning(line)
    est = estimate(case, nprocs)
    check_writable(folder, "output")  # else an unwritable place reads as a full disk (0 B free in /proc)
    disk, memory = free_disk(folder), available_memory()
    if not fits(est, disk, memory):
        free = f"{_size(disk)} free on disk" + (f", {_size(memory)} memory available" if memory is not None else "")
        raise ConfigError("run", f"too large for this machine: {est}; {free} "
                                 "(fewer particles, a shorter run or a longer run.output_interval)")
    if est.seconds > LONG_RUN_SECONDS and not yes:
        raise ConfigError("run", f"estimated {est}; pass --yes (yes=True) to start a run this long")
    mistake = unit_warnings(case) if case.chain.far_end == "long" and not yes else []
    if mistake:  # the long lattice sizes itself from r0 and V_I: a unit slip builds a huge chain that touches at once
        field, message = mistake[0].split(": ", 1)
        raise ConfigError(field, f"{message}; with chain.far_end = \"long\" that builds {case.chain.particles} magnets "
                                 f"({est}); pass --yes (yes=True) to run it as it is")
    case.check_draws()  # after the refusals, which need N alone: N draws for a disordered chain
    coarse_dt_warning(case)  # it builds the chain's arrays
    return est


def fits(est: Estimate, disk: float, memory: float | None) -> bool:
    """Whether a run of estimate `est` fits `disk` bytes and `memory` bytes (None: not known)."""
    return est.output_bytes <= disk and (memory is None or est.memory_bytes <= memory)


def coarse_dt_warning(case: Case) -> str | None:
    """Warn (and return the text) when dt is stable but above 1/50 of the linear period 1/f0.

    Velocity Verlet advances a linear mode of angular frequency w with a phase error of
    (w dt)^2 / 24 per period, here at f0 (the top of the linear band, the summary's f0).
    Behind a shock the chain is compressed and stiffer, so shock measures err more: for the
    paper's long lattice at dt = 0.4 ms, V_P by +0.19 % and the first peak by -0.66 %.
    """
    from ..case_measures import linear_constants  # (and the measures: none is needed before a sweep's first task)

    f0 = linear_constants(case)[1]  # Hz
    t0 = period(f0)  # ms
    if case.run.dt <= COARSE_DT_FRACTION * t0:
        return None
    error = (2 * math.pi * case.run.dt / t0) ** 2 / 24
    text = (f"run.dt: {case.run.dt:g} ms is stable but coarse, more than 1/50 of the linear period "
            f"1/f0 = {t0:.4g} ms; expected phase error of linear waves {100 * error:.2g} %, "
            f"more behind a shock; use dt <= {COARSE_DT_FRACTION * t0:.3g} ms")
    log.warning(text)
    return text


def free_disk(folder: str | Path) -> float:
    """Free bytes on the file system that holds (or will hold) `folder`."""
    return float(free_bytes(_existing(folder)))


def disk_size(folder: str | Path) -> float:
    """Bytes of the whole file system that holds (or will hold) `folder`."""
    return float(shutil.disk_usage(_existing(folder)).total)


def check_writable(folder: str | Path, field: str) -> None:
    """ConfigError naming `field` unless a file can be made in `folder`, or, where it does not
    exist yet, in its nearest existing parent (which makes it). Tried with an anonymous
    temporary file, which leaves nothing behind: permission bits alone do not tell (root, /proc,
    a read-only mount)."""
    where = _existing(folder)
    try:
        with tempfile.TemporaryFile(dir=where):
            pass
    except OSError as err:
        made = "" if where == Path(folder).resolve() else f" (to make {folder} there)"
        raise UsageError(field, f"cannot write in {where}{made}: {err.strerror}; "
                                 "expected a folder you can write") from None


def _existing(folder: str | Path) -> Path:
    """`folder`, or its nearest parent that exists."""
    path = Path(folder).resolve()
    while not path.exists():
        path = path.parent
    return path


def available_memory() -> float | None:
    """Bytes of memory available to a new process (Linux MemAvailable), None where unknown."""
    try:
        for line in Path("/proc/meminfo").read_text().splitlines():
            if line.startswith("MemAvailable:"):
                return float(line.split()[1]) * 1024
    except OSError:
        pass
    return None
