"""Sweeps on a batch scheduler: the [cluster] section, the job script, and a real one-node SLURM.

The tests marked `slurm` start munged, slurmctld and slurmd on localhost (the `slurm` fixture,
tests/slurm_cluster.py), installing Debian's slurm-wlm and munge first where they are missing.
"""

from __future__ import annotations

import json
from collections import Counter
from concurrent.futures import Future
import subprocess
import sys
import tempfile
import threading
import time
import tomllib
from pathlib import Path

import pandas as pd
import pytest
from dask_jobqueue.pbs import PBSJob
from dask_jobqueue.slurm import SLURMJob
from distributed import Client
from test_sweep import SIX, write_sweep

from pylmp_lattice.cli import main
from pylmp_lattice.sweep import load_results, load_sweep, run_sweep
from pylmp_lattice.sweep import cluster
from pylmp_lattice.sweep.cluster import ClusterSpec, job_options
from pylmp_lattice.sweep.store import STATUS

CLUSTER = """
[cluster]
queue = "short"
cores = 4
memory = "3GiB"
walltime = "1-02:00:00"
directives = ["--account=abc", "--constraint=x86"]
"""


def job_script(job_cls, spec: ClusterSpec, tmp_path: Path) -> str:
    options = job_options("slurm" if job_cls is SLURMJob else "pbs", spec, tmp_path / "cluster")
    return job_cls(scheduler="tcp://127.0.0.1:8786", name="w", **options).job_script()


def test_cluster_section_reaches_the_slurm_job_script(tmp_path):
    """26 h walltime: the worker retires in 85-95 % of it, 84240 s +- 4680 s."""
    script = job_script(SLURMJob, ClusterSpec(**tomllib.loads(CLUSTER)["cluster"]), tmp_path)
    lines = script.splitlines()
    for line in ("#SBATCH -p short", "#SBATCH --cpus-per-task=4", "#SBATCH --mem=3G", "#SBATCH -t 1-02:00:00",
                 "#SBATCH --account=abc", "#SBATCH --constraint=x86", "#SBATCH -n 1"):
        assert line in lines, script
    worker = lines[-1].split()
    assert worker[:3] == [sys.executable, "-m", "distributed.cli.dask_worker"]
    assert worker[worker.index("--nthreads") + 1] == "1"  # one member at a time per worker
    assert worker[worker.index("--lifetime") + 1] == "84240s"
    assert worker[worker.index("--lifetime-stagger") + 1] == "4680s"
    assert f"#SBATCH -o {tmp_path / 'cluster'}/pylmp-sweep-%J.out" in lines


def test_cluster_section_reaches_the_pbs_job_script(tmp_path):
    script = job_script(PBSJob, ClusterSpec(**tomllib.loads(CLUSTER)["cluster"]), tmp_path)
    lines = script.splitlines()
    for line in ("#PBS -q short", "#PBS -l select=1:ncpus=4:mem=3072MB", "#PBS -l walltime=26:00:00",
                 "#PBS --account=abc"):
        assert line in lines, script
    assert "--lifetime 84240s" in lines[-1]


