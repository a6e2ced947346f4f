"""The sweep file and its members: a base case, overrides, and the cases they expand to.

A sweep file (TOML) holds

    base = "case.toml"        # path relative to the sweep file
    replicas = 1              # runs per parameter point (random chains only)
    seed = 0                  # the sweep seed; member i gets a seed derived from (seed, i)
    keep = "all"              # or "measures": no per-frame output (output.format = "none"), the
                              # front measures from the engine's record
    runner = "embedded"       # LAMMPS in the worker process; or "lmp" (the executable)
    engine = "lammps"         # or "cpu", "gpu": the chain kernel runs batched members (see
                              # sweep.batch; its results are LAMMPS's, within rounding)
    [set]                     # fixed overrides of the base case
    "impactor.velocity" = 1.5
    [grid]                    # the product of these lists
    "force.q" = [2.0, 3.0, 4.0]
    [zip]                     # taken pairwise (equal lengths), one axis of the product
    "impactor.velocity" = [0.5, 1.0]
    "run.duration" = [400.0, 200.0]

A key is a dotted case field ("section.field") or a section name. In [set] a table is merged
into the base section (TOML reads `impactor.velocity = 1` and `impactor = {velocity = 1}`
alike). In [grid] and [zip] a list of tables replaces the whole section per member, e.g.
`force = [{law = "power", K = 413.8, b = 3.917, q = 3.0}, {law = "linear", k = 0.5, r_free = 30.0}]`.

Members are the grid product (keys in file order, the zip as one more axis), each repeated
`replicas` times (innermost), numbered from 0 in that order. A member whose chain is random
(thermal velocities or disorder) gets chain.seed derived from the sweep seed and its number,
unless the sweep itself sets chain.seed. A member is identified by the hash of its resolved
case (`case.case_id`, numbers normalised: 1 and 1.0 are one value); two members with the same
case are one member. A field is set or swept, not both; swept numbers must be finite, and a
swept value of a kind its field never takes (text for a number) is an error of the sweep file. The [set]
values and the base are checked once, on the first point's case, before any member runs (a bad
one is an error of the sweep file, naming set.<key>, set or base); a grid or zip value that makes some members' cases invalid
fails those members only (recorded as failed, with the error).

Enumeration is lazy where it can be: the first replica of each parameter point is validated
when enumerated; the others differ from it only in chain.seed, so their identity is derived
from its resolved case and each is built and validated (`Member.case`) by whoever runs it.
"""

from __future__ import annotations

import copy
import itertools
import logging
import math
import os
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field, replace
from functools import cached_property
from pathlib import Path
from typing import Any

from ..case import (Case, FieldKindError, brief, case_from_dict, case_id, case_to_dict, identity_hash, normalised,
                    read_toml)
from ..case.chain import CHUNK, check_seed
from ..case.checks import _is_number
from ..case.toml import plain
from ..case.identity import SeededHashes, seeded_hashes
from ..engine import RUNNERS
from ..engines import ENGINES
from ..errors import ConfigError
from .seeds import PointSeeds, member_seed

log = logging.getLogger(__name__)
member_id = case_id  # a member's identity is its case's (one identity for run folders and members)

KEYS = ("base", "set", "grid", "zip", "replicas", "seed", "keep", "runner", "engine", "cluster")
KEEP = ("all", "measures")
RANDOM_FIELDS = ("thermal_velocity", "mass_disorder", "r0_disorder")
# A point's seeded replicas come in runs (`Sweep.iter_runs`) of at most this many: the coordinator's
# first task goes out once its members are made, not all of the point's (their identities, 1.5-2.3
# us each: 10^6 replicas held the first of 16 GPU tasks back 2.3 s on this VM, while the device,
# whose launches run one after another, waited).
RUN = 16384


