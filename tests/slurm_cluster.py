"""A real single-node SLURM for the tests: munged, slurmctld and slurmd on localhost.

`LocalSlurm.started()` writes a minimal slurm.conf into a new folder (no cgroups:
proctrack/linuxproc and task/none; no database: jobcomp/filetxt writes one line per finished
job), starts the three daemons in the foreground as children of this process on free ports,
and waits until the node is idle; `stop()` cancels the cluster's jobs, ends the daemons and
removes the folder (the daemons also get SIGTERM if the test process dies). Clients (sbatch, squeue, dask-jobqueue) find the cluster through `env` (SLURM_CONF).

`install()` installs Debian's `slurm-wlm` and `munge` where they are missing (needs root and
apt-get, as on CI). Every failure raises SlurmUnavailable saying exactly what failed, with the
end of the daemon's log.
"""

from __future__ import annotations

import os
import re
import shutil
import signal
import socket
import subprocess
import tempfile
import time
from pathlib import Path

PACKAGES = ("slurm-wlm", "munge")
PROGRAMS = ("munged", "munge", "slurmctld", "slurmd", "sbatch", "squeue", "scancel", "sinfo", "scontrol")
START_TIMEOUT_S = 60.0

CONF = """\
# A one-node cluster for the tests; every path is in {folder}.
ClusterName=pylmp-test
SlurmctldHost={host}(127.0.0.1)
SlurmctldPort={ctld_port}
SlurmdPort={slurmd_port}
SlurmUser={user}
SlurmdUser={user}
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket={folder}/munge/munge.socket
StateSaveLocation={folder}/state
SlurmdSpoolDir={folder}/spool
SlurmctldPidFile={folder}/slurmctld.pid
SlurmdPidFile={folder}/slurmd.pid
SlurmctldLogFile={folder}/log/slurmctld.log
SlurmdLogFile={folder}/log/slurmd.log
SlurmctldDebug=info
SlurmdDebug=info
# No cgroups: processes tracked through /proc, no task binding.
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
# No accounting database: each finished job is one line of the job completion file.
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/filetxt
JobCompLoc={folder}/log/jobcomp.txt
MailProg=/bin/true
MpiDefault=none
SchedulerType=sched/builtin
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
ReturnToService=2
KillWait=5
# The node as configured here, whatever the machine has (a 1-core CI runner still gets two
# one-core jobs side by side); config_overrides keeps slurmd from draining it.
SlurmdParameters=config_overrides
NodeName={host} NodeAddr=127.0.0.1 CPUs={cpus} RealMemory={memory_mb} State=UNKNOWN
PartitionName=test Nodes=ALL Default=YES MaxTime=INFINITE State=UP
"""


class SlurmUnavailable(RuntimeError):
    """SLURM cannot be installed or started here; the message says why."""


def install() -> None:
    """Install slurm-wlm and munge with apt-get where a program of theirs is missing."""
    missing = [p for p in PROGRAMS if shutil.which(p) is None]
    if not missing:
        return
    if os.geteuid() != 0:
        raise SlurmUnavailable(f"{', '.join(missing)} not installed, and installing {' '.join(PACKAGES)} needs root")
    if shutil.which("apt-get") is None:
        raise SlurmUnavailable(f"{', '.join(missing)} not installed, and there is no apt-get to install them")
    env = os.environ | {"DEBIAN_FRONTEND": "noninteractive"}
    for cmd in (["apt-get", "update", "-q"],
                ["apt-get", "install", "-y", "-q", "--no-install-recommends", *PACKAGES]):
        done = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=900)
        if done.returncode != 0:
            raise SlurmUnavailable(f"`{' '.join(cmd)}` exited {done.returncode}: {_tail(done.stdout + done.stderr)}")
    still = [p for p in PROGRAMS if shutil.which(p) is None]
    if still:
        raise SlurmUnavailable(f"{', '.join(still)} still missing after installing {' '.join(PACKAGES)}")


