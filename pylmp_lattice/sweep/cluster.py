"""Sweeps on a batch scheduler: the sweep file's `[cluster]` section and dask-jobqueue's clusters.

    [cluster]                          # every key optional
    queue = "short"                    # SLURM partition or PBS queue (default: the scheduler's)
    cores = 1                          # cores booked per job
    memory = "2GiB"                    # memory per job (also the Dask worker's memory limit)
    walltime = "01:00:00"              # per job, [D-]HH:MM:SS
    directives = ["--account=abc"]     # further #SBATCH / #PBS lines, one option each
    interface = "ib0"                  # the network interface the compute nodes reach this machine on

`pylmp-lattice sweep SWEEP.toml -o DIR --cluster slurm --jobs N` submits N jobs (SLURM's sbatch
or PBS's qsub), each one Dask worker with one thread: a worker runs one task at a time (the
embedded runner needs one LAMMPS instance at a time; a member's `lmp` runner may use the job's
other cores). A task is one member, or many members of one parameter point batched in one
instance (hundreds of small chains; see `execute` and `batch`). The sweep
then runs through `run_sweep`'s executor path (a Dask client's executor, one task in flight per
job, whether or not its worker has started yet). Job scripts and logs go to
DIR/cluster/. dask-jobqueue's own configuration (~/.config/dask/jobqueue.yaml: interface,
account, ...) still applies where this section says nothing.

A worker retires at a random time in 85-95 % of the walltime (dask's `--lifetime` with
`--lifetime-stagger`), and a new job replaces it, so a job rarely meets its walltime; if one
does, its running task is lost (the members of a batch are written together at its end; what
finished before is on disk), and the scheduler runs that task again elsewhere; re-running the
command resumes in any case.

The Dask scheduler runs in this process and listens on one network interface only: loopback
("lo", the default: jobs that run on this machine, as on a one-node SLURM) or the one `interface`
names (else jobqueue's own configuration's `interface`), the cluster's network that the compute
nodes reach this machine on, e.g. "ib0" or "eth0". It speaks TLS with mutual authentication
(`distributed.Security.temporary()`: a key and certificate made for this sweep, valid one day):
a worker or client without them cannot connect, so nobody who merely reaches the port can
submit work. The workers' copy of them is written to DIR/cluster/ (readable by the owner alone),
which the compute nodes must see (the members write DIR anyway); the dashboard is off.

jobqueue writes these values into a job script that a shell runs, so every one is checked
against a strict pattern (no spaces except one between a directive's option and its value, no
quotes, no newlines), and so is the sweep folder's path (DIR/cluster/ is named in the script);
the scheduler's address and the Python are this process's own.
"""

from __future__ import annotations

import contextlib
import logging
import re
import shutil
import sys
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

from ..case import read_toml
from ..errors import ConfigError, UsageError

log = logging.getLogger(__name__)

KINDS = ("slurm", "pbs")
LOGS = "cluster"  # under the sweep folder: job scripts' output and errors
JOB_NAME = "pylmp-sweep"
# The worker retires in [LIFETIME - STAGGER, LIFETIME + STAGGER] of the walltime.
LIFETIME, STAGGER = 0.90, 0.05

_QUEUE = re.compile(r"[A-Za-z0-9_.@-]+")
_MEMORY = re.compile(r"\d+(\.\d+)?([kKMGTP]i?)?B")
_WALLTIME = re.compile(r"(?:(\d+)-)?(\d+):([0-5]\d):([0-5]\d)")
_PATH = re.compile(r"[A-Za-z0-9_./+@%,=~-]+")
_INTERFACE = re.compile(r"[A-Za-z0-9_.:-]{1,15}")
LOOPBACK = "lo"
_DIRECTIVE = re.compile(r"-{1,2}[A-Za-z][A-Za-z0-9_-]*(?:[ =][A-Za-z0-9_.,:@%/+=-]+)?")