@dataclass(frozen=True)
class Member:
    """One run of the sweep.

    params: the swept fields (dotted key -> value), with "replica" and "chain.seed" where the
    sweep sets them; data: the case as a dict (TOML form), resolved for all but the first
    replica of a point (whose case the sweep built to validate it). `case` is built on first
    use: None when the parameters are invalid (then `error` says why, and the member is
    recorded as failed without running). point: its parameter point's key (`point_key`),
    set once per point by the sweep; members of one point differ only in their seed.
    """

    index: int
    id: str
    params: dict
    data: dict = field(repr=False)
    base_dir: Path = field(default=Path("."), repr=False)
    built: Case | None = field(default=None, repr=False, compare=False)  # the case, when already built
    point: str = field(default="", repr=False, compare=False)

    def __post_init__(self):
        if not self.point:  # a member made by hand: its key from its parameters
            object.__setattr__(self, "point", point_key(self.params))

    @cached_property
    def _case(self) -> tuple[Case | None, str | None]:
        if self.built is not None:
            return self.built, None
        try:
            return case_from_dict(self.data, base_dir=self.base_dir), None
        except ConfigError as err:
            return None, str(err)

    @property
    def case(self) -> Case | None:
        """The member's case once built (`build_from`); None if it is invalid (see `error`)."""
        return self._case[0]

    @property
    def error(self) -> str | None:
        """Why the member's case is invalid, one line; None for a valid case."""
        return self._case[1]

    def build_from(self, template: Case, seed, draws: dict | None = None) -> None:
        """Build this member's case as `template` (a case of its parameter point) with chain.seed
        `seed`, unless it is built already (`_reseeded`: what the seed draws is checked again;
        the rest was checked when the template was built). draws: the masses and gaps the seed
        draws under disorder, drawn with the point's other replicas (`chain.replica_draws`)."""
        if "_case" in self.__dict__ or self.built is not None:
            return
        try:
            case = _reseeded(template, seed, draws), None
        except ConfigError as err:
            case = None, str(err)
        self.__dict__["_case"] = case  # where the cached property `_case` keeps its value


@dataclass(frozen=True)
class Replicas:
    """Seeded replicas of one parameter point, as columns: their numbers and seeds (a sweep of
    10^6 replicas makes no object per member until a worker runs them). `first`: the point's
    first member, its case built; the others' data is its data with their seed. point: the
    swept values; start: the point's first number, params' "replica" counting from it (None:
    params hold no "replica"); identity: a seed's member identity (`case.identity.seeded_hashes`),
    made where `ids` is first asked for (a worker, for the members it runs: 1-2 us each, most
    of the coordinator's time per member at 10^6); made: the ids, where they were made already.
    Iterating gives the Members, in order; `take` some."""

    first: Member
    point: dict
    start: int | None
    index: list
    seeds: list
    identity: Callable[[int], str] | None  # None: the ids are `made`
    made: list | None = None

    def __len__(self) -> int:
        return len(self.seeds)

    @cached_property
    def ids(self) -> list[str]:
        """The members' identities."""
        return self.made if self.made is not None else list(map(self.identity, self.seeds))

    def __getstate__(self):  # sent without the ids a SeededHashes makes: the worker makes them again
        state = {k: v for k, v in self.__dict__.items() if k != "ids"}
        return state if self.identity is None else state | {"made": None}

    def __setstate__(self, state):
        self.__dict__.update(state)

    def __iter__(self) -> Iterator[Member]:
        first = self.first
        for k, (i, member_id, seed) in enumerate(zip(self.index, self.ids, self.seeds)):
            resolved = first.data | {"chain": first.data["chain"] | {"seed": seed}}
            yield Member(i, member_id, self.params(k), resolved, first.base_dir, point=first.point)

    def params(self, k: int) -> dict:
        """The swept values of the member at position k (`Member.params`)."""
        i = self.index[k]
        return dict(self.point) | ({} if self.start is None else {"replica": i - self.start}) | {"chain.seed": self.seeds[k]}

    def take(self, positions) -> Replicas:
        """These members at `positions` (in order; a range: a slice of the columns)."""
        made = self.__dict__.get("ids", self.made)
        if isinstance(positions, range) and positions.step == 1:
            part = slice(positions.start, positions.stop)
            return replace(self, index=self.index[part], seeds=self.seeds[part],
                           made=None if made is None else made[part])
        return replace(self, index=[self.index[k] for k in positions], seeds=[self.seeds[k] for k in positions],
                       made=None if made is None else [made[k] for k in positions])


def point_key(params: dict) -> str:
    """The key of a member's parameter point: its swept values but "replica" and "chain.seed"."""
    return identity_hash({k: v for k, v in params.items() if k not in ("replica", "chain.seed")})