class LocalSlurm:
    """The daemons of a one-node cluster in `folder` (see the module docstring)."""

    def __init__(self, folder: Path):
        self.folder = Path(folder)
        self.conf = self.folder / "slurm.conf"
        self.jobcomp = self.folder / "log" / "jobcomp.txt"
        self.env = os.environ | {"SLURM_CONF": str(self.conf)}
        self.processes: dict[str, subprocess.Popen] = {}

    @classmethod
    def started(cls) -> LocalSlurm:
        """Install if needed, write the configuration, start the daemons (SlurmUnavailable if not)."""
        install()
        # munged wants every folder above its socket searchable by all: not pytest's 0700 ones
        folder = Path(tempfile.mkdtemp(prefix="pylmp-slurm-", dir="/tmp"))
        cluster = cls(folder)
        try:
            cluster._configure()
            cluster._start()
        except BaseException:
            cluster.stop()
            raise
        return cluster

    def _configure(self) -> None:
        for sub in ("", "munge", "state", "spool", "log"):
            (self.folder / sub).mkdir(exist_ok=True)
            (self.folder / sub).chmod(0o755)
        key = self.folder / "munge" / "munge.key"
        key.write_bytes(os.urandom(1024))
        key.chmod(0o400)  # munged refuses a key others can read
        import pwd

        self.conf.write_text(CONF.format(
            folder=self.folder, host=socket.gethostname().split(".")[0], user=pwd.getpwuid(os.geteuid()).pw_name,
            ctld_port=_free_port(), slurmd_port=_free_port(), cpus=max(2, os.cpu_count() or 1), memory_mb=4096))

    def _start(self) -> None:
        munge = self.folder / "munge"
        self._spawn("munged", ["munged", "--foreground", f"--key-file={munge / 'munge.key'}",
                               f"--socket={munge / 'munge.socket'}", f"--pid-file={munge / 'munged.pid'}",
                               f"--log-file={self.folder / 'log' / 'munged.log'}", f"--seed-file={munge / 'munged.seed'}"])
        self._wait("munged answers", lambda: self._ok(["munge", "-n", "-S", str(munge / "munge.socket")]))
        self._spawn("slurmctld", ["slurmctld", "-D", "-i"])
        self._wait("slurmctld answers", lambda: self._ok(["scontrol", "ping"], "UP"))
        self._spawn("slurmd", ["slurmd", "-D"])
        self._wait("the node is idle", lambda: self._ok(["sinfo", "-h", "-N", "-o", "%T"], "idle"))

    def _spawn(self, name: str, cmd: list[str]) -> None:
        with open(self.folder / "log" / f"{name}.stdout", "wb") as out:
            self.processes[name] = subprocess.Popen(cmd, env=self.env, stdin=subprocess.DEVNULL, stdout=out,
                                                    stderr=subprocess.STDOUT, start_new_session=True,
                                                    preexec_fn=_die_with_parent)

    def _ok(self, cmd: list[str], expect: str = "") -> bool:
        done = subprocess.run(cmd, env=self.env, capture_output=True, text=True, timeout=30)
        return done.returncode == 0 and expect in done.stdout

    def _wait(self, what: str, ready) -> None:
        deadline = time.monotonic() + START_TIMEOUT_S
        while not ready():
            for name, process in self.processes.items():
                if process.poll() is not None:
                    raise SlurmUnavailable(f"{name} exited with {process.returncode} before {what}: {self._log(name)}")
            if time.monotonic() > deadline:
                last = next(reversed(self.processes))
                raise SlurmUnavailable(f"{what}: not within {START_TIMEOUT_S:.0f} s; {last}: {self._log(last)}")
            time.sleep(0.2)

    def _log(self, name: str) -> str:
        """The end of a daemon's own log, else of what it printed."""
        for path in (self.folder / "log" / f"{name}.log", self.folder / "log" / f"{name}.stdout"):
            if path.exists() and path.stat().st_size:
                return _tail(path.read_text(errors="replace"))
        return "(no log)"

    def jobs(self) -> list[dict[str, str]]:
        """Finished jobs from the job completion file: one dict per job (JobId, Name, JobState, ...)."""
        if not self.jobcomp.exists():
            return []
        return [dict(re.findall(r"(\w+)=(\S*)", line)) for line in self.jobcomp.read_text().splitlines() if line]

    def queued(self) -> list[str]:
        """Ids of the jobs pending or running now."""
        done = subprocess.run(["squeue", "-h", "-o", "%i"], env=self.env, capture_output=True, text=True, timeout=30)
        return done.stdout.split()

    def stop(self) -> None:
        """Cancel every job of this cluster, end the daemons this object started, remove the folder."""
        if "slurmctld" in self.processes and self.processes["slurmctld"].poll() is None:
            subprocess.run(["scancel", "--full", "--partition=test"], env=self.env, capture_output=True, timeout=30)
            deadline = time.monotonic() + 20
            while self.queued() and time.monotonic() < deadline:
                time.sleep(0.5)
        for name in reversed(list(self.processes)):
            process = self.processes[name]
            if process.poll() is None:
                process.send_signal(signal.SIGTERM)
                try:
                    process.wait(timeout=15)
                except subprocess.TimeoutExpired:
                    process.kill()
                    process.wait()
        self.processes.clear()
        shutil.rmtree(self.folder, ignore_errors=True)


def _die_with_parent() -> None:
    """In the daemon (before exec): SIGTERM when the test process ends, however it ends."""
    import ctypes

    PR_SET_PDEATHSIG = 1
    ctypes.CDLL(None, use_errno=True).prctl(PR_SET_PDEATHSIG, signal.SIGTERM)


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _tail(text: str, lines: int = 6) -> str:
    return " | ".join(line.strip() for line in text.strip().splitlines()[-lines:])
