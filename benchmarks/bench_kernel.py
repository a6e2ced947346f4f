"""The host engine (engines.cpu: the chain kernel, OpenMP over chains) against the plain C loop
(benchmarks/ensemble_loop.c) on the same chains and the same number of cores, in one run.

Members: --members thermal replicas of inputs/paper_experiment.toml (21 magnets, or --particles, 4800 steps), with
and without friction, as bench_sweep.py builds them. Engine: the sweep's batch road
(`run_folder.execute_batch` with `engines.road.KernelEngine("cpu")` on --workers threads), timed
from the engine's arrays to the measures read from its front record, with the record (as a
sweep's members) and without (output.front = false: the loop's work alone); kernel: the library's
call alone (engines.cpu.run_arrays on the batch's arrays, with the record), wall and CPU time (the
CPU ratio to the loop's CPU time holds on a loaded machine with --workers 1; with more, it counts
OpenMP's threads spinning at each call's end). Loop: ensemble_loop.c on
--workers processes (bench_sweep.run_loop). Check: every chain's final velocities, engine against
loop, within 1e-9 m/s (the same equations and operations).

    python benchmarks/bench_kernel.py [--members 1000,10000] [--workers 2] [--thermal 0.02] [--particles 21]
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import subprocess
import sys
import tempfile
import time
from datetime import datetime, timezone
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_sweep import LOOP, ROOT, loop_states, package, run_loop, write_sweep  # noqa: E402


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--members", default="1000,10000")
    p.add_argument("--workers", type=int, default=2)
    p.add_argument("--thermal", type=float, default=0.02, help="m/s RMS")
    p.add_argument("--particles", type=int, default=21, help="magnets a chain (the experiment's 21)")
    args = p.parse_args()
    from pylmp_lattice.case_measures import read_front_batch
    from pylmp_lattice.engines.cpu import run_arrays
    from pylmp_lattice.engines.road import KernelEngine
    from pylmp_lattice.formats.layout import FRONT_BIN
    from pylmp_lattice.run_folder import execute_batch

    rows = []
    with tempfile.TemporaryDirectory(prefix=".bench_kernel.", dir=ROOT) as tmp:
        tmp = Path(tmp)
        exe = tmp / "ensemble_loop"
        subprocess.run(["gcc", "-O3", "-o", str(exe), str(LOOP), "-lm"], check=True)
        for friction in (True, False):
            for members in (int(n) for n in args.members.split(",")):
                folder = tmp / f"{friction}-{members}"
                folder.mkdir()
                cases, x, v, m = loop_states(write_sweep(folder, members, args.thermal, friction, args.particles))
                load = os.getloadavg()[0]
                engine = {}
                for record in (True, False):
                    members_ = [dataclasses.replace(c, output=dataclasses.replace(c.output, format="none", front=record))
                                for c in cases]
                    start = time.perf_counter()
                    batch = KernelEngine("cpu", members_, threads=args.workers)
                    execute_batch(members_, folder / f"record-{record}", batch)
                    if record:
                        read_front_batch(members_, folder / f"record-{record}" / FRONT_BIN)
                    engine[record] = time.perf_counter() - start
                    if record:
                        start, cpu = time.perf_counter(), time.process_time()
                        run_arrays(batch.arrays, args.workers)
                        engine["kernel"] = time.perf_counter() - start
                        engine["kernel_cpu"] = time.process_time() - cpu
                loop_wall, loop_cpu, final = run_loop(exe, folder, cases, x, v, m, args.workers)
                engine["kernel_cpu"] /= loop_cpu
                error = float(np.max(np.abs(batch.final[1] - final)))
                assert error < 1e-9, f"engine and loop differ by {error} m/s"
                rows.append((friction, members, engine, loop_wall, error, load))
    print(f"{datetime.now(timezone.utc):%Y-%m-%d %H:%M} UTC; {os.cpu_count()} cores; {args.workers} threads / loop "
          f"processes; {args.particles} magnets, 4800 steps, thermal {args.thermal} m/s; pylmp_lattice from "
          f"{package(child=False)}")
    print("| friction | members | engine (s) | per member (ms) | C loop (s) | engine / loop | atom-steps/s | "
          "engine without the record (s) | its / loop | kernel alone (s) | its / loop | its CPU / loop's | "
          "max |v engine - v loop| (m/s) | load before |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for friction, members, engine, loop_wall, error, load in rows:
        e = engine[True]
        print(f"| {'yes' if friction else 'no'} | {members} | {e:.3f} | {1e3 * e / members:.4f} | "
              f"{loop_wall:.3f} | {e / loop_wall:.2f}x | {members * args.particles * 4800 / e:.3g} | {engine[False]:.3f} | "
              f"{engine[False] / loop_wall:.2f}x | {engine['kernel']:.3f} | {engine['kernel'] / loop_wall:.2f}x | "
              f"{engine['kernel_cpu']:.2f}x | {error:.1e} | {load:.1f} |")
    if len(rows) == 4:
        print()
        for friction in (True, False):
            (_, n1, e1, l1, *_), (_, n2, e2, l2, *_) = [r for r in rows if r[0] == friction]
            print(f"friction {'yes' if friction else 'no'}: marginal engine / loop from {n1} to {n2} members: "
                  f"{(e2[True] - e1[True]) / (l2 - l1):.2f}x with the record, {(e2[False] - e1[False]) / (l2 - l1):.2f}x without")


if __name__ == "__main__":
    main()
