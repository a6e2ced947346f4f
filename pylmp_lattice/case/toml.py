"""The TOML boundary: a case from a file or a dict with `--set` overrides, and back.

A TOML case has the sections [chain], [force], [impactor], [run] and optionally [table],
[friction] (absent: no friction), [second_neighbour] (absent: nearest neighbours only) and
[output] (absent: the defaults of `OutputSettings`);
`case_to_dict` writes the same shape back, so a run folder's case.toml reloads unchanged.
"""

from __future__ import annotations

import logging
import math
import os
import re
import tomllib
import warnings
from dataclasses import MISSING, fields
from pathlib import Path

import numpy as np

from ..errors import ConfigError, UsageError
from ..exact import weak_shock
from ..formats.layout import as_path
from ..impactor import PROFILES
from .case import Case
from .chain import Chain
from .checks import NAME, _choice, _is_number, brief, check_name
from .model import FORCE_LAWS, Friction, SecondNeighbour
from .settings import OutputSettings, RunSettings, TableSettings

logger = logging.getLogger(__name__)


def load_case(path: str | Path, overrides: list[str] | str = ()) -> Case:
    """Read a case from TOML; `overrides` are 'section.key=value' strings (TOML values), a list
    of them or one alone.

    Files the case names (force.file, impactor.file) are read from the case file's folder."""
    overrides = [overrides] if isinstance(overrides, str) else overrides
    if not (isinstance(overrides, (list, tuple)) and all(isinstance(item, str) for item in overrides)):
        raise UsageError("overrides", f"got {brief(overrides)}; expected a list of 'section.key=value' strings, "
                                      "e.g. ['run.duration=40']")
    path = as_path(path, "path", "the path of a case file (TOML)")
    data = read_toml(path, "case")
    switched = _switch_laws(data, overrides)
    for item in overrides:
        apply_override(data, item)
    try:
        return case_from_dict(data, base_dir=path.parent)
    except ConfigError as err:
        section = err.field.split(".")[0]
        message = str(err)[len(err.field) + 2:]
        if section not in switched or not message.startswith(("missing", "unknown key")):  # the keys afresh
            raise
        raise ConfigError(err.field, f"{message} (--set {section}.{switched[section]} "
                                     f"starts [{section}] afresh: give its fields with --set {section}.KEY=VALUE)") from None


def as_case(case: Case | str | os.PathLike, argument: str = "case") -> Case:
    """`case` itself, or the case its TOML file holds (`load_case`) if it is a path; else a
    UsageError naming `argument`."""
    if isinstance(case, Case):
        return case
    if isinstance(case, (str, os.PathLike)):
        return load_case(case)
    raise UsageError(argument, f"got {brief(case)}; expected a Case or the path of a case file (TOML)")


# A law's parameters belong to it, a profile's to it: another one named with --set starts its
# section afresh. {section: (key, the default)}
_KIND_KEYS = {"force": ("law", "power"), "second_neighbour": ("law", "power"), "impactor": ("profile", "constant")}


def _switch_laws(data: dict, overrides: list[str]) -> dict[str, str]:
    """Empty the sections whose law or profile `overrides` switch to another than the file's, so
    that the new one's fields come from `overrides` alone; {section: "KEY=new value"}."""
    given = {}
    for item in overrides:
        apply_override(given, item)
    switched = {}
    for section, (key, default) in _KIND_KEYS.items():
        new = given.get(section, {}).get(key)
        if section in data and new is not None and new != data[section].get(key, default):
            data[section] = {}
            switched[section] = f"{key}={new}"
    return switched


def read_toml(path: Path, field: str) -> dict:
    """A TOML file as a dict; a missing, unreadable or malformed file is a ConfigError naming `field`."""
    path = Path(path)
    try:
        if path.exists() and not path.is_file():  # a folder, a device or a pipe: never read
            raise ConfigError(field, f"{path} is not a file; expected a TOML file")
        return tomllib.loads(path.read_bytes().decode())  # TOML is UTF-8 whatever the locale
    except FileNotFoundError as err:
        raise ConfigError(field, f"file not found: {path}") from err
    except OSError as err:
        raise ConfigError(field, f"cannot read {path} ({err.strerror})") from err
    except UnicodeDecodeError as err:
        raise ConfigError(field, f"{path} is not a text file; expected TOML (UTF-8)") from err
    except tomllib.TOMLDecodeError as err:
        raise ConfigError(field, f"{path} is not valid TOML ({err})") from err


