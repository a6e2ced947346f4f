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
Beside it, members.arrow holds the same columns in binary (`columns_file`), which a resumed
sweep reads instead of parsing the JSON's numbers.
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
from dataclasses import dataclass
from datetime import datetime, timezone
from functools import cache, cached_property
from itertools import repeat
from pathlib import Path

import numpy as np

from ..columnar import columns
from ..file_lock import Held, exclusive
from ..formats.files import atomic_write
from ..formats.layout import BATCHES, MEMBERS, SWEEP_FILE
from ..run_folder.marker import DONE, FAILED, INTERRUPTED, RUNNING
from .columns_file import read_columns, write_columns

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
    read once, at the first `get`). A batch's outcomes are kept as columns (`Batch`): a
    member's dict is made when asked for."""

    def __init__(self, root: str | Path, batches: list[str] | None = None):
        self.root, self.batches = Path(root), batches
        self._batched: dict[str, tuple[Batch, int]] | None = None  # member id -> its batch, its place there
        self._folders: set[str] = set()

    def get(self, member_id: str) -> dict | None:
        """The member's outcome: done in a batch, else from its folder (`outcome`)."""
        found = self.batched(member_id)
        if found is not None:
            return found[0].outcome(found[1])
        return None if member_id not in self._folders else outcome(self.root, member_id)

    def batched(self, member_id: str) -> tuple[Batch, int] | None:
        """The batch whose members.json holds the member done, and its place there; or None."""
        self._read()
        return self._batched.get(member_id)

    def at_most(self) -> int:
        """How many members may have an outcome on disk (done in a batch, or a folder of their
        own, finished or not): an upper bound, known without reading any member's folder."""
        self._read()
        return len(self._batched) + len(self._folders - self._batched.keys())

    def to_keep(self, retry_failed: bool = False, ids=None) -> int:
        """How many members may keep their outcome on disk (not run again): done in a batch, or a
        folder of their own whose status says done (or failed, unless `retry_failed`); a folder that
        is a link, or whose run was interrupted or never recorded, is run again. An upper bound (the
        estimate's members to run, a lower one): it reads each member folder's status.json, not its
        summary or case (`outcome` does), and counts any member's (another sweep's too), or with
        `ids` only those members'."""
        self._read()
        batched, folders = self._batched.keys(), self._folders - self._batched.keys()
        if ids is not None:
            ids = set(ids)
            batched, folders = batched & ids, folders & ids
        keep = (DONE,) if retry_failed else (DONE, FAILED)
        own = sum((_finished(self.root, m) or {}).get("status") in keep for m in folders)
        return len(batched) + own

    def none_of(self, member_ids: list[str]) -> bool:
        """Whether none of these members has an outcome on disk, or a folder of its own."""
        self._read()
        return self._batched.keys().isdisjoint(member_ids) and self._folders.isdisjoint(member_ids)

    def _read(self) -> None:
        if self._batched is None:  # what is on disk now: the batch files and the member folders
            folder = self.root / BATCHES
            names = listing(folder)  # one listing, not a look per possible batch
            self._batched = {}
            for name in sorted(names if self.batches is None else names & set(self.batches)):
                batch = read_batch_columns(folder / name / BATCH_FILE)
                if batch is not None:  # each done member's id with its own place (not the ids in order)
                    ids = batch.ids() if isinstance(batch.done, range) else [batch.ids()[k] for k in batch.done]
                    self._batched |= zip(ids, zip(repeat(batch), batch.done))
            self._folders = listing(self.root / MEMBERS)  # one listing, not a look per member


class Batch:
    """A batch's outcomes as its members.json holds them: the record they share, and their
    columns (`columns`: id, index, params, chain, summary); `done`, the places of the members
    whose summary is a table (those whose outcome stands)."""

    KEYS = ("id", "index", "params", "chain")  # what a member's record adds to the batch's

    def __init__(self, record: dict, table: dict):
        self.record, self.table = record, table
        summaries = table["cols"]["summary"]
        n = len(self.ids())
        if ({len(rows) if type(rows) is list else -1 for rows in _leaves(table)} - {n} or not set(map(type, self.ids())) <= {str}
                or not table["cols"].keys() >= {*self.KEYS, "summary"}):
            raise ValueError("not a batch's columns: of unequal lengths, an id not text, or a column missing")
        self.done = range(n) if "cols" in summaries else [k for k, v in enumerate(summaries["rows"]) if isinstance(v, dict)]

    def ids(self) -> list[str]:
        """The members' ids, in the batch's order."""
        return self.table["cols"]["id"]["rows"]

    def outcome(self, k: int) -> dict:
        """Member k's outcome, {"record", "summary"}."""
        cols = self.table["cols"]
        return {"record": self.record | {key: _at(cols[key], k) for key in self.KEYS}, "summary": _at(cols["summary"], k)}

    def summaries(self, places: list[int]):
        """The summaries of the members at these places, as columns (`columns`)."""
        every = len(places) == len(self.ids()) and places == list(range(len(places)))
        return self.table["cols"]["summary"] if every else _taken(self.table["cols"]["summary"], places)


