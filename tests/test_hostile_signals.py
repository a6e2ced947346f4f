"""SIGTERM at each stage of a run and of a sweep (issue 27, item 4): never an exit 0, never a
state on disk that says more than happened.

A stage is reached for certain, not by timing: the command runs in a child Python in which the
stage's function first sends SIGTERM (to the process, or to its process group as a batch
system does), then goes on as it would.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from pylmp_lattice.sweep import load_results
from test_sweep_faults import assert_table_matches_disk, running, start, statuses, wait_for
from test_sweep import BASE

pytestmark = pytest.mark.lammps

# python HOOK MODULE:ATTR[.ATTR] WHO -- ARGS: the CLI with ATTR wrapped to send SIGTERM first
# (WHO: "self" to this process, "group" to its process group)
HOOK = """\
import importlib, os, signal, sys


def hooked(wrapped, who):
    def call(*args, **kwargs):
        os.killpg(os.getpgid(0), signal.SIGTERM) if who == "group" else os.kill(os.getpid(), signal.SIGTERM)
        return wrapped(*args, **kwargs)
    return call


if __name__ == "__main__":  # a sweep's workers import this script again
    where, who = sys.argv[1], sys.argv[2]
    module, names = where.split(":")
    owner = importlib.import_module(module)
    *parents, name = names.split(".")
    for part in parents:
        owner = getattr(owner, part)
    setattr(owner, name, hooked(getattr(owner, name), who))
    from pylmp_lattice.cli import main
    sys.exit(main(sys.argv[4:]))
