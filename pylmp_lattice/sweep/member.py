"""A sweep's member alone: run in its folder DIR/members/<id>/ with `run_case`, its record
(status.json, written first as "running" and last with its outcome), and the records of members
that failed before running (invalid parameters), were stopped, or never started; an error as
one line for the table.
"""

from __future__ import annotations

import contextlib
import os
import resource
import time
from pathlib import Path

from ..case import Case
from ..errors import Interrupted, LatticeError
from ..formats.files import DiskFull, as_disk_full, disk_full, remove_tree
from . import signals
from .spec import Member
from .store import DONE, FAILED, INTERRUPTED, RUNNING, member_folder, now, provenance, write_status


def run_member(root: Path, m: Member, case: Case, runner: str, started: str) -> dict:
    """Run one member alone in its folder (`run_case`); any earlier attempt there is removed first."""
    from ..run_folder import run_case

    folder = _fresh(member_folder(root, m.id))
    start, cpu = time.perf_counter(), _cpu_time()
    record = _record(m, started)
    write_status(folder, record)
    try:
        # yes: a sweep is batch work, started knowingly; the disk and memory guard still applies
        summary = run_case(case, folder, runner=runner, figure=False, yes=True)
        record["status"] = DONE
    except Interrupted as err:
        signals.stopping(err.signum)
        return _stopped([(m, case)], root, [record])[m.id]
    except Exception as err:  # noqa: BLE001 - any failure is recorded, and the sweep goes on
        if signals.STOP.is_set():  # it broke while the sweep was being stopped (a second signal): redone on resume
            return _stopped([(m, case)], root, [record])[m.id]
        if disk_full(err) or _no_room(case, folder):  # the sweep stops (see execute); the member's
            # folder goes, which frees room for the table, and the member runs again on resume
            with contextlib.suppress(OSError):
                remove_tree(folder)
            raise DiskFull(as_disk_full(err, folder).path, f"member {m.id}'s folder is removed; it runs again on "
                                                           "resume") from err
        summary = None
        record |= {"status": FAILED, "error": one_line(err, root)}
    record |= {"ended": now(), "wall_time_s": round(time.perf_counter() - start, 3),
               "cpu_time_s": round(_cpu_time() - cpu, 3)}
    write_status(folder, record)
    return {"id": m.id, "record": record, "summary": summary}


def _record(m: Member, started: str | None = None) -> dict:
    return {"id": m.id, "index": m.index, "params": m.params, "status": RUNNING, "error": None,
            "started": started or now(), "pid": os.getpid(), "provenance": provenance()}


def _invalid(root: Path, m: Member) -> dict:
    folder = _fresh(member_folder(root, m.id))
    record = _record(m) | {"status": FAILED, "error": m.error, "ended": now(), "wall_time_s": 0.0}
    write_status(folder, record)
    return {"id": m.id, "record": record, "summary": None}


def _stopped(group, root: Path, records: list[dict]) -> dict[str, dict]:
    """Members stopped by a signal: "interrupted" on disk too (redone on resume)."""
    out = {}
    for (m, _), record in zip(group, records):
        record |= {"status": INTERRUPTED, "ended": now()}
        write_status(member_folder(root, m.id), record)
        out[m.id] = {"id": m.id, "record": record, "summary": None}
    return out


def unstarted(m: Member) -> dict:
    """A member not started (a stop came first), or whose worker was lost before it finished."""
    return {"id": m.id, "record": {"id": m.id, "index": m.index, "params": m.params, "status": INTERRUPTED,
                                   "error": None}, "summary": None}


def _fresh(folder: Path) -> Path:
    """An empty folder: an earlier unfinished attempt never counted as done."""
    remove_tree(folder)  # a link there is removed, never followed
    folder.mkdir(parents=True)
    return folder


def _no_room(case: Case, folder: Path) -> bool:
    """Whether a failed member's disk is too full for its run (its writes, LAMMPS's included,
    may have failed on it in other ways: a refusal by preflight, a truncated record), where
    room can be made: a run larger than the whole disk, or than the memory, fails as a member
    (preflight's refusal says why), as freeing space and resuming would meet it again."""
    from ..preflight import available_memory, disk_size, estimate, fits, free_disk

    try:
        est = estimate(case)
        return fits(est, disk_size(folder), available_memory()) and not fits(est, free_disk(folder), None)
    except (OSError, LatticeError):
        return False


def _cpu_time() -> float:
    """CPU seconds of this process and its finished children (the `lmp` runner's engine)."""
    children = resource.getrusage(resource.RUSAGE_CHILDREN)
    return time.process_time() + children.ru_utime + children.ru_stime


def one_line(err: BaseException, root: Path | None = None) -> str:
    """An exception as one line; our own errors speak for themselves, others get their type.
    Paths under the sweep folder `root` are given relative to it."""
    lines = str(err).strip().splitlines()
    text = lines[0] if lines else ""
    text = text if isinstance(err, LatticeError) and text else f"{type(err).__name__}: {text}".rstrip(": ")
    return text.replace(f"{root}/", "") if root is not None else text
