"""The GPU engine: the chain kernel (pylmp_lattice/plugin/kernel, the physics of fix lattice/chain)
compiled at run time by NVRTC through CuPy, one thread per chain, or a block per long chain
(kernel/engine_gpu.cu).

The same batch as `engines.cpu` (`arrays.prepare`), the splines fitted on the host by the host
engine's library (`library`: the plugin's fits, fit.h), the same results (`cpu.run_arrays`'s).
CuPy is an optional dependency: without it, or without a device, `available` says why.

Chains of up to 64 magnets (the ensembles') run in a module compiled for their length (and for
one mass, where the batch has one): its loops unroll, so that the chain's x, v, f live in
registers where they fit, its marks in a row of shared memory, the rest in each thread's local
memory, which CUDA interleaves by thread (coalesced); only the record's 7 output columns per
magnet go back to global memory. Longer chains run a block per chain, each thread a segment of
the chain in its local memory, its neighbours' edge atoms as ghosts (as the fix's MPI slabs).
benchmarks/gpu_resources.py prints each module's registers, local and shared memory (NVRTC, no
device needed); bench_gpu.py --variants times the choices below on a device.

Run on an NVIDIA H200 on 2026-11-27 and 2026-11-28 (benchmarks/gpu_check.sh; numbers in
docs/performance.md).
NVRTC compiles it with `compile_options` (tests/test_gpu_build.py, on any machine with the
nvidia-cuda-nvrtc wheel); its tests (tests/test_kernel_cpu.py, tests/test_sweep_engines.py,
marked gpu) and benchmarks/bench_gpu.py --check compare it with the host engine where CuPy finds a
device; tests/test_gpu_emulated.py runs everything here but the device on any machine (the kernels
built by g++ and run thread after thread behind a stand-in for CuPy): bit for bit the host engine's.
"""

from __future__ import annotations

import dataclasses
import hashlib
import threading
from functools import lru_cache
from pathlib import Path

import numpy as np

from .arrays import DRIVES, LAWS, Arrays
from .library import layout, library, ptr

__all__ = ["available", "run_arrays"]
KERNEL = Path(__file__).resolve().parent.parent / "plugin" / "kernel"
THREADS = 128
# The short chains' kernel keeps a row per thread in static shared memory, at most 48 KB a block:
# the first SHARED_ARRAYS of the chain's marks, x, v and f (n doubles each; the rest in registers),
# 4 where a block of 32 threads fits (`shared_arrays`), else the marks alone. The marks alone, with
# the due rows listed, ran fastest on an H200 (bench_gpu.py --variants 100000, 2026-11-27 17:10 UTC:
# 4.62e10 atom-steps/s against 3.53e10 with all four; 10^6 members alternating, 17:12 UTC: 1.89 and
# 1.91 s against 2.27 and 1.98 s), although ptxas spills some of x, v, f there to local memory
SHARED_LIMIT = 48 * 1024
SHARED_ARRAYS = 1
# ... in blocks of SHARED_THREADS threads where more than the marks are in the row (bench_gpu.py
# --variants: 32 or 64 threads, no clear winner in two runs, 16:11 and 17:10 UTC)
SHARED_THREADS = 32
# The front record's due rows (chain.h's Sampling): "per_atom", each sampled right after its
# atom's kick; "listed", listed and sampled together after the step: 1.07x (marks alone in shared
# memory) and 1.18x (all four) per_atom's speed (--variants, 17:10 UTC); "masked", marked in a bit
# mask and sampled after the step from where their v and f are, no list in local memory (ptxas:
# a smaller stack and fewer spills, benchmarks/gpu_resources.py; on an H200, 2026-11-28, within the
# 10 % spread of "listed" in six alternating runs at 10^6 members: docs/performance.md)
SAMPLING = "listed"
SAMPLINGS = {"per_atom": 0, "listed": 1, "masked": 2}  # engine_gpu.cu's PL_SAMPLING
# ... each due row read whole into registers before its sampling and written back after (chain.h's
# PL_ROW_COPY): one wait on local memory for its loads, where front::advance waits on one load
# after another behind its branches (static SASS of the paper's module, 2026-11-28: its 36 loads in
# one wave, against about eight; more register moves). Off until timed on a device (bench_gpu.py
# --variants); the bits are the same either way (tests/test_gpu_emulated.py)
ROW_COPY = False
# Chains of up to 64 magnets run in a module compiled for their length n (engine_gpu.cu: PL_LOCAL_N)
LOCAL_MAX = 64
# ... in runs of free atoms of at most SHORT_BLOCK: the paper's 21 magnets in one run of 19, every
# loop unrolled (runs of 10: 0.78x, --variants 16:11 UTC); the bits do not depend on it
SHORT_BLOCK = 32
# Chains over LOCAL_MAX run a block per chain (engine_gpu.cu's pl_run_long_chains_gpu), each of its
# threads on a segment of LONG_SEGMENT free atoms or fewer, more where LONG_THREADS would not cover
# the chain (its shared memory is compiled for that many): 10^3 chains of 1000 magnets ran at 7.6-7.8x
# the C loop on 16 cores on an H200 (2026-11-28; the one thread a chain it replaced: 0.2x)
LONG_SEGMENT = 8
LONG_THREADS = 256
# ... in segments of at most LONG_SEGMENT_MAX: a thread keeps about 88 bytes an atom of its segment
# in local memory (ptxas: 34.6 kB at 10^5 magnets, 688 kB, over CUDA's 512 kB, at 2 x 10^6), which
# the driver reserves for every thread the device can hold; longer chains are refused (`too_long`)
LONG_SEGMENT_MAX = 256
# Atom-steps per launch: about 0.2 s at the 4.2e10-5.3e10 atom-steps/s an H200 ran (docs/performance.md),
# so a signal's handler waits at most that long; 10^5 chains of 21 magnets in one launch (1e10) ran as
# fast per atom-step as 10^6 in two, so smaller launches cost no speed there
CHUNK_ATOM_STEPS = 1e10


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