def _reseeded(template: Case, seed, draws: dict | None = None) -> Case:
    """`template` with chain.seed `seed`, at ~5 us instead of `dataclasses.replace`'s ~70 us,
    which checks every field again. Only what the seed draws differs from the template, whose
    other checks passed: the seed is checked, and what it drew before is dropped. Without mass
    or gap disorder it draws only the thermal velocities, which no check reads. With disorder
    it also draws the masses and gaps: their extremes and the checks that read them run again
    (`Case.check_draws`; `draws`, those masses and gaps if drawn already, kept by the chain
    before the checks read them)."""
    chain = template.chain
    if chain.seed is None:
        return replace(template, chain=replace(chain, seed=seed))
    check_seed(seed)
    new = _copy(chain)  # its __dict__: the fields and what it keeps (draws, ranges)
    new.__dict__["seed"] = seed
    kept = new.__dict__.get("_draws")
    case = _copy(template)
    case.__dict__["chain"] = new
    if not (chain.mass_disorder or chain.r0_disorder):
        if kept is not None:
            new.__dict__["_draws"] = {k: v for k, v in kept.items() if k != "velocities"}
        return case
    for name in ("mass_range", "gap_range"):  # (`Chain`'s and `Case`'s cached properties of the draws)
        new.__dict__.pop(name, None)
    case.__dict__.pop("_extremes", None)
    new.__dict__["_draws"] = dict(draws or {})  # (`Chain._kept`'s: not a field)
    if new.draws() <= CHUNK:  # as `Case.__post_init__` checks them: at once, or at first use
        case.check_draws()
    return case


def _copy(obj):
    """A shallow copy of a frozen dataclass instance (its __dict__), without `copy.copy`'s reduce."""
    new = object.__new__(type(obj))
    new.__dict__.update(obj.__dict__)
    return new


def member_cases(members) -> list[Case | None]:
    """`Member.case` of each member, built once per parameter point: a member whose case dict
    differs from an earlier one's only in chain.seed (a replica) is that case with its own seed
    (`_reseeded`: what the seed draws is checked again; the rest was checked when the first was
    built, so its `case_from_dict` would give the same case, ~0.1 ms more)."""
    points: list[tuple[dict, Case]] = []
    out = []
    for m in members:
        seed, rest = _seed_and_rest(m.data)
        case = next((c for d, c in points if d == rest), None)
        if case is not None:
            m.build_from(case, seed)
        elif m.case is not None:
            points.append((rest, m.case))
        out.append(m.case)
    return out


def _seed_and_rest(data: dict) -> tuple:
    """A case dict's chain.seed, and the dict without it."""
    chain = data.get("chain")
    if not isinstance(chain, dict):
        return None, data
    return chain.get("seed"), data | {"chain": {k: v for k, v in chain.items() if k != "seed"}}


