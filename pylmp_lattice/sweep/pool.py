"""The workers of a sweep: any `concurrent.futures` executor, or a local process pool whose
workers are forked from a fork server that loads the engine once.

This module imports nothing heavy, so that `start_forkserver` can start the server (and its
imports) while the command still loads the sweep.
"""

from __future__ import annotations

import contextlib
import logging
import multiprocessing
import os
import signal
import sys
import threading
import time
from concurrent.futures import Executor, Future  # (ProcessPoolExecutor where used: after the fork server starts)

from ..errors import ConfigError, Interrupted, UsageError

STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM)
# Seconds a local worker lives on after a stop signal (to stop its engine and report).
GRACE = 1.0
# What the fork server imports once for all workers: the package's modules (`preload`), and
# LAMMPS's libraries (`forkserver`), which the kernel engines need only for a member that falls
# back to LAMMPS.
LIBRARIES = "pylmp_lattice.sweep.forkserver"
PRELOAD = ["pylmp_lattice.sweep.preload", LIBRARIES]
# CuPy, which each worker of engine "gpu" imports at its first task (on the way to the command's
# first members), imported once by the fork server instead: its import loads its libraries and
# starts no CUDA context (CuPy keeps it so for programs that fork; a context would not survive
# a fork), so each worker still starts its own. Where CuPy is missing the server goes on without it.
GPU_PRELOAD = "cupy"
# numpy's OpenBLAS starts a thread per core as it loads, which spins while a core is free: import
# numpy took 0.128 s of CPU, 0.083 s with one thread (fresh Pythons, 2-core VM), and the sweep
# command and the fork server each paid it on the cores they share on the way to the first member.
# A sweep's processes do no linear algebra that a thread pool would speed up, and a local pool has
# a worker per core already.
ONE_BLAS_THREAD = {"OPENBLAS_NUM_THREADS": "1"}


class Pool:
    """An executor, its number of worker slots, and how to stop its workers (local pools only:
    `stop` tells every worker, also one the pool starts later, to stop)."""

    def __init__(self, executor: Executor | None, slots: int, stop=None, local: bool = False):
        self.executor, self.slots, self._stop, self._local = executor, slots, stop, local
        self.released: threading.Thread | None = None

    def release(self) -> None:
        """No task follows: a local pool's workers exit now, in the background, while the caller
        writes its table (the pool's end waits for them; an executor the caller gave is left as it
        is). 16 GPU workers took 1.0 s to exit, one after another, each freeing its CUDA context
        (benchmarks/trace_sweep.py on an H200)."""
        if self._local and self.released is None:
            self.released = threading.Thread(target=self.executor.shutdown, name="pylmp-lattice-pool-release",
                                             daemon=True)
            self.released.start()

    def submit(self, task) -> Future:
        """Start a task (`batch.run_task`) on a worker; its future."""
        from .batch import run_task

        return self.executor.submit(run_task, task)

    def on_signal(self, count: int) -> None:
        """First signal: the workers stop their engines (a process pool the caller gave: those it
        has now; a Dask cluster's run on); second: they are killed."""
        if count > 1:
            self.kill()
        elif self._stop is not None:
            self._stop()
        else:
            self._signal(signal.SIGINT)

    def kill(self, wait: bool = False) -> None:
        """SIGKILL the workers (when they did not stop on SIGTERM); wait: until they are gone (a
        process pool's; at most GRACE s each)."""
        self._signal(signal.SIGKILL)
        if wait and _process_pool(self.executor):
            for process in list((self.executor._processes or {}).values()):  # noqa: SLF001 - as in _signal
                with contextlib.suppress(AssertionError, ValueError):  # not started, or closed
                    process.join(GRACE)

    def _signal(self, signum: int) -> None:
        if _process_pool(self.executor):
            for process in list((self.executor._processes or {}).values()):  # no public list of workers
                with contextlib.suppress(ProcessLookupError, TypeError, AttributeError):
                    os.kill(process.pid, signum)


def _process_pool(executor) -> bool:
    """Whether `executor` is a ProcessPoolExecutor (its module looked at only if it was loaded)."""
    process = sys.modules.get("concurrent.futures.process")
    return process is not None and isinstance(executor, process.ProcessPoolExecutor)


def pool_slots(workers: int | None, scheduler: str | None, executor: Executor | None, slots: int | None) -> int | None:
    """The worker slots of the pool `executor_pool` makes of these, known before it is made (the
    sweep's estimate of time and disk uses them): an executor's `slots` (1 if not given), a local
    pool's `workers` (one per core if not given); None on a Dask scheduler, whose workers are
    counted only once it is reached. UsageError for a count that is no integer >= 1, or a
    combination that leaves one unused (`slots` counts an executor's workers only)."""
    for name, value in (("--workers", workers), ("slots", slots)):
        if value is not None and not (isinstance(value, int) and not isinstance(value, bool) and value >= 1):
            raise UsageError(name, f"got {value!r}; expected an integer >= 1")
    if executor is not None:
        if workers is not None or scheduler is not None:
            raise UsageError("--workers", "an executor has its own workers; leave out --workers and --scheduler")
        return slots or 1
    if slots is not None:
        raise UsageError("slots", f"got {slots}; it counts the workers of an executor: give executor= too, or leave "
                                  "it out (--workers for a local pool)")
    if scheduler is not None:
        if workers is not None:
            raise UsageError("--workers", "the Dask cluster has its own workers; leave --workers out with --scheduler")
        return None
    return workers or os.cpu_count() or 1