def warm_up(batch: Arrays | None = None) -> None:
    """This process's CUDA context made now, and with a `batch` (`warm_batch`: one chain, one
    step) its module loaded and launched once; a sweep's worker, beside its first task's Python.
    On an H200 most workers' first launches waited 0.8-2.4 s, the later ones 0.03 s
    (benchmarks/trace_sweep.py, docs/performance.md); with the context made and the module loaded
    ahead, still 1.2-2.3 s. A launch also sizes the context's local memory for the kernel (its
    stack for every thread the device can hold: 2.5 GB for the paper's chain with the record,
    benchmarks/gpu_resources.py), which the launch here does ahead too (not yet timed on a
    device). Errors are left to the batch's own launch."""
    try:
        import cupy

        cupy.zeros(1)
        if batch is not None:
            Launched(batch).result()  # (not through `launch`: no batch of a task's)
    except Exception:  # noqa: BLE001 - only a head start: run_arrays says what is wrong
        pass


def warm_batch(case) -> Arrays | None:
    """One chain of `case` for one step, in the module a batch of members like it runs (`warm_up`);
    None if the engine cannot run it."""
    from .arrays import prepare

    try:
        a = prepare([case], "gpu")
        return None if too_long(a.n) else dataclasses.replace(a, steps=1)
    except Exception:  # noqa: BLE001 - a case the engine cannot run: the batch says why, later
        return None


class Launched:
    """A batch whose first launch is on the device (`launch`)."""

    def __init__(self, a: Arrays):
        self._steps, self._done = _run(a), None
        try:
            next(self._steps)
        except StopIteration as done:  # no launch (no chain)
            self._done = done.value

    def result(self):
        """`run_arrays`'s results, once the rest of the launches have run (a call after one that
        raised is refused: the batch did not run)."""
        if self._done is None:
            steps, self._steps = self._steps, None
            if steps is None:
                raise RuntimeError("this batch's results were collected, or its run failed, already")
            try:
                next(steps)
            except StopIteration as done:
                self._done = done.value
            else:
                raise AssertionError("run_arrays's steps go on after their last launch")
        return self._done


def launch(a: Arrays) -> Launched:
    """`run_arrays` with its first launch started now: the device runs it (or queues it behind
    the other workers' launches) while the caller goes on, e.g. writes the batch's folder."""
    return Launched(a)


