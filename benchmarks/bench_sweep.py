"""Sweep throughput with 1 and 2 workers, and the sweep's overhead per member.

1. Throughput: the paper's long lattice (inputs/paper_long_lattice.toml) shortened to
   --duration ms (N follows from it), swept over --members impactor velocities from 1.0 to
   2.0 m/s, members of about a second or more each. The same sweep runs with --workers 1 and
   2 into fresh folders; wall time from the call to the finished table, pool start included.
2. Overhead per member: the paper's 21-magnet experiment (inputs/paper_experiment.toml),
   --small members over impactor velocity, once as a sweep with one worker and once as a plain
   loop of `simulation.run_case` in this process (the same runs, the sweep's engine runner).
   overhead = (sweep wall - loop wall) / members: process pool, status and provenance writes,
   and rewriting results.csv/.parquet after every member.

Sweeps of each kind run in one session, interleaved (1, 2, 1, 2, ...) so that load from other
users hits both alike; best of --repeat.

    python benchmarks/bench_sweep.py [--members 6] [--duration 200] [--small 20] [--repeat 2]
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from pathlib import Path

import numpy as np

from pylmp_lattice.case import case_from_dict, load_case
from pylmp_lattice.simulation import run_case
from pylmp_lattice.sweep import Sweep, run_sweep

INPUTS = Path(__file__).resolve().parent.parent / "inputs"


def timed_sweep(sweep: Sweep, workers: int) -> tuple[float, float]:
    """(wall time of the sweep, mean member wall time) into a fresh folder."""
    with tempfile.TemporaryDirectory() as tmp:
        start = time.perf_counter()
        table = run_sweep(sweep, tmp, workers=workers, progress=False)
        wall = time.perf_counter() - start
    assert set(table["status"]) == {"done"}, table["error"].dropna().tolist()
    return wall, float(table["wall_time_s"].mean())


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--members", type=int, default=6)
    p.add_argument("--duration", type=float, default=200.0, help="ms, long-lattice members")
    p.add_argument("--small", type=int, default=20, help="members of the 21-magnet overhead sweep")
    p.add_argument("--repeat", type=int, default=2)
    args = p.parse_args()

    base = load_case(INPUTS / "paper_long_lattice.toml", [f"run.duration={args.duration}"])
    velocities = [float(v) for v in np.linspace(1.0, 2.0, args.members)]
    long_sweep = Sweep(base=base, grid={"impactor.velocity": velocities})
    walls = {1: [], 2: []}
    member = {1: [], 2: []}
    for _ in range(args.repeat):
        for workers in (1, 2):
            wall, per = timed_sweep(long_sweep, workers)
            walls[workers].append(wall)
            member[workers].append(per)

    small = load_case(INPUTS / "paper_experiment.toml")
    small_v = [float(v) for v in np.linspace(1.5, 2.8, args.small)]
    small_sweep = Sweep(base=small, grid={"impactor.velocity": small_v})
    loop, swept = [], []
    for _ in range(args.repeat):
        with tempfile.TemporaryDirectory() as tmp:
            start = time.perf_counter()
            for i, member_case in enumerate(m.case for m in small_sweep.members()):
                run_case(member_case, Path(tmp) / str(i), runner=small_sweep.runner, figure=False)
            loop.append(time.perf_counter() - start)
        swept.append(timed_sweep(small_sweep, 1)[0])

    print(f"machine: {os.cpu_count()} cores, load average {os.getloadavg()[0]:.1f} at the end "
          "(shared with other users: ratios only)")
    print(f"\n1. throughput: {args.members} members, long lattice N = {base.chain.particles}, "
          f"{base.run.steps()} steps each (best of {args.repeat})")
    print("| workers | sweep wall (s) | members/s | mean member wall (s) | speed-up |")
    print("|---|---|---|---|---|")
    best = {w: min(walls[w]) for w in walls}
    for w in (1, 2):
        print(f"| {w} | {best[w]:.2f} | {args.members / best[w]:.3f} | {min(member[w]):.2f} | {best[1] / best[w]:.2f}x |")
    per_loop, per_sweep = min(loop) / args.small, min(swept) / args.small
    print(f"\n2. overhead per member: {args.small} members of the 21-magnet experiment "
          f"({small.run.steps()} steps, friction), 1 worker (best of {args.repeat})")
    print("| way | wall per member (s) |")
    print("|---|---|")
    print(f"| run_case loop in one process | {per_loop:.3f} |")
    print(f"| sweep, 1 worker | {per_sweep:.3f} |")
    print(f"| overhead per member | {per_sweep - per_loop:.3f} |")


if __name__ == "__main__":
    main()
