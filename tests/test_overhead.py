"""This machine's overheads for the estimates (`overhead`): measured once from the commands'
wall times over their contention, cached per host, Python and version, and used at the
contention now by a run's and a sweep's estimate."""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
import time
from pathlib import Path

import pytest

from pylmp_lattice import overhead, preflight
from pylmp_lattice.overhead import Overheads, contention

from conftest import make_case

ROOT = Path(__file__).resolve().parents[1]
CACHED = {"run_s": 2.5, "sweep_s": 3.0, "replica_s": 4.0, "member_s": 0.1}


@pytest.fixture
def cache(tmp_path, monkeypatch):
    """A fresh cache folder, measuring allowed (conftest forbids it elsewhere), at contention 1
    (the machine's load does not move the numbers asserted)."""
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    monkeypatch.delenv(overhead.MEASURING)
    monkeypatch.setattr(overhead, "contention", lambda: 1.0)
    return tmp_path


def write_cache(data: dict) -> None:
    overhead.cache_file().parent.mkdir(parents=True, exist_ok=True)
    overhead.cache_file().write_text(json.dumps(data))


def test_measured_once_from_the_commands_wall_times_then_read_from_the_cache(cache, monkeypatch):
    """run: 3.1 s; a sweep of 1 member: 3.5 s, of 32: 9.7 s -> 0.2 s a member, less the
    engine's model of its 4800 steps of 21 magnets (0.0067 s): member_s 0.193 s; 3.3 s the
    sweep's own; the replica sweep (2 points, 2 tasks, 4 members): 5.4 s -> 4.998 s its own,
    statistics included."""
    calls = []
    walls = {"run": 3.1, "sweep1.toml": 3.5, "sweep32.toml": 9.7, "replicas.toml": 5.4}

    def wall(args, cwd, tries=2):
        calls.append(args)
        assert (cwd / "tiny.toml").is_file() and (cwd / "replica.toml").is_file()  # the cases the commands run
        return walls[args[0] if args[0] == "run" else args[1]]

    monkeypatch.setattr(overhead, "_wall", wall)
    assert overhead.overheads() == Overheads()  # not measured unless asked
    found = overhead.overheads(measure=True)
    member = 0.2 - 4800 * (1.3e-6 + 4.7e-9 * 21)  # 0.193
    # the replica sweep's 2 tasks (member_s and 4800 steps each) and 4 batched members (their
    # atom-steps and worker Python) are its work, the rest its own
    work = 2 * (member + 1.3e-6 * 4800) + 4 * (4.7e-9 * 21 * 4800 + 2.3e-4)
    assert found == Overheads(run_s=3.1, sweep_s=3.3, replica_s=round(5.4 - work, 3), member_s=round(member, 3),
                              measured=True)
    assert (found.member_s, found.replica_s) == (0.193, 4.998)
    assert len(calls) == 4 and json.loads(overhead.cache_file().read_text()) == {
        "run_s": 3.1, "sweep_s": 3.3, "replica_s": 4.998, "member_s": 0.193}
    assert overhead.cache_file().parent == cache / "pylmp_lattice"
    assert overhead.overheads(measure=True) == found and len(calls) == 4  # once per machine
    write_cache({"run_s": 1.0, "sweep_s": 1.0, "member_s": 0.1, "contention": 2.0})  # an older version's
    assert overhead.overheads(measure=True) == found and len(calls) == 8  # measured again, not half read


def test_the_measured_member_is_the_21_magnet_experiment_its_engine_share_named():
    import tomllib

    from pylmp_lattice.case import case_from_dict

    data = tomllib.loads(overhead._REPLICA_CASE)
    data["chain"]["seed"] = 1  # the sweep gives each member one
    case = case_from_dict(data)
    assert (case.chain.particles, case.run.steps()) == overhead._REPLICA_CHAIN == (21, 4800)


def test_a_runs_estimate_is_its_engine_and_output_plus_the_machines_run_overhead(cache, monkeypatch):
    case = make_case(particles=21, duration=60.0)
    base = preflight.estimate(case).seconds - Overheads().run_s  # engine and output alone
    write_cache(CACHED)
    assert preflight.estimate(case).seconds == pytest.approx(2.5 + base, rel=1e-12)
    assert 0 < base < 0.1  # a small run is mostly its overhead: the engine's model alone was 24-55 % low


