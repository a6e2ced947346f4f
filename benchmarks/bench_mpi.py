"""MPI benchmark: one long chain on 1 and 2 ranks, the per-step cost of a rank more, and a
projection to 4-64 ranks.

The chain is bench_engine.py's (the paper's magnets, constant 2 m/s impactor, dt = 0.01 ms), as
the package writes its deck (chain engine, per-step front record on; RunFolder.create), run by
runner.run_executable(nprocs); the time is LAMMPS's Loop time minus its Output section
(bench_engine.run_lammps), best of --repeat runs, ranks interleaved. The load average (1 min)
is read before every run and printed beside the best.

1. Speed-up: N = --n (10^6) magnets, --steps (2000) steps, 1 against 2 ranks. Beside the wall
   times: the CPU time a step of the slowest rank's passes and its wall time in the exchanges
   (the fix reports both at the end of a run on several ranks). On a loaded machine a rank waits
   for a core at every exchange, so the wall speed-up falls far below what the work division
   gives; the CPU speed-up (1-rank CPU time over the slowest rank's) shows that division.
2. The cost of a rank more, per step: a chain of --slab magnets per rank (10^4) on 1 rank
   against 2 slabs of it on 2 ranks, --comm-steps steps. Each rank does the same work in both,
   so the difference is what having a neighbour costs at every step: the slab-edge exchange
   (two MPI_Sendrecv of a few doubles), the contact flag's MPI_Allreduce, and LAMMPS's own
   forward communication of its (few) ghosts, plus waiting for the slower rank.
3. Projection: a step on P ranks takes N t_atom / P + t_comm(P), with t_atom the 1-rank CPU
   time per magnet and step from 1., and t_comm(P) = t_comm(2) log2(P) from 2. (each doubling
   of the ranks adds one stage to the allreduce; counting the whole measured cost as growing
   so makes the projection lean pessimistic), t_comm(2) taken twice: the fix's exchanges at
   their fastest step (both ranks on a core, as on a machine of one's own) and the loop
   difference on average under the load of the run. It assumes that each rank has its own core and its
   memory bandwidth (on one node, ranks share the memory bus: a slab of N/P magnets, 32 bytes
   each with the front record, leaves the last-level cache at large N/P). Scaling stops where
   the exchange costs as much as the work: efficiency 50%.
4. A batch of chains (an ensemble's members in one instance): --batch chains of the paper's 21
   magnets, --batch-steps steps, front record on, as a sweep writes them
   (deck.render_replicas(front=True)), on 1 rank and on 2 ranks split two ways: by whole chains
   (the deck's `processors 1 * 1`: no exchanges) and by slabs of every chain (`processors * 1 1`,
   as for one long chain: every chain crosses the slab edge).

    python benchmarks/bench_mpi.py                    # about 3 minutes on an idle 2-core machine
    python benchmarks/bench_mpi.py --n 100000 --repeat 2
"""

from __future__ import annotations

import argparse
import math
import os
import re
import tempfile
from dataclasses import dataclass
from datetime import datetime, timezone
from pathlib import Path

import numpy as np

from bench_engine import paper_case, run_lammps
from pylmp_lattice.deck import render_replicas
from pylmp_lattice.run_folder import RunFolder


@dataclass
class Timing:
    """One run: engine wall seconds (Loop - Output), the load average (1 min) before it, the CPU
    time a step of the slowest rank's passes and its wall time a step in the exchanges (slab
    edges and contact flag), us; on one rank the CPU time is LAMMPS's (Loop - Output) x CPU use."""

    wall: float = math.inf
    load: float = math.nan
    pass_cpu: float = math.nan
    exchange: float = 0.0
    fastest: float = 0.0  # us, the exchanges of the fastest step


FIX_LINE = re.compile(r"owned steps: pass (\S+) us CPU a step, exchanges (\S+) us wall a step, (\S+) us at the fastest")


def timed(folder: Path, ranks: int, steps: int) -> Timing:
    load = os.getloadavg()[0]
    took = run_lammps(folder, nprocs=ranks)
    line = FIX_LINE.search((folder / "log.lammps").read_text())
    if ranks == 1:
        return Timing(took.wall, load, 1e6 * took.cpu / steps)
    return Timing(took.wall, load, *map(float, line.groups()))


