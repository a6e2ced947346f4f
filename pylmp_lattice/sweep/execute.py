"""Running a sweep: the coordinator. One code path for a local process pool and any
`concurrent.futures` executor (a Dask cluster's `get_executor()`, a batch system's).

The coordinator counts the members and estimates the run before enumerating them, claims the
folder (one coordinator per DIR, DIR/sweep.json names the sweep it holds), then enumerates the
members lazily: a member done on disk (status done, summary that parses) is skipped, the others
are grouped into tasks, consecutive members of one parameter point, sized to the workers
(`blocks._Blocks`), and run by `batch.run_task` in the workers, whose results live on disk. At most one
task per worker is in flight, so a stop never finds members queued. The table is kept in
memory (O(1) per member), written at most every 30 s (`Table`) and at the end.

Stopping (SIGINT, SIGTERM): no further task is sent, the local workers are told to stop (their
engines stop at the next step, their members become "interrupted"), the table is written, and
`Interrupted` is raised, within about a second; a second signal kills the workers at once.
A local worker exits by itself when the coordinator dies (it watches a pipe, which closes
whether or not the dead coordinator is reaped). A lost worker (killed, out of memory) breaks
the pool: every member in flight is read back from its folder, "done" if it finished there,
else "interrupted", and the sweep stops; running the command again completes it.
"""

from __future__ import annotations

import contextlib
import importlib
import itertools
import logging
import os
import threading
import time
from concurrent.futures import FIRST_COMPLETED, Executor, Future, wait
from pathlib import Path

from ..errors import ConfigError, Interrupted, UsageError, require_bool
from ..formats.files import DiskFull, remove_tree
from ..formats.layout import deck_dir
from ..run_folder import marker
from . import disk
from .batch import Note, Task
from .blocks import GPU_MAX_ATOMS, _Blocks  # noqa: F401 - GPU_MAX_ATOMS: read here by tests
from .estimate import _estimate
from .folder import check_folder, claim, lock, refuse_other, refuse_running
from .member import one_line, unstarted
from .pool import GRACE, Pool, executor_pool, pool_slots
from .progress import _Progress
from .signals import _StopSignals
from .spec import Member, Replicas, Sweep
from .store import (DONE, FAILED, INTERRUPTED, MEMBERS, RUNNING, Outcomes, member_folder, now, read_status, remove_stale_locks,
                    write_status)
from .table import CSV, Rows, Table, batch_rows, member_row

log = logging.getLogger(__name__)

# A grid this large needs yes=True (--yes): enumerating it alone takes minutes.
MANY_MEMBERS = 100_000
PRELOAD_THREAD = "sweep-preload"  # the coordinator's thread that loads what the end needs (`_preload`)


