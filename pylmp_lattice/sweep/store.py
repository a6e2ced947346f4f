"""A sweep on disk: a member's outcome written last and atomically, in its own folder or, for
members run together as a batch, in the batch's one file.

A member run alone has DIR/members/<id>/: the run's files (case.toml, deck, log, trajectory
unless keep = "measures", summary.json) and `status.json`: status ("running", "done", "failed"
or "interrupted"), the one-line error, the swept parameters, wall and CPU time and provenance
(package version and git commit, LAMMPS version, plugin build, Python and numpy versions, host,
start and end times). Members batched in one instance (keep = "measures", those of one
parameter point the chain engine can hold together, see `batch`) share
DIR/batches/<id of the first>/, a run folder (`run_folder.execute_batch`: deck, data,
replicas.toml, run.json, log and front record), and `members.json`, their outcomes
(`write_batch`): the record above once (status "done", times, provenance, engine), and per
member its id, index, parameters, chain number in the batch, case and summary, as columns
(each key once for the batch: `columns`); O(1) files for the batch instead of five per member.
A member counts as done only when its record says so and its summary parses; status.json and
members.json are each replaced in one step after everything else is written: a member killed
half-way is re-run. DIR/sweep.json names the sweep the folder holds.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import math
import os
import platform
import socket
import subprocess
from datetime import datetime, timezone
from functools import cache
from itertools import repeat
from operator import is_, itemgetter
from pathlib import Path

import numpy as np

from ..file_lock import Held, exclusive
from ..formats.files import atomic_write
from ..formats.layout import BATCHES, MEMBERS, SWEEP_FILE
from ..run_folder.marker import DONE, FAILED, INTERRUPTED, RUNNING

BATCH_FILE = "members.json"  # in a batch's folder: its members' outcomes
STATUS = "status.json"
# A member's states are its run folder's (DONE, FAILED, RUNNING); INTERRUPTED: stopped by a signal
# or a lost worker, redone on resume.


def member_folder(root: str | Path, member_id: str) -> Path:
    """The folder of a member run alone: ROOT/members/<id>."""
    return Path(root) / MEMBERS / member_id


def write_status(folder: Path, record: dict) -> None:
    """The member's status, replaced atomically but not synced: thousands of members write it,
    a killed process leaves the old or the new file, and after a power cut a member whose
    status or summary does not parse is simply run again."""
    atomic_write(Path(folder) / STATUS, json.dumps(record, separators=(",", ":")) + "\n", sync=False)


def read_status(folder: Path) -> dict | None:
    """The member's status record, or None if it never started (or its record is unreadable)."""
    return read_json(Path(folder) / STATUS)


class Outcomes:
    """The members' outcomes on disk, {"record", "summary"}, if they stand (see `get`).

    batches: the names of the batch folders that may hold them (default: all in DIR/batches/,
    read once, at the first `get`)."""

    def __init__(self, root: str | Path, batches: list[str] | None = None):
        self.root, self.batches = Path(root), batches
        self._batched: dict[str, dict] | None = None
        self._folders: set[str] = set()

    def get(self, member_id: str) -> dict | None:
        """The member's outcome: done in a batch, else from its folder (`outcome`)."""
        self._read()
        found = self._batched.get(member_id)
        return found if found is not None or member_id not in self._folders else outcome(self.root, member_id)

    def at_most(self) -> int:
        """How many members may have an outcome on disk (done in a batch, or a folder of their
        own, finished or not): an upper bound, known without reading any member's folder."""
        self._read()
        return len(self._batched) + len(self._folders - set(self._batched))

    def _read(self) -> None:
        if self._batched is None:  # what is on disk now: the batch files and the member folders
            folder = self.root / BATCHES
            names = listing(folder)  # one listing, not a look per possible batch
            files = [folder / name / BATCH_FILE for name in (names if self.batches is None else names & set(self.batches))]
            self._batched = {}
            for path in files:
                self._batched |= read_batch(path)
            self._folders = listing(self.root / MEMBERS)  # one listing, not a look per member


def listing(folder: Path) -> set[str]:
    """The names in a folder (none if it does not exist)."""
    try:
        return set(os.listdir(folder))
    except (FileNotFoundError, NotADirectoryError):
        return set()