def apply_override(data: dict, item: str) -> None:
    """Set data[section][key] from 'section.key=value' (or the name from 'name=value'); the
    value is parsed as TOML, a bare word as text."""
    key, sep, text = item.partition("=")
    parts = key.strip().split(".")
    if not sep or not (parts == ["name"] or (len(parts) == 2 and all(parts))) or not item.isprintable():
        raise UsageError("--set", f"got {brief(item)}; expected SECTION.KEY=VALUE (one line) or name=VALUE, "
                                   "e.g. impactor.velocity=1.5")
    try:
        value = tomllib.loads(f"v = {text.strip()}")["v"]
    except tomllib.TOMLDecodeError:
        value = text.strip()  # a bare word, e.g. far_end=long
    if parts == ["name"]:
        data["name"] = value
        return
    section = data.setdefault(parts[0], {})
    if not isinstance(section, dict):
        raise ConfigError(_key(parts[0]), f"got {brief(section)}; expected a table [{_key(parts[0])}]")
    section[parts[1]] = value


SECTIONS = ("chain", "force", "impactor", "run", "table", "friction", "second_neighbour", "output")


def case_from_dict(data: dict, base_dir: Path = Path(".")) -> Case:
    """A case from its TOML form, a dict {section: {key: value}} (numpy numbers and 1-D arrays
    taken as numbers and lists); files it names are read from `base_dir` (see `data_file`)."""
    if not isinstance(data, dict):
        raise UsageError("data", f"got {brief(data)}; expected a dict of the case's sections, "
                                 "{section: {key: value}} as in its TOML file")
    data = dict(data)
    name = check_name(data.pop("name", "case"))
    for key, value in data.items():
        if key not in SECTIONS:
            raise ConfigError(_key(key), f"unknown section; expected one of {', '.join(sorted(SECTIONS))}")
        if not isinstance(value, dict):
            raise ConfigError(key, f"got {brief(value)}; expected a table [{key}]")
    for key in ("chain", "force", "impactor", "run"):
        if key not in data:
            raise ConfigError(key, "missing section")

    law, force, force_keys = _kind("force", data["force"], FORCE_LAWS, base_dir)
    profile, impactor, impactor_keys = _kind("impactor", data["impactor"], PROFILES, base_dir)
    case = Case(
        chain=_build(Chain, "chain", data["chain"]),
        force=_build(FORCE_LAWS[law], "force", force, force_keys),
        impactor=_build(PROFILES[profile], "impactor", impactor, impactor_keys),
        # second neighbours run on the stock deck path: the default engine there
        run=_build(RunSettings, "run", ({"engine": "stock"} if "second_neighbour" in data else {}) | data["run"]),
        table=_build(TableSettings, "table", data.get("table", {})),
        friction=_build(Friction, "friction", data["friction"]) if "friction" in data else None,
        output=_build(OutputSettings, "output", data.get("output", {})),
        second_neighbour=_second_neighbour(data["second_neighbour"]) if "second_neighbour" in data else None,
        name=name,
    )
    for message in unit_warnings(case):
        logger.warning(message)
    return case


# The law or profile whose values a CSV file may give: {section: (its name, the two fields, the columns)}
_FILE_KINDS = {"force": ("sampled", ("r", "F"), "r [mm], F [N]"),
               "impactor": ("measured", ("t", "values"), "t [ms], u [mm] or v [m/s]")}


def _kind(section: str, values: dict, choices, base_dir: Path) -> tuple[str, dict, tuple[str, ...]]:
    """The law or profile that a [force] or [impactor] table names (default: see _KIND_KEYS), its
    other values with the columns of the file it names read in, and the keys it takes besides
    its fields ("file", or none)."""
    values = dict(values)
    key, default = _KIND_KEYS[section]
    kind = _choice(f"{section}.{key}", values.pop(key, default), choices)
    file_kind, names, columns = _FILE_KINDS[section]
    if kind != file_kind:
        return kind, values, ()
    if "file" in values:
        field = f"{section}.file"
        values[names[0]], values[names[1]] = _read_columns(data_file(base_dir, values.pop("file"), field), field,
                                                           columns)
    return kind, values, ("file",)


