"""A sweep's work in the worker: a task, its members batched, many chains in one LAMMPS instance,
or alone (`member`).

A task is a few members of one parameter point (they differ only in chain.seed, see `spec`).
Those the chain engine can hold together (keep = "measures": no per-frame output, a front
record; decks equal but for the data file) run as one deck (`deck.render_replicas(front=True)`)
in DIR/batches/<id of the first>/, a run folder written and run by `run_folder.execute_batch`
(the road of every run: claim, write, run.json, run, record): its chains are the members'
chains bit for bit, and the fix's front record is per atom, so chain r's rows are member r's
record (with friction, the fix also reports each chain's friction work). The batch's
members.json then records every member's outcome with the summary a run alone would write
(`store.write_table`: no file per member).
If the batch fails (a contact, an engine error), its members run alone, so that each gets its
own outcome. Anything else (trajectories kept; with LAMMPS, one member) runs alone with `run_case`.

The engine of a batch is LAMMPS, or with engine = "cpu" or "gpu" the chain kernel
(`engines.road.KernelEngine`) on the same road into the same folder; members it cannot run
(and those that run alone) run with LAMMPS, and the sweep's log says so once per reason (`Note`).

Stopping: with this process's stop flag set (`signals.STOP`) no further member starts: the task
returns its unstarted and stopped members as "interrupted".
"""

from __future__ import annotations

import gc
import logging
import os
import shutil
import threading
import time
from contextlib import contextmanager
from dataclasses import dataclass
from itertools import repeat
from pathlib import Path

from ..case import KEPT_DRAWS, Case
from ..case.chain import replica_draws
from ..columnar import columns, repeated
from ..errors import Interrupted, LatticeError
from ..formats.files import DiskFull, remove_tree
from . import signals
from .member import _cpu_time, _fresh, _invalid, _record, one_line, run_member, unstarted
from .spec import Member, Replicas, member_cases
from .store import (BATCHES, DONE, INTERRUPTED, MEMBERS, Outcomes, listing, member_folder, now, provenance, task_lock,
                    write_table)
from .table import Rows, batch_rows

log = logging.getLogger(__name__)
# Whether the plugin's fix lattice/chain writes each chain's friction work (`fix_modify chain
# write_work FILE`); an older build refuses that command at the end of the batch deck ("Fix chain
# lattice/chain does not support fix_modify write_work command"), and from then on this process
# runs members with friction one per instance.
FRICTION_PER_CHAIN = True
NO_CHAIN_WORK = "fix_modify write_work"
# Likewise for fix lattice/front's per-chain levels (`length n levels FILE`): a build without
# them refuses the batch deck, and from then on chains batch only with equal levels.
LEVELS_PER_CHAIN = True


@dataclass(frozen=True)
class Task:
    """What a worker needs to run some members (small and picklable): the sweep folder
    (absolute), the members (a point's replicas as `spec.Replicas`, one or more), the runner, the
    batches' engine and its threads (cpu)."""

    root: str
    members: tuple[Member | Replicas, ...]
    runner: str
    engine: str = "lammps"
    threads: int | None = None

    def each(self) -> tuple[Member, ...]:
        """The task's members, its `Replicas` made members."""
        return tuple(m for part in self.members for m in (part if isinstance(part, Replicas) else (part,)))


def run_task(task: Task) -> list[dict | Rows | Note]:
    """Run the task's members: the table's rows of the members done in a batch (`table.Rows`,
    one per batch: no dict per member), then one result per other member, in order: {"id",
    "record", "summary"}, then the `Note`s for the sweep's log. Every member's outcome is on
    disk (its status written last) before it is returned."""
    signals.IN_TASK.set()
    try:
        with _collector_paused():
            return _run_task(task)
    finally:
        signals.IN_TASK.clear()


_PAUSES = {"tasks": 0, "was_enabled": False}
_PAUSES_LOCK = threading.Lock()


@contextmanager
def _collector_paused():
    """Python's cyclic garbage collector off while tasks run (in this process: tasks in threads
    share it). A task makes some 100 objects a member that live until its end, and the
    collector's passes over them cost 24-34 us a member (bench_per_member's task, ~834
    members, 36 young and one full pass, timed by gc.callbacks), while a task leaves some 200
    objects in cycles in all: they are collected after it."""
    with _PAUSES_LOCK:
        if _PAUSES["tasks"] == 0:
            _PAUSES["was_enabled"] = gc.isenabled()
            gc.disable()
        _PAUSES["tasks"] += 1
    try:
        yield
    finally:
        with _PAUSES_LOCK:
            _PAUSES["tasks"] -= 1
            if _PAUSES["tasks"] == 0 and _PAUSES["was_enabled"]:
                gc.enable()