def run_arrays(a: Arrays):
    """`engines.cpu.run_arrays` on the GPU (in launches of CHUNK_ATOM_STEPS: Ctrl-C waits for one)."""
    return launch(a).result()


def _run(a: Arrays):
    """run_arrays's work, a generator that pauses once, after its first launch (`launch`)."""
    import cupy as cp

    lib, lay = library(), layout()
    NOUT, NCOL = lay.nout, lay.ncol  # noqa: N806 - the kernel's names
    n, chains = a.n, a.chains
    block = min(lay.block, n - 2)
    empty = np.zeros(1)
    if a.table:  # the host's fit, as the plugin's
        r, u, f = (np.ascontiguousarray(t, float) for t in a.table[:3])
        yd2, x0_dx = np.zeros(4 * len(r)), np.zeros(2)
        lib.pl_fit_table(ptr(r), ptr(u), ptr(f), len(r), a.table[3], a.table[4], ptr(yd2), ptr(x0_dx))
        table_n, (x0, dx) = len(r), x0_dx
    else:
        yd2, table_n, x0, dx = empty, 0, 0.0, 1.0
    if a.samples:
        t_s, y_s = (np.ascontiguousarray(s, float) for s in a.samples)
        fit = np.zeros(2 * len(t_s))
        lib.pl_fit_measured(ptr(t_s), ptr(y_s), len(t_s), ptr(fit))
    else:
        t_s = y_s = fit = empty
    mu, p, g = a.friction or (0.0, 0.0, 0.0)
    path = drive_path(a)
    d = cp.asarray
    x, v, mass, levels = d(a.x), d(a.v), d(a.mass), d(a.levels)
    work, end_step, status = cp.zeros(chains), cp.zeros(chains, cp.int64), cp.zeros(chains, cp.int32)
    setup = (np.int32(n), np.int64(a.steps), np.float64(a.dt), np.int32(block),
             np.int32(LAWS[a.law]), d(a.law_values), np.int32(table_n), np.float64(x0), np.float64(dx), d(yd2),
             np.int32(DRIVES[a.drive]), np.float64(a.V), np.float64(a.T), np.int32(len(t_s)), d(t_s), d(y_s), d(fit),
             np.int32(a.given_velocity), np.int32(a.hold), np.int32(a.friction is not None), np.float64(mu),
             np.float64(p), np.float64(g), np.float64(a.range[0]), np.float64(a.range[1]), np.int32(a.record),
             d(path if len(path) else empty), np.int64(len(path) // 2))
    local = local_size(n)
    options = compile_options(n, batch_case(a), one_mass=one_mass(a))
    if local:
        front = cp.empty(chains * n * NOUT if a.record else 1)
        threads = block_threads(local)
    else:  # the record's rows in global memory (NCOL columns each), their output columns copied out
        rec = cp.full(chains * n * NCOL if a.record else 1, np.nan)
        phase = cp.zeros(chains * n if a.record else 1, cp.uint8)  # front.h's WAITING
        index = cp.arange(n, dtype=cp.int32)
        threads = long_threads(n)
    # launches of about CHUNK_ATOM_STEPS: a signal's handler runs between two
    per_launch = int(CHUNK_ATOM_STEPS // max(1, n * a.steps))
    chunk = max(threads, per_launch // threads * threads) if local else max(1, per_launch)
    for k, lo in enumerate(range(0, chains, chunk)):
        hi = min(chains, lo + chunk)
        rows = slice(lo, hi)
        if local:
            args = (np.int32(hi - lo), *setup, x[rows], v[rows], mass[rows], levels[rows],
                    front[lo * n * NOUT:hi * n * NOUT] if a.record else front, work[rows], end_step[rows], status[rows])
            _kernel("pl_run_short_chains_gpu", options)((-(-(hi - lo) // threads),), (threads,), args)
        else:
            args = (np.int32(hi - lo), *setup, x[rows], v[rows], mass[rows], index, levels[rows],
                    *((rec[lo * n * NCOL:hi * n * NCOL], phase[lo * n:hi * n]) if a.record else (rec, phase)),
                    work[rows], end_step[rows], status[rows])
            _kernel("pl_run_long_chains_gpu", options)((hi - lo,), (threads,), args)
        if k == 0:
            yield
        # waited for asleep (cudaEventBlockingSync), not spinning: a stream's synchronize spins a core
        # while the other workers' launches run before this one, and the workers share the cores
        done = cp.cuda.Event(block=True, disable_timing=True)
        done.record()
        done.synchronize()
    if int(end_step.min()) < 0:  # a module built for another law, friction or record (run_compiled)
        raise RuntimeError(f"the GPU kernel compiled with {options} did not run this batch's chains")
    if not a.record:
        out = None
    elif local:
        out = front.reshape(chains * n, NOUT).get()
    else:
        out = rec.reshape(chains * n, NCOL)[:, :NOUT].get()
    return x.get(), v.get(), out, work.get(), end_step.get(), status.get()


def drive_path(a: Arrays) -> np.ndarray:
    """The sine drive's u, ud at steps 0, 1, ... while t < T (pairs), from the host build (Drive::path):
    the GPU's own sin and cos differ from glibc's in the last bit, which parts its chains from the
    host's and LAMMPS's. Empty for the other drives, whose operations round alike on both."""
    if a.drive != "sine":
        return np.zeros(0)
    steps = min(a.steps, int(np.ceil(a.T / a.dt)) + 1) + 1  # beyond, t > T: the drive's constant branch
    out = np.empty(2 * steps)
    library().pl_drive_path(DRIVES[a.drive], a.V, a.T, a.dt, steps, ptr(out))
    return out


def batch_case(a: Arrays) -> tuple[int, float, bool, bool]:
    """The batch's case of the kernel's dispatch: law kind (LAWS), a power law's q (else 0),
    friction, record."""
    return LAWS[a.law], float(a.law_values[2]) if a.law == "power" else 0.0, a.friction is not None, bool(a.record)


def one_mass(a: Arrays) -> bool:
    """Every magnet of the batch has one mass (no mass disorder): the short chains' module then
    keeps one of each mass term, not n (engine_gpu.cu's PL_ONE_MASS)."""
    return bool(a.mass.size) and bool(np.all(a.mass == a.mass.flat[0]))


def compile_options(n: int, case: tuple[int, float, bool, bool], block: int | None = None,
                    one_mass: bool = False) -> tuple[str, ...]:
    """NVRTC's options for engine_gpu.cu for chains of n magnets: up to LOCAL_MAX the short
    chains' kernel for that length in runs of at most `block` (default `short_block`), longer the
    long chains' kernel in segments of at most `block` (default `long_segment(n)`); only the
    batch's `case` (`batch_case`) of the law, friction and record (one copy of the run, not 44:
    seconds to compile, not minutes); with `one_mass`, for a batch whose magnets
    all have one mass (`one_mass`: the mass terms in registers, 1 of each, not n).
    -fmad=false: no multiply-add contracted into one FMA, as the host build and LAMMPS's plugin
    are compiled (-ffp-contract=off). On an H200 (bench_gpu.py --check, 2026-11-27) the GPU's
    entries still differ from the host build's by up to 2.6e-11 relative, with or without it;
    the sine drive's sin and cos were the cause: taken from the host (`drive_path`), the GPU
    gives the host build's bits (0.00e+00 on the H200, 2026-11-27 15:50 UTC and after:
    docs/performance.md).
    -default-device: the kernel's lambdas (the law's dispatch) carry no execution space, which
    NVRTC's JIT mode takes for host code and refuses; nvcc infers it from the enclosing function.
    -DPL_ROW_COPY: ROW_COPY, for the short chains' kernel alone (with it the long chains' kernel
    for 100 magnets took 250 registers, not 164, and held 104 threads an SM, not 156: ptxas
    through NVRTC, 2026-11-28).
    -DPL_KERNEL_SOURCES: CuPy's disk cache keys a compiled module by its source and options, not
    the headers it includes, so their digest goes in the options (an edited header, a new version
    of the package, compiles anew instead of loading the old kernel)."""
    law, q, friction, record = case
    local = local_size(n)
    if block is None:
        block = short_block(local) if local else long_segment(n)
    return ("-std=c++17", f"-I{KERNEL}", f"-DPL_LOCAL_N={local}", f"-DPL_BLOCK={block}", f"-DPL_LAW_KIND={law}",
            f"-DPL_LAW_Q={q!r}", f"-DPL_FRICTION={int(friction)}", f"-DPL_RECORD={int(record)}",
            f"-DPL_ONE_MASS={int(bool(local) and one_mass)}",
            f"-DPL_THREADS={block_threads(local) if local else LONG_THREADS}",
            f"-DPL_SHARED_ARRAYS={shared_arrays(local)}", f"-DPL_SAMPLING={SAMPLINGS[SAMPLING]}",
            f"-DPL_ROW_COPY={int(ROW_COPY and bool(local))}", "-fmad=false",
            "-default-device", f"-DPL_KERNEL_SOURCES={_sources_digest(KERNEL)}")


@lru_cache
def _sources_digest(folder: Path) -> str:
    """A digest of the kernel's sources in `folder` (names and contents)."""
    h = hashlib.sha256()
    for path in sorted(folder.glob("*.[hc]*")):
        h.update(path.name.encode() + b"\0" + path.read_bytes() + b"\0")
    return h.hexdigest()[:16]


def long_segment(n: int) -> int:
    """The long chains' largest segment of free atoms a thread (PL_BLOCK): LONG_SEGMENT, more where
    LONG_THREADS threads of LONG_SEGMENT would not cover the n - 2 free atoms, in multiples of
    LONG_SEGMENT (so that lengths share a module: the bits do not depend on it)."""
    need = -(-(n - 2) // LONG_THREADS)
    return max(LONG_SEGMENT, -(-need // LONG_SEGMENT) * LONG_SEGMENT)


def too_long(n: int) -> str | None:
    """Why chains of n magnets are too long for the GPU engine (one line), else None."""
    most = 2 + LONG_THREADS * LONG_SEGMENT_MAX
    if n <= most:
        return None
    return (f"chains of {n} magnets: the GPU engine runs at most {most} (a block of {LONG_THREADS} threads a chain, "
            f"each on at most {LONG_SEGMENT_MAX} magnets in its local memory); --engine cpu runs any length")


def long_threads(n: int) -> int:
    """The long chains' threads a chain (its block): as many as segments of `long_segment(n)`."""
    return -(-(n - 2) // long_segment(n))


def shared_row(local: int) -> int:
    """The doubles of a thread's row of shared memory in the short chains' kernel (engine_gpu.cu:
    odd, so that a half-warp's threads hit distinct banks): n for each of its `shared_arrays`."""
    return (shared_arrays(local) * local) | 1


def shared_arrays(local: int) -> int:
    """How many of the short chains' marks, x, v, f (in that order) sit in shared memory:
    SHARED_ARRAYS where a block of 32 threads fits, else 1 (the marks); 0 for the long chains' kernel."""
    if not local:
        return 0
    return SHARED_ARRAYS if 32 * ((SHARED_ARRAYS * local) | 1) * 8 <= SHARED_LIMIT else 1


def block_threads(local: int) -> int:
    """The short chains' threads per block: SHARED_THREADS with more than the marks in shared
    memory, else THREADS, halved until their rows of shared memory (`shared_row`) fit in SHARED_LIMIT."""
    threads = SHARED_THREADS if shared_arrays(local) > 1 else THREADS
    while threads > 32 and threads * shared_row(local) * 8 > SHARED_LIMIT:
        threads //= 2
    return threads


def local_size(n: int) -> int:
    """PL_LOCAL_N for chains of n magnets: n itself (a module per length, compiled in about a
    second and cached by CuPy), 0 for the long chains' kernel."""
    return n if 3 <= n <= LOCAL_MAX else 0


def short_block(local: int) -> int:
    """PL_BLOCK, the short chains' largest run of free atoms."""
    return min(SHORT_BLOCK, local - 2)


_MODULES: dict = {}
_MODULES_LOCK = threading.Lock()  # a worker's warm-up thread may be loading the module its task needs


def _kernel(name: str, options: tuple[str, ...]):
    """A kernel of engine_gpu.cu compiled with `options` (CuPy caches the compilation on disk)."""
    with _MODULES_LOCK:
        if options not in _MODULES:
            import cupy as cp

            source = (KERNEL / "engine_gpu.cu").read_text()
            _MODULES[options] = cp.RawModule(code=source, options=options)
        return _MODULES[options].get_function(name)