@dataclass(frozen=True)
class Sweep:
    """A sweep: a base case (TOML path, `Case`, or case dict) and how to vary it.

    `set`, `grid` and `zip` map dotted keys to values (see the module docstring).
    """

    base: Any
    set: dict = field(default_factory=dict)
    grid: dict = field(default_factory=dict)
    zip: dict = field(default_factory=dict)
    replicas: int = 1
    seed: int = 0
    keep: str = "all"
    runner: str = "embedded"
    engine: str = "lammps"  # not part of the identity: every engine gives the same members' results
    base_dir: Path = Path(".")  # where files named by the base case (force.file, ...) are

    def __post_init__(self):
        base, base_dir = _base_dict(self.base, self.base_dir)
        object.__setattr__(self, "base", plain(base))
        object.__setattr__(self, "base_dir", base_dir)
        for name in ("replicas", "seed"):
            object.__setattr__(self, name, plain(getattr(self, name)))
        object.__setattr__(self, "set", _flatten(plain(self.set), "set"))
        for table in ("grid", "zip"):
            flat = _flatten(plain(getattr(self, table)), table)
            for key, values in flat.items():
                if not isinstance(values, list):
                    raise ConfigError(f"{table}.{key}", f"got {values!r}; expected a list of values")
                if not values:
                    raise ConfigError(f"{table}.{key}", "empty list; expected at least one value")
            object.__setattr__(self, table, flat)
        for table in ("set", "grid", "zip"):
            for key, value in getattr(self, table).items():
                _check_finite(f"{table}.{key}", value)
        for table in ("grid", "zip"):
            for key in getattr(self, table):
                clash = next((k for k in self.set if _overlap(k, key)), None)
                if clash is not None:
                    raise ConfigError(f"{table}.{key}", f"also given in [set] as {clash!r}; a field is set or swept, not both")
        lengths = {key: len(v) for key, v in self.zip.items()}
        if len(set(lengths.values())) > 1:
            first = next(iter(lengths))
            odd = next(k for k, n in lengths.items() if n != lengths[first])
            raise ConfigError(f"zip.{odd}", f"got {lengths[odd]} values; expected {lengths[first]} like zip.{first}")
        swept = [(table, key) for table in ("grid", "zip") for key in getattr(self, table)]
        for i, (table, key) in enumerate(swept):  # a field, or a section and one of its fields
            other = next((f"{t}.{k}" for t, k in swept[:i] if _overlap(k, key)), None)
            if other is not None:
                raise ConfigError(f"{table}.{key}", f"also swept as {other}; a field can be swept once")
        if self.keep == "measures":
            values = [(f"{t}.{k}", v if t == "set" else None) for t in ("set", "grid", "zip") for k, v in getattr(self, t).items()]
            values += [(f"{t}.{k}", v) for t in ("grid", "zip") for k, vs in getattr(self, t).items() for v in vs]
            given = next((key for key, v in values if key.endswith(".output.format")
                          or (key.endswith(".output") and isinstance(v, dict) and "format" in v)), None)
            if given is not None:
                raise ConfigError(given, 'keep = "measures" sets output.format = "none" (no trajectories); '
                                  'leave it out, or set keep = "all"')
        if not (_is_int(self.replicas) and self.replicas >= 1):
            raise ConfigError("replicas", f"got {self.replicas!r}; expected an integer >= 1")
        if not (_is_int(self.seed) and 0 <= self.seed < 2**63):
            raise ConfigError("seed", f"got {self.seed!r}; expected an integer in [0, 2**63 - 1]")
        if self.keep not in KEEP:
            raise ConfigError("keep", f"got {self.keep!r}; choose one of {', '.join(KEEP)}")
        if self.runner not in RUNNERS:
            raise ConfigError("runner", f"got {self.runner!r}; choose one of {', '.join(RUNNERS)}")
        if self.engine not in ENGINES:
            raise ConfigError("engine", f"got {self.engine!r}; choose one of {', '.join(ENGINES)}")
        seeded = [f"{table}.chain.seed" for table in ("set", "grid", "zip") if "chain.seed" in getattr(self, table)]
        if self.replicas > 1 and seeded:
            raise ConfigError(seeded[0], f"with replicas = {self.replicas}, every replica would have this seed (one "
                              "chain, run once); leave chain.seed out: each replica gets its own from the sweep's seed")
        self._check_fixed()
        self._check_kinds()
        if self.replicas > 1 and not self._may_be_random():  # (after the fields: a misspelt one is named first)
            raise ConfigError("replicas", f"got {self.replicas}; no member has a random chain "
                              f"({', '.join('chain.' + f for f in RANDOM_FIELDS)}), so replicas would be identical")

    def _may_be_random(self) -> bool:
        """Whether some member's chain is random: the base with [set], or a swept chain value."""
        data = copy.deepcopy(self.base)
        for key, value in self.set.items():
            _assign(data, key, value)
        if _is_random(data):
            return True
        swept = [(k, v) for table in (self.grid, self.zip) for k, values in table.items() for v in values]
        return any(_is_random({"chain": v} if k == "chain" else {"chain": {k[6:]: v}})
                   for k, v in swept if k == "chain" or k.startswith("chain."))

    def describe(self) -> dict:
        """The sweep as plain data (what DIR/sweep.json records)."""
        return {"base": self.base, "set": self.set, "grid": self.grid, "zip": self.zip, "replicas": self.replicas,
                "seed": self.seed, "keep": self.keep}

    def identity(self) -> str:
        """A hash of everything that decides the members (not how they run): two sweeps with the
        same identity have the same members."""
        return identity_hash(self.describe())

    def count(self) -> int:
        """Members before identical cases are merged: known without enumerating them."""
        points = math.prod(len(v) for v in self.grid.values()) * (len(next(iter(self.zip.values()))) if self.zip else 1)
        return points * self.replicas

    def members(self) -> list[Member]:
        """All members, numbered in sweep order; invalid parameter sets give failed members.

        A key that names no case field is an error of the sweep file (ConfigError naming it)."""
        return list(self.iter_members())

    def iter_members(self) -> Iterator[Member]:
        """The members one by one (see `members`): the first ones are ready before the last are made."""
        for run in self.iter_runs():
            yield from run

    def iter_runs(self) -> Iterator[Replicas | tuple[Member, ...]]:
        """The members (see `members`) in runs: a point's seeded replicas as `Replicas` (no
        object per member) of at most RUN each, any other member alone."""
        axes = [[{k: v} for v in values] for k, values in self.grid.items()]
        if self.zip:
            axes.append([dict(zip(self.zip, row)) for row in zip(*self.zip.values())])
        # Members seen: their ids; a point's seeded replicas also by their seeds, in `cases` by
        # their case's text without the seed (`SeededHashes.key`): two are the same case only if
        # both are equal, so no replica's id is made here
        seen, cases, same = set(), {}, []
        index = 0
        for combo in itertools.product(*axes):
            point = {k: v for part in combo for k, v in part.items()}
            data = self._data(point)
            random = _is_random(data)
            seeded = random and "chain.seed" not in self.set and "chain.seed" not in point
            first = None
            key = point_key(point)
            seeds = PointSeeds(self.seed, index, self.replicas, RUN) if seeded else None
            for replica in range(self.replicas):
                params = dict(point)
                if self.replicas > 1:
                    params["replica"] = replica
                if seeded:
                    params["chain.seed"] = seeds.run(replica, replica + 1)[0]
                if first is not None and first.case is not None and seeded:
                    break  # the point's other replicas: its resolved case with their seeds
                if seeded:
                    data.setdefault("chain", {})["seed"] = params["chain.seed"]
                member = first = self._member(index + replica, copy.deepcopy(data), params, key)
                identity = space = None
                if seeded and member.case is not None:
                    # (its sections are shared with the first's: a case dict is read, never changed)
                    identity = seeded_hashes(normalised({k: v for k, v in first.data.items() if k != "name"}))
                    if isinstance(identity, SeededHashes):
                        space = cases.setdefault(identity.key, set())
                if member.id in seen or (space is not None and params["chain.seed"] in space):
                    same.append(member.index)
                else:
                    seen.add(member.id)
                    if space is not None:
                        space.add(params["chain.seed"])
                    yield (member,)
            else:
                index += self.replicas
                continue
            start = index if self.replicas > 1 else None
            for lo in range(replica, self.replicas, RUN):  # the rest in runs of RUN
                hi = min(self.replicas, lo + RUN)
                part = seeds.run(lo, hi)
                marks = part if space is not None else list(map(identity, part))  # (else: ids, made here)
                taken = seen if space is None else space
                fresh = set(marks)
                if len(fresh) == len(marks) and taken.isdisjoint(fresh):  # all new (as good as always): as a whole
                    taken |= fresh
                    yield Replicas(first, point, start, list(range(index + lo, index + hi)), part,
                                   *((identity, None) if space is not None else (None, marks)))
                    continue
                kept = [k for k, i in enumerate(marks, lo) if not (i in taken or taken.add(i))]
                if len(kept) < len(marks):
                    same += [index + k for k in sorted(set(range(lo, hi)) - set(kept))]
                if kept:
                    yield Replicas(first, point, start, [index + k for k in kept], [part[k - lo] for k in kept],
                                   *((identity, None) if space is not None else (None, [marks[k - lo] for k in kept])))
            index += self.replicas
        if same and not self.__dict__.get("_said_same"):  # one line for all (study thermal printed 14), once
            self.__dict__["_said_same"] = True  # per sweep (a study enumerates its sweep, then runs it: it printed 2)
            log.info("%d member%s the same case as earlier ones (member%s %s); each case runs once", len(same),
                     " is" if len(same) == 1 else "s are", "" if len(same) == 1 else "s", _numbers(same))

    def _data(self, point: dict, fixed: bool = True) -> dict:
        """The case dict of a parameter point: the base, [set] (if `fixed`), then the point's values."""
        data = copy.deepcopy(self.base)
        if self.keep == "measures":  # no per-frame output: the engine records the front measures
            data.setdefault("output", {})["format"] = "none"
        for key, value in ((self.set if fixed else {}) | point).items():
            _assign(data, key, value)
        return data

    def _check_fixed(self) -> None:
        """Build the first point's case before any member runs: a bad [set] value, or a bad base
        field that nothing sweeps, would fail every member alike, so it is an error of the sweep
        file (ConfigError naming set.<key>, set or base). A swept value that is bad for some
        members only fails those members."""
        point = {k: v[0] for table in (self.grid, self.zip) for k, v in table.items()}
        err = self._error(self._data(point))
        if err is None or any(_overlap(k, err.field) for k in point):
            return
        message = str(err).split(": ", 1)[1]
        key = next((k for k in self.set if _overlap(k, err.field)), None)
        if key is not None:
            raise ConfigError(f"set.{key}", message) from err
        base = self._error(self._data({}, fixed=False))
        if base is not None and str(base) == str(err):
            raise ConfigError("base", f"the base case is invalid ({err})") from err
        if base is None and self._error(self._data({})) is not None:
            raise ConfigError("set", f"makes the base case invalid ({err})") from err

    def _check_kinds(self) -> None:
        """A swept value of a kind its field never takes (text or true/false for a number, or a
        section's table holding one) fails every member that has it, whatever the other axes:
        an error of the sweep file (ConfigError naming grid.<key> or zip.<key>), found by building
        the first point's case with each such value."""
        first = {k: v[0] for table in (self.grid, self.zip) for k, v in table.items()}
        for table in ("grid", "zip"):
            for key, values in getattr(self, table).items():
                for value in values:
                    if _is_number(value) or isinstance(value, list) and all(map(_is_number, value)):
                        continue  # a number or a list of them: its range is checked per member
                    err = self._error(self._data(first | {key: value}))
                    if isinstance(err, FieldKindError) and _overlap(err.field, key):
                        raise ConfigError(f"{table}.{key}", str(err).split(": ", 1)[1]
                                          + ("" if err.field == key else f" (for {err.field})")) from err

    def _error(self, data: dict) -> ConfigError | None:
        """Why a case dict is no case (None if it is one); an unknown field is the sweep's error."""
        if _is_random(data):
            data.setdefault("chain", {}).setdefault("seed", member_seed(self.seed, 0))
        try:
            case_from_dict(data, base_dir=self.base_dir)
        except ConfigError as err:
            self._check_known(err)
            return err
        return None

    def _member(self, index: int, data: dict, params: dict, point: str) -> Member:
        try:
            case = case_from_dict(data, base_dir=self.base_dir)
        except ConfigError as err:
            self._check_known(err)
            return Member(index, _case_id(data), params, data, self.base_dir, point=point)
        return Member(index, member_id(case), params, case_to_dict(case), self.base_dir, built=case, point=point)

    def _check_known(self, err: ConfigError) -> None:
        """Re-raise an unknown field or section named by the sweep as an error of the sweep file."""
        # unknown fields, and names and files that are unsafe, are errors of the sweep file, not failed members
        if not (str(err).startswith(f"{err.field}: unknown") or err.field == "name" or err.field.endswith(".file")):
            return
        message = str(err).split(": ", 1)[1]
        section = err.field.split(".")[0]
        tables = [(table, key) for table in ("set", "grid", "zip") for key in getattr(self, table)]
        for table, key in tables:
            if err.field == key or err.field.startswith(f"{key}."):  # (a key inside a swept section: named)
                raise ConfigError(f"{table}.{err.field}", message) from err
            if key.split(".")[0] == err.field:
                raise ConfigError(f"{table}.{key}", message) from err
        for table, key in tables:  # e.g. force.law swept alone: the base's other force fields do not fit
            if key.split(".")[0] == section:
                raise ConfigError(f"{table}.{key}", f"makes the base case's {err.field} an {message.split(';')[0]}; "
                                  f"sweep the whole section instead, e.g. {section} = [{{...}}, {{...}}]") from err
        raise ConfigError("base", f"the base case is invalid ({err})") from err