def _run_task(task: Task) -> list[dict | Rows | Note]:
    members = task.each()
    with task_lock(task.root, [m.id for m in members]):  # copies of a task (Dask) take turns
        return _run_members(Path(task.root), task, members)


def _run_members(root: Path, task: Task, members: tuple[Member, ...]) -> list[dict | Rows | Note]:
    results: dict[str, dict] = {}
    rows: list[Rows] = []  # of the batches done
    notes: dict[str, None] = {}  # why some ran with LAMMPS (`Note`s, in order, each once)
    # a task run again (e.g. by Dask after its worker died) keeps what is done: its batches are
    # named by their first member
    ids = [m.id for m in members]
    done = Outcomes(root, batches=ids)
    for m in members if not done.none_of(ids) else ():  # (a first run: no look at each)
        found = done.get(m.id)
        if found is not None and found["record"]["status"] == DONE:
            results[m.id] = {"id": m.id} | found
    todo = [m for m in members if m.id not in results] if results else list(members)
    cases = _cases(task, todo)
    for m, case in zip(todo, cases):
        if case is None:  # invalid parameters (a replica's own draw): failed without running
            results[m.id] = _invalid(root, m)
    valid = [(m, c) for m, c in zip(todo, cases) if c is not None]
    for group in _batches(valid):
        started = now()  # before the look at STOP: a member never starts after a stop signal
        if signals.stop_asked():
            break
        # a kernel engine runs a member a batch can hold in a batch of its own (a grid's point with
        # one replica, a task's last member, a tabulated law's replica with its own table range),
        # LAMMPS in a member folder: an instance of its own costs it as much
        if len(group) > 1 or (task.engine != "lammps" and batchable(group[0][1])):
            done = _run_batch(root, group, task.runner, started, task.engine, task.threads, notes=notes)
            if isinstance(done, list):
                rows += done
            else:
                results |= done
        else:
            if task.engine != "lammps":
                notes[_fallback(task.engine, "a member a batch cannot hold (trajectories kept, no front record, "
                                             "or a setup of LAMMPS's own engine)")] = None
            results[group[0][0].id] = run_member(root, *group[0], task.runner, started)
    batched = {i for r in rows for i in r.columns["id"]}
    return [*rows, *(results.get(m.id) or unstarted(m) for m in members if m.id not in batched), *map(Note, notes)]


def _cases(task: Task, members: list[Member]) -> list[Case | None]:
    """Each member's case (`spec.member_cases`): the seeded replicas of a point (`spec.Replicas`)
    straight from their first member's case with their own seed (`Member.build_from`), without
    comparing their case dicts, which differ in chain.seed alone."""
    seeded = {}
    for part in task.members:
        if isinstance(part, Replicas) and part.first.case is not None:
            draws = _replicas_draws(part.first.case.chain, part.seeds)
            seeded.update(zip(part.ids, zip(repeat(part.first.case), part.seeds, draws)))
    for m in members:
        if m.id in seeded:
            m.build_from(*seeded[m.id])
    others = iter(member_cases([m for m in members if m.id not in seeded]))
    return [m.case if m.id in seeded else next(others) for m in members]


def _replicas_draws(chain, seeds) -> list[dict | None]:
    """Under disorder, the masses and gaps each seed draws (`chain.replica_draws`), drawn together
    for a chain that keeps its draws (`Chain._kept`); else None for each."""
    if not chain.draws() or chain.particles > KEPT_DRAWS:
        return [None] * len(seeds)
    masses, gaps = replica_draws(chain, seeds)
    return [{"masses": m, "gaps": g} for m, g in zip(masses, gaps)]


def batchable(case: Case) -> bool:
    """Whether the case can share an instance: chain engine, no per-frame output, a front record."""
    from ..deck import records_front, uses_chain_engine

    return (uses_chain_engine(case) and case.output.format == "none" and records_front(case)
            and (case.friction is None or FRICTION_PER_CHAIN))