"""


def hooked(tmp_path: Path, where: str, args: list[str], who: str = "self") -> subprocess.CompletedProcess:
    script = tmp_path / "hook.py"
    script.write_text(HOOK)
    return subprocess.run([sys.executable, str(script), where, who, "--", *args], capture_output=True, text=True,
                          cwd=tmp_path, timeout=300, start_new_session=True)


def state(folder: Path) -> str | None:
    try:
        return json.loads((folder / "run.json").read_text())["state"]
    except FileNotFoundError:
        return None


# stage -> (the function that sends SIGTERM as it starts, run.json's state after, files there and not)
RUN_STAGES = {
    "deck write": ("pylmp_lattice.run_folder.cases:case_to_dict", None, [], ["in.lattice", "case.toml"]),
    "engine": ("pylmp_lattice.runner:new_lammps", "interrupted", ["in.lattice", "log.lammps"], ["summary.json"]),
    "conversion": ("pylmp_lattice.run_folder.execution:convert_claimed", "done", ["traj.bin"], ["summary.json"]),
    "summary": ("pylmp_lattice.summary:summary_of", "done", ["traj.h5md"], ["summary.json"]),
    "figure": ("pylmp_lattice.run_folder.folder:RunFolder.figure", "done", ["summary.json"], ["shock.png"]),
}


@pytest.mark.parametrize("stage", RUN_STAGES)
def test_sigterm_at_each_stage_of_a_run_exits_143_and_records_what_happened(tmp_path, stage):
    where, recorded, kept, absent = RUN_STAGES[stage]
    (tmp_path / "base.toml").write_text(BASE.format(particles=20, duration=5.0, output=1.0))
    done = hooked(tmp_path, where, ["run", "base.toml", "-o", "r", "--quiet"])
    assert done.returncode == 143, done.stderr
    assert done.stdout == "" and "Traceback" not in done.stderr
    last = done.stderr.splitlines()[-1]
    assert last.startswith("pylmp-lattice: interrupted"), done.stderr
    # once LAMMPS has ended, the line says that nothing of the run is lost and what finishes it
    assert ("after the run had ended" in last and "`pylmp-lattice summarize r` finishes it" in last) \
        == (recorded == "done"), last
    folder = tmp_path / "r"
    assert state(folder) == recorded
    assert all((folder / name).is_file() for name in kept), sorted(p.name for p in folder.iterdir())
    assert not any((folder / name).exists() for name in absent), sorted(p.name for p in folder.iterdir())
    if stage == "deck write":  # a write stopped half-way leaves nothing that blocks the same command again
        assert not list(folder.iterdir())
        again = subprocess.run([sys.executable, "-m", "pylmp_lattice.cli", "run", "base.toml", "-o", "r", "--quiet"],
                               capture_output=True, text=True, cwd=tmp_path, timeout=300)
        assert again.returncode == 0, again.stderr
        assert state(folder) == "done"


def test_a_stop_before_an_overwriting_run_ends_is_not_said_to_come_after_it(tmp_path):
    """The folder holds a finished run; `--overwrite` with another case is stopped before its own
    run ends: the line must not say that the run had ended (the folder's run.json is the old
    run's, not this command's)."""
    (tmp_path / "base.toml").write_text(BASE.format(particles=20, duration=5.0, output=1.0))
    first = subprocess.run([sys.executable, "-m", "pylmp_lattice", "run", "base.toml", "-o", "r", "--quiet"],
                           capture_output=True, text=True, cwd=tmp_path, timeout=300)
    assert first.returncode == 0 and state(tmp_path / "r") == "done", first.stderr
    for where in ("pylmp_lattice.preflight:check", "pylmp_lattice.runner:new_lammps"):
        done = hooked(tmp_path, where, ["run", "base.toml", "-o", "r", "--quiet", "--overwrite", "--set",
                                        "run.duration=6"])
        last = done.stderr.splitlines()[-1]
        assert done.returncode == 143 and last.startswith("pylmp-lattice: interrupted"), done.stderr
        assert "after the run had ended" not in last, last


@pytest.mark.slow
def test_sigterm_to_a_sweeps_process_group_records_its_running_members_interrupted(tmp_path):
    """As a batch system stops a job: every process of the group gets SIGTERM, the fork server
    included; it must not die under the pool (a broken pool killed the workers, whose members
    stayed "running")."""
    cmd, out, proc = start(tmp_path, workers=2)
    wait_for(lambda: len(running(out)) == 2, proc)
    os.killpg(proc.pid, signal.SIGTERM)
    err = proc.communicate(timeout=60)[1]
    assert proc.returncode == 143, err
    assert "Traceback" not in err and "a worker was lost" not in err
    records = statuses(out).values()
    assert records and {r["status"] for r in records} <= {"done", "interrupted"}, records
    assert_table_matches_disk(out)


def test_sigterm_to_a_sweeps_process_group_while_the_fork_server_starts(tmp_path):
    sweep = tmp_path / "sweep.toml"
    (tmp_path / "base.toml").write_text(BASE.format(particles=8, duration=5.0, output=1.0))
    sweep.write_text('base = "base.toml"\nkeep = "measures"\n[grid]\n"impactor.velocity" = [0.5, 0.6]\n')
    done = hooked(tmp_path, "pylmp_lattice.sweep.pool:start_forkserver", ["sweep", str(sweep), "-o", "out", "--quiet"],
                  who="group")
    assert done.returncode == 143, done.stderr
    assert "Traceback" not in done.stderr
    assert done.stderr.splitlines()[-1].startswith("pylmp-lattice: interrupted;")
    assert not statuses(tmp_path / "out")  # no member started


def test_sigterm_to_a_sweeps_process_group_while_its_table_is_written(tmp_path):
    """The members are done, the table is written whole, and the command still says it was stopped."""
    sweep = tmp_path / "sweep.toml"
    (tmp_path / "base.toml").write_text(BASE.format(particles=8, duration=5.0, output=1.0))
    sweep.write_text('base = "base.toml"\nkeep = "measures"\n[grid]\n"impactor.velocity" = [0.5, 0.6]\n')
    out = tmp_path / "out"
    done = hooked(tmp_path, "pylmp_lattice.sweep.table:Table.write", ["sweep", str(sweep), "-o", "out", "--quiet"],
                  who="group")
    assert done.returncode == 143, done.stderr
    assert "Traceback" not in done.stderr
    assert list(load_results(out)["status"]) == ["done", "done"]
    assert_table_matches_disk(out)


def test_a_hand_run_stopped_by_ctrl_c_is_quiet_and_summarized_at_once(tmp_path):
    """The deck's own hint, `pylmp-lattice lmp -in in.lattice`, stopped by Ctrl-C (SIGINT to the
    terminal's process group): one line, exit 130, and `summarize` measures it at once (it used
    to refuse for 30 s, "still being written by LAMMPS")."""
    import re
    import time

    from pylmp_lattice.run_folder import RunFolder

    (tmp_path / "base.toml").write_text(BASE.format(particles=400, duration=2000.0, output=10.0))
    cli = [sys.executable, "-m", "pylmp_lattice.cli"]
    deck = subprocess.run(cli + ["deck", "base.toml", "-o", "d"], cwd=tmp_path, capture_output=True, text=True)
    assert "(cd d && pylmp-lattice lmp -in in.lattice)" in deck.stdout
    proc = subprocess.Popen(cli + ["lmp", "-in", "in.lattice"], cwd=tmp_path / "d", start_new_session=True,
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    folder = RunFolder(tmp_path / "d")
    log = tmp_path / "d" / "log.lammps"
    # three thermo rows (a row a frame): the stop leaves frames to measure and draw
    while len(re.findall(r"^\s+\d+\s+\S", (log.read_text() if log.exists() else "").partition("Step")[2], re.M)) < 3:
        assert proc.poll() is None, proc.stderr.read()
        time.sleep(0.05)
    assert folder.status == "running"
    os.killpg(proc.pid, signal.SIGINT)
    err = proc.communicate(timeout=60)[1]
    at = json.loads((tmp_path / "d" / "run.json").read_text())["time_ms"]
    assert proc.returncode == 130 and err == f"pylmp-lattice: interrupted at t = {at:g} ms (files kept in {tmp_path / 'd'})\n", err
    assert folder.status == "interrupted" and state(tmp_path / "d") == "interrupted"
    summary = folder.summarize(figure=False)  # at once: no "still being written" for 30 s
    assert summary["status"] == "interrupted" and summary["stopped"]["time_ms"] == pytest.approx(at, rel=1e-14)
    assert 0 < at < 2000.0
    # the run ended softly, as the CLI's does: the deck's lines after `run` wrote the engine's
    # front record (lmp, killed, wrote none: the front came from frames, with a +-1 % sawtooth in V_P)
    assert (tmp_path / "d" / "front.bin").is_file() and summary["front_resolution"]["source"] == "engine record"
    assert (tmp_path / "d" / "log.lammps").read_text().rstrip().splitlines()[-1].startswith("Total wall time")
    assert folder.figure()._suptitle.get_text().endswith(f"; stopped at {at:.5g} of 2000 ms (interrupted)")


def test_a_killed_cli_run_is_known_to_have_ended_at_once(tmp_path):
    """SIGKILL leaves run.json "running", but it names its writer, which is gone: the run is
    "interrupted" at once, not after 30 s."""
    import time

    from pylmp_lattice.run_folder import RunFolder

    (tmp_path / "base.toml").write_text(BASE.format(particles=400, duration=2000.0, output=10.0))
    proc = subprocess.Popen([sys.executable, "-m", "pylmp_lattice.cli", "run", "base.toml", "-o", "r", "--quiet"],
                            cwd=tmp_path, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    log = tmp_path / "r" / "log.lammps"
    while "Step" not in (log.read_text() if log.exists() else ""):
        assert proc.poll() is None
        time.sleep(0.05)
    proc.kill()
    proc.wait()
    assert state(tmp_path / "r") == "running"
    assert RunFolder(tmp_path / "r").status == "interrupted"


def test_a_pool_workers_own_threads_leave_the_stop_signals_to_its_main_thread():
    """A stop signal that the kernel hands to a worker's pipe-watching thread never runs the
    handler (Python runs handlers in the main thread only): a worker whose main thread was
    blocked on the task queue's lock stayed blocked, and the pool's shutdown with it (5 of 30
    SIGTERMs to a sweep's process group at its table's write hung, with the pool's kill after
    GRACE disabled). Its threads block the stop signals; the main thread takes them."""
    code = """
