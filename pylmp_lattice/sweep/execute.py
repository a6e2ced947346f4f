"""Running a sweep's members: one code path for a local process pool and a Dask cluster.

Both are `concurrent.futures` executors (`ProcessPoolExecutor`, or a `distributed.Client`'s
`get_executor()`); `run_member` runs in the worker and writes everything to the member's
folder, so results live on disk, not in worker memory. The coordinator (this process) skips
members that are done, collects the rest as they finish, and rewrites the table after each.
"""

from __future__ import annotations

import contextlib
import fcntl
import multiprocessing
import os
import resource
import shutil
import signal
import sys
import threading
import time
from concurrent.futures import Executor, ProcessPoolExecutor, as_completed
from dataclasses import dataclass
from pathlib import Path

import pandas as pd

from ..case import Case
from ..errors import Interrupted
from .spec import Member, Sweep
from .store import DONE, FAILED, INTERRUPTED, MEMBERS, RUNNING, member_folder, now, provenance, read_status, write_status
from .table import member_row, write_table

LOCK = "sweep.lock"


@dataclass(frozen=True)
class Task:
    """What a worker needs to run one member (small and picklable)."""

    folder: str
    id: str
    index: int
    params: dict
    case: Case
    runner: str


def run_member(task: Task) -> dict:
    """Run one member in its folder; return {"record": status record, "summary": summary or None}.

    Any earlier unfinished attempt in the folder is removed first (it never counted as done).
    Every error of the run becomes the member's one-line error; the status is written last.
    """
    from ..run_folder import run_case

    folder = Path(task.folder)
    if folder.exists():
        shutil.rmtree(folder)
    folder.mkdir(parents=True)
    start, cpu = time.perf_counter(), _cpu_time()
    record = {"id": task.id, "index": task.index, "params": task.params, "status": RUNNING, "error": None,
              "started": now(), "provenance": provenance()}
    write_status(folder, record)
    summary = None
    try:
        # yes: a sweep is batch work, started knowingly; the disk and memory guard still applies
        summary = run_case(task.case, folder, runner=task.runner, figure=False, yes=True)
        record["status"] = DONE
    except Interrupted:  # Ctrl-C or SIGTERM: unfinished, not failed; on disk it stays "running"
        return {"record": record | {"status": INTERRUPTED}, "summary": None}
    except Exception as err:  # noqa: BLE001 - any failure is recorded, and the sweep goes on
        record |= {"status": FAILED, "error": one_line(err)}
    record |= {"ended": now(), "wall_time_s": round(time.perf_counter() - start, 3),
               "cpu_time_s": round(_cpu_time() - cpu, 3)}
    write_status(folder, record)
    return {"record": record, "summary": summary}


def _cpu_time() -> float:
    """CPU seconds of this process and its finished children (the `lmp` runner's engine)."""
    children = resource.getrusage(resource.RUSAGE_CHILDREN)
    return time.process_time() + children.ru_utime + children.ru_stime


def one_line(err: BaseException) -> str:
    """An exception as one line; our own errors speak for themselves, others get their type."""
    from ..errors import LatticeError

    lines = str(err).strip().splitlines()
    text = lines[0] if lines else ""
    return text if isinstance(err, LatticeError) and text else f"{type(err).__name__}: {text}".rstrip(": ")


def run_sweep(sweep: Sweep, root: str | Path, workers: int | None = None, scheduler: str | None = None,
              retry_failed: bool = False, progress: bool = True) -> pd.DataFrame:
    """Run every member not yet done; return the table (also in root/results.{csv,parquet}).

    workers: local processes (default: one per core); scheduler: a Dask scheduler address
    (tcp://HOST:PORT), whose workers must see `root` on a shared file system.
    Members that failed before are skipped unless `retry_failed`.
    """
    root = Path(root)
    members = sweep.members()
    (root / MEMBERS).mkdir(parents=True, exist_ok=True)
    with _lock(root):
        return _run(sweep, root, members, workers, scheduler, retry_failed, progress)