def test_estimates_are_the_times_on_a_machine_to_itself_times_the_contention_now(cache, monkeypatch):
    """The cache holds the times on a machine to itself; at contention 2.5 a run's estimate,
    overhead and engine, and a sweep's are 2.5 times those at contention 1."""
    from pylmp_lattice.sweep import load_sweep
    from pylmp_lattice.sweep.estimate import _estimate

    write_cache(CACHED)
    assert overhead.overheads() == Overheads(**CACHED, measured=True)  # as cached: not scaled
    case = make_case(particles=2000, duration=60.0)  # the engine's part is 0.6 s of it
    example = load_sweep(ROOT / "inputs" / "sweep_thermal_experiment.toml")
    alone, said = preflight.estimate(case).seconds, _estimate(example, 12, 2)
    monkeypatch.setattr(overhead, "contention", lambda: 2.5)
    assert preflight.estimate(case).seconds == pytest.approx(2.5 * alone, rel=1e-12)
    # sweep_s 3.0 and (3 tasks (0.1 + 1.3e-6 4800) + 12 members (4.7e-9 21 4800 + 2.3e-4)) / 2: 3.16 s
    assert said == "about 3.2 s on 2 workers (batched), if all are like the first"
    assert _estimate(example, 12, 2) == "about 7.9 s on 2 workers (batched), if all are like the first"


def test_contention_is_the_commands_own_wait_for_a_core(monkeypatch):
    """A command's contention is its main thread's (running + waiting) / running since it
    started: 0.4 s run and 0.6 s waited -> 2.5, whatever the load average says (7 on 2 cores:
    3.5, a minute's past). A process over YOUNG_S old, or one that has run under 50 ms, has no
    start-up that tells the present: the 1-minute load / cores; never below 1."""
    record = {"ran": 0.4, "waited": 0.6, "age": 1.0}
    monkeypatch.setattr(overhead, "_schedstat", lambda pid: (record["ran"], record["waited"]))
    monkeypatch.setattr(overhead, "process_age", lambda: record["age"])
    monkeypatch.setattr(overhead.os, "getloadavg", lambda: (7.0, 0.0, 0.0))
    monkeypatch.setattr(overhead.os, "cpu_count", lambda: 2)
    assert contention() == pytest.approx(2.5, rel=1e-12)
    record["waited"] = 0.0
    assert contention() == 1.0  # alone: no wait at all
    record["age"] = overhead.YOUNG_S + 1
    assert contention() == pytest.approx(3.5, rel=1e-12)
    record.update(age=1.0, ran=0.01)
    assert contention() == pytest.approx(3.5, rel=1e-12)
    monkeypatch.setattr(overhead.os, "getloadavg", lambda: (1.9, 0.0, 0.0))
    assert contention() == 1.0  # under a load per core of 1: never below 1


@pytest.mark.skipif(not os.path.exists("/proc/self/schedstat"), reason="the kernel's record is Linux's")
def test_the_records_of_a_command_and_the_processes_under_it_are_read():
    """A sweep's time is its workers', grandchildren of the command: the measurement reads the
    records of every process under the command while they live (a grandchild that sleeps 0.5 s
    is among them) and the command's own once it has exited, before it is reaped."""
    nap = "import time; time.sleep(0.5)"
    parent = f"import subprocess, sys\np = subprocess.Popen([sys.executable, '-c', {nap!r}])\nprint(p.pid, flush=True)\np.wait()"
    started = time.perf_counter()
    child = subprocess.Popen([sys.executable, "-c", parent], stdout=subprocess.PIPE, text=True)
    grandchild = int(child.stdout.readline())
    assert grandchild in overhead._records(child.pid) and overhead._records(grandchild) == {}
    wall, contended = overhead._timed(child, started, every=0.05)
    ran, waited = overhead._schedstat(str(child.pid))  # exited, not reaped: still readable
    assert child.wait() == 0 and child.stdout.read() == ""
    assert 0 < ran < 5 and 0 <= waited < 60 and 0.5 <= wall < 60 and 1.0 <= contended < 100


def test_a_measured_wall_time_counts_over_its_commands_contention(monkeypatch, tmp_path):
    """A command that took 3.0 s while it waited for a core as long as it ran (contention 2)
    counts 1.5 s: the time on a machine to itself, the least over the tries (a disturbed try of
    5.0 s, 2.5 s so corrected, does not count)."""
    seen = []

    class Child:
        pid, returncode = 0, 0

        def __init__(self, args, **kwargs):
            seen.append(args[3:])

        def wait(self):
            return 0

    monkeypatch.setattr(overhead.subprocess, "Popen", Child)
    monkeypatch.setattr(overhead, "_timed", lambda child, start: (5.0 if len(seen) == 1 else 3.0, 2.0))
    assert overhead._wall(["run", "tiny.toml", "-o", "r{}"], tmp_path) == 1.5
    assert seen == [["run", "tiny.toml", "-o", "r0"], ["run", "tiny.toml", "-o", "r1"]]