@dataclass(frozen=True)
class ClusterSpec:
    """What each batch job books (see the module docstring); validated when built."""

    queue: str | None = None
    cores: int = 1
    memory: str = "2GiB"
    walltime: str = "01:00:00"
    directives: tuple[str, ...] = ()
    interface: str | None = None  # None: jobqueue's configured interface, else loopback

    def __post_init__(self):
        if self.interface is not None and not (isinstance(self.interface, str) and _INTERFACE.fullmatch(self.interface)):
            raise ConfigError("cluster.interface", f"got {self.interface!r}; expected a network interface name, "
                                                   "e.g. \"ib0\" or \"lo\"")
        if self.queue is not None and not (isinstance(self.queue, str) and _QUEUE.fullmatch(self.queue)):
            raise ConfigError("cluster.queue", f"got {self.queue!r}; expected a name of letters, digits, _ . @ -")
        if not (isinstance(self.cores, int) and not isinstance(self.cores, bool) and 1 <= self.cores <= 4096):
            raise ConfigError("cluster.cores", f"got {self.cores!r}; expected an integer in 1..4096")
        from dask.utils import parse_bytes  # dask takes a quarter of a second to load: only with a [cluster]

        if not (isinstance(self.memory, str) and _MEMORY.fullmatch(self.memory)) or parse_bytes(self.memory) < 2**20:
            raise ConfigError("cluster.memory", f"got {self.memory!r}; expected at least 1 MiB with a unit, "
                              "e.g. \"2GiB\" or \"500MB\"")
        if not (isinstance(self.walltime, str) and _WALLTIME.fullmatch(self.walltime)) or self.seconds < 60:
            raise ConfigError("cluster.walltime", f"got {self.walltime!r}; expected [D-]HH:MM:SS of at least a minute")
        if not (isinstance(self.directives, (list, tuple)) and all(isinstance(d, str) for d in self.directives)):
            raise ConfigError("cluster.directives", f"got {self.directives!r}; expected a list of strings")
        for i, directive in enumerate(self.directives):
            if not _DIRECTIVE.fullmatch(directive):
                raise ConfigError(f"cluster.directives[{i}]", f"got {directive!r}; expected one option like "
                                  "\"--account=abc\" or \"-l mem=4gb\" (letters, digits, _ . , : @ % / + = -)")
        object.__setattr__(self, "directives", tuple(self.directives))

    @property
    def seconds(self) -> int:
        """The walltime in seconds."""
        days, hours, minutes, seconds = (int(g or 0) for g in _WALLTIME.fullmatch(self.walltime).groups())
        return ((days * 24 + hours) * 60 + minutes) * 60 + seconds


def cluster_spec(table) -> ClusterSpec:
    """A `[cluster]` table as a ClusterSpec; an unknown key is an error naming it."""
    if not isinstance(table, dict):
        raise ConfigError("cluster", f"got {table!r}; expected a table [cluster]")
    known = ClusterSpec.__dataclass_fields__
    for key in table:
        if key not in known:
            raise ConfigError(f"cluster.{key}", f"unknown key; expected one of {', '.join(known)}")
    return ClusterSpec(**table)


def read_cluster(sweep_file: str | Path) -> ClusterSpec:
    """The sweep file's `[cluster]` section (defaults when it has none)."""
    return cluster_spec(read_toml(Path(sweep_file), "sweep").get("cluster", {}))


def listening_interface(kind: str, spec: ClusterSpec) -> str:
    """The network interface the scheduler listens on (see the module): the section's, else
    jobqueue's configured one, else loopback; ConfigError naming cluster.interface if this
    machine has no such interface (the ones it has listed)."""
    import dask
    import psutil

    name = spec.interface or dask.config.get(f"jobqueue.{kind}.interface", None) or LOOPBACK
    have = sorted(psutil.net_if_addrs())
    if name not in have:
        raise ConfigError("cluster.interface", f"got {name!r}; this machine's interfaces are {', '.join(have)}")
    return name


def job_options(kind: str, spec: ClusterSpec, log_directory: str | Path) -> dict:
    """Keyword arguments of dask-jobqueue's SLURMCluster or PBSCluster for one worker per job;
    the scheduler's interface and TLS come from `batch_cluster`."""
    lifetime, stagger = round(LIFETIME * spec.seconds), round(STAGGER * spec.seconds)
    options = {
        "cores": 1, "processes": 1, "memory": spec.memory, "queue": spec.queue,
        "job_name": JOB_NAME, "job_extra_directives": list(spec.directives),
        "python": sys.executable,  # the workers import this installation of the package
        "log_directory": str(log_directory),
        "worker_extra_args": ["--lifetime", f"{lifetime}s", "--lifetime-stagger", f"{stagger}s"],
    }
    if kind == "slurm":
        return options | {"walltime": spec.walltime, "job_cpu": spec.cores}
    from dask.utils import parse_bytes
    from dask_jobqueue.pbs import pbs_format_bytes_ceil

    hours, rest = divmod(spec.seconds, 3600)
    return options | {"walltime": f"{hours:02d}:{rest // 60:02d}:{rest % 60:02d}",
                      "resource_spec": f"select=1:ncpus={spec.cores}:mem={pbs_format_bytes_ceil(parse_bytes(spec.memory))}"}