def run_sweep(sweep: Sweep, root: str | Path, workers: int | None = None, scheduler: str | None = None,
              retry_failed: bool = False, progress: bool = True, executor: Executor | None = None,
              slots: int | None = None, overwrite: bool = False, yes: bool = False, engine: str | None = None,
              stats: bool | ReplicaDrawing = False):
    """Run every member not yet done; return the table (a pandas DataFrame, also in
    root/results.{csv,parquet}).

    workers: local processes (default: one per core); scheduler: a Dask scheduler address
    (tcp://HOST:PORT), whose workers must see `root` on a shared file system; or executor: any
    `concurrent.futures.Executor` with `slots` workers (default 1; e.g. a batch system's), used
    as given; the estimate of time and disk counts the workers the pool will have (`pool_slots`).
    Members that failed before are skipped unless `retry_failed`. A folder that holds a
    different sweep is refused unless `overwrite` (see `folder.claim`); a sweep of over
    MANY_MEMBERS members needs `yes`. engine: "lammps", "cpu" or "gpu" for the batched members
    (default: the sweep's, `Sweep.engine`); with "gpu" every worker feeds the one device (the
    members' Python, not the kernel, takes most of the time: `blocks._Blocks`). stats: the
    caller writes the replica statistics next (`stats.write_replica_stats`, as the CLI does),
    so the estimate includes them; a `ReplicaDrawing` has them drawn while the table's files are
    written, for the caller to write.
    Raises Interrupted on SIGINT or SIGTERM, after writing the table. A script that calls it
    needs the `if __name__ == "__main__":` guard: the local workers import it again.
    """
    if _from_worker_import():
        raise RuntimeError("run_sweep was called while a sweep worker imported the main script again (as Python's "
                           "multiprocessing does); put the script's code under `if __name__ == \"__main__\":`")
    require_bool(retry_failed=retry_failed, progress=progress, overwrite=overwrite, yes=yes,
                 **({} if isinstance(stats, ReplicaDrawing) else {"stats": stats}))
    check_folder(root)
    sweep = _with_engine(sweep, engine)
    # every member's folder is in it: refused now, not each member as it runs (a kernel engine's batches need no deck
    # path, but its members that run alone, one a point or keeping trajectories, run with LAMMPS)
    if sweep.runner == "embedded" and (sweep.engine == "lammps" or sweep.replicas == 1 or sweep.keep == "all"):
        deck_dir(Path(root))
    root = Path(root).resolve()
    total = sweep.count()
    counted = pool_slots(workers, scheduler, executor, slots)  # as the pool will have them; None: a Dask scheduler's
    cores = os.cpu_count() or 1
    if workers is not None and executor is None and workers > cores:
        log.warning("--workers %d is more than this machine's %d cores: the members share them (each runs slower, "
                    "and each worker holds its own engine in memory)", workers, cores)
    held = refuse_other(root, sweep, overwrite)  # before the estimate is said (and again, under the lock, by `claim`)
    refuse_running(root)  # likewise a sweep running there (its lock is taken below)
    # the members left to run (--yes or not): all where DIR holds no sweep, or another one (--overwrite keeps its
    # members' folders, which are not this sweep's); else those not kept (`to_keep`, which may count such folders
    # left from an earlier --overwrite too, so that it may exceed total)
    ours = held is not None and held.get("identity") == sweep.identity()
    # (where DIR holds other sweeps' outcomes too, only this sweep's members count: each one's id made)
    ids = _ids(sweep) if ours and held.get("others") else None
    todo = max(0, total - Outcomes(root).to_keep(retry_failed, ids)) if ours else total
    disk_need = disk.check(sweep, root, todo, counted)
    kept = f", {total - todo} kept from before" if todo < total else ""
    log.info("%s: %d members%s (%s; %s)", root.name, total, kept, _estimate(sweep, todo, counted, bool(stats)),
             disk_need)
    if total > MANY_MEMBERS and not yes:
        raise UsageError("--yes", f"the sweep has {total} members (over {MANY_MEMBERS}); pass --yes (yes=True) "
                          "to run them, or sweep fewer values")
    root.mkdir(parents=True, exist_ok=True)
    with lock(root), _StopSignals() as stop:
        claim(root, sweep, overwrite)
        (root / MEMBERS).mkdir(exist_ok=True)
        try:
            warm = _gpu_warm(sweep) if executor is None and scheduler is None else None  # (a local pool's alone)
            with executor_pool(workers, scheduler, sweep.runner, executor, slots, sweep.engine, warm) as pool:
                stop.on_signal = pool.on_signal
                return _Coordinator(sweep, root, pool, stop, retry_failed, progress, total,
                                    figure=bool(stats) and sweep.replicas > 1,
                                    drawing=stats if isinstance(stats, ReplicaDrawing) else None, todo=todo).run()
        finally:
            remove_stale_locks(root)  # those of tasks whose worker was killed


def _gpu_warm(sweep: Sweep):
    """For engine "gpu": one chain of its first member for one step (`engines.gpu.warm_batch`), which
    each worker runs as it starts; None otherwise."""
    if sweep.engine != "gpu":
        return None
    from ..engines.gpu import warm_batch

    run = next(iter(sweep.iter_runs()), None)
    return warm_batch(_first(run).case) if run is not None else None


def _ids(sweep: Sweep) -> set[str]:
    """The identities of the sweep's members."""
    return {i for run in sweep.iter_runs() for i in (run.ids if isinstance(run, Replicas) else (m.id for m in run))}