def test_ctrl_c_while_measuring_stops_the_measuring_command_and_goes_on(monkeypatch, tmp_path, cache, caplog):
    """Ctrl-C during a machine's first estimate: the command being measured gets the SIGINT too
    and the KeyboardInterrupt goes on to the caller (exit 130), where it used to be taken for a
    failed measurement (the child's exit -2), so that the sweep ran on to its end and exited 0;
    nothing is cached."""
    children = []
    real = subprocess.Popen

    def popen(args, **kwargs):  # a command that would run for a minute (Ctrl-C stops it, also where this
        # process was started with SIGINT ignored, which a child inherits)
        children.append(real([sys.executable, "-c", "import signal, time; signal.signal(signal.SIGINT, "
                              "signal.SIG_DFL); time.sleep(60)"]))
        return children[-1]

    def interrupted(child, start):
        raise KeyboardInterrupt

    monkeypatch.setattr(overhead.subprocess, "Popen", popen)
    monkeypatch.setattr(overhead, "_timed", interrupted)
    start = time.perf_counter()
    with pytest.raises(KeyboardInterrupt):
        overhead.overheads(measure=True)
    assert time.perf_counter() - start < 5 and len(children) == 1
    assert children[0].returncode == -2  # stopped as Ctrl-C stops it
    assert not overhead.cache_file().exists() and "could not measure" not in caplog.text


def test_a_sweep_estimate_adds_the_replica_statistics_where_the_cli_draws_them(cache):
    """The 12-member example (3 points x 4 batched replicas of the 21-magnet experiment, 4800
    steps) on 2 workers: the sweep's own start-up and end, 3 tasks at member_s and their steps,
    12 members' atom-steps and worker Python; with the CLI's statistics and figure (stats, a
    sweep with replicas), replica_s instead of sweep_s: 1 s of the example's 2.7 s on this
    machine, which the estimate left out (it said 0.92 s)."""
    from pylmp_lattice.sweep import Sweep, load_sweep
    from pylmp_lattice.sweep.estimate import _estimate

    write_cache(CACHED)
    example = load_sweep(ROOT / "inputs" / "sweep_thermal_experiment.toml")
    work = (3 * (0.1 + 1.3e-6 * 4800) + 12 * (4.7e-9 * 21 * 4800 + 2.3e-4)) / 2
    assert _estimate(example, 12, 2) == f"about {3.0 + work:.2g} s on 2 workers (batched), if all are like the first"
    assert _estimate(example, 12, 2, stats=True) == (f"about {4.0 + work:.2g} s on 2 workers (batched, the replica "
                                                     "statistics and figure included), if all are like the first")
    points = Sweep(base=ROOT / "inputs" / "paper_experiment.toml", grid={"impactor.velocity": [1.0, 2.0]},
                   keep="measures")  # no replicas: no statistics drawn
    assert _estimate(points, 2, 2, stats=True) == _estimate(points, 2, 2) and "statistics" not in _estimate(points, 2, 2)