def unit_warnings(case: Case) -> list[str]:
    """Warnings for values that look like another unit than the case's (mm, g, m/s): r0
    under 0.1 mm (metres?), a mass under 0.01 g (kilograms?) or over 1 kg (milligrams?), V_I
    over 100 times the chain's linear wave speed V0 (mm/s?). Such a case is valid, but builds
    e.g. a chain of 10^5 magnets that touch at once."""
    out = []
    # the nominal values (lists only if given per magnet): no array of N values for a huge chain
    r0, m = float(np.mean(case.chain.r0)), float(np.mean(case.chain.mass))
    if r0 < 0.1:
        out.append(f"chain.r0: got {r0:g} mm; lengths are in mm: if it is in m, that is {r0 * 1e3:g} mm")
    if m < 0.01:
        out.append(f"chain.mass: got {m:g} g; masses are in g: if it is in kg, that is {m * 1e3:g} g")
    elif m > 1e3:
        out.append(f"chain.mass: got {m:g} g; masses are in g: if it is in mg, that is {m * 1e-3:g} g")
    if out:  # V0 = r0 sqrt(k/m) is then off too
        return out
    vi = case.impactor.peak_velocity()
    with np.errstate(all="ignore"):
        v0 = weak_shock(case.force, r0, m).c0
    if np.isfinite(v0) and vi > 100 * v0:
        out.append(f"impactor.velocity: got {vi:g} m/s, over 100 times the chain's linear wave speed V0 = {v0:.3g} m/s; "
                   f"velocities are in m/s: if it is in mm/s, that is {vi * 1e-3:g} m/s")
    return out


def data_file(base_dir: str | Path, value, field: str) -> Path:
    """The file that `value` names, relative to `base_dir` (the folder of the file naming it).

    Case and sweep files are shared like documents: a path in one never reads outside its
    folder (no absolute path, no '..' or symlink leading out)."""
    if not (isinstance(value, str) and value and value.isprintable()):
        raise ConfigError(field, f"got {brief(value)}; expected a file name, relative to the folder of the file "
                                 "naming it")
    root = Path(base_dir).resolve()
    path = (root / value).resolve()
    if Path(value).is_absolute() or not path.is_relative_to(root):
        raise ConfigError(field, f"got {brief(value)}; expected a file inside the folder of the file naming it "
                                 "(no absolute path, no '..' or link leading out)")
    return path


def case_to_dict(case: Case) -> dict:
    """The case as a TOML-ready dict, the inverse of `case_from_dict` (N resolved)."""
    out = {"name": case.name}
    for section, obj, tag in (
        ("chain", case.chain, None),
        ("force", case.force, ("law", case.force.law)),
        ("impactor", case.impactor, ("profile", case.impactor.profile)),
        ("run", case.run, None),
        ("table", case.table, None),
        ("friction", case.friction, None),
        ("output", case.output, None),
    ):
        if obj is None:
            continue
        out[section] = ({tag[0]: tag[1]} if tag else {}) | _fields(obj)
    if case.second_neighbour is not None:
        sn = case.second_neighbour
        out["second_neighbour"] = {"law": sn.law.law, **_fields(sn.law), "sign": sn.sign}
    return out


def _second_neighbour(values: dict) -> SecondNeighbour:
    values = dict(values)
    law, sign = values.pop("law", "power"), plain(values.pop("sign", -1.0))
    law = _choice("second_neighbour.law", law, [k for k in FORCE_LAWS if k != "sampled"])
    if isinstance(sign, bool) or not isinstance(sign, (int, float)):
        raise ConfigError("second_neighbour.sign", f"got {brief(sign)}; expected -1 (attractive) or 1 (repulsive)")
    return SecondNeighbour(_build(FORCE_LAWS[law], "second_neighbour", values), float(sign))


def _fields(obj) -> dict:
    """A case dataclass's given fields as TOML values (tuples as lists)."""
    out = {}
    for f in fields(obj):
        value = getattr(obj, f.name)
        if f.init and value is not None:
            out[f.name] = list(value) if isinstance(value, tuple) else value
    return out


def _build(cls, section: str, values: dict, other_keys: tuple[str, ...] = ()):
    """Construct a case dataclass from a TOML table, naming the field on any error.

    other_keys: keys the TOML section also accepts that were consumed before (e.g. `file`)."""
    known = {f.name: f for f in fields(cls) if f.init}
    converted = {}
    for key, value in values.items():
        if key not in known:
            raise ConfigError(f"{section}.{_key(key)}",
                              f"unknown key; expected one of {', '.join([*other_keys, *known])}")
        value = plain(value)
        _check_type(f"{section}.{key}", value, known[key].type)
        converted[key] = tuple(value) if isinstance(value, list) else value
    missing = [k for k, f in known.items() if k not in values and f.default is MISSING]
    if missing:
        raise ConfigError(f"{section}.{missing[0]}", "missing" + (f"; or give {section}.{other_keys[0]}" if other_keys else ""))
    try:
        return cls(**converted)
    except (TypeError, ValueError) as err:
        if isinstance(err, ConfigError):
            raise
        raise ConfigError(section, f"invalid values ({err})") from err