def _at(table: dict, k: int):
    """Row k of a table of columns (`columns`)."""
    if "rows" in table:
        return table["rows"][k]
    return {key: _at(column, k) for key, column in table["cols"].items()}


def _taken(table: dict, places: list[int]) -> dict:
    """The rows at these places of a table of columns (`columns`)."""
    if "rows" in table:
        return {"rows": [table["rows"][k] for k in places]}
    return {"cols": {key: _taken(column, places) for key, column in table["cols"].items()}}


def _leaves(table: dict):
    """The lists of a table of columns (`columns`), each leaf's."""
    if "rows" in table:
        yield table["rows"]
        return
    for column in table["cols"].values():
        yield from _leaves(column)


def listing(folder: Path) -> set[str]:
    """The names in a folder (none if it does not exist)."""
    try:
        return set(os.listdir(folder))
    except (FileNotFoundError, NotADirectoryError):
        return set()


def write_batch(folder: Path, record: dict, members: list[dict], texts: dict | None = None) -> dict:
    """The outcome of members done in one batch: DIR/batches/<name>/members.json, `record` (what
    they share: status, times, provenance) and `members` ({id, index, params, chain, case,
    summary} each) as columns (`columns`), written last and atomically (`write_table`)."""
    same: dict = {}
    return write_table(folder, record, columns(members, same), texts, same)


def write_table(folder: Path, record: dict, table: dict, texts: dict | None = None, same: dict | None = None) -> dict:
    """`write_batch` of the members' columns (`columns` of their rows, or made a key at a time:
    `sweep.batch`). Returns those columns as written (strict: what `read_batch` reads back), for
    the table's rows (`table.batch_rows`); `texts` gets each column of finite floats as `Floats`,
    by id of its list. same: the columns of one value n times (`columns`), by id of their lists:
    each looked at once (a point's shared case values)."""
    # strict JSON (no NaN); only summaries hold numpy values or NaN (ids, parameters and cases
    # are TOML values, finite by validation)
    texts = {} if texts is None else texts
    same = {} if same is None else same
    table = _strict(table, texts, same)
    text = (_json(record, table, texts, same) + "\n").encode()
    write_columns(Path(folder), record, table, text, texts, same)  # read back on resume, where it fits
    atomic_write(Path(folder) / BATCH_FILE, text, sync=False)
    return table


_SEPARATORS = (",", ":")


@dataclass
class Floats:
    """A column of finite floats of a batch (a list: a summary's measure, a swept value), as
    `write_batch` found it, for what it writes and the table's rows (`table.batch_rows`) make
    of it alike: its values' texts (repr, as JSON writes them), those joined by commas, and
    `array`, the values as float64 (members.arrow's column, the table's). Each made once: some
    60 columns of up to 32768 members a task."""

    values: list
    cells: list[str]
    joined: str

    @cached_property
    def array(self) -> np.ndarray:
        return np.array(self.values, dtype=np.float64)

    @classmethod
    def repeated(cls, values: list) -> Floats:
        """The `Floats` of a list of one finite float n times, made from that value once."""
        text, n = repr(values[0]), len(values)
        made = cls(values, [text] * n, ",".join(repeat(text, n)))
        made.__dict__["array"] = np.full(n, values[0], dtype=np.float64)  # (the cached property's value)
        return made


def _json(record: dict, table: dict, texts: dict, same: dict | None = None) -> str:
    """`json.dumps({**record, "columns": table}, allow_nan=False, separators=_SEPARATORS)`, the
    columns of finite floats from their texts (`_strict`): a batch's summaries are some 60
    floats a member, whose texts the table's CSV cells are made of too (`table.batch_rows`);
    a column of one value (`same`, by id of its list: `columns`) from that value's text."""
    same = same or {}

    def dumps(value) -> str:
        return json.dumps(value, allow_nan=False, separators=_SEPARATORS)

    def encoded(column: dict) -> str:
        if "cols" in column:
            return '{"cols":{' + ",".join(f"{dumps(k)}:{encoded(c)}" for k, c in column["cols"].items()) + "}}"
        values = column["rows"]
        made = texts.get(id(values))
        if made is not None:
            return '{"rows":[' + made.joined + "]}"
        if id(values) in same:
            return '{"rows":[' + ",".join(repeat(dumps(values[0]), len(values))) + "]}"
        return '{"rows":' + dumps(values) + "}"

    return "{" + ",".join([*(f"{dumps(k)}:{dumps(v)}" for k, v in record.items() if k != "columns"),
                           '"columns":' + encoded(table)]) + "}"