def test_a_gpu_sweep_estimate_measures_nothing_and_puts_the_kernel_on_the_one_device(cache, monkeypatch):
    """engine "gpu": no LAMMPS command is timed (the GPU machine's image has no LAMMPS: the
    failed measurement, not cached, cost every sweep 1-3 s; the defaults stand in), the workers
    share the tasks' member_s and the members' Python (a kernel engine's: 0.044 ms, not the LAMMPS
    road's 0.23), the coordinator's 5 us a member are one after another, and the kernel's
    atom-steps (1e4 x 21 x 4800 = 1.008e9, at 4.67e10 a second on an H200) are the device's, not
    divided by the workers: the LAMMPS model said 46 s for 10^6 members on 16 workers that took
    26 s; the model with the LAMMPS road's Python, 26 s for 10^6 that took 14.7 s."""
    import dataclasses

    from pylmp_lattice.sweep import Sweep
    from pylmp_lattice.sweep.estimate import _estimate

    monkeypatch.setattr(overhead, "_measure", lambda: pytest.fail("a gpu sweep measured the LAMMPS commands"))
    sweep = Sweep(base=ROOT / "inputs" / "paper_experiment.toml", set={"chain.thermal_velocity": 0.02},
                  replicas=10_000, keep="measures", engine="gpu")
    costs = Overheads()
    kernel = 10_000 * 21 * 4800 / 4.67e10
    seconds = costs.replica_s + (costs.member_s + 10_000 * 4.4e-5) / 16 + 10_000 * 5e-6 + kernel
    assert _estimate(sweep, 10_000, 16, stats=True) == (f"about {seconds:.2g} s on 16 workers (batched, the replica "
                                                        "statistics and figure included), if all are like the first")
    write_cache(CACHED)  # measured before (a lammps sweep's): used as they are
    seconds = CACHED["sweep_s"] + (CACHED["member_s"] + 10_000 * 4.4e-5) / 16 + 10_000 * 5e-6 + kernel
    assert _estimate(sweep, 10_000, 16) == f"about {seconds:.2g} s on 16 workers (batched), if all are like the first"
    lammps = CACHED["sweep_s"] + (CACHED["member_s"] + 1.3e-6 * 4800 + 10_000 * (4.7e-9 * 21 * 4800 + 2.3e-4)) / 16
    assert _estimate(dataclasses.replace(sweep, engine="lammps"), 10_000, 16) == (  # its atom-steps in the workers
        f"about {lammps + 10_000 * 5e-6:.2g} s on 16 workers (batched), if all are like the first")
    cpu = CACHED["sweep_s"] + (CACHED["member_s"] + 10_000 * (4.7e-9 * 21 * 4800 + 4.4e-5)) / 16 + 10_000 * 5e-6
    assert _estimate(dataclasses.replace(sweep, engine="cpu"), 10_000, 16) == (  # no instance's steps
        f"about {cpu:.2g} s on 16 workers (batched), if all are like the first")


@pytest.mark.slow
@pytest.mark.lammps
def test_the_real_measurement_runs_the_commands(cache):
    """The commands it times run (no stand-in): plausible numbers, cached. ~15 s: marked slow."""
    found = overhead._measure()
    assert found.measured and 0.3 < found.run_s < 60 and 0 < found.sweep_s < 60 and 0 <= found.member_s < 10
    assert found.sweep_s < found.replica_s < 60  # the statistics and their figure cost something


def test_an_estimate_of_100_to_119_s_is_written_in_seconds():
    """.2g wrote 100-119 s as "1e+02 s" (the 1000-member sweep under load: the battery could not
    read it); two digits below 99.5 s, whole seconds up to 2 min."""
    from pylmp_lattice.preflight.estimate import _duration

    assert [_duration(s) for s in (3.16, 64.0, 99.4, 99.6, 112.7, 119.4, 121.0)] == [
        "3.2 s", "64 s", "99 s", "100 s", "113 s", "119 s", "2.02 min"]


def test_a_sweep_on_a_dask_scheduler_is_not_estimated_on_this_machine_s_cores(cache, tmp_path, monkeypatch, caplog):
    """With --scheduler the estimate said "on 2 workers" (this machine's cores), a wall time for
    workers it cannot count: it says the sweep's own time plus the work the scheduler's workers
    share. The 12-member example: 3.0 s its own, 3 tasks and 12 batched members its workers'."""
    import logging

    from pylmp_lattice.sweep import execute, load_sweep
    from pylmp_lattice.sweep.estimate import _estimate

    write_cache(CACHED)
    example = load_sweep(ROOT / "inputs" / "sweep_thermal_experiment.toml")
    work = 3 * (0.1 + 1.3e-6 * 4800) + 12 * (4.7e-9 * 21 * 4800 + 2.3e-4)
    said = f"about 3 s plus {work:.2g} s shared by the Dask scheduler's workers (batched), if all are like the first"
    assert _estimate(example, 12, None) == said

    def no_cluster(*args):
        raise RuntimeError("no cluster in this test")

    monkeypatch.setattr(execute, "executor_pool", no_cluster)
    monkeypatch.setattr(execute.os, "cpu_count", lambda: 2)
    with caplog.at_level(logging.INFO, logger=execute.__name__), pytest.raises(RuntimeError, match="no cluster"):
        execute.run_sweep(example, tmp_path / "s", scheduler="tcp://127.0.0.1:8786", progress=False)
    # its disk neither: from one batch of a point's 4 replicas (2.56 MB) to 4 (10 MB), not 2 for the 2 cores (5.05 MB)
    assert f"s: 12 members ({said}; about 2.56 MB to 10 MB on disk, as the Dask scheduler's workers run a point's " \
           "4 replicas in 1 to 4 batches)" in caplog.text, caplog.text
    assert "on 2 workers" not in caplog.text