def best_of(folders: dict[int, Path], repeat: int, steps: int) -> dict[int, Timing]:
    """Each rank count's best run by wall time, and its best CPU and exchange times a step,
    the counts interleaved over the repeats."""
    best = {ranks: Timing() for ranks in folders}
    for _ in range(repeat):
        for ranks, folder in folders.items():
            took, b = timed(folder, ranks, steps), best[ranks]
            if took.wall < b.wall:
                b.wall, b.load = took.wall, took.load
            b.pass_cpu = took.pass_cpu if math.isnan(b.pass_cpu) else min(b.pass_cpu, took.pass_cpu)
            b.exchange = took.exchange if b.exchange == 0.0 else min(b.exchange, took.exchange)
            b.fastest = took.fastest if b.fastest == 0.0 else min(b.fastest, took.fastest)
    return best


def owned_on_all_ranks(folder: Path, ranks: int) -> bool:
    return f"owns the state (one pass per step, front record inside) on {ranks} rank" in \
        (folder / "log.lammps").read_text()


def batch_split(args) -> None:
    """Part 4: a batch of short chains on 1 rank and on 2, by whole chains and by slabs."""
    cases = [paper_case(21, args.batch_steps)] * args.batch
    splits = {"1 rank": (1, None), "2 ranks, whole chains": (2, None),
              "2 ranks, slabs of every chain": (2, ("processors      1 * 1", "processors      * 1 1"))}
    with tempfile.TemporaryDirectory(prefix="bench_mpi_batch_") as tmp:
        folders = {}
        for name, (ranks, swap) in splits.items():
            folder = Path(tmp) / str(len(folders))
            folder.mkdir()
            for file, text in render_replicas(cases, front=True).items():
                (folder / file).write_text(text.replace(*swap) if swap and file == "in.lattice" else text)
            folders[name] = (ranks, folder)
        best = {name: math.inf for name in splits}
        for _ in range(args.repeat):
            for name, (ranks, folder) in folders.items():
                best[name] = min(best[name], run_lammps(folder, nprocs=ranks).wall)
        print(f"\n4. A batch of {args.batch} chains of 21 magnets, {args.batch_steps} steps, front record on")
        print(f"{'split':>30} {'loop [s]':>9} {'speed-up':>9}  path")
        for name, (ranks, folder) in folders.items():
            log = (folder / "log.lammps").read_text()
            path = re.search(r"Fix lattice/chain: (.*)", log).group(1)
            print(f"{name:>30} {best[name]:>9.4g} {best['1 rank'] / best[name]:>9.2f}  {path}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=1_000_000, help="magnets of the long chain (10^6)")
    parser.add_argument("--steps", type=int, default=2000, help="its steps (2000)")
    parser.add_argument("--slab", type=int, default=10_000, help="magnets per rank for the cost of a rank (10^4)")
    parser.add_argument("--comm-steps", type=int, default=20_000, help="steps for the cost of a rank (20000)")
    parser.add_argument("--repeat", type=int, default=5, help="runs of each, best kept (5)")
    parser.add_argument("--batch", type=int, default=500, help="chains of 21 magnets in the batch (500)")
    parser.add_argument("--batch-steps", type=int, default=4800, help="the batch's steps (4800: 60 ms at 12.5 us)")
    args = parser.parse_args()

    stamp = datetime.now(timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    print(f"MPI benchmark, {stamp}, {os.cpu_count()} cores, load average {os.getloadavg()[0]:.2f} at start; "
          f"best of {args.repeat}, interleaved; time = LAMMPS Loop - Output")
    with tempfile.TemporaryDirectory(prefix="bench_mpi_") as tmp:
        tmp = Path(tmp)
        # 1. speed-up at N
        case = paper_case(args.n, args.steps)
        folders = {ranks: RunFolder.create(case, tmp / f"long_{ranks}").path for ranks in (1, 2)}
        long = best_of(folders, args.repeat, args.steps)
        v = {ranks: RunFolder(folder).trajectory().v[-1] for ranks, folder in folders.items()}
        print(f"\n1. N = {args.n} magnets, {args.steps} steps, front record on")
        print(f"{'ranks':>6} {'loop [s]':>9} {'atom-st/s':>10} {'speed-up':>9} {'load 1 min':>11} "
              f"{'CPU/step [us]':>14} {'CPU speed-up':>13} {'exch/step [us]':>15}  path")
        for ranks, t in long.items():
            path = "owned, slab edges exchanged" if owned_on_all_ranks(folders[ranks], ranks) else "atom arrays"
            print(f"{ranks:>6} {t.wall:>9.4g} {args.n * args.steps / t.wall:>10.3g} {long[1].wall / t.wall:>9.2f} "
                  f"{t.load:>11.2f} {t.pass_cpu:>14.1f} {long[1].pass_cpu / t.pass_cpu:>13.2f} {t.exchange:>15.1f}  {path}")
        print("CPU/step: the slowest rank's CPU time in its passes (1 rank: the whole loop's); CPU speed-up: how\n"
              "the work divides when each rank has a core; exch/step: wall time in the exchanges (best run)")
        same = np.array_equal(v[1], v[2])
        print(f"final velocities on 1 and 2 ranks: {'bit-identical' if same else 'DIFFER'}")

        # 2. the per-step cost of a neighbour
        cases = {1: paper_case(args.slab, args.comm_steps), 2: paper_case(2 * args.slab, args.comm_steps)}
        folders = {ranks: RunFolder.create(c, tmp / f"slab_{ranks}").path for ranks, c in cases.items()}
        slab = best_of(folders, args.repeat, args.comm_steps)
        t_comm = max(0.0, (slab[2].wall - slab[1].wall) / args.comm_steps)
        print(f"\n2. {args.slab} magnets a rank, {args.comm_steps} steps: 1 rank (N = {args.slab}) against "
              f"2 ranks (N = {2 * args.slab})")
        print(f"{'ranks':>6} {'loop [s]':>9} {'per step [us]':>14} {'load 1 min':>11} {'exch/step [us]':>15} "
              f"{'fastest step':>13}")
        for ranks, t in slab.items():
            print(f"{ranks:>6} {t.wall:>9.4g} {1e6 * t.wall / args.comm_steps:>14.2f} {t.load:>11.2f} {t.exchange:>15.2f} "
                  f"{t.fastest:>13.2f}")
        t_fast = 1e-6 * slab[2].fastest
        print(f"cost of a neighbour rank: t_comm(2) = {1e6 * t_comm:.2f} us a step on average under this load (loop "
              f"difference);\nthe fix's exchanges took {slab[2].exchange:.2f} us a step on average and "
              f"{1e6 * t_fast:.2f} us at the fastest step (both ranks on a core: the machine's own cost)")

    # 3. projection, with the exchange cost of a step when both ranks have a core, and under this load
    t_atom = 1e-6 * long[1].pass_cpu / args.n  # CPU time per magnet and step on one rank
    work = args.n * t_atom
    costs = {"at the fastest step": t_fast, "under this load": t_comm}
    print(f"\n3. Projection for N = {args.n}: step = N t_atom / P + t_comm log2(P), t_atom = {1e9 * t_atom:.2f} ns "
          f"(1-rank CPU), t_comm = {1e6 * t_fast:.2f} us (fastest step) or {1e6 * t_comm:.1f} us (this load)")
    print(f"{'ranks':>6}" + "".join(f" {'step [us]':>10} {'speed-up':>9} {'effic.':>7}" for _ in costs) +
          "   <- t_comm: " + ", ".join(costs))
    stops = dict.fromkeys(costs)
    for ranks in (1, 2, 4, 8, 16, 32, 64, 128, 256, 512, 1024, 2048, 4096):
        cells = ""
        for name, cost in costs.items():
            step = work / ranks + cost * math.log2(ranks)
            speedup = work / step
            if stops[name] is None and speedup / ranks < 0.5:
                stops[name] = ranks
            cells += f" {1e6 * step:>10.1f} {speedup:>9.1f} {speedup / ranks:>7.0%}"
        if ranks <= 64 or ranks in stops.values():
            print(f"{ranks:>6}{cells}")
    for name, at in stops.items():
        where = f"at {at} ranks, {args.n // at} magnets a rank" if at else "not up to 4096 ranks"
        print(f"t_comm {name}: stops scaling (efficiency < 50%) {where}")
    t_slab = 1e-6 * slab[1].pass_cpu / args.slab  # per magnet and step at the slab's size (in cache)
    print(f"magnets a rank at which the exchange costs a tenth of the work: {10 * t_fast / t_slab:.0f} "
          f"(t_comm at the fastest step, {1e9 * t_slab:.2f} ns a magnet-step at {args.slab} magnets; "
          "pylmp_lattice.ranks.MIN_MAGNETS_PER_RANK)")
    batch_split(args)
    print(f"\nload average {os.getloadavg()[0]:.2f} at the end ({os.cpu_count()} cores, shared machine)")


if __name__ == "__main__":
    main()
