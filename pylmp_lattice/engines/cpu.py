"""The host engine: equal-length ensemble members integrated by the chain kernel on every core.

The kernel (pylmp_lattice/plugin/kernel/*.h) is the physics of fix lattice/chain: the same laws,
drives, friction, far end, contact check and front record, in the same operations and order, so a
chain here has the bits of the same chain in a LAMMPS batch (`deck.render_replicas(front=True)`).
The library latticeengine.so (engine_cpu.cpp, built beside the plugin, loaded by `library`) runs
the chains with OpenMP, each thread 4 chains side by side in the lanes of AVX2 vectors (2 without
AVX2); `run_arrays` hands it the batch's arrays in engine units (`arrays.prepare`), as the road's
engine (`road.KernelEngine`) runs them.
"""

from __future__ import annotations

import ctypes
import os

import numpy as np

from .arrays import DRIVES, LAWS, Arrays
from .library import layout, library, ptr

__all__ = ["run_arrays"]
# A chunk of chains per call of the library, per thread: about 0.1 s of one core (the 21-magnet
# experiment with friction and the record runs 2.4e8 atom-steps/s per thread on a 2-core AMD EPYC,
# benchmarks/bench_kernel.py --members 1000 --workers 1, kernel CPU time), so a stop waits at most
# that long, and the threads' wait at each call's end stays small.
CHUNK_ATOM_STEPS = 2e7


def run_arrays(a: Arrays, threads: int | None = None):
    """The kernel over the batch `a`: x, v, front (R N, nout: each atom's fix lattice/front
    columns; None without a record), work, end_step, status (codes of `layout().status`), in
    engine units. The chains run in chunks of about CHUNK_ATOM_STEPS per thread: Python's signal handlers run between two (a call into C defers
    them), so Ctrl-C (KeyboardInterrupt, a sweep worker's Interrupted) stops it within one."""
    lib, lay = library(), layout()
    threads = int(threads or os.cpu_count() or 1)
    x, v = a.x.copy(), a.v.copy()
    empty = np.zeros(1)
    r, u, f, fp_lo, fp_hi = ([np.ascontiguousarray(t, float) for t in a.table[:3]] + list(a.table[3:])
                             if a.table else (empty, empty, empty, 0.0, 0.0))
    t_s, y_s = (np.ascontiguousarray(s, float) for s in a.samples) if a.samples else (empty, empty)
    mu, p, g = a.friction or (0.0, 0.0, 0.0)
    front = np.full((a.chains * a.n, lay.nout), np.nan) if a.record else np.zeros((1, lay.nout))
    work = np.zeros(a.chains)
    end_step = np.zeros(a.chains, np.int64)
    status = np.zeros(a.chains, np.int32)
    # each thread's share a multiple of its lanes: fewer chains cost as much (its other lanes run copies)
    per_thread = max(1, int(CHUNK_ATOM_STEPS // max(1, a.n * a.steps)))
    chunk = threads * -(-per_thread // lay.lanes) * lay.lanes
    for lo in range(0, a.chains, chunk):
        hi = min(a.chains, lo + chunk)
        atoms = slice(lo * a.n, hi * a.n)
        lib.pl_run_chains(
            hi - lo, a.n, a.steps, a.dt, LAWS[a.law], ptr(a.law_values), len(r), ptr(r), ptr(u), ptr(f),
            float(fp_lo), float(fp_hi), DRIVES[a.drive], a.V, a.T, len(t_s), ptr(t_s), ptr(y_s),
            int(a.given_velocity), int(a.hold), int(a.friction is not None), mu, p, g, *a.range,
            ptr(x[lo:hi]), ptr(v[lo:hi]), ptr(a.mass[lo:hi]), int(a.record), ptr(a.levels[lo:hi]),
            ptr(front[atoms] if a.record else front), ptr(work[lo:hi]),
            end_step[lo:hi].ctypes.data_as(ctypes.POINTER(ctypes.c_longlong)),
            status[lo:hi].ctypes.data_as(ctypes.POINTER(ctypes.c_int)), threads)
    return x, v, front if a.record else None, work, end_step, status