@contextlib.contextmanager
def sweep_workers(sweep_file: str | Path, folder: str | Path, kind: str | None, jobs: int | None,
                  scheduler: str | None, workers: int | None) -> Iterator[dict]:
    """The command line's choice of workers as keyword arguments of `run_sweep`: a batch cluster
    (`kind`, `jobs`) kept for the block, else the given `workers` or `scheduler`.
    The sweep file's [cluster] section is checked in every case."""
    if kind is None:
        if "cluster" in read_toml(Path(sweep_file), "sweep"):  # (without one, dask is not loaded)
            read_cluster(sweep_file)
        if jobs is not None:
            raise UsageError("--jobs", "counts batch jobs; use it with --cluster (or --workers for local processes)")
        yield {"workers": workers, "scheduler": scheduler}
        return
    for option, value in (("--scheduler", scheduler), ("--workers", workers)):
        if value is not None:
            raise UsageError(option, "the batch cluster has its own workers; leave it out with --cluster")
    from distributed import Client

    jobs = 1 if jobs is None else jobs
    with batch_cluster(kind, jobs, read_cluster(sweep_file), folder) as cluster, Client(cluster) as client:
        # one task in flight per job, whether or not its worker has started yet
        yield {"executor": client.get_executor(pure=False), "slots": jobs}


@contextlib.contextmanager
def batch_cluster(kind: str, jobs: int, spec: ClusterSpec, folder: str | Path):
    """Keep `jobs` batch jobs of one Dask worker each while the block runs; yield the jobqueue
    cluster (a `distributed.Client` connects to it). Leaving the block cancels the jobs."""
    if kind not in KINDS:
        raise UsageError("--cluster", f"got {kind!r}; choose one of {', '.join(KINDS)}")
    if not (isinstance(jobs, int) and jobs >= 1):
        raise UsageError("--jobs", f"got {jobs!r}; expected an integer >= 1")
    logs = Path(folder).resolve() / LOGS
    if not _PATH.fullmatch(str(logs)):  # it is written into the job script's directives
        raise UsageError("-o", f"got {str(folder)!r}; with --cluster, a folder path of letters, digits and "
                          "_ . / + - @ % , = ~ only (no spaces or shell characters)")
    interface = listening_interface(kind, spec)
    from dask_jobqueue import PBSCluster, SLURMCluster

    cls = SLURMCluster if kind == "slurm" else PBSCluster
    submit = cls.job_cls.submit_command
    if shutil.which(submit) is None:  # jobqueue would only log the failed submissions, and wait
        raise UsageError("--cluster", f"{submit} is not on PATH; a {kind} cluster is submitted from a machine that has it")
    from distributed.security import Security

    logs.mkdir(parents=True, exist_ok=True)  # the workers' key and certificate go here (mode 0600)
    secure = {"security": Security.temporary(), "shared_temp_directory": str(logs), "interface": interface,
              "scheduler_options": {"interface": interface, "dashboard": False}}
    with _quiet("distributed", "dask_jobqueue"), cls(**job_options(kind, spec, logs), **secure) as cluster:
        # adapt, not scale: a worker that retired at its lifetime is replaced by a new job
        cluster.adapt(minimum_jobs=jobs, maximum_jobs=jobs)
        log.info("%s: %d jobs of one worker (%d cores, %s, %s); scheduler %s (TLS, interface %s); job logs in %s",
                 kind, jobs, spec.cores, spec.memory, spec.walltime, cluster.scheduler_address, interface, logs)
        yield cluster


@contextlib.contextmanager
def _quiet(*names: str):
    """Dask's scheduler logs every worker and client coming and going; warnings are enough here."""
    loggers = [logging.getLogger(name) for name in names]
    levels = [logger.level for logger in loggers]
    for logger in loggers:
        logger.setLevel(logging.WARNING)
    try:
        yield
    finally:
        for logger, level in zip(loggers, levels):
            logger.setLevel(level)
