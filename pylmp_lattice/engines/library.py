"""The host build of the chain kernel, latticeengine.so (plugin/engine_cpu.cpp), loaded once with
its functions typed, and the layout it exports (`Layout`), which Python reads and never restates:
the host engine runs its chains in it, the GPU engine fits its splines with it.
"""

from __future__ import annotations

import ctypes
from dataclasses import dataclass

import numpy as np

from ..errors import LatticeError, RunError

ABI = 6


class Unsupported(LatticeError):
    """A kernel engine cannot run these members (the message says why): run them with LAMMPS."""


@dataclass(frozen=True)
class Layout:
    """block: the largest run of free atoms stepped as one block; nout, ncol: a front record
    row's output columns (fix lattice/front's) and all its columns; status: each chain status's
    name, by its code (kernel/chain.h ChainStatus); lanes: the chains a thread of the host
    engine runs side by side (a vector's lanes)."""

    block: int
    nout: int
    ncol: int
    status: tuple[str, ...]
    lanes: int


_LOADED: list = []


def library() -> ctypes.CDLL:
    """The loaded library, its functions typed; Unsupported if it is not built or of another ABI."""
    if not _LOADED:
        _LOADED.append(_load())
    return _LOADED[0][0]


def layout() -> Layout:
    """The library's layout (Unsupported as `library`)."""
    library()
    return _LOADED[0][1]


def ptr(a: np.ndarray):
    """A float64 C-contiguous array as the library's double *."""
    assert a.dtype == np.float64 and a.flags.c_contiguous
    return a.ctypes.data_as(ctypes.POINTER(ctypes.c_double))


def _load(path=None) -> tuple[ctypes.CDLL, Layout]:
    """The library at `path` (the installed one if None), typed, and its layout."""
    from ..plugin import ENGINE, library_file

    try:
        lib = ctypes.CDLL(str(path or library_file(ENGINE)))
    except RunError as err:
        raise Unsupported(f"the host engine is not built: {err}") from None
    if lib.pl_engine_abi() != ABI:
        raise Unsupported(f"{ENGINE} has ABI {lib.pl_engine_abi()}; this package needs {ABI}: reinstall it")
    d, i, ll, p = ctypes.c_double, ctypes.c_int, ctypes.c_longlong, ctypes.POINTER(ctypes.c_double)
    lib.pl_run_chains.argtypes = [i, i, ll, d, i, p, i, p, p, p, d, d, i, d, d, i, p, p, i, i, i, d, d, d, d, d,
                                  p, p, p, i, p, p, p, ctypes.POINTER(ll), ctypes.POINTER(i), i]
    lib.pl_run_chains.restype = i
    lib.pl_fit_table.argtypes = [p, p, p, i, d, d, p, p]
    lib.pl_fit_table.restype = None
    lib.pl_fit_measured.argtypes = [p, p, i, p]
    lib.pl_fit_measured.restype = None
    lib.pl_drive_path.argtypes = [i, d, d, d, ll, p]
    lib.pl_drive_path.restype = i
    lib.pl_engine_status.argtypes = [i]
    lib.pl_engine_status.restype = ctypes.c_char_p
    status = []
    while (name := lib.pl_engine_status(len(status))) is not None:
        status.append(name.decode())
    return lib, Layout(lib.pl_engine_block(), lib.pl_engine_nout(), lib.pl_engine_ncol(), tuple(status),
                       lib.pl_engine_lanes())