def write_batch(folder: Path, record: dict, members: list[dict]) -> dict:
    """The outcome of members done in one batch: DIR/batches/<name>/members.json, `record` (what
    they share: status, times, provenance) and `members` ({id, index, params, chain, case,
    summary} each) as columns (`columns`), written last and atomically. Returns those columns
    as written (strict: what `read_batch` reads back), for the table's rows (`table.batch_rows`)."""
    # strict JSON (no NaN); only summaries hold numpy values or NaN (ids, parameters and cases
    # are TOML values, finite by validation)
    data = {**record, "columns": _strict(columns(members))}
    atomic_write(Path(folder) / BATCH_FILE, json.dumps(data, allow_nan=False, separators=(",", ":")) + "\n", sync=False)
    return data["columns"]


def columns(rows: list):
    """Rows as columns, for a batch of up to 10^6 members: dicts with the same keys become
    {"cols": {key: columns(their values)}} (each key once), anything else {"rows": rows}."""
    first = rows[0] if rows else None
    if rows and all(map(is_, rows, repeat(first))):  # one value n times (replicas' cases share most of theirs)
        return _repeated(first, len(rows))
    if type(first) is dict and first and set(map(type, rows)) == {dict} and all(map(first.keys().__eq__,
                                                                                      map(dict.keys, rows))):
        return {"cols": {key: columns(list(map(itemgetter(key), rows))) for key in first}}  # (map: at C speed)
    return {"rows": rows}


def _repeated(value, n: int) -> dict:
    """`columns` of `n` times one value, without looking at each."""
    if type(value) is dict and value:
        return {"cols": {key: _repeated(v, n) for key, v in value.items()}}
    return {"rows": [value] * n}


def _strict(table: dict) -> dict:
    """`columns`' table with its values strict JSON (`serialize.jsonable`): a column of plain
    numbers, strings and None in one pass (non-finite floats become None), any other value by
    value: a batch's summaries are some 60 values a member."""
    from ..serialize import jsonable

    if "cols" in table:
        return {"cols": {key: _strict(column) for key, column in table["cols"].items()}}
    values = table["rows"]
    kinds = set(map(type, values))
    if kinds == {float} and all(map(math.isfinite, values)):  # most columns: finite numbers, kept as they are
        return {"rows": values}
    if kinds <= _PLAIN:
        return {"rows": [None if type(v) is float and not math.isfinite(v) else v for v in values]}
    if kinds == {list} and {type(x) for v in values for x in v} <= _EXACT:  # lists of gap or magnet numbers
        return {"rows": values}
    return {"rows": jsonable(values)}


_PLAIN = {float, int, bool, str, type(None)}
_EXACT = _PLAIN - {float}  # strict JSON as they are


def rows(table: dict) -> list:
    """`columns` undone."""
    if "rows" in table:
        return table["rows"]
    cols = {key: rows(column) for key, column in table["cols"].items()}
    return [dict(zip(cols, values)) for values in zip(*cols.values(), strict=True)]


def read_batch(path: Path) -> dict[str, dict]:
    """The outcomes in a batch's members.json by member id; none if it is missing or does not parse."""
    data = read_json(path)
    try:
        return _batch_outcomes(data) if data is not None and data["status"] == DONE else {}
    except (KeyError, TypeError, AttributeError, ValueError):
        return {}


def _batch_outcomes(data: dict) -> dict[str, dict]:
    record = {k: v for k, v in data.items() if k not in ("members", "columns")}
    if "columns" in data:  # the rows without their cases (only the outcomes' keys are read)
        table = data["columns"]
        members = rows({"cols": {k: v for k, v in table["cols"].items() if k != "case"}} if "cols" in table else table)
    else:
        members = data["members"]  # "members": a list, before columns
    return {m["id"]: {"record": record | {k: m[k] for k in ("id", "index", "params", "chain")}, "summary": m["summary"]}
            for m in members if isinstance(m["summary"], dict)}


def outcome(root: str | Path, member_id: str) -> dict | None:
    """The outcome in the member's own folder, {"record", "summary"}, if it stands: "done" with a
    summary that parses, or "failed"; else None (never run, unfinished, or done without a summary)."""
    from ..run_folder import RunFolder

    folder = member_folder(root, member_id)
    if folder.is_symlink():  # not the sweep's own folder: run again (which removes the link)
        return None
    record = read_status(folder)
    if record is None or record.get("id") != member_id or record.get("status") not in (DONE, FAILED):
        return None
    if record["status"] == DONE and _case_identity(folder) != member_id:  # another case was run there
        return None
    summary = RunFolder(folder).summary if record["status"] == DONE else None
    return None if record["status"] == DONE and summary is None else {"record": record, "summary": summary}


