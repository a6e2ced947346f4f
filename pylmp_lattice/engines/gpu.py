"""The GPU engine: the chain kernel (pylmp_lattice/plugin/kernel, the physics of fix lattice/chain)
compiled at run time by NVRTC through CuPy, one thread per chain (kernel/engine_gpu.cu).

The same batch as `engines.cpu` (`arrays.prepare`), the splines fitted on the host by the host
engine's library (the plugin's fits, fit.h), the same results (`arrays.ChainBatch`). CuPy is an
optional dependency: without it, or without a device, `run_chains` raises `Unsupported`.

Not yet run on a GPU (the session that wrote it had none): its test (tests/test_kernel_cpu.py,
marked gpu) compares it with the host engine within 1e-12 where CuPy finds a device. Memory is
chain-major (each thread reads its own slices: not coalesced) and every chain keeps its front
record (n x 37 doubles); a layout for 10^6 members is the next step.
"""

from __future__ import annotations

import ctypes
from pathlib import Path

import numpy as np

from ..case import Case
from .arrays import DRIVES, LAWS, NOUT, Arrays, ChainBatch, Unsupported, prepare, result

__all__ = ["ChainBatch", "Unsupported", "available", "run_arrays", "run_chains"]
KERNEL = Path(__file__).resolve().parent.parent / "plugin" / "kernel"
NCOL = 37  # kernel/front.h: a record row
THREADS = 128
BLOCK = 256  # the largest run of free atoms, as the fix's


def available() -> str | None:
    """None if a GPU can run the engine, else why not (one line)."""
    try:
        import cupy
    except ImportError:
        return "CuPy is not installed (pip install cupy-cuda12x or cupy-cuda13x)"
    try:
        count = cupy.cuda.runtime.getDeviceCount()
    except Exception as err:  # noqa: BLE001 - CUDA's errors have no common base class
        return f"CuPy finds no CUDA device: {err}"
    return None if count else "CuPy finds no CUDA device"


def run_chains(cases: list[Case], arrival_method: str = "level") -> ChainBatch:
    """`engines.cpu.run_chains` on the GPU."""
    why = available()
    if why:
        raise Unsupported(why)
    a = prepare(cases, "gpu")
    return result(cases, a, *run_arrays(a), arrival_method)


def run_arrays(a: Arrays):
    """`engines.cpu.run_arrays` on the GPU (one launch: Ctrl-C waits for it)."""
    import cupy as cp

    from .cpu import _library, _ptr

    lib = _library()
    n, chains = a.n, a.chains
    block = min(BLOCK, n - 2)
    nruns = (n - 2 + block - 1) // block
    empty = np.zeros(1)
    if a.table:  # the host's fit, as the plugin's
        r, u, f = (np.ascontiguousarray(t, float) for t in a.table[:3])
        yd2, x0_dx = np.zeros(4 * len(r)), np.zeros(2)
        lib.pl_fit_table.restype = None
        lib.pl_fit_table(_ptr(r), _ptr(u), _ptr(f), ctypes.c_int(len(r)), ctypes.c_double(a.table[3]),
                         ctypes.c_double(a.table[4]), _ptr(yd2), _ptr(x0_dx))
        table_n, (x0, dx) = len(r), x0_dx
    else:
        yd2, table_n, x0, dx = empty, 0, 0.0, 1.0
    if a.samples:
        t_s, y_s = (np.ascontiguousarray(s, float) for s in a.samples)
        fit = np.zeros(2 * len(t_s))
        lib.pl_fit_measured.restype = None
        lib.pl_fit_measured(_ptr(t_s), _ptr(y_s), ctypes.c_int(len(t_s)), _ptr(fit))
    else:
        t_s = y_s = fit = empty
    mu, p, g = a.friction or (0.0, 0.0, 0.0)
    d = cp.asarray
    x, v, mass = d(a.x), d(a.v), d(a.mass)
    per_atom = chains * n
    rec = cp.full(per_atom * NCOL if a.record else 1, np.nan)
    mark = cp.full(per_atom if a.record else 1, np.nan)
    gate = cp.zeros(per_atom if a.record else 1)
    phase = cp.zeros(per_atom if a.record else 1, cp.uint8)
    work = cp.zeros(chains)
    end_step = cp.zeros(chains, cp.int64)
    status = cp.zeros(chains, cp.int32)
    args = (np.int32(chains), np.int32(n), np.int64(a.steps), np.float64(a.dt), np.int32(block),
            np.int32(LAWS[a.law]), d(a.law_values), np.int32(table_n), np.float64(x0), np.float64(dx), d(yd2),
            np.int32(DRIVES[a.drive]), np.float64(a.V), np.float64(a.T), np.int32(len(t_s)), d(t_s), d(y_s), d(fit),
            np.int32(a.given_velocity), np.int32(a.hold), np.int32(a.friction is not None), np.float64(mu),
            np.float64(p), np.float64(g), np.float64(a.range[0]), np.float64(a.range[1]), x, v, mass,
            cp.zeros(per_atom), cp.zeros(per_atom), cp.zeros(per_atom), cp.arange(n, dtype=cp.int32),
            np.int32(a.record), d(a.levels), rec, mark, gate, phase, cp.zeros(chains * nruns * 5, cp.int32),
            cp.zeros(chains * (5 * block + 1)), work, end_step, status)
    _kernel()((-(-chains // THREADS),), (THREADS,), args)
    front = rec.reshape(per_atom, NCOL)[:, :NOUT].get() if a.record else None
    return x.get(), v.get(), front, work.get(), end_step.get(), status.get()


_KERNEL = None


def _kernel():
    """The compiled kernel (CuPy caches the compilation on disk)."""
    global _KERNEL
    if _KERNEL is None:
        import cupy as cp

        source = (KERNEL / "engine_gpu.cu").read_text()
        module = cp.RawModule(code=source, options=("-std=c++17", f"-I{KERNEL}"))
        _KERNEL = module.get_function("pl_run_chains_gpu")
    return _KERNEL
