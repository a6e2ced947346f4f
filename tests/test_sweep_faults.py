"""Sweeps under signals and faults: Ctrl-C, a second Ctrl-C, a killed coordinator, a killed worker.

Each test runs `pylmp-lattice sweep` as a command in its own process group and waits for
states on disk (never for a fixed time), so that it holds on a loaded machine. Time limits are
the issue's (2 s to exit after a signal, 5 s for orphaned workers) plus the machine's own
latency, measured in the same test as the start-up and exit of a Python that loads what the
command loads (on an idle machine about 0.5 s; on one shared by many, several seconds).
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from datetime import datetime
from pathlib import Path

import pytest

from pylmp_lattice.sweep import load_results
from pylmp_lattice.sweep.store import STATUS, Outcomes
from test_sweep import BASE

pytestmark = [pytest.mark.lammps, pytest.mark.slow]

# Six members, each run alone (one parameter point each), each about 10^7 atom-steps.
SWEEP = 'base = "base.toml"\nkeep = "measures"\n[grid]\n"impactor.velocity" = [0.5, 0.6, 0.7, 0.8, 0.9, 1.0]\n'


def start(tmp_path: Path, workers: int):
    (tmp_path / "base.toml").write_text(BASE.format(particles=600, duration=150.0, output=1.0))
    (tmp_path / "sweep.toml").write_text(SWEEP)
    out = tmp_path / "out"
    cmd = [sys.executable, "-m", "pylmp_lattice.cli", "sweep", str(tmp_path / "sweep.toml"), "-o", str(out),
           "--workers", str(workers), "--quiet"]
    return cmd, out, subprocess.Popen(cmd, start_new_session=True, stderr=subprocess.PIPE, text=True)


def statuses(out: Path) -> dict[str, dict]:
    """Member id -> status record, as written so far."""
    found = {}
    for path in (out / "members").glob(f"*/{STATUS}"):
        try:
            found[path.parent.name] = json.loads(path.read_text())
        except (OSError, json.JSONDecodeError):  # being replaced right now
            pass
    return found


def wait_for(condition, proc, limit=300.0):
    deadline = time.monotonic() + limit
    while not condition():
        assert proc.poll() is None, f"the sweep ended early: {proc.stderr.read()}"
        assert time.monotonic() < deadline, "timed out waiting for the sweep"
        time.sleep(0.01)


def latency() -> float:
    """Seconds this machine takes now to start and end a Python with the command's modules
    loaded: the slack on time limits."""
    start = time.monotonic()
    subprocess.run([sys.executable, "-c", "import pandas, pyarrow.parquet, pylmp_lattice.sweep.batch"], check=True)
    return time.monotonic() - start


def grandchildren(pid: int) -> list[int]:
    """The processes whose parent's parent is `pid` (a sweep's workers: the fork server's children)."""
    parents = {}
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            parents[int(stat.parent.name)] = int(stat.read_text().rsplit(")", 1)[1].split()[1])
        except (OSError, ValueError, IndexError):  # gone meanwhile
            pass
    children = {p for p, parent in parents.items() if parent == pid}
    return [p for p, parent in parents.items() if parent in children]


def running(out: Path) -> list[dict]:
    return [r for r in statuses(out).values() if r["status"] == "running"]


def alive(pid: int) -> bool:
    """Whether the process exists and is not a zombie."""
    try:
        return Path(f"/proc/{pid}/stat").read_text().split(")")[-1].split()[0] != "Z"
    except FileNotFoundError:
        return False


def assert_table_matches_disk(out: Path) -> None:
    """Done in the table is done on disk (with a summary), and the other way round; the rest is
    interrupted in the table, and running, interrupted or not started on disk."""
    table = load_results(out)
    disk, found = statuses(out), Outcomes(out)
    for row in table.itertuples():
        assert not isinstance(row.folder, str) or (out / row.folder).is_dir(), f"{row.id}: no folder {row.folder}"
        outcome = found.get(row.id)
        if row.status == "done":
            assert outcome["record"]["status"] == "done" and outcome["summary"]
        else:
            record = disk.get(row.id)
            assert row.status == "interrupted" and outcome is None
            assert record is None or record["status"] in ("running", "interrupted")
    finished = {i for i in [*disk, *table.id] if (found.get(i) or {"record": {}})["record"].get("status") == "done"}
    assert finished <= set(table.id[table.status == "done"])  # every member done on disk is done in the table
    assert not list(out.glob("batches/task-*.lock"))  # no stale lock, even of a killed worker's task


def test_sigint_exits_within_2_s_starts_nothing_after_and_a_rerun_finishes(tmp_path):
    slack = latency()
    cmd, out, proc = start(tmp_path, workers=1)
    wait_for(lambda: running(out), proc)
    sent = time.time()
    os.killpg(proc.pid, signal.SIGINT)  # as Ctrl-C does: to the whole foreground group
    err = proc.communicate(timeout=60)[1]
    took = time.time() - sent
    assert proc.returncode == 130, err
    assert took < 2.0 + slack, f"exit {took:.2f} s after SIGINT (slack {slack:.2f} s)"
    assert err.strip().splitlines()[-1].startswith("pylmp-lattice: interrupted; finished members are kept in")
    assert " members done" in err.split("stopped with ")[1].splitlines()[0]  # where it stopped
    records = statuses(out).values()
    assert all(datetime.fromisoformat(r["started"]).timestamp() <= sent for r in records), "a member started after SIGINT"
    assert len(records) < 6 and "failed" not in {r["status"] for r in records}
    assert {r["status"] for r in records} <= {"done", "interrupted", "running"}
    assert_table_matches_disk(out)
    assert subprocess.run(cmd, stderr=subprocess.DEVNULL).returncode == 0
    assert set(load_results(out)["status"]) == {"done"} and len(load_results(out)) == 6


