"""The host engine: equal-length ensemble members integrated by the chain kernel on every core.

The kernel (pylmp_lattice/plugin/kernel/*.h) is the physics of fix lattice/chain: the same laws,
drives, friction, far end, contact check and front record, in the same operations and order, so a
chain here has the bits of the same chain in a LAMMPS batch (`deck.render_replicas(front=True)`).
The library latticeengine.so (engine_cpu.cpp, built beside the plugin) runs the chains with
OpenMP, one chain per thread at a time; this module hands it the batch's arrays in engine units
(`units`) and returns what the LAMMPS batch gives: every chain's final x and v, its front record
(`case_measures.front_batch`, the arrays `read_front_batch` yields) and its friction work
(`arrays.ChainBatch`).

Members it cannot run raise `Unsupported` with the reason (the caller runs them with LAMMPS).
"""

from __future__ import annotations

import ctypes
import os

import numpy as np

from ..case import Case
from ..errors import RunError
from .arrays import DRIVES, LAWS, NOUT, Arrays, ChainBatch, Unsupported, prepare, result

__all__ = ["ChainBatch", "Unsupported", "run_arrays", "run_chains"]
ABI = 1
# A chunk of chains per call of the library, per thread: about 0.1 s of one core (the 21-magnet
# experiment with friction and the record runs 4.5e7 atom-steps/s per thread on a 2-core AMD EPYC,
# benchmarks/bench_kernel.py --members 1000), so a stop waits at most that long.
CHUNK_ATOM_STEPS = 5e6


def run_chains(cases: list[Case], arrival_method: str = "level", threads: int | None = None) -> ChainBatch:
    """Run `cases` (equal N and everything but [chain] equal, as `deck.render_replicas` takes them,
    with output.format = "none") on `threads` cores (default: all); arrival by `arrival_method`
    ("level" or "velocity_peak", as `case_measures.read_front_batch`)."""
    a = prepare(cases, "cpu")
    return result(cases, a, *run_arrays(a, threads), arrival_method)


def run_arrays(a: Arrays, threads: int | None = None):
    """The kernel over the batch `a`: x, v, front (R N, NOUT, or None), work, end_step, status,
    in engine units, as `arrays.result` takes them. The chains run in chunks of about
    CHUNK_ATOM_STEPS per thread: Python's signal handlers run between two (a call into C defers
    them), so Ctrl-C (KeyboardInterrupt, a sweep worker's Interrupted) stops it within one."""
    lib = _library()
    threads = int(threads or os.cpu_count() or 1)
    x, v = a.x.copy(), a.v.copy()
    empty = np.zeros(1)
    r, u, f, fp_lo, fp_hi = ([np.ascontiguousarray(t, float) for t in a.table[:3]] + list(a.table[3:])
                             if a.table else (empty, empty, empty, 0.0, 0.0))
    t_s, y_s = (np.ascontiguousarray(s, float) for s in a.samples) if a.samples else (empty, empty)
    mu, p, g = a.friction or (0.0, 0.0, 0.0)
    front = np.full((a.chains * a.n, NOUT), np.nan) if a.record else np.zeros((1, NOUT))
    work = np.zeros(a.chains)
    end_step = np.zeros(a.chains, np.int64)
    status = np.zeros(a.chains, np.int32)
    chunk = max(threads, threads * int(CHUNK_ATOM_STEPS // max(1, a.n * a.steps)))
    for lo in range(0, a.chains, chunk):
        hi = min(a.chains, lo + chunk)
        atoms = slice(lo * a.n, hi * a.n)
        lib.pl_run_chains(
            hi - lo, a.n, a.steps, a.dt, LAWS[a.law], _ptr(a.law_values), len(r), _ptr(r), _ptr(u), _ptr(f),
            float(fp_lo), float(fp_hi), DRIVES[a.drive], a.V, a.T, len(t_s), _ptr(t_s), _ptr(y_s),
            int(a.given_velocity), int(a.hold), int(a.friction is not None), mu, p, g, *a.range,
            _ptr(x[lo:hi]), _ptr(v[lo:hi]), _ptr(a.mass[lo:hi]), int(a.record), _ptr(a.levels[lo:hi]),
            _ptr(front[atoms] if a.record else front), _ptr(work[lo:hi]),
            end_step[lo:hi].ctypes.data_as(ctypes.POINTER(ctypes.c_longlong)),
            status[lo:hi].ctypes.data_as(ctypes.POINTER(ctypes.c_int)), threads)
    return x, v, front if a.record else None, work, end_step, status


_LIB = None


def _library():
    """The loaded library, its functions typed; Unsupported if it is not built or of another ABI."""
    global _LIB
    if _LIB is None:
        from ..plugin import ENGINE, library_file

        try:
            lib = ctypes.CDLL(str(library_file(ENGINE)))
        except RunError as err:
            raise Unsupported(f"the host engine is not built: {err}") from None
        if lib.pl_engine_abi() != ABI:
            raise Unsupported(f"{ENGINE} has ABI {lib.pl_engine_abi()}; this package needs {ABI}: reinstall it")
        d, i, ll, p = ctypes.c_double, ctypes.c_int, ctypes.c_longlong, ctypes.POINTER(ctypes.c_double)
        lib.pl_run_chains.argtypes = [i, i, ll, d, i, p, i, p, p, p, d, d, i, d, d, i, p, p, i, i, i, d, d, d, d, d,
                                      p, p, p, i, p, p, p, ctypes.POINTER(ll), ctypes.POINTER(i), i]
        lib.pl_run_chains.restype = i
        _LIB = lib
    return _LIB


def _ptr(a: np.ndarray):
    assert a.dtype == np.float64 and a.flags.c_contiguous
    return a.ctypes.data_as(ctypes.POINTER(ctypes.c_double))