def load_sweep(path: str | Path) -> Sweep:
    """Read a sweep file (TOML); every error names the field (ConfigError)."""
    path = Path(path)
    data = read_toml(path, "sweep")
    if "base" not in data and {"chain", "force"} <= set(data):  # a case file given for the sweep
        raise ConfigError("sweep", f"{path} is a case file (it has [chain] and [force]); expected a sweep file, whose "
                                   f"base = \"{path.name}\" names it (or run it: pylmp-lattice run {path})")
    for key in data:
        if key not in KEYS:
            raise ConfigError(key, f"unknown key; expected one of {', '.join(KEYS)}")
    if "base" not in data:
        raise ConfigError("base", "missing; expected the path of the base case, e.g. base = \"case.toml\"")
    for table in ("set", "grid", "zip"):
        if not isinstance(data.get(table, {}), dict):
            raise ConfigError(table, f"got {data[table]!r}; expected a table [{table}]")
    data.pop("cluster", None)  # what batch jobs book: sweep.cluster reads it
    return Sweep(base=base_file(path.parent, data.pop("base")), **data)


def base_file(folder: Path, value) -> Path:
    """The base case a sweep file names: a path relative to the sweep file's folder, or absolute.
    Unlike the files a case names (`case.data_file`, kept inside its folder), it may lie
    anywhere: the sweep only reads it, as `pylmp-lattice run CASE` reads a case, and writes in
    its -o folder only; the files the base case names stay inside the base case's folder."""
    if not (isinstance(value, str) and value and value.isprintable()):
        raise ConfigError("base", f"got {brief(value)}; expected the path of a case file (TOML), relative to "
                                  "the sweep file's folder or absolute")
    return (Path(folder) / value).resolve()


