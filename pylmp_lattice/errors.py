"""The package's exceptions: bad input (a case field; a flag, folder or argument), a failed engine
run, a stop signal; and the short form of a value in their messages and the check of a
function's switches, which every layer shares."""

from __future__ import annotations

import shlex
import sys
from pathlib import Path


class LatticeError(Exception):
    """Base of every error this package raises on purpose."""


class ConfigError(LatticeError, ValueError):
    """A case field is missing, unknown or out of range; the message names the field."""

    def __init__(self, field: str, message: str):
        self.field = field
        super().__init__(f"{field}: {message}")


class UsageError(ConfigError):
    """A command-line flag, a folder or a function's argument is wrong (not a case field); the
    message names it, e.g. "--np: got 0; expected an integer >= 1". A ConfigError, so that both
    are bad input (the command line's exit 2) while a ConfigError raised as such names a field
    of a case or sweep file."""


def brief(value, limit: int = 40) -> str:
    """repr(value) cut to `limit` characters: one short line for any input."""
    text = repr(value)
    return text if len(text) <= limit else text[:limit - 3] + "..."


def require_bool(**flags) -> None:
    """UsageError naming the first of a function's switches (overwrite, yes, ...) that is not
    True or False: "no" or 1 would count as true. A numpy bool is one (numpy is not imported
    here: such a value exists only once numpy is loaded)."""
    numpy = sys.modules.get("numpy")
    for name, value in flags.items():
        if not (isinstance(value, bool) or (numpy is not None and isinstance(value, numpy.bool_))):
            raise UsageError(name, f"got {brief(value)}; expected True or False")


class DumpFormatError(LatticeError, ValueError):
    """A dump or log file is not in the layout `dump` reads; the message names the file."""


class RunError(LatticeError):
    """LAMMPS stopped with an error; carries its ERROR line, exit code and run folder."""

    def __init__(self, message: str, folder: Path | None = None, exit_code: int | None = None):
        self.message = message  # without the folder, e.g. for run.json
        self.folder = folder
        self.exit_code = exit_code
        where = f" (files kept in {folder})" if folder else ""
        super().__init__(f"{message}{where}")


class ContactError(RunError):
    """Two magnets touched or passed through each other: the model is no longer physical.

    `summarized`: its summary up to the contact is written (`run_folder.run_case`)."""

    def __init__(self, pair: tuple[int, int], time_ms: float, gap_mm: float, folder: Path | None = None,
                 summarized: bool = False):
        self.pair = pair
        self.time_ms = time_ms
        self.gap_mm = gap_mm
        self.summarized = summarized
        super().__init__(f"magnets {pair[0]} and {pair[1]} touched (gap {gap_mm:.4g} mm) at t = {time_ms:.4f} ms")
        if folder is not None:  # where its files are, and its measures up to the contact
            self.folder = folder
            done = "measured up to the contact in summary.json; redo it with" if summarized else "measure it up to the contact with"
            self.args = (f"{self} (files kept in {folder}; {done} `pylmp-lattice summarize {shlex.quote(str(folder))}`)",)


class Interrupted(BaseException):
    """A run stopped by SIGINT or SIGTERM; what it wrote so far stays in its folder.

    Not a LatticeError, nor an Exception: like KeyboardInterrupt, it passes every `except
    Exception` (a figure that fails is a warning, a signal while it is drawn is not).
    exit_code follows the shell's convention, 128 + signal number (130 for SIGINT, 143 for SIGTERM).
    """

    def __init__(self, signum: int, time_ms: float | None = None, folder: Path | None = None):
        self.signum = signum
        self.time_ms = time_ms
        self.folder = folder
        self.exit_code = 128 + signum
        where = f" at t = {time_ms:.6g} ms" if time_ms is not None else ""
        kept = f" (files kept in {folder})" if folder else ""
        super().__init__(f"interrupted{where}{kept}")

    def __reduce__(self):  # a worker's Interrupted reaches its coordinator whole (pickled)
        return type(self), (self.signum, self.time_ms, self.folder)