def _case_identity(folder: Path) -> str | None:
    """The identity (`case.case_id`) of the case in a run folder's case.toml, read without
    building the case (the file is `case_to_dict` of the case that ran); None if unreadable."""
    import tomllib

    from ..case import identity_hash
    from ..formats.layout import CASE

    try:
        data = tomllib.loads((Path(folder) / CASE).read_text())
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError):
        return None
    return identity_hash({k: v for k, v in data.items() if k != "name"})


def read_json(path: Path) -> dict | None:
    """A strict JSON object from a file (`serialize.loads_object`); None if it is missing or is
    anything else (the package writes these files strict: a NaN in one was never ours)."""
    from ..serialize import loads_object

    try:
        return loads_object(Path(path).read_bytes())
    except (FileNotFoundError, NotADirectoryError, IsADirectoryError):
        return None


@contextlib.contextmanager
def task_lock(root: str | Path, member_ids):
    """Hold the lock of the task of these members (DIR/batches/task-<hash>.lock).

    Dask runs a task at least once: the copy of a task whose worker retires may start while the
    first still runs. The copies take turns on the lock (which the kernel releases if a worker
    is killed), and the later one finds the members done on disk (`file_lock.exclusive`: the
    holder removes the file as it lets go; `remove_stale_locks` removes those killed workers leave)."""
    folder = Path(root) / BATCHES
    folder.mkdir(exist_ok=True)
    with exclusive(folder / f"task-{hashlib.sha256(' '.join(member_ids).encode()).hexdigest()[:16]}.lock"):
        yield


def remove_stale_locks(root: str | Path) -> None:
    """Remove the lock files of tasks whose worker was killed (none holds them); a lock still
    held (a copy of a task that Dask runs on) is left to its holder, which removes it."""
    for path in (Path(root) / BATCHES).glob("task-*.lock"):
        with contextlib.suppress(Held), exclusive(path, timeout=0):
            pass


def now() -> str:
    """The time now, UTC, ISO 8601 to the millisecond, as status.json records it."""
    return datetime.now(timezone.utc).isoformat(timespec="milliseconds")


@cache
def provenance() -> dict:
    """Where and with what a member ran (computed once per worker process)."""
    from ..version import __version__

    return {
        "pylmp_lattice": __version__,
        "git_commit": _git_commit(),
        "lammps": _version("lammps"),
        "plugin_build": _plugin_build(),
        "python": platform.python_version(),
        "numpy": np.__version__,
        "host": socket.gethostname(),
    }


def _version(dist: str) -> str | None:
    import importlib.metadata  # here, not at import: the coordinator never needs it

    try:
        return importlib.metadata.version(dist)
    except importlib.metadata.PackageNotFoundError:
        return None


def _git_commit() -> str | None:
    """The source tree's commit (with -dirty if modified): of the checkout the package runs from,
    else of the local clone it was installed from (`pip install .` records it in the
    distribution's direct_url.json; the commit is that clone's now)."""
    source = Path(__file__).resolve().parents[2]
    if not (source / ".git").exists():
        source = _installed_from()
    if source is None or not (source / ".git").exists():
        return None
    try:
        done = subprocess.run(["git", "-C", str(source), "describe", "--always", "--dirty", "--abbrev=40"],
                              capture_output=True, text=True, timeout=10)
    except (OSError, subprocess.TimeoutExpired):
        return None
    return done.stdout.strip() or None if done.returncode == 0 else None


def _installed_from() -> Path | None:
    """The local folder the package was installed from, if pip recorded one (PEP 610)."""
    import importlib.metadata
    from urllib.parse import unquote, urlparse

    try:
        text = importlib.metadata.distribution("pylmp_lattice").read_text("direct_url.json")
        url = urlparse(json.loads(text)["url"]) if text else None
    except (importlib.metadata.PackageNotFoundError, json.JSONDecodeError, KeyError, TypeError):
        return None
    return Path(unquote(url.path)) if url is not None and url.scheme == "file" else None


def _plugin_build() -> str | None:
    """The plugin library's file name and the start of its SHA-256: which build ran."""
    from ..errors import RunError
    from ..plugin import plugin_file

    try:
        path = plugin_file()
    except RunError:
        return None
    return f"{path.name} sha256:{hashlib.sha256(path.read_bytes()).hexdigest()[:16]}"