def _run(sweep: Sweep, root: Path, members: list[Member], workers, scheduler, retry_failed, progress) -> pd.DataFrame:
    rows: dict[int, dict] = {}
    todo: list[Member] = []
    for m in members:
        folder = member_folder(root, m.id)
        record = read_status(folder)
        finished = record is not None and record.get("id") == m.id and record["status"] in (DONE, FAILED)
        if finished and (record["status"] == DONE or not retry_failed):
            rows[m.index] = _row(m, record, _summary(folder) if record["status"] == DONE else None)
        elif m.case is None:  # invalid parameters: failed without running
            folder.mkdir(parents=True, exist_ok=True)
            record = {"id": m.id, "index": m.index, "params": m.params, "status": FAILED, "error": m.error,
                      "started": now(), "ended": now(), "wall_time_s": 0.0, "provenance": provenance()}
            write_status(folder, record)
            rows[m.index] = _row(m, record, None)
        else:
            todo.append(m)
    table = write_table(root, [rows[i] for i in sorted(rows)])
    bar = _Progress(len(members), rows, progress)
    with _executor(workers, scheduler, sweep.runner) as (executor, slots):
        bar.slots = slots
        futures = {executor.submit(run_member, _task(root, m, sweep)): m for m in todo}
        bar.show(running=len(futures))
        try:
            for future in as_completed(futures):
                # dropped once handled: a Dask future kept would keep the result in a worker's
                # memory, and a worker retiring (its lifetime) would have the member run again
                m = futures.pop(future)
                try:
                    result = future.result()
                except Exception as err:  # noqa: BLE001 - the worker itself was lost (killed, crashed)
                    result = _lost(root, m, err)
                del future
                if result["record"]["status"] == INTERRUPTED:
                    continue
                rows[m.index] = _row(m, result["record"], result["summary"])
                table = write_table(root, [rows[i] for i in sorted(rows)])
                bar.advance(running=len(futures))
        except (KeyboardInterrupt, Interrupted):
            # queued members never start; running ones are stopped (pool) and re-run on resume
            for future in futures:
                future.cancel()
            _interrupt_workers(executor)
            bar.close()
            raise
    bar.close()
    return table