def plain(value):
    """A value from Python as TOML would give it: a numpy scalar as the Python number (or text,
    bool) it holds, a numpy array as a list, in lists, tuples (as lists) and dicts at any depth
    (a sweep's grid of `list(np.arange(...))` or of whole sections); anything else as it is (a
    case's field then checked by `_check_type`, np.bool_ as a bool)."""
    if isinstance(value, (np.generic, np.ndarray)):
        return value.tolist()
    if isinstance(value, dict):
        return {k: plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [plain(v) for v in value]
    return value


def _check_type(field: str, value, annotation: str) -> None:
    """A TOML value of the kind a field's annotation allows ("float | tuple[float, ...]", "str",
    "bool", ...); numbers finite. The dataclass then checks the range."""
    scalar = re.sub(r"tuple\[[^\]]*\]", "", annotation)
    numeric = "float" in scalar or "int" in scalar
    if "str" in scalar and not numeric:  # a choice: the dataclass names the allowed values
        return
    if value is None:  # from Python (TOML has no null): the field's default
        ok = "None" in scalar
    elif isinstance(value, bool):
        ok = "bool" in scalar
    elif isinstance(value, (int, float)):
        ok = numeric and math.isfinite(value)
    elif isinstance(value, str):
        ok = "str" in scalar
    elif isinstance(value, (list, tuple)):
        ok = "tuple" in annotation and all(_is_number(v) and math.isfinite(v) for v in value)
    else:
        ok = False
    if not ok:
        kinds = (["a finite number" if _is_number(value) else "a number"] * numeric + ["text"] * ("str" in scalar)
                 + ["true or false"] * ("bool" in scalar) + ["a list of finite numbers"] * ("tuple" in annotation))
        raise FieldKindError(field, f"got {brief(value)}; expected {' or '.join(kinds)}")


class FieldKindError(ConfigError):
    """A value of a kind its field never takes (text for a number, ...): wrong in any case,
    whatever the other fields (a sweep refuses such a swept value before any member runs)."""


def _key(key: str) -> str:
    """A key from a file as it may be shown in a field name: itself, or its short repr."""
    return key if NAME.fullmatch(key) else brief(key)


def _read_columns(path: Path, field: str, columns: str):
    """Two numeric columns of a CSV file as two tuples; lines starting with '#' are comments (a
    header line too: a first line of text is refused, never guessed to be a header).

    Errors name the file and the row, never its text: a data file may be anything."""
    if not path.is_file():
        raise ConfigError(field, f"{path.name}: {'not a file' if path.exists() else 'file not found'}")
    try:
        with warnings.catch_warnings():  # an empty file: shown as an error below, not a warning
            warnings.simplefilter("ignore")
            table = np.loadtxt(path, delimiter=",", comments="#", ndmin=2)
    except OSError as err:
        raise ConfigError(field, f"{path.name}: cannot read ({err.strerror})") from err
    except ValueError as err:  # UnicodeDecodeError included; numpy's message quotes the text
        where = re.search(r"at row (\d+), column (\d+)", str(err))  # numpy: data rows from 0, columns from 1
        note = "a header line must start with '#'" if where and where[1] == "0" else "'#' comment lines not counted"
        raise ConfigError(field, f"{path.name}: expected two numeric columns {columns}, comma-separated"
                                 + (f"; not a number in data row {int(where[1]) + 1}, column {where[2]} ({note})"
                                    if where else "")) from err
    if table.shape[1] != 2 or len(table) == 0:
        columns_got = table.shape[1] if len(table) else 0
        raise ConfigError(field, f"{path.name}: got {columns_got} columns; expected 2 ({columns})")
    bad = np.flatnonzero(~np.isfinite(table).all(axis=1))
    if bad.size:  # nan, inf: numbers to numpy, never a sample
        raise ConfigError(field, f"{path.name}: not a finite number in data row {bad[0] + 1} ('#' comment lines "
                                 f"not counted); expected two finite columns {columns}")
    return tuple(table[:, 0].tolist()), tuple(table[:, 1].tolist())