def _first(run: Replicas | list[Member]) -> Member:
    """The first member of a run of `Sweep.iter_runs`."""
    return run.first if isinstance(run, Replicas) else run[0]


# ----------------------------------------------------------------------------- the coordinator

class _Coordinator:
    def __init__(self, sweep: Sweep, root: Path, pool: Pool, stop: _StopSignals, retry_failed: bool,
                 progress: bool, total: int, figure: bool = False, drawing: ReplicaDrawing | None = None,
                 todo: int | None = None):
        self.sweep, self.root, self.pool, self.stop = sweep, root, pool, stop
        self.figure = figure  # the caller draws the replica statistics' figure next
        self.drawing = drawing if figure else None  # ... or has it drawn beside the table's last write
        self.retry_failed, self.total = retry_failed, total
        self.table = Table(root)
        self.disk = Outcomes(root)
        # the members to run, which size the tasks: `run_sweep`'s count, all of them where DIR held
        # another sweep (its outcomes, which --overwrite leaves on disk, counted as this sweep's
        # had made every task one member, run alone); without it, what the folder may hold is done
        todo = total - self.disk.at_most() if todo is None else todo
        self.blocks = _Blocks(max(1, todo), pool.slots, max(1, total // sweep.replicas), sweep.replicas,
                              engine=sweep.engine)
        self.bar = _Progress(total, progress)
        self.lost = False
        self.full: DiskFull | None = None  # a full disk: the sweep stops as on a signal
        self.preload = None
        self.broken: list[Task] = []  # tasks whose worker did not report: read from disk once the workers are gone
        self.kept = self.kept_failed = 0  # members whose outcome on disk stood (a resumed sweep's), failed ones
        self.noted: set[str] = set()  # the workers' notes said (`batch.Note`)

    def run(self):
        tasks = self._tasks()
        running: dict[Future, Task] = {}
        sent = done_at = None  # when the first task went out, and the last members came back (monotonic s)
        origin = _origin()
        try:
            ready: list[Task] = []  # the next tasks, enumerated while the workers run
            while True:
                stopping = self.stop.signals or self.lost or self.full
                while not stopping and len(running) < self.pool.slots and (ready or self._more(tasks, ready)):
                    task = ready.pop(0)
                    running[self.pool.submit(task)] = task
                    sent = sent or time.monotonic()
                    self.bar.show(len(running))
                if not running:
                    break
                busy = not stopping and len(ready) < self.pool.slots and self._more(tasks, ready)
                if self.preload is None and not busy:  # what the end needs, loaded while members run
                    # (not earlier: its imports hold the GIL, and the workers wait for the tasks)
                    self.preload = threading.Thread(target=_preload, args=(self.figure, self._stopping), name=PRELOAD_THREAD,
                                                    daemon=True)
                    self.preload.start()
                done, _ = wait(running, timeout=0 if busy else 0.2, return_when=FIRST_COMPLETED)
                for future in done:
                    self._collect(running.pop(future), future)
                    done_at = time.monotonic()
                if (self.stop.signals or self.lost or self.full) and running:
                    self._wind_down(running)
                self._write_table(flush=True)
            if self.broken:
                self.pool.kill(wait=True)
                for task in self.broken:
                    self._from_disk(task)
            elif not self._stopping():
                self.pool.release()  # the workers exit while the table is written
        finally:
            self.bar.close()
            table = self._write_table(beside=self._draw if self.drawing and not self._stopping() else None)
            if self.kept:
                failed = self.kept_failed
                log.info("%s: %d of %d members had an outcome before this run (%d done, %d failed): kept, not run "
                         "again%s", self.root.name, self.kept, self.total, self.kept - failed, failed,
                         " (--retry-failed runs the failed ones)" if failed else "")
        done = int((table["status"] == DONE).sum())
        if sent is not None and done_at is not None and not self._stopping():
            _timeline(self.root.name, origin, sent, done_at)
        if self.preload is not None:  # ended (after a stop: at its next step), so that the caller's figure does not
            # draw beside it, nor does the command exit while it runs an extension's code (an abort at exit)
            self.preload.join()
        if self.stop.signals:
            # a warning: where a stopped sweep stands is said under --quiet too
            log.warning("%s: stopped with %d of %d members done", self.root.name, done, self.total)
            raise Interrupted(self.stop.signals[0])
        if self.full:
            # the table the last write left (`_write_table`): current, as last written, or none
            csv = (f"and its {CSV}" if not self.table.dirty else f"and its {CSV} as last written (it may lack the "
                   "latest rows)" if (self.root / CSV).is_file() else f"(no room to write {CSV})")
            raise DiskFull(self.full.path, f"the sweep stopped with {done} of {self.total} members done, kept in "
                                           f"{self.root} {csv}; free space and run the same command to resume")
        return table

    def _stopping(self) -> bool:
        """Whether the sweep is stopping (a signal, a lost worker, a full disk)."""
        return bool(self.stop.signals or self.lost or self.full)

    def _draw(self, table) -> None:
        """The replica statistics drawn (`ReplicaDrawing`), once the thread that warmed matplotlib
        up has ended (it is not thread-safe)."""
        if self.preload is not None:
            self.preload.join()
        self.drawing(table)

    def _write_table(self, flush: bool = False, beside=None):
        """The table written (`flush`: if due; `beside`, see `table.write_table`); on a full disk
        the files keep their last rows and the sweep stops."""
        try:
            return self.table.flush(self.total) if flush else self.table.write(beside)
        except DiskFull as err:
            if self.full is None:
                self._disk_full(err)
            return self.table.frame()

    def _disk_full(self, err: DiskFull) -> None:
        """Stop as on a signal: no task is sent, the workers stop their members."""
        log.warning("%s: %s; stopping", self.root.name, err)
        self.full = err
        self.pool.on_signal(1)

    def _more(self, tasks, ready: list[Task]) -> bool:
        """Enumerate the next task into `ready`; whether there was one."""
        task = next(tasks, None)
        if task is not None:
            ready.append(task)
        return task is not None

    def _tasks(self):
        """Tasks of members not done, in sweep order (members are enumerated as tasks are needed,
        a point's replicas as columns: `spec.Replicas`)."""
        group: list[Member | Replicas] = []
        key = size = None
        count = 0  # members in the group
        for run in self.sweep.iter_runs():
            todo = self._todo(run)
            first = _first(run)
            start = 0
            while start < len(todo):
                if group and (first.point != key or count >= size):
                    yield self._task(group)
                    group, count = [], 0
                if not group:
                    key, size = first.point, self.blocks.next_size(first)
                stop = min(len(todo), start + size - count)
                group += [todo.take(range(start, stop))] if isinstance(todo, Replicas) else todo[start:stop]
                count += stop - start
                start = stop
        if group:
            yield self._task(group)

    def _todo(self, run):
        """The members of a run (`Sweep.iter_runs`) not done; those whose outcome on disk stands
        get their rows (`_finished`)."""
        if not isinstance(run, Replicas):
            return [m for m in run if not self._finished(m)]
        if not self.disk.at_most() or self.disk.none_of(run.ids):  # (a new sweep's: no look at each member, nor its id)
            return run
        found = list(map(self.disk.batched, run.ids))
        self._kept(run, [k for k, f in enumerate(found) if f is not None], found)  # done in a batch: they stand
        todo = [k for k, f in enumerate(found) if f is None and self.disk.get(run.ids[k]) is None]
        had = sorted(set(k for k, f in enumerate(found) if f is None) - set(todo))  # in a folder of their own
        todo = sorted(todo + [k for k, m in zip(had, run.take(had)) if not self._finished(m)])  # unless failed and retried
        return run if len(todo) == len(run) else run.take(todo)

    def _kept(self, run: Replicas, places: list[int], found: list) -> None:
        """The rows of the members at these places of the run, done in a batch on disk (`found`:
        its `store.Batch` and their place there), made a batch at a time (`table.batch_rows`)."""
        for batch, group in itertools.groupby(places, key=lambda k: found[k][0]):
            group = list(group)
            record = batch.record
            if not record.get("batch"):  # (a batch names its folder; one that does not: member by member)
                for m in run.take(group):
                    self._finished(m)
                continue
            rows = batch_rows([run.index[k] for k in group], [run.ids[k] for k in group], list(map(run.params, group)),
                              record["batch"], record, batch.summaries([found[k][1] for k in group]))
            for part in rows:
                self.table.add(part)
            self.bar.advance(DONE, len(group))
            self.kept += len(group)

    def _task(self, group: list[Member | Replicas]) -> Task:
        """A task of these members; the cpu engine gets this machine's cores shared by its workers."""
        threads = max(1, (os.cpu_count() or 1) // self.pool.slots) if self.sweep.engine == "cpu" else None
        return Task(str(self.root), tuple(group), self.sweep.runner, self.sweep.engine, threads)

    def _finished(self, m: Member) -> bool:
        """Whether the member's outcome on disk stands (its row is set from it)."""
        found = self.disk.get(m.id)
        if found is None or (found["record"]["status"] == FAILED and self.retry_failed):
            return False
        self._row(m, found["record"], found["summary"])
        self.kept += 1
        self.kept_failed += found["record"]["status"] == FAILED
        return True

    def _collect(self, task: Task, future: Future) -> None:
        try:
            results = future.result()
        except DiskFull as err:  # its members are read back from the disk
            if self.full is None:
                self._disk_full(err)
            self.broken.append(task)
            return
        except (Exception, Interrupted) as err:  # noqa: BLE001 - the worker was lost (killed, crashed), or stopped
            if not (self.stop.signals or self.lost or self.full):
                log.warning("a worker was lost (%s); the members in flight are read back from their folders",
                            one_line(err))
                self.lost = True
            self.broken.append(task)
            return
        members = None
        for result in results:
            if isinstance(result, Note):  # a line for the log, once a sweep
                if result.text not in self.noted:
                    self.noted.add(result.text)
                    log.warning("%s", result.text)
                continue
            if isinstance(result, Rows):  # a batch's members, done
                self.table.add(result)
                self.bar.advance(DONE, len(result))
                continue
            members = members or {m.id: m for m in task.each()}
            self._row(members[result["id"]], result["record"], result["summary"])

    def _from_disk(self, task: Task) -> None:
        members = task.each()
        disk = Outcomes(self.root, batches=[m.id for m in members])  # as it stands now
        for m in members:
            result = disk.get(m.id)
            if result is None:
                _settle(self.root, m)
            result = result or unstarted(m)
            self._row(m, result["record"], result["summary"])

    def _wind_down(self, running: dict[Future, Task]) -> None:
        """After a stop signal or a lost worker: the workers' reports for GRACE seconds, then
        the workers are killed and what they did not report is read from the disk."""
        deadline = time.monotonic() + GRACE
        while running and time.monotonic() < deadline and len(self.stop.signals) < 2:
            done, _ = wait(running, timeout=0.05, return_when=FIRST_COMPLETED)
            for future in done:
                self._collect(running.pop(future), future)
        self.broken += running.values()
        running.clear()

    def _row(self, m: Member, record: dict, summary: dict | None) -> None:
        folder = record.get("batch") or f"{MEMBERS}/{m.id}"  # a batched member's outcome is its batch's
        if record["status"] == INTERRUPTED and not (self.root / folder).is_dir():
            folder = None  # not started, or its batch stopped before it wrote anything
        self.table.set(m.index, member_row(m.id, m.params, folder, record, summary))
        self.bar.advance(record["status"])


def _origin() -> tuple[float, str]:
    """Where a sweep's timeline starts (monotonic s) and what it is: the command's start where the
    process is one (younger than YOUNG_S as the sweep starts, Linux), else now (a notebook's or
    script's process may be hours old)."""
    from ..overhead import YOUNG_S, process_age

    now = time.monotonic()
    try:
        age = process_age()
    except (OSError, ValueError, IndexError):
        age = YOUNG_S
    return (now - age, "the command started") if age < YOUNG_S else (now, "the sweep started")


def _timeline(name: str, origin: tuple[float, str], sent: float, done_at: float) -> None:
    """Say where the sweep's time went (info): since `origin` (`_origin`), when the first task went
    out, the last members came back and the table (and the replica figure drawn beside it) was
    written."""
    start, since = origin
    now = time.monotonic()
    log.info("%s: %.2f s since %s: the first task sent at %.2f s, the last members done at %.2f s, the table written "
             "at %.2f s", name, now - start, since, sent - start, done_at - start, now - start)


def _settle(root: Path, m: Member) -> None:
    """A member whose status.json still says "running" though its worker is gone (killed GRACE
    s after a stop while it still wrote, or lost while it recorded its stop on a full disk) is
    recorded "interrupted", as a stopped member is; where even that does not fit on the disk,
    its folder goes (freeing room). It runs again on resume either way; only a SIGKILL of the
    whole sweep leaves "running" (a worker of another machine, or one alive, is left alone)."""
    folder = member_folder(root, m.id)
    record = read_status(folder)
    if record is None or record.get("status") != RUNNING:
        return
    host = record.get("provenance", {}).get("host") if isinstance(record.get("provenance"), dict) else None
    if not marker.writer_gone({"state": marker.RUNNING, "host": host, "pid": record.get("pid")}):
        return
    try:
        write_status(folder, record | {"status": INTERRUPTED, "ended": now()})
    except (DiskFull, OSError):
        with contextlib.suppress(OSError):
            remove_tree(folder)


def _with_engine(sweep: Sweep, engine: str | None) -> Sweep:
    """The sweep with `engine` if given; ConfigError for "gpu" where CuPy finds no device."""
    import dataclasses

    if engine is not None:
        sweep = dataclasses.replace(sweep, engine=engine)
    if sweep.engine == "gpu":
        from ..engines.gpu import available

        why = available()
        if why:
            raise ConfigError("engine", f"gpu: {why}; run with engine cpu or lammps")
    return sweep


class ReplicaDrawing:
    """The replica statistics (`stats.draw_replica_stats`) of a sweep's table, drawn while its
    last write writes and syncs the files (`run_sweep(stats=ReplicaDrawing())`): at 10^6 members
    the figure takes some 0.4 s, the CSV's write and sync over a second, mostly without the
    GIL. `drawn(table)` gives them, drawn now if they were not (a lost worker's table), and
    raises what drawing them raised."""

    def __init__(self):
        self.made = None  # (the table, its Drawn or the exception that drawing it raised)

    def __call__(self, table) -> None:
        from .stats import draw_replica_stats

        try:
            self.made = table, draw_replica_stats(table)
        except Exception as err:  # noqa: BLE001 - raised by `drawn`, where the caller would have drawn them
            self.made = table, err

    def drawn(self, table):
        """`stats.Drawn` of this table."""
        from .stats import draw_replica_stats

        if self.made is None or self.made[0] is not table:
            return draw_replica_stats(table)
        if isinstance(self.made[1], Exception):
            raise self.made[1]
        return self.made[1]


def _from_worker_import() -> bool:
    """Whether this process is a multiprocessing child still importing its parent's main script
    (the flag multiprocessing's own check reads): a script without the main guard would start
    a sweep of its own there."""
    import multiprocessing

    return bool(getattr(multiprocessing.current_process(), "_inheriting", False))


def _preload(figure: bool, stopping) -> None:
    """Import what the end of the sweep needs: the table's pandas and parquet writer (about a
    second), and for the `figure` of the replica statistics (which the command draws) matplotlib,
    its first drawing done (`stats.warm_up`); each step only while not `stopping()`."""
    for name in ["pandas", "pyarrow.parquet"]:
        if stopping():
            return
        importlib.import_module(name)
    if figure and not stopping():
        from .stats import warm_up

        try:
            warm_up()
        except Exception:  # noqa: BLE001 - only a head start: the figure itself says what is wrong
            log.debug("the replica figure's warm-up failed", exc_info=True)