@contextlib.contextmanager
def executor_pool(workers: int | None, scheduler: str | None, runner: str, executor: Executor | None,
                  slots: int | None, engine: str | None = None, warm=None):
    """A `Pool`: the given executor, a local process pool, or a Dask cluster's executor (a local
    pool's workers for `engine` "gpu" make their CUDA context, and run the one-step batch `warm`,
    as they start: `engines.gpu.warm_up`).

    A process holds one LAMMPS (and MPI) instance at a time, so the embedded runner needs one
    task at a time per process: pool processes are, Dask workers must be (one thread each)."""
    count = pool_slots(workers, scheduler, executor, slots)
    if executor is not None:
        yield Pool(executor, count)
        return
    if scheduler is None:
        yield from _local_pool(count, engine, warm)
        return
    from distributed import Client
    from distributed.comm.addressing import parse_address, parse_host_port
    from distributed.comm.registry import backends

    try:  # checked before a Client exists: one made of a bad address can hang in its finalizer
        kind, where = parse_address(scheduler, strict=True)
        parse_host_port(where)
        if kind not in backends:
            raise ValueError(f"unknown scheme {kind!r}")
    except ValueError as err:
        raise UsageError("--scheduler", f"got {scheduler!r} ({err}); expected an address like tcp://HOST:PORT") from err
    try:
        client = Client(scheduler, timeout="20s")
    except (OSError, TimeoutError, ValueError) as err:
        raise UsageError("--scheduler", f"cannot reach {scheduler} ({err}); expected tcp://HOST:PORT") from err
    try:
        threads = client.nthreads()
        if runner == "embedded" and any(n > 1 for n in threads.values()):
            raise ConfigError("runner", "the embedded runner needs Dask workers with one thread each "
                              "(dask worker --nthreads 1); or set runner = \"lmp\" in the sweep file")
        yield Pool(client.get_executor(pure=False), max(1, sum(threads.values())))
    finally:
        client.close()


def _local_pool(workers: int, engine: str | None = None, warm=None):
    """Worker processes forked from a clean fork server (never from a coordinator that may hold
    threads or an initialised MPI), which imports the package once and stays up for later
    sweeps of the same Python session. Each worker holds the read ends of two pipes whose write
    ends only this process holds: when "stop" closes (a stop signal), the worker stops, also
    one that the pool starts after the signal; when "alive" closes (this process died), the
    worker exits."""
    from concurrent.futures import ProcessPoolExecutor

    context = start_forkserver()
    alive_r, alive_w = context.Pipe(duplex=False)
    stop_r, stop_w = context.Pipe(duplex=False)
    pool = ProcessPoolExecutor(workers, mp_context=context, initializer=_pool_worker_init,
                               initargs=(alive_r, stop_r, engine == "gpu", warm if engine == "gpu" else None))
    handle = Pool(pool, workers, stop=stop_w.close, local=True)
    try:
        yield handle
    finally:
        if stop_w.closed:  # stopped: the workers exit within GRACE; one that does so while it holds the task
            _end_workers(pool)  # queue's lock would leave another waiting on it, and the shutdown with it, forever
        if handle.released is not None:
            handle.released.join()
        else:
            pool.shutdown(wait=True, cancel_futures=True)
        for end in (alive_w, alive_r, stop_w, stop_r):
            end.close()


def _end_workers(pool) -> None:
    """Kill the pool's workers still alive GRACE seconds from now (their members are on disk, or
    "interrupted" and redone on resume), so that its shutdown cannot wait on a dead worker's lock."""
    deadline = time.monotonic() + GRACE
    for process in list((pool._processes or {}).values()):  # noqa: SLF001 - no public way before Python 3.14
        process.join(max(0.0, deadline - time.monotonic()))
        if process.is_alive():
            process.kill()


