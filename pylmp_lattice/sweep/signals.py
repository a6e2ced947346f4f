"""Stopping a sweep on SIGINT or SIGTERM: the coordinator's signals (`_StopSignals`) and a
worker's stop flag.

In a worker, a stop signal soft-stops the engine (runner) and sets this process's flag (`STOP`,
`stopping`); with the flag set no further member starts: the task returns its unstarted and
stopped members as "interrupted". A pool worker's handler (`pool._pool_worker_init`) sets it.
"""

from __future__ import annotations

import os
import signal
import threading

# Set by a stop signal (see pool._pool_worker_init); read before each start (`stop_asked`).
STOP = threading.Event()
# A pool worker's end of the coordinator's stop pipe (pool._pool_worker_init): readable once the
# coordinator closed it to stop the workers.
STOP_PIPE = None
# In a local pool worker: seconds after a stop before the process exits (its pool may be gone).
EXIT_AFTER_STOP: float | None = None
# Whether this process is inside run_task (a pool worker's signal handler stops it there).
IN_TASK = threading.Event()
# Held by a pool worker while it sends a result (`pool._pool_worker_init`): its exit after a stop
# waits for the send, at most SEND_LIMIT s. Cut off halfway, a result was lost (the pool broken),
# and the coordinator's reader could wait for the rest of it forever.
SENDING = threading.Lock()
SEND_LIMIT = 30.0


class _StopSignals:
    """SIGINT and SIGTERM recorded (in the main thread; elsewhere the process's handling stays):
    the first asks the workers to stop, the second kills them (`on_signal(count)`)."""

    def __init__(self):
        self.signals: list[int] = []
        self.on_signal = lambda count: None
        self.previous = {}

    def __enter__(self):
        if threading.current_thread() is threading.main_thread():
            self.previous = {s: signal.signal(s, self._handle) for s in (signal.SIGINT, signal.SIGTERM)}
        return self

    def _handle(self, signum, frame):
        self.signals.append(signum)
        self.on_signal(len(self.signals))

    def __exit__(self, *exc):
        for s, handler in self.previous.items():
            signal.signal(s, handler)


def stop_asked() -> bool:
    """A stop signal came, or the coordinator closed the stop pipe: the thread that watches the
    pipe may not have run yet (a worker forked as Ctrl-C came missed the signal itself, and under
    load started a member after it: tests/test_sweep_faults.py), so the pipe is looked at too."""
    if STOP.is_set():
        return True
    pipe = STOP_PIPE
    try:
        return pipe is not None and pipe.poll()
    except (OSError, EOFError):  # this end closed: the worker is going away
        return True


def stopping(signum: int) -> None:
    """A stop signal arrived: no member starts from now on; a pool worker exits soon after."""
    STOP.set()
    if EXIT_AFTER_STOP is not None:
        threading.Timer(EXIT_AFTER_STOP, _exit_between_sends, (128 + signum,)).start()


def _exit_between_sends(code: int) -> None:
    SENDING.acquire(timeout=SEND_LIMIT)
    os._exit(code)
