"""The sweep file and its members: a base case, overrides, and the cases they expand to.

A sweep file (TOML) holds

    base = "case.toml"        # path relative to the sweep file
    replicas = 1              # runs per parameter point (random chains only)
    seed = 0                  # the sweep seed; member i gets a seed derived from (seed, i)
    keep = "all"              # or "measures": no per-frame output (output.format = "none"), the
                              # front measures from the engine's record
    runner = "embedded"       # LAMMPS in the worker process; or "lmp" (the executable)
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
case (`case.case_id`); two members with the same case are one member.
"""

from __future__ import annotations

import copy
import itertools
import logging
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..case import Case, case_from_dict, case_id, case_to_dict, data_file, identity_hash, read_toml
from ..errors import ConfigError

log = logging.getLogger(__name__)
member_id = case_id  # a member's identity is its case's (one identity for run folders and members)

KEYS = ("base", "set", "grid", "zip", "replicas", "seed", "keep", "runner")
KEEP = ("all", "measures")
RUNNERS = ("embedded", "lmp")
RANDOM_FIELDS = ("thermal_velocity", "mass_disorder", "r0_disorder")


@dataclass(frozen=True)
class Member:
    """One run of the sweep.

    params: the swept fields (dotted key -> value), with "replica" and "chain.seed" where the
    sweep sets them; case: the resolved case, or None when its parameters are invalid
    (then `error` says why, and the member is recorded as failed without running).
    """

    index: int
    id: str
    params: dict
    case: Case | None
    error: str | None = None


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
    base_dir: Path = Path(".")  # where files named by the base case (force.file, ...) are

    def __post_init__(self):
        base, base_dir = _base_dict(self.base, self.base_dir)
        object.__setattr__(self, "base", base)
        object.__setattr__(self, "base_dir", base_dir)
        object.__setattr__(self, "set", _flatten(self.set, "set"))
        for table in ("grid", "zip"):
            flat = _flatten(getattr(self, table), table)
            for key, values in flat.items():
                if not isinstance(values, list):
                    raise ConfigError(f"{table}.{key}", f"got {values!r}; expected a list of values")
                if not values:
                    raise ConfigError(f"{table}.{key}", "empty list; expected at least one value")
            object.__setattr__(self, table, flat)
        lengths = {key: len(v) for key, v in self.zip.items()}
        if len(set(lengths.values())) > 1:
            first = next(iter(lengths))
            odd = next(k for k, n in lengths.items() if n != lengths[first])
            raise ConfigError(f"zip.{odd}", f"got {lengths[odd]} values; expected {lengths[first]} like zip.{first}")
        both = set(self.grid) & set(self.zip)
        if both:
            raise ConfigError(f"zip.{sorted(both)[0]}", "also in [grid]; a field can be swept once")
        if not (_is_int(self.replicas) and self.replicas >= 1):
            raise ConfigError("replicas", f"got {self.replicas!r}; expected an integer >= 1")
        if not (_is_int(self.seed) and 0 <= self.seed < 2**63):
            raise ConfigError("seed", f"got {self.seed!r}; expected an integer >= 0")
        if self.keep not in KEEP:
            raise ConfigError("keep", f"got {self.keep!r}; choose one of {', '.join(KEEP)}")
        if self.runner not in RUNNERS:
            raise ConfigError("runner", f"got {self.runner!r}; choose one of {', '.join(RUNNERS)}")

    def members(self) -> list[Member]:
        """All members, numbered in sweep order; invalid parameter sets give failed members.

        A key that names no case field is an error of the sweep file (ConfigError naming it)."""
        axes = [[{k: v} for v in values] for k, values in self.grid.items()]
        if self.zip:
            axes.append([dict(zip(self.zip, row)) for row in zip(*self.zip.values())])
        members, seen, any_random = [], set(), False
        index = 0
        for combo in itertools.product(*axes):
            point = {k: v for part in combo for k, v in part.items()}
            for replica in range(self.replicas):
                data = copy.deepcopy(self.base)
                if self.keep == "measures":  # no per-frame output: the engine records the front measures
                    data.setdefault("output", {})["format"] = "none"
                for key, value in self.set.items():
                    _assign(data, key, value)
                for key, value in point.items():
                    _assign(data, key, value)
                params = dict(point)
                if self.replicas > 1:
                    params["replica"] = replica
                random = _is_random(data)
                any_random |= random
                if random and "chain.seed" not in self.set and "chain.seed" not in point:
                    params["chain.seed"] = data.setdefault("chain", {})["seed"] = member_seed(self.seed, index)
                member = self._member(index, data, params)
                index += 1
                if member.id in seen:
                    log.info("member %d is the same case as an earlier one (id %s); run once", member.index, member.id)
                    continue
                seen.add(member.id)
                members.append(member)
        if self.replicas > 1 and not any_random:
            raise ConfigError("replicas", f"got {self.replicas}; no member has a random chain "
                              f"({', '.join('chain.' + f for f in RANDOM_FIELDS)}), so replicas would be identical")
        return members

    def _member(self, index: int, data: dict, params: dict) -> Member:
        try:
            case = case_from_dict(data, base_dir=self.base_dir)
        except ConfigError as err:
            self._check_known(err)
            return Member(index, identity_hash({k: v for k, v in data.items() if k != "name"}), params, None, str(err))
        return Member(index, case_id(case), params, case)

    def _check_known(self, err: ConfigError) -> None:
        """Re-raise an unknown field or section named by the sweep as an error of the sweep file."""
        # unknown fields, and names and files that are unsafe, are errors of the sweep file, not failed members
        if not (str(err).startswith(f"{err.field}: unknown") or err.field == "name" or err.field.endswith(".file")):
            return
        message = str(err).split(": ", 1)[1]
        section = err.field.split(".")[0]
        tables = [(table, key) for table in ("set", "grid", "zip") for key in getattr(self, table)]
        for table, key in tables:
            if err.field == key or section == key or key.split(".")[0] == err.field:
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
    for key in data:
        if key not in KEYS:
            raise ConfigError(key, f"unknown key; expected one of {', '.join(KEYS)}")
    if "base" not in data:
        raise ConfigError("base", "missing; expected the path of the base case, e.g. base = \"case.toml\"")
    for table in ("set", "grid", "zip"):
        if not isinstance(data.get(table, {}), dict):
            raise ConfigError(table, f"got {data[table]!r}; expected a table [{table}]")
    return Sweep(base=data_file(path.parent, data.pop("base"), "base"), **data)


def member_seed(sweep_seed: int, index: int) -> int:
    """The seed of member `index`: independent streams for every (sweep seed, index) pair."""
    return int(np.random.SeedSequence([sweep_seed, index]).generate_state(1, np.uint64)[0] >> 1)


def _base_dict(base, base_dir: Path) -> tuple[dict, Path]:
    if isinstance(base, Case):
        data = case_to_dict(base)
        if base.chain.far_end == "long":  # N is chosen again for each member's drive and duration
            del data["chain"]["particles"]
        return data, Path(base_dir)
    if isinstance(base, dict):
        return copy.deepcopy(base), Path(base_dir)
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


def _is_int(value) -> bool:
    return isinstance(value, int) and not isinstance(value, bool)