def _strict(table: dict, texts: dict, same: dict | None = None) -> dict:
    """`columns`' table with its values strict JSON (`serialize.jsonable`): a column of plain
    numbers, strings and None in one pass (non-finite floats become None), any other value by
    value: a batch's summaries are some 60 values a member. A column of finite floats is kept
    as it is, and `texts` gets it as `Floats` by id of its list; a column of one value (`same`,
    by id of its list: `columns`) is looked at once, not per member (a case's 30 values)."""
    from ..serialize import jsonable

    same = {} if same is None else same
    if "cols" in table:
        return {"cols": {key: _strict(column, texts, same) for key, column in table["cols"].items()}}
    values = table["rows"]
    if id(values) in same:
        kinds = {type(values[0])}
        if kinds == {float} and math.isfinite(values[0]):
            texts[id(values)] = Floats.repeated(values)
            return {"rows": values}
        if kinds <= _EXACT or kinds == {list} and set(map(type, values[0])) <= _EXACT:
            return {"rows": values}
    else:
        kinds = set(map(type, values))
    if kinds == {float}:  # most columns: finite numbers, kept as they are
        made = _float_texts(values)
        joined = ",".join(made)
        if "n" not in joined:  # finite: "inf" and "nan" are the only float texts with an n
            texts[id(values)] = Floats(values, made, joined)
            return {"rows": values}
    if kinds <= _EXACT:  # strict as they are (no float)
        return {"rows": values}
    if kinds <= _PLAIN:
        return {"rows": [None if type(v) is float and not math.isfinite(v) else v for v in values]}
    if kinds == {list} and {type(x) for v in values for x in v} <= _EXACT:  # lists of gap or magnet numbers
        return {"rows": values}
    return {"rows": jsonable(values)}


def _float_texts(values: list) -> list[str]:
    """repr of each float, made once per value where a column repeats its values (a rounded
    measure of 10^4 members takes a few hundred), judged from its first 1000: a float's repr
    is a function of its value but for 0.0 and -0.0 (equal, their texts not)."""
    if len(set(values[:1000])) * 2 > min(len(values), 1000):
        return list(map(repr, values))
    distinct = set(values)
    if 0.0 in distinct:
        return list(map(repr, values))
    texts = {v: repr(v) for v in distinct}
    return list(map(texts.__getitem__, values))


_PLAIN = {float, int, bool, str, type(None)}
_EXACT = _PLAIN - {float}  # strict JSON as they are


def read_batch(path: Path) -> dict[str, dict]:
    """The outcomes in a batch's members.json by member id; none if it is missing or does not parse."""
    batch = read_batch_columns(path)
    return {} if batch is None else {batch.ids()[k]: batch.outcome(k) for k in batch.done}


def read_batch_columns(path: Path) -> Batch | None:
    """A batch's outcomes (`Batch`) from its members.json (its columns from members.arrow where
    that is members.json's, `columns_file`); None if it is missing, does not parse, or is not
    done."""
    try:
        text = Path(path).read_bytes()
    except (FileNotFoundError, NotADirectoryError, IsADirectoryError):
        return None
    found = read_columns(Path(path).parent, text)
    if found is None:
        from ..serialize import loads_object

        data = loads_object(text)
        if data is None:
            return None
        table = data.get("columns") if "columns" in data else {"rows": data.get("members")}  # (a list, before columns)
        found = {k: v for k, v in data.items() if k not in ("members", "columns")}, table
    record, table = found
    try:
        if "rows" in table:  # members as a list of tables (columns of unequal rows, or before columns)
            members = table["rows"]
            table = {"cols": {key: {"rows": [m[key] for m in members]} for key in (*Batch.KEYS, "summary")}}
        return Batch(record, table) if record["status"] == DONE else None
    except (KeyError, TypeError, AttributeError, ValueError):
        return None


def outcome(root: str | Path, member_id: str) -> dict | None:
    """The outcome in the member's own folder, {"record", "summary"}, if it stands: "done" with a
    summary that parses, or "failed"; else None (never run, unfinished, or done without a summary)."""
    from ..run_folder import RunFolder

    record = _finished(root, member_id)
    if record is None:
        return None
    folder = member_folder(root, member_id)
    if record["status"] == DONE and _case_identity(folder) != member_id:  # another case was run there
        return None
    summary = RunFolder(folder).summary if record["status"] == DONE else None
    return None if record["status"] == DONE and summary is None else {"record": record, "summary": summary}


def _finished(root: str | Path, member_id: str) -> dict | None:
    """The status record in the member's own folder if it says the member finished ("done" or
    "failed") and is its own; else None (a link, never run, unfinished, or another member's)."""
    folder = member_folder(root, member_id)
    if folder.is_symlink():  # not the sweep's own folder: run again (which removes the link)
        return None
    record = read_status(folder)
    if not isinstance(record, dict) or record.get("id") != member_id or record.get("status") not in (DONE, FAILED):
        return None
    return record


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