@contextlib.contextmanager
def _lock(root: Path):
    """One coordinator per sweep folder (the kernel drops the lock if the coordinator dies)."""
    from ..errors import ConfigError

    with open(root / LOCK, "a+") as f:
        try:
            fcntl.flock(f, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError as err:
            raise ConfigError("-o", f"another sweep is running in {root}; wait for it or choose another folder") from err
        yield


def _task(root: Path, m: Member, sweep: Sweep) -> Task:
    return Task(str(member_folder(root, m.id).resolve()), m.id, m.index, m.params, m.case, sweep.runner)


def _row(m: Member, record: dict, summary: dict | None) -> dict:
    return member_row(m.id, m.params, f"{MEMBERS}/{m.id}", record, summary)


def _summary(folder: Path) -> dict | None:
    from ..run_folder import RunFolder

    return RunFolder(folder).summary


def _lost(root: Path, m: Member, err: BaseException) -> dict:
    """A member whose worker died: recorded as failed (re-run with --retry-failed)."""
    folder = member_folder(root, m.id)
    record = (read_status(folder) or {"id": m.id, "index": m.index, "params": m.params, "started": None})
    record |= {"status": FAILED, "error": f"worker lost: {one_line(err)}", "ended": now(), "wall_time_s": None}
    folder.mkdir(parents=True, exist_ok=True)
    write_status(folder, record)
    return {"record": record, "summary": None}


@contextlib.contextmanager
def _executor(workers: int | None, scheduler: str | None, runner: str):
    """(executor, number of worker slots): a local process pool, or a Dask cluster's executor.

    The embedded runner changes the worker's working directory while LAMMPS runs, so it
    needs one member at a time per process: pool processes are, Dask workers must be."""
    from ..errors import ConfigError

    if workers is not None and not (isinstance(workers, int) and workers >= 1):
        raise ConfigError("--workers", f"got {workers!r}; expected an integer >= 1")
    if scheduler is None:
        workers = workers or os.cpu_count() or 1
        # forkserver: workers are forked from a clean server process (never from a coordinator
        # that may hold threads or an initialised MPI), which imports the package once and
        # stays up for later sweeps of the same Python session.
        context = multiprocessing.get_context("forkserver")
        context.set_forkserver_preload(["pylmp_lattice.sweep.execute", "pylmp_lattice.run_folder.execution", "pylmp_lattice.summary"])
        _start_forkserver()
        with ProcessPoolExecutor(workers, mp_context=context, initializer=_pool_worker_init,
                                 initargs=(os.getpid(),)) as pool:
            yield pool, workers
        return
    if workers is not None:
        raise ConfigError("--workers", "the Dask cluster has its own workers; leave --workers out with --scheduler")
    from distributed import Client

    try:
        client = Client(scheduler, timeout="20s")
    except (OSError, TimeoutError) as err:
        raise ConfigError("--scheduler", f"cannot reach {scheduler} ({err})") from err
    try:
        threads = client.nthreads()
        if runner == "embedded" and any(n > 1 for n in threads.values()):
            raise ConfigError("runner", "the embedded runner needs Dask workers with one thread each "
                              "(dask worker --nthreads 1); or set runner = \"lmp\" in the sweep file")
        executor: Executor = client.get_executor(pure=False)
        yield executor, max(1, sum(threads.values()))
    finally:
        client.close()


def _interrupt_workers(executor: Executor) -> None:
    """Ask a local pool's workers to stop their members (the engine stops at the next step).
    A Dask cluster's running members finish on their own; their results stay on disk."""
    if isinstance(executor, ProcessPoolExecutor):
        for process in list((executor._processes or {}).values()):  # no public list of workers
            with contextlib.suppress(ProcessLookupError, TypeError):
                os.kill(process.pid, signal.SIGINT)


def _start_forkserver() -> None:
    """Start the fork server with Ctrl-C ignored (inherited): it and its workers are left to the
    coordinator, and an early Ctrl-C does not interrupt its imports with a traceback."""
    from multiprocessing import forkserver

    if threading.current_thread() is not threading.main_thread():
        return  # signal handlers can only be set from the main thread
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        forkserver.ensure_running()
    finally:
        signal.signal(signal.SIGINT, previous)


def _pool_worker_init(coordinator: int) -> None:
    """A pool worker: Ctrl-C is for the coordinator, and the worker ends when the sweep does.

    Without this watch, the workers of a coordinator killed with SIGKILL would wait for work
    forever (and keep the fork server alive).
    """
    signal.signal(signal.SIGINT, signal.SIG_IGN)

    def watch():
        while True:
            time.sleep(1.0)
            try:
                os.kill(coordinator, 0)
            except ProcessLookupError:
                os._exit(1)  # the member in hand stays "running" on disk and is re-run on resume

    threading.Thread(target=watch, daemon=True).start()


class _Progress:
    """A progress bar on stderr: members finished of all, failed, running, and time left."""

    def __init__(self, total: int, rows: dict, enabled: bool):
        from tqdm import tqdm

        self.rows, self.slots = rows, 1
        self.bar = tqdm(total=total, initial=len(rows), file=sys.stderr, disable=not enabled,
                        unit="member", dynamic_ncols=True)

    def show(self, running: int, refresh: bool = True) -> None:
        failed = sum(r["status"] == FAILED for r in self.rows.values())
        self.bar.set_postfix_str(f"done {len(self.rows) - failed}, failed {failed}, running {min(self.slots, running)}",
                                 refresh=refresh)

    def advance(self, running: int) -> None:
        self.show(running, refresh=False)
        self.bar.update(1)

    def close(self) -> None:
        self.bar.close()