import json, multiprocessing, os, time
from pylmp_lattice.sweep import pool
alive, stop = multiprocessing.Pipe(duplex=False), multiprocessing.Pipe(duplex=False)
pool._pool_worker_init(alive[0], stop[0])
time.sleep(0.1)  # the threads set their masks
masks = {}
for tid in os.listdir("/proc/self/task"):
    status = open(f"/proc/self/task/{tid}/status").read().splitlines()
    masks[tid] = int(next(line for line in status if line.startswith("SigBlk")).split()[1], 16)
print(json.dumps({"main": masks.pop(str(os.getpid())), "others": list(masks.values())}))
"""
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    masks = json.loads(done.stdout)
    stops = (1 << (signal.SIGINT - 1)) | (1 << (signal.SIGTERM - 1))
    assert masks["main"] & stops == 0
    assert len(masks["others"]) == 2 and all(mask & stops == stops for mask in masks["others"]), masks


def test_a_stop_that_lands_in_a_finalizer_prints_no_traceback():
    """A worker's stop signal raises Interrupted in whatever Python code runs: inside a finalizer
    (an h5py object's __dealloc__, a weak reference's callback) Python drops it and printed
    "Exception ignored in ..." with a traceback (2 of 15 Ctrl-C of a keep = "all" sweep). Now
    dropped quietly; the stop itself stands, and another exception in a finalizer is still shown."""
    code = """