@pytest.mark.parametrize(
    "text, args, field",
    [
        ('queue = "short; rm -rf ~"', [], "cluster.queue: got 'short; rm -rf ~'; expected a name"),
        ("cores = 0", [], "cluster.cores: got 0; expected an integer in 1..4096"),
        ("cores = true", [], "cluster.cores: got True"),
        ('memory = "lots"', [], "cluster.memory: got 'lots'; expected at least 1 MiB"),
        ('memory = "2 GB"', [], "cluster.memory: got '2 GB'"),
        ('walltime = "1h"', [], "cluster.walltime: got '1h'; expected [D-]HH:MM:SS"),
        ('walltime = "00:00:30"', [], "cluster.walltime: got '00:00:30'; expected [D-]HH:MM:SS of at least a minute"),
        ('directives = "--account=abc"', [], "cluster.directives: got '--account=abc'; expected a list"),
        ('directives = ["--account=abc", "--x=1\\nrm -rf ~"]', [], "cluster.directives[1]: got '--x=1\\nrm -rf ~'"),
        ('directives = ["--comment=$(reboot)"]', [], "cluster.directives[0]: got '--comment=$(reboot)'"),
        ('directives = ["#SBATCH --x"]', [], "cluster.directives[0]: got '#SBATCH --x'"),
        ("nodes = 2", [], "cluster.nodes: unknown key; expected one of queue, cores, memory, walltime, directives, "
                          "interface"),
        ('interface = "eth0; rm -rf x"', [], "cluster.interface: got 'eth0; rm -rf x'; expected a network interface"),
        ('interface = "nosuch9"', ["--cluster", "slurm"], "cluster.interface: got 'nosuch9'; this machine's "
                                                          "interfaces are "),
        ("", ["--jobs", "2"], "--jobs: counts batch jobs; use it with --cluster"),
        ("", ["--cluster", "slurm", "--jobs", "0"], "--jobs: got 0; expected an integer >= 1"),
        ("", ["--cluster", "slurm", "--workers", "2"], "--workers: the batch cluster has its own workers"),
        ("", ["--cluster", "slurm", "--scheduler", "tcp://h:1"], "--scheduler: the batch cluster has its own workers"),
        ("", ["--cluster", "pbs"], "--cluster: qsub is not on PATH"),
        ("", ["--cluster", "slurm", "-o", "my out"], "-o: got 'my out'; with --cluster, a folder path of letters"),
    ],
)
def test_bad_cluster_section_or_options_are_one_line_naming_the_field_exit_2(tmp_path, capsys, monkeypatch, text,
                                                                            args, field):
    monkeypatch.setenv("PATH", "/nonexistent")  # nothing may be submitted
    path = write_sweep(tmp_path, SIX + "[cluster]\n" + text + "\n")
    monkeypatch.chdir(tmp_path)
    assert main(["sweep", str(path), "-o", "out", *args]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith(f"pylmp-lattice: error: {field}"), err
    assert not (tmp_path / "out" / "members").exists()


def test_the_scheduler_listens_on_loopback_with_tls_and_refuses_a_client_without_the_key(tmp_path, monkeypatch):
    """--cluster's scheduler (issue 27 item 12: it listened on the machine's address, without
    authentication): on loopback by default, TLS with a key made for the sweep; a client
    without it cannot connect, one with it can; the workers' job script names the key files
    in DIR/cluster/, readable by the owner alone. sbatch and scancel are stand-ins here (no
    job starts); tests marked slurm run real workers through it."""
    import os
    import stat

    from distributed.comm import connect
    from distributed.security import Security

    bin_ = tmp_path / "bin"
    bin_.mkdir()
    for name, text in (("sbatch", "echo 'Submitted batch job 42'"), ("scancel", "true")):
        (bin_ / name).write_text(f"#!/bin/sh\n{text}\n")
        (bin_ / name).chmod(0o755)
    monkeypatch.setenv("PATH", f"{bin_}:{os.environ['PATH']}")
    spec = ClusterSpec(memory="1GiB", walltime="00:10:00")
    with cluster.batch_cluster("slurm", 1, spec, tmp_path / "out") as jobs, Client(jobs, timeout="20s") as client:
        address = jobs.scheduler_address
        assert address.startswith("tls://127.0.0.1:"), address
        assert client.scheduler_info()["address"] == address  # the sweep's own client holds the key
        script = jobs.job_script()
        keys = sorted((tmp_path / "out" / "cluster").glob(".dask-jobqueue.worker.*"))
        assert keys and all(stat.S_IMODE(k.stat().st_mode) == 0o600 for k in keys)
        assert all(f"--tls-{flag}" in script for flag in ("ca-file", "cert", "key"))
        with pytest.raises(OSError):  # TLS without the sweep's certificate: refused
            Client(address, security=Security.temporary(), timeout="3s")
        with pytest.raises(OSError):  # plain TCP: not even spoken
            Client(address.replace("tls://", "tcp://"), timeout="3s")


def comparable(table: pd.DataFrame) -> pd.DataFrame:
    """The table without the columns that differ between two runs: timings and hosts."""
    return table.drop(columns=[c for c in table.columns if c.endswith("time_s") or "host" in c])


@pytest.mark.slurm
@pytest.mark.lammps
@pytest.mark.slow
def test_sweep_on_slurm_gives_the_local_pools_table_in_two_jobs(tmp_path, slurm):
    path = write_sweep(tmp_path, SIX + '[cluster]\nmemory = "1GiB"\nwalltime = "00:10:00"\n')
    out = tmp_path / "slurm"
    done = subprocess.run([sys.executable, "-m", "pylmp_lattice.cli", "sweep", str(path), "-o", str(out),
                           "--cluster", "slurm", "--jobs", "2", "--quiet"],
                          env=slurm.env, cwd=tmp_path, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    assert "6 members: 6 done, 0 failed" in done.stderr
    # closing the sweep's cluster cancelled its jobs (squeue lists a cancelled job while it
    # completes: on a loaded machine for a moment after the command ends)
    deadline = time.monotonic() + 10
    while slurm.queued() and time.monotonic() < deadline:
        time.sleep(0.2)
    assert not slurm.queued()

    local = run_sweep(load_sweep(path), tmp_path / "local", workers=2, progress=False)
    table = load_results(out)
    assert len(table) == 6 and set(table["status"]) == {"done"}
    pd.testing.assert_frame_equal(comparable(table), comparable(local))

    # SLURM's job completion records show the two jobs, each one task on one core
    jobs = [j for j in slurm.jobs() if j["Name"] == "pylmp-sweep" and j["WorkDir"] == str(tmp_path)]
    assert len(jobs) == 2, slurm.jobs()
    assert {j["JobState"] for j in jobs} <= {"COMPLETED", "CANCELLED"}
    assert all(j["ProcCnt"] == "1" and j["TimeLimit"] == "10" and j["StartTime"] != "Unknown" for j in jobs)
    # each job's worker joined this sweep's scheduler, and its log is in the sweep folder
    for job in jobs:
        log = (out / "cluster" / f"pylmp-sweep-{job['JobId']}.err").read_text()
        assert "Registered to:" in log, log
    record = json.loads((out / table["folder"][0] / STATUS).read_text())
    assert record["status"] == "done" and record["provenance"]["python"]


@pytest.mark.slurm
@pytest.mark.lammps
@pytest.mark.slow
def test_workers_retire_before_the_walltime_and_new_jobs_finish_the_sweep(tmp_path, slurm, monkeypatch):
    """Workers live 12 +- 1.2 s of a 1 min walltime here (LIFETIME 0.2 instead of 0.9), and the
    sweep starts 10 s after they joined, so both retire 1-3 s into it (its 80 members take
    longer, at 0.1-0.5 s each): new jobs replace them, no job meets its walltime, and results
    already handed over are never computed again."""
    monkeypatch.setattr(cluster, "LIFETIME", 0.2)
    monkeypatch.setattr(cluster, "STAGGER", 0.02)
    monkeypatch.setenv("SLURM_CONF", slurm.env["SLURM_CONF"])
    velocities = ", ".join(f"{0.5 + 0.02 * i:.2f}" for i in range(80))
    sweep = load_sweep(write_sweep(tmp_path, f'base = "base.toml"\n[grid]\n"impactor.velocity" = [{velocities}]\n'))
    spec = ClusterSpec(memory="1GiB", walltime="00:01:00")
    with cluster.batch_cluster("slurm", 2, spec, tmp_path / "out") as batch:
        with Client(batch) as client:
            client.wait_for_workers(2, timeout=120)
            time.sleep(10.0)
            table = run_sweep(sweep, tmp_path / "out", executor=client.get_executor(pure=False), slots=2,
                              progress=False)
        log = list(batch.scheduler.transition_log)  # (key, start, finish, ...)
    assert len(table) == 80 and set(table["status"]) == {"done"}, table["error"].dropna().unique()

    jobs = [j for j in slurm.jobs() if j["Name"] == "pylmp-sweep" and j["WorkDir"] == str(Path.cwd())]
    retired = [j for j in jobs if j["JobState"] == "COMPLETED"]  # the worker left; the job script ended
    assert len(retired) >= 2 and len(jobs) >= 4, [(j["JobId"], j["JobState"]) for j in jobs]
    assert {j["JobState"] for j in jobs} <= {"COMPLETED", "CANCELLED"}  # no TIMEOUT
    # A result still on a worker when it leaves is computed again elsewhere (Dask runs a task at
    # least once); handled results are released at once, so that is at most one per retired job.
    finished = Counter(key for key, start, finish, *_ in log if finish == "memory")
    assert len(finished) == 80 and sum(n - 1 for n in finished.values()) <= len(retired), finished


def in_background(fn, *args, **kwargs) -> Future:
    """fn(*args, **kwargs) in a daemon thread, as a Future: a test that gives up waiting for it
    fails, instead of waiting for it forever at exit as a ThreadPoolExecutor would."""
    future = Future()

    def run():
        try:
            future.set_result(fn(*args, **kwargs))
        except BaseException as err:  # noqa: BLE001 - handed to the test
            future.set_exception(err)

    threading.Thread(target=run, daemon=True).start()
    return future


@pytest.mark.slurm
@pytest.mark.lammps
@pytest.mark.slow
def test_a_job_killed_mid_sweep_loses_only_its_running_member(tmp_path, slurm, monkeypatch):
    """scancel ends a job as its walltime does (SIGTERM, then SIGKILL): the sweep goes on with
    the other worker (a new job replaces the killed one once Dask gives the worker up, after
    15 s), and every member is done; at most the killed worker's last result is computed again."""
    monkeypatch.setenv("SLURM_CONF", slurm.env["SLURM_CONF"])
    velocities = ", ".join(f"{0.5 + 0.02 * i:.2f}" for i in range(60))
    sweep = load_sweep(write_sweep(tmp_path, f'base = "base.toml"\n[grid]\n"impactor.velocity" = [{velocities}]\n'))
    out = tmp_path / "out"
    with cluster.batch_cluster("slurm", 2, ClusterSpec(memory="1GiB", walltime="00:10:00"), out) as batch, \
            Client(batch) as client:
        result = in_background(run_sweep, sweep, out, executor=client.get_executor(pure=False), slots=2,
                               progress=False)
        while len(list(out.glob(f"members/*/{STATUS}"))) < 10 and not result.done():
            time.sleep(0.1)
        killed = slurm.queued()[0]
        subprocess.run(["scancel", killed], env=slurm.env, check=True)
        table = result.result(timeout=300)
        log = list(batch.scheduler.transition_log)
    assert len(table) == 60 and set(table["status"]) == {"done"}
    jobs = {j["JobId"]: j for j in slurm.jobs() if j["Name"] == "pylmp-sweep" and j["WorkDir"] == str(Path.cwd())}
    assert jobs[killed]["JobState"] == "CANCELLED", jobs
    finished = Counter(key for key, start, finish, *_ in log if finish == "memory")
    assert len(finished) == 60 and sum(n - 1 for n in finished.values()) <= 1, finished  # the killed job's


@pytest.mark.slurm
def test_a_daemon_that_cannot_start_is_named_with_the_end_of_its_log(slurm):
    """The fixture's skip reason: which daemon stopped, before what, and its own words."""
    from slurm_cluster import LocalSlurm, SlurmUnavailable

    broken = LocalSlurm(Path(tempfile.mkdtemp(prefix="pylmp-slurm-", dir="/tmp")))
    try:
        broken._configure()
        (broken.folder / "munge" / "munge.key").chmod(0o644)  # munged refuses a key others can read
        with pytest.raises(SlurmUnavailable, match=r"^munged exited with \d+ before munged answers: .*key"):
            broken._start()
    finally:
        broken.stop()