def _case_id(data: dict) -> str:
    """`case.case_id` of a resolved case dict."""
    return identity_hash({k: v for k, v in data.items() if k != "name"})


def _check_finite(key: str, value) -> None:
    """A swept or set number must be finite (NaN or inf is no case)."""
    if isinstance(value, dict):
        for k, v in value.items():
            _check_finite(f"{key}.{k}", v)
    elif isinstance(value, (list, tuple)):
        for v in value:
            _check_finite(key, v)
    elif isinstance(value, float) and not math.isfinite(value):
        raise ConfigError(key, f"got {value}; expected a finite number")


def _overlap(a: str, b: str) -> bool:
    """Whether two dotted keys name the same field (a section covers its fields)."""
    return a == b or a.startswith(b + ".") or b.startswith(a + ".")


def _base_dict(base, base_dir: Path) -> tuple[dict, Path]:
    if isinstance(base, Case):
        data = case_to_dict(base)
        if base.chain.far_end == "long":  # N is chosen again for each member's drive and duration
            del data["chain"]["particles"]
        return data, Path(base_dir)
    if isinstance(base, dict):
        return copy.deepcopy(base), Path(base_dir)
    if not isinstance(base, (str, os.PathLike)):
        raise ConfigError("base", f"got {brief(base)}; expected a Case, a dict of case sections or the path of a case "
                                  "file (TOML)")
    path = Path(base)
    return read_toml(path, "base"), path.parent