def test_a_sigint_during_start_up_starts_no_member(tmp_path):
    """The signal comes while the coordinator waits for its first worker (the fork server still
    loads the engine): the worker that the pool starts afterwards stops too."""
    slack = latency()
    cmd, out, proc = start(tmp_path, workers=2)
    wait_for(lambda: grandchildren(proc.pid), proc)  # the fork server forked the first worker: it starts up
    sent = time.time()
    os.killpg(proc.pid, signal.SIGINT)
    err = proc.communicate(timeout=60)[1]
    took = time.time() - sent
    assert proc.returncode == 130, err
    assert took < 2.0 + slack, f"exit {took:.2f} s after SIGINT (slack {slack:.2f} s)"
    records = statuses(out).values()
    assert all(datetime.fromisoformat(r["started"]).timestamp() <= sent for r in records), "a member started after SIGINT"
    assert_table_matches_disk(out)


def start_two(tmp_path: Path):
    """The sweep on 2 workers, once both run a member: (command, folder, process, worker pids, slack)."""
    slack = latency()
    cmd, out, proc = start(tmp_path, workers=2)
    wait_for(lambda: len(running(out)) == 2, proc)
    return cmd, out, proc, {r["pid"] for r in running(out)}, slack


def test_a_second_sigint_only_makes_it_faster(tmp_path):
    cmd, out, proc, workers, slack = start_two(tmp_path)
    sent = time.time()
    os.killpg(proc.pid, signal.SIGINT)
    time.sleep(0.05)
    os.killpg(proc.pid, signal.SIGINT)
    proc.communicate(timeout=60)
    assert proc.returncode == 130
    assert time.time() - sent < 2.0 + slack
    assert_table_matches_disk(out)


def test_sigterm_to_the_coordinator_alone_stops_its_workers(tmp_path):
    """SIGTERM (e.g. from a batch system) reaches only the coordinator, which stops the workers."""
    cmd, out, proc, workers, slack = start_two(tmp_path)
    sent = time.time()
    proc.send_signal(signal.SIGTERM)
    proc.communicate(timeout=60)
    assert proc.returncode == 143
    assert time.time() - sent < 2.0 + slack
    assert not any(alive(pid) for pid in workers)
    assert_table_matches_disk(out)


def test_workers_exit_when_the_coordinator_is_killed_and_not_reaped(tmp_path):
    cmd, out, proc, workers, slack = start_two(tmp_path)
    os.kill(proc.pid, signal.SIGKILL)  # the coordinator alone; this test, its parent, does not reap it yet
    killed = time.monotonic()
    while any(alive(pid) for pid in workers) and time.monotonic() - killed < 5.0 + slack:
        time.sleep(0.05)
    assert not any(alive(pid) for pid in workers), "workers outlived their coordinator"
    assert Path(f"/proc/{proc.pid}").exists()  # still a zombie: the workers did not wait for the reaping
    proc.wait()
    assert subprocess.run(cmd, stderr=subprocess.DEVNULL).returncode == 0
    assert set(load_results(out)["status"]) == {"done"} and len(load_results(out)) == 6
    assert not list(out.glob("batches/task-*.lock"))  # the killed workers' locks went with the re-run


def test_a_killed_worker_leaves_a_table_that_matches_the_disk_and_a_rerun_finishes(tmp_path):
    """As an out-of-memory kill would: the members in flight are read back from their folders."""
    cmd, out, proc, workers, slack = start_two(tmp_path)
    victim = min(workers)
    os.kill(victim, signal.SIGKILL)
    err = proc.communicate(timeout=120)[1]
    assert proc.returncode == 1, err
    assert "a worker was lost" in err and "interrupted" in err
    table = load_results(out)
    assert "failed" not in set(table["status"]) and "interrupted" in set(table["status"])
    done, interrupted = ((table["status"] == s).sum() for s in ("done", "interrupted"))
    # the sweep's members, not the table's rows: those never enumerated are not started
    assert f"6 members: {done} done, 0 failed, {interrupted} interrupted, up to {6 - len(table)} not started" in err, err
    assert_table_matches_disk(out)
    assert subprocess.run(cmd, stderr=subprocess.DEVNULL).returncode == 0
    assert set(load_results(out)["status"]) == {"done"} and len(load_results(out)) == 6


def test_the_first_member_starts_within_1_s_of_the_command(tmp_path):
    """Start-up: the command to the first member's start (its status.json), against 1 s plus the
    machine's latency for loading the command's modules (see `latency`)."""
    slack = latency()
    launched = time.time()
    cmd, out, proc = start(tmp_path, workers=2)
    wait_for(lambda: statuses(out), proc)
    first = min(datetime.fromisoformat(r["started"]).timestamp() for r in statuses(out).values())
    os.killpg(proc.pid, signal.SIGINT)
    proc.communicate(timeout=60)
    assert first - launched < 1.0 + slack, f"first member {first - launched:.2f} s after the command (slack {slack:.2f} s)"