import multiprocessing, os, signal, time
from pylmp_lattice.sweep import pool, signals
alive, stop = multiprocessing.Pipe(duplex=False), multiprocessing.Pipe(duplex=False)
pool._pool_worker_init(alive[0], stop[0])
signals.IN_TASK.set()  # in a task: a stop raises Interrupted where the main thread is

class Finalized:
    def __del__(self):
        os.kill(os.getpid(), signal.SIGINT)
        time.sleep(0.2)  # the handler runs here, inside the finalizer

class Broken:
    def __del__(self):
        raise ValueError("a finalizer's own error")

del_me = Finalized()
del del_me
print("stop stands:", signals.STOP.is_set(), flush=True)
other = Broken()
del other
"""
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert "stop stands: True" in done.stdout, (done.stdout, done.stderr)
    assert "Interrupted" not in done.stderr and done.stderr.count("Exception ignored") == 1, done.stderr
    assert "a finalizer's own error" in done.stderr


STOPPED_WHILE_SENDING = """import os, sys, time
from pathlib import Path
from pylmp_lattice.errors import Interrupted
from pylmp_lattice.sweep import pool, signals


def big_after_stop(size, lead):
    signals.IN_TASK.set()  # as run_task sets it: a stop raises Interrupted here
    data = b"x" * size
    try:
        time.sleep(30)
    except Interrupted:
        pass
    time.sleep(pool.GRACE - lead)  # its send starts `lead` s before the worker's exit after the stop
    signals.IN_TASK.clear()
    return data


def big_then_stopped(size, mark):
    data = b"x" * size
    Path(mark).touch()  # the coordinator stops the pool now: while this result is sent
    return data