def _flatten(table: dict, name: str, prefix: str = "") -> dict:
    """{"impactor": {"velocity": x}} -> {"impactor.velocity": x}; a list ends a key."""
    if not isinstance(table, dict):
        raise ConfigError(name, f"got {table!r}; expected a table of dotted keys")
    out = {}
    for key, value in table.items():
        dotted = f"{prefix}{key}"
        if dotted.count(".") > 1:
            raise ConfigError(f"{name}.{dotted}", "expected SECTION.FIELD or SECTION")
        if isinstance(value, dict):
            out |= _flatten(value, name, prefix=f"{dotted}.")
        else:
            out[dotted] = value
    return out


def _assign(data: dict, key: str, value) -> None:
    """Set a dotted key in a case dict; a table value for a section replaces the section."""
    section, _, name = key.partition(".")
    if name:
        if not isinstance(data.get(section, {}), dict):
            raise ConfigError(key, f"{section} is not a section")
        data.setdefault(section, {})[name] = value
    else:
        data[section] = copy.deepcopy(value)


def _is_random(data: dict) -> bool:
    chain = data.get("chain", {})
    return isinstance(chain, dict) and any(chain.get(f) for f in RANDOM_FIELDS)


def _numbers(indices: list[int], shown: int = 5) -> str:
    """'3, 7, 9' or '3, 7, 9, 12, 15, ... 40' for a long list."""
    head = ", ".join(map(str, indices[:shown]))
    return head if len(indices) <= shown else f"{head}, ... {indices[-1]}"


def _is_int(value) -> bool:
    return isinstance(value, int) and not isinstance(value, bool)