def start_forkserver(engine: str | None = None, also: tuple[str, ...] = ()):
    """The forkserver context, its server started (at once: it loads PRELOAD, without LAMMPS's
    libraries for engine "cpu" or "gpu", CuPy for "gpu", then the modules `also`, while the caller goes on),
    with the stop signals ignored in it (inherited): it and its workers are left to the
    coordinator, an early Ctrl-C does not interrupt its imports with a traceback, and a SIGTERM
    to the process group (a batch system's) does not kill it, which would break the pool and
    leave the members in hand "running". It exits when the coordinator does."""
    from multiprocessing import forkserver

    context = multiprocessing.get_context("forkserver")
    lammps = engine in (None, "lammps")
    gpu = [GPU_PRELOAD] if engine == "gpu" else []
    context.set_forkserver_preload([*(m for m in PRELOAD if lammps or m != LIBRARIES), *gpu, *also])
    if threading.current_thread() is not threading.main_thread():
        forkserver.ensure_running()
        return context
    previous = {s: signal.signal(s, signal.SIG_IGN) for s in STOP_SIGNALS}
    try:
        forkserver.ensure_running()
    finally:
        for s, handler in previous.items():
            signal.signal(s, handler)
    return context


@contextlib.contextmanager
def one_blas_thread():
    """numpy imported in the block gets one OpenBLAS thread (unless the environment says how many);
    the environment is as it was after it (processes started later inherit the user's)."""
    added = {k: v for k, v in ONE_BLAS_THREAD.items() if k not in os.environ}
    os.environ.update(added)
    try:
        yield
    finally:
        for name in added:
            os.environ.pop(name, None)


def _send_whole() -> None:
    """This worker's results go whole: its exit after a stop waits while one is sent
    (`signals.SENDING`). A pool worker's results go through the executor's SimpleQueue (its only
    one it puts to), whose `put` is wrapped in this process alone."""
    from multiprocessing.queues import SimpleQueue

    from . import signals

    put = SimpleQueue.put

    def whole(self, obj):
        with signals.SENDING:
            put(self, obj)

    SimpleQueue.put = whole


def _quiet_stops_in_finalizers() -> None:
    """A stop signal's Interrupted raised while a finalizer ran (an h5py object's __dealloc__, a
    weak reference's callback) is dropped by Python with a traceback on stderr (2 of 15 Ctrl-C of
    a keep = "all" sweep): dropped quietly. The stop stands (`signals.STOP`): no member starts
    after it, and the worker exits GRACE s later (`signals.stopping`)."""
    default = sys.unraisablehook

    def hook(unraisable):
        if not isinstance(unraisable.exc_value, Interrupted):
            default(unraisable)

    sys.unraisablehook = hook


def _pool_worker_init(alive, stop, gpu: bool = False, warm=None) -> None:
    """A pool worker: a stop signal, or the coordinator's stop pipe closing, stops its member and
    any later start, and the worker exits GRACE seconds later, once a result it is sending is
    sent (`_send_whole`); it exits at once when the coordinator is gone. `gpu` (a GPU sweep's
    worker): its CUDA context is made, and the one-step batch `warm` run, beside its first task
    (`engines.gpu.warm_up`)."""
    from ..log_lines import log_to_stderr
    from . import signals

    log_to_stderr(logging.WARNING)  # what a member's run says, as the command says it (Python printed it bare)

    def on_signal(signum, frame):
        if signals.STOP.is_set():  # stopping already (Ctrl-C reaches this worker and its coordinator both)
            return
        signals.stopping(signum)
        if signals.IN_TASK.is_set():  # stop the member in hand (an engine run has its own handler)
            raise Interrupted(signum)
        if signals.SENDING.locked():  # a task's result half sent (this handler runs between its writes):
            return  # the exit after the stop waits for the rest (`stopping`)
        os._exit(128 + signum)  # between tasks: nothing in hand

    signals.EXIT_AFTER_STOP = GRACE
    signals.STOP_PIPE = stop
    for s in STOP_SIGNALS:
        signal.signal(s, on_signal)
    _send_whole()
    _quiet_stops_in_finalizers()

    def watch(end, then):
        with contextlib.suppress(EOFError, OSError):
            end.recv()  # nothing is ever sent: returns when the coordinator's end closes
        then()

    # A stop signal must reach the main thread, the only one whose handler runs: one that the
    # kernel gave a watching thread left a main thread blocked on the task queue's lock blocked
    # for good (the pool's shutdown hung on it: 5 of 30 stops at the table's write). The threads
    # inherit the stop signals blocked from their start. (The cpu engine's OpenMP threads do not
    # block them; a stop sent through the pipe reaches the main thread by pthread_kill all the same.)
    unblocked = signal.pthread_sigmask(signal.SIG_BLOCK, STOP_SIGNALS)
    try:
        # the coordinator is gone: the members in hand stay unfinished on disk and run again on resume
        threading.Thread(target=watch, args=(alive, lambda: os._exit(1)), daemon=True).start()
        # the coordinator was told to stop: as if this worker got the signal itself (the handler above)
        main = threading.main_thread().ident
        threading.Thread(target=watch, args=(stop, lambda: signal.pthread_kill(main, signal.SIGINT)),
                         daemon=True).start()
        if gpu:
            from ..engines.gpu import warm_up

            threading.Thread(target=warm_up, args=(warm,), name="pylmp-lattice-cuda-context", daemon=True).start()
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, unblocked)