def _batches(valid: list[tuple[Member, Case]]) -> list[list[tuple[Member, Case]]]:
    """Members that can run together, in order: N and, for a tabulated law, the table range equal
    (see deck.render_replicas), and, a task being one parameter point, decks equal but for the
    data file, the front record's levels (each chain gets its own) and the gaps' guard:
    `_run_batch` checks that as it renders the batch (its members run alone if not). Without
    per-chain levels, equal decks."""
    from ..deck import deck_text, replica_range

    groups: dict[tuple, list] = {}
    able: dict[str, bool] = {}  # `batchable` of each parameter point (it does not look at the seed)
    keys: dict[str, tuple] = {}  # the key of each point whose law is exact (`replica_range` None: no look at the seed)
    for i, (m, case) in enumerate(valid):
        if m.point not in able:
            able[m.point] = batchable(case)
            if able[m.point] and LEVELS_PER_CHAIN and replica_range(case) is None:
                keys[m.point] = (case.chain.particles, None, None)
        key = keys.get(m.point)
        if key is None:
            shared = None if LEVELS_PER_CHAIN else deck_text(case)
            key = (case.chain.particles, replica_range(case), shared) if able[m.point] else ("alone", i)
        groups.setdefault(key, []).append((m, case))
    return list(groups.values())


def _run_batch(root: Path, group: list[tuple[Member, Case]], runner: str, started: str, kind: str = "lammps",
               threads: int | None = None, *, notes: dict) -> list[Rows] | dict[str, dict]:
    """Run the group as one batch, a run folder on the road of every run (`execute_batch`), by
    the `kind` engine (LAMMPS if the kernel cannot run it, which `notes` gets: `_fallback`): its
    members' rows of the table (`table.batch_rows`). A failed batch runs each member alone, a
    stopped one leaves them interrupted: their results by id."""
    from ..case_measures import chain_draws
    from ..engines.road import kernel_engine
    from ..formats import layout
    from ..run_folder import execute_batch

    start, cpu = time.perf_counter(), _cpu_time()
    cases = [case for _, case in group]
    draws = chain_draws(cases)  # the members' chains, drawn once for the engine and the measures
    engine = kernel_engine(kind, cases, threads, draws) if kind != "lammps" else runner
    if isinstance(engine, str) and kind != "lammps":
        notes[_fallback(kind, engine)] = None
        engine, kind = runner, "lammps"
    batch = _fresh(root / BATCHES / group[0][0].id)
    try:
        execute_batch(cases, batch, engine, draws=draws)  # ConfigError if they differ beyond [chain]
    except Interrupted as err:
        return _batch_stopped(group, batch, started, err)
    except DiskFull as err:  # the sweep stops (see execute): its members are run again on resume
        shutil.rmtree(batch, ignore_errors=True)
        raise DiskFull(err.path, f"batch {batch.name}'s folder is removed; its members run again on resume") from err
    except LatticeError as err:  # unequal cases, a contact or an engine error in some chain: each member alone
        global FRICTION_PER_CHAIN, LEVELS_PER_CHAIN
        if NO_CHAIN_WORK in str(err):
            FRICTION_PER_CHAIN = False
        if (batch / layout.FRONT_LEVELS).is_file() and "lattice/front" in str(err):
            LEVELS_PER_CHAIN = False
        return _alone(root, group, runner)
    same: dict = {}  # the columns of one value n times (`columnar.columns`)
    try:
        summaries = _summaries(cases, batch, draws, [m.point for m, _ in group],
                               None if isinstance(engine, str) else engine.record, same)
    except Interrupted as err:  # a stop while its measures were read: as one during the run
        return _batch_stopped(group, batch, started, err)
    except Exception as err:  # noqa: BLE001 - a record that cannot be read (or a bug in reading it): each
        # member alone, with its own outcome, and the reason in the log with its traceback
        log.warning("batch %s: its measures could not be read (%s); its members run alone", batch.name,
                    one_line(err, root), exc_info=True)
        return _alone(root, group, runner)
    wall, cpu = (time.perf_counter() - start) / len(group), (_cpu_time() - cpu) / len(group)
    record = {"status": DONE, "error": None, "started": started, "ended": now(), "pid": os.getpid(),
              "provenance": provenance(), "engine": kind, "batch": f"{BATCHES}/{batch.name}", "wall_time_s": round(wall, 4),
              "cpu_time_s": round(cpu, 4)}
    where = {"folder": str(batch), "log": str(batch / layout.LOG)}
    outcome = {"status": DONE, "files": where, "wall_time_s": round(wall, 4)}
    n = len(group)
    if "cols" in summaries:
        summaries["cols"] |= {key: repeated(value, n, same) for key, value in outcome.items()}
    else:  # summaries of unequal keys: each this batch's own, extended in place
        for summary in summaries["rows"]:
            summary.update(outcome)
    # the members' {id, index, params, chain, case, summary} as `columns` of them, a key at a time
    members = [m for m, _ in group]
    table = {"cols": {"id": columns([m.id for m in members], same), "index": columns([m.index for m in members], same),
                      "params": columns([m.params for m in members], same), "chain": columns(list(range(n)), same),
                      "case": columns([m.data for m in members], same), "summary": summaries}}
    texts: dict = {}  # the texts of its columns of floats, for members.json and the CSV's cells alike
    written = write_table(batch, record, table, texts, same)  # last: the members are done
    alone = listing(root / MEMBERS)
    for m, _ in group:  # an earlier outcome of a member alone (failed, interrupted) is out of date
        if m.id in alone:
            remove_tree(member_folder(root, m.id))
    return batch_rows([m.index for m, _ in group], [m.id for m, _ in group], [m.params for m, _ in group],
                      record["batch"], record, written["cols"]["summary"], texts)