if __name__ == "__main__":
    size, case = 100_000_000, sys.argv[1]
    with pool.executor_pool(1, None, "embedded", None, None) as p:
        if case == "exit":
            future = p.executor.submit(big_after_stop, size, 0.03)
            time.sleep(1.5)  # in the task
        else:
            mark = Path(sys.argv[2])
            future = p.executor.submit(big_then_stopped, 2 * size, str(mark))
            while not mark.exists():
                time.sleep(0.001)
        p.on_signal(1)
        try:
            print(f"got {len(future.result(timeout=10))} bytes", flush=True)
        except Exception as err:
            print(f"got {type(err).__name__}", flush=True)
    print("shut down", flush=True)
"""


@pytest.mark.parametrize("case", ["exit", "signal"])
def test_a_stopped_worker_sends_its_result_whole_before_it_exits(tmp_path, case):
    """A stopped worker sends the result in hand whole: cut off halfway, the result was lost and
    the coordinator's reader waited for the rest of it forever, and the sweep's command with it
    (SIGINT 1-2 s into 10^4-member sweeps: 1 run in 13 to 20 never ended). Two ways: its exit
    GRACE s after the stop came as it sent a result (`exit`: 100 MB, begun 30 ms before), and
    the stop signal itself came between tasks, with the last task's result half sent (`signal`:
    200 MB, the stop sent as the task returns)."""
    script = tmp_path / "stopper.py"
    script.write_text(STOPPED_WHILE_SENDING)
    process = subprocess.Popen([sys.executable, str(script), case, str(tmp_path / "mark")], stdout=subprocess.PIPE,
                               text=True, start_new_session=True)
    try:
        out, _ = process.communicate(timeout=30)
    except subprocess.TimeoutExpired:
        os.killpg(process.pid, signal.SIGKILL)
        out, _ = process.communicate()
    size = 100_000_000 if case == "exit" else 200_000_000
    assert out.split("\n")[:2] == [f"got {size} bytes", "shut down"], out


SLOW_IMPORT = "import os, signal, time\nos.kill(os.getpid(), signal.SIGTERM)\ntime.sleep(0.2)\nDONE = True\n"


def test_sigterm_inside_an_import_stops_the_command_after_it(tmp_path, monkeypatch):
    """A SIGTERM that arrives while a module initialises (matplotlib's C extensions as the figure
    is drawn) is not raised there, which left the module broken, the stop read as the figure's
    ImportError and Python aborting at exit: it is sent again once the import is done. Here a
    module that signals itself in its own import: it loads whole, and the stop comes after it,
    in the work that follows or, when the command ends first, as its exit code."""
    from pylmp_lattice import cli
    from pylmp_lattice.errors import ConfigError, Interrupted

    monkeypatch.syspath_prepend(str(tmp_path))
    (tmp_path / "slow_import_a.py").write_text(SLOW_IMPORT)
    (tmp_path / "slow_import_b.py").write_text(SLOW_IMPORT)
    previous = signal.signal(signal.SIGTERM, cli._raise_interrupted)
    try:
        import slow_import_a

        assert slow_import_a.DONE
        with pytest.raises(Interrupted):
            for _ in range(100):  # 1 s; the signal comes again after RETRY_S
                time.sleep(0.01)
    finally:
        signal.signal(signal.SIGTERM, previous)

    def info_then_import(args):
        import slow_import_b  # noqa: F401

        return 0

    monkeypatch.setattr(cli, "_info", info_then_import)
    assert cli.main(["info"]) == 128 + signal.SIGTERM
    assert signal.getsignal(signal.SIGTERM) is previous

    def import_then_fail(args):  # an error's path: the stop is its exit code, not a kill by SIGTERM later
        import slow_import_c  # noqa: F401

        raise ConfigError("impactor.velocity", "must be > 0")

    (tmp_path / "slow_import_c.py").write_text(SLOW_IMPORT)
    monkeypatch.setattr(cli, "_info", import_then_fail)
    try:
        assert cli.main(["info"]) == 128 + signal.SIGTERM
        assert not cli._RETRY  # no signal left to come, which would end the process after its error
    finally:
        while cli._RETRY:
            cli._RETRY.pop().cancel()