def test_an_executor_s_sweep_is_estimated_on_the_slots_its_pool_has(cache, tmp_path, monkeypatch, caplog):
    """run_sweep(executor=...) without `slots` runs on 1 slot (`slots or 1`), but its estimate
    took this machine's cores: "about 3.2 s on 2 workers ... about 5.05 MB on disk" (2 batches
    of a point) where slots=1 said "3.3 s on 1 worker ... 2.56 MB". The pool's count
    (`pool.pool_slots`) now makes both, with slots or without; slots=2 is 2 workers."""
    import logging
    from concurrent.futures import ThreadPoolExecutor

    from pylmp_lattice.sweep import execute, load_sweep

    write_cache(CACHED)
    example = load_sweep(ROOT / "inputs" / "sweep_thermal_experiment.toml")

    def no_pool(*args):
        raise RuntimeError("no pool in this test")

    monkeypatch.setattr(execute, "executor_pool", no_pool)
    monkeypatch.setattr(execute.os, "cpu_count", lambda: 2)
    said = []
    for slots in (None, 1, 2):
        caplog.clear()
        with ThreadPoolExecutor(1) as pool, caplog.at_level(logging.INFO, logger=execute.__name__), \
                pytest.raises(RuntimeError, match="no pool"):
            execute.run_sweep(example, tmp_path / "s", executor=pool, slots=slots, progress=False)
        said.append(re.search(r"s: 12 members \((.*)\)$", caplog.text, re.M)[1])
    one = "about 3.3 s on 1 worker (batched), if all are like the first; about 2.56 MB on disk"
    assert said == [one, one, "about 3.2 s on 2 workers (batched), if all are like the first; about 5.05 MB on disk"]


def test_a_sweep_on_a_dask_scheduler_is_refused_only_what_one_batch_a_point_cannot_fit(tmp_path, monkeypatch):
    """On a Dask scheduler the disk was sized for this machine's cores (2 batches of a point's 4
    replicas here: 5.05 MB). Its workers are not counted before it is reached: the check now
    says 1 to 4 batches (2.56 to 10 MB), adds the free space where the most does not fit, and
    refuses only what the least cannot fit, saying "at least"."""
    from pylmp_lattice import preflight
    from pylmp_lattice.errors import UsageError
    from pylmp_lattice.sweep import disk, load_sweep

    example = load_sweep(ROOT / "inputs" / "sweep_thermal_experiment.toml")
    batches = "as the Dask scheduler's workers run a point's 4 replicas in 1 to 4 batches"
    monkeypatch.setattr(preflight, "free_disk", lambda folder: 1e12)
    assert disk.check(example, tmp_path, 12, None) == f"about 2.56 MB to 10 MB on disk, {batches}"
    assert disk.check(example, tmp_path, 12, 2) == "about 5.05 MB on disk"
    monkeypatch.setattr(preflight, "free_disk", lambda folder: 5e6)
    assert disk.check(example, tmp_path, 12, None) == f"about 2.56 MB to 10 MB on disk, {batches} ({tmp_path} has 5 MB free)"
    monkeypatch.setattr(preflight, "free_disk", lambda folder: 2e6)
    with pytest.raises(UsageError) as err:
        disk.check(example, tmp_path, 12, None)
    assert str(err.value) == (f"-o: the sweep needs at least about 2.56 MB on disk (12 members to run, about 213 kB "
                              f"each) and {tmp_path} has 2 MB free; free space or sweep fewer members")


def test_a_sweep_s_slots_count_an_executor_s_workers_only(tmp_path):
    """`slots` was taken as given (-1 made a pool of no worker and 0 one of 1, 2 without an executor sized
    the estimate for 2 workers that were never made), and an executor with --workers was refused
    only after DIR was claimed. Each is one line now, before anything is written."""
    from concurrent.futures import ThreadPoolExecutor

    from pylmp_lattice.errors import UsageError
    from pylmp_lattice.sweep import load_sweep, run_sweep

    example = load_sweep(ROOT / "inputs" / "sweep_thermal_experiment.toml")
    with ThreadPoolExecutor(1) as pool:
        for kwargs, message in (
                ({"executor": pool, "slots": 0}, "slots: got 0; expected an integer >= 1"),
                ({"executor": pool, "slots": "2"}, "slots: got '2'; expected an integer >= 1"),
                ({"slots": 2}, "slots: got 2; it counts the workers of an executor: give executor= too, or leave it "
                               "out (--workers for a local pool)"),
                ({"executor": pool, "workers": 2}, "--workers: an executor has its own workers; leave out --workers "
                                                   "and --scheduler")):
            with pytest.raises(UsageError) as err:
                run_sweep(example, tmp_path / "s", progress=False, **kwargs)
            assert str(err.value) == message
    assert list(tmp_path.iterdir()) == []