@dataclass(frozen=True)
class Note:
    """A line for the sweep's log among a task's results: the coordinator says each once a sweep
    (a worker's own log would say it once per worker, without the command's prefix). A task
    lost or stopped before it returns says none (its members are read back from disk)."""

    text: str


def _fallback(kind: str, why: str) -> str:
    """The line that says members run with LAMMPS, not the `kind` engine, and why."""
    return f"engine {kind} cannot run some members ({why}): they run with LAMMPS"


def _batch_stopped(group: list[tuple[Member, Case]], batch: Path, started: str, err: Interrupted) -> dict[str, dict]:
    """A batch stopped by a signal before its members were recorded: interrupted, none of them
    on disk (redone on resume)."""
    signals.stopping(err.signum)
    shutil.rmtree(batch, ignore_errors=True)
    return {m.id: {"id": m.id, "record": _record(m, started) | {"status": INTERRUPTED, "ended": now()}, "summary": None}
            for m, _ in group}


def _alone(root: Path, group: list[tuple[Member, Case]], runner: str) -> dict[str, dict]:
    """The members of a failed batch, each run alone (none starts after a stop signal)."""
    out = {}
    for m, case in group:
        started = now()
        if signals.stop_asked():
            break
        out[m.id] = run_member(root, m, case, runner, started)
    return out


def _summaries(cases: list[Case], batch: Path, draws, points: list[str], rows=None, same: dict | None = None) -> dict:
    """Each chain's summary from the batch's front record, as its run alone would write it, as
    columns (`summary.summary_columns`; same: as `columnar.columns`') (draws: the members'
    `case_measures.chain_draws`; points: their `Member.point`; rows: the record as a kernel
    engine holds it, `engines.road.KernelEngine.record`, not read back)."""
    from .. import measures
    from ..case_measures import read_front_batch
    from ..formats import layout
    from ..summary import summary_columns

    method = measures.default_arrival_method(pulse=cases[0].impactor.is_pulse())  # as RunFolder's
    record = read_front_batch(cases, batch / layout.FRONT_BIN, method, draws, rows)
    out = summary_columns(cases, record.front, record.max_speed, draws, points, same)
    if cases[0].friction is not None:
        import numpy as np

        from ..summary import rounds
        from ..units import from_engine

        # as a run alone reads it from its log: the thermo column's 8 significant digits
        works = (batch / layout.CHAIN_WORK).read_text().split()
        if len(works) != len(cases):
            raise ValueError(f"{layout.CHAIN_WORK}: {len(works)} chains' work for {len(cases)} chains")
        logged = (" ".join(["%.8g"] * len(works)) % tuple(map(float, works))).split()
        # (+ 0.0: no -0.0 where the work rounds to zero, as a sum of kicks' tiny rounding errors can with mu = 0)
        work = [w + 0.0 for w in rounds(from_engine(np.array(list(map(float, logged))), "energy"), 6)]
        if "cols" in out:
            out["cols"]["friction_dissipated_energy_mJ"] = columns(work, same)
        else:
            for summary, value in zip(out["rows"], work):
                summary["friction_dissipated_energy_mJ"] = value
    return out
