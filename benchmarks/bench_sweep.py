"""Sweep throughput with 1 and 2 workers, and the sweep's overhead per member.

1. Throughput: the paper's long-lattice case (inputs/paper_long_lattice.toml) with a fixed far
   end, --particles magnets and --duration ms, swept over --members impactor velocities from
   1.0 to 2.0 m/s: members of equal cost (same N, steps and frames), about a second or more
   each. The same sweep runs with --workers 1 and 2 into fresh folders; wall time from the call
   to the finished table.
2. Overhead per member: the paper's 21-magnet experiment (inputs/paper_experiment.toml),
   --small members over impactor velocity, as a sweep with one worker. Each member's
   `run.run_case` times itself (summary.json wall_time_s); overhead = sweep wall time /
   members - mean run_case time: process pool, task transfer, status and provenance writes,
   and rewriting results.csv/.parquet after every member, measured within the same sweep.

0. Control: a CPU-bound pure-Python loop in 1 and 2 processes, "cores used" = CPU time / wall
   time. On an idle 2-core machine it is 1.0 and 2.0; on a shared one it shows the share the
   kernel gives this session (Linux autogroup scheduling shares CPU between sessions, not
   processes, so a busy machine gives a session about the same share with 1 or 2 workers).
   The sweep's speed-up cannot exceed the control's ratio.

Everything runs in one session after a warm-up (the pool's fork server started, the engine and
scipy loaded once), the ways being compared interleaved (1, 2, 1, 2, ...) so that load from
other users hits them alike; best of --repeat.

    python benchmarks/bench_sweep.py [--members 6] [--particles 300] [--duration 600] [--small 20] [--repeat 2]
"""

from __future__ import annotations

import argparse
import json
import os
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

from pylmp_lattice.case import load_case
from pylmp_lattice.run_folder import run_case
from pylmp_lattice.run_folder.layout import SUMMARY
from pylmp_lattice.sweep import Sweep, run_sweep
from pylmp_lattice.sweep.store import STATUS

INPUTS = Path(__file__).resolve().parent.parent / "inputs"


def _burn(n: int) -> float:
    start = time.process_time()
    x = 0
    for i in range(n):
        x += i * i
    return time.process_time() - start


def control(processes: int, loops: int = 3_000_000) -> float:
    """Cores used by `processes` CPU-bound Python processes, 2 tasks each."""
    start = time.perf_counter()
    with ProcessPoolExecutor(processes) as pool:
        cpu = sum(pool.map(_burn, [loops] * (2 * processes)))
    return cpu / (time.perf_counter() - start)


def timed_sweep(sweep: Sweep, workers: int) -> tuple[float, float, float, float]:
    """Into a fresh folder: (sweep wall time, total member wall time, total member CPU time,
    total run_case time), seconds."""
    with tempfile.TemporaryDirectory() as tmp:
        start = time.perf_counter()
        table = run_sweep(sweep, tmp, workers=workers, progress=False)
        wall = time.perf_counter() - start
        folders = [Path(tmp) / f for f in table["folder"]]
        cpu = sum(json.loads((f / STATUS).read_text())["cpu_time_s"] for f in folders)
        run_case_wall = sum(json.loads((f / SUMMARY).read_text())["wall_time_s"] for f in folders)
    assert set(table["status"]) == {"done"}, table["error"].dropna().tolist()
    return wall, float(table["wall_time_s"].sum()), cpu, run_case_wall


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--members", type=int, default=6)
    p.add_argument("--particles", type=int, default=300, help="magnets of a throughput member")
    p.add_argument("--duration", type=float, default=600.0, help="ms, throughput members")
    p.add_argument("--small", type=int, default=20, help="members of the 21-magnet overhead sweep")
    p.add_argument("--repeat", type=int, default=2)
    args = p.parse_args()

    small = load_case(INPUTS / "paper_experiment.toml")
    with tempfile.TemporaryDirectory() as tmp:  # warm-up
        run_case(small, Path(tmp) / "warm", figure=False)
        timed_sweep(Sweep(base=small), 2)

    base = load_case(INPUTS / "paper_long_lattice.toml", [f"run.duration={args.duration}", "chain.far_end=fixed",
                                                           f"chain.particles={args.particles}"])
    velocities = [float(v) for v in np.linspace(1.0, 2.0, args.members)]
    long_sweep = Sweep(base=base, grid={"impactor.velocity": velocities})
    runs, controls = {1: [], 2: []}, {1: [], 2: []}
    for _ in range(args.repeat):
        for workers in (1, 2):
            controls[workers].append(control(workers))
            runs[workers].append(timed_sweep(long_sweep, workers))

    small_v = [float(v) for v in np.linspace(1.5, 2.8, args.small)]
    small_sweep = Sweep(base=small, grid={"impactor.velocity": small_v})
    small_wall, _, _, run_case_wall = min(timed_sweep(small_sweep, 1) for _ in range(args.repeat))

    print(f"machine: {os.cpu_count()} cores, load average {os.getloadavg()[0]:.1f} at the end "
          "(shared with other users: ratios only)")
    print(f"\n0. control, CPU-bound Python (best of {args.repeat}): cores used with 1 process "
          f"{max(controls[1]):.2f}, with 2 processes {max(controls[2]):.2f}")
    print(f"\n1. throughput: {args.members} members, N = {base.chain.particles}, {base.run.steps()} steps, "
          f"{base.run.steps() // base.run.steps('output_interval')} frames each (best of {args.repeat})")
    print("| workers | sweep wall (s) | members/s | members running at once | cores used | speed-up |")
    print("|---|---|---|---|---|---|")
    best = {w: min(runs[w]) for w in runs}  # the run with the shortest wall time
    for w in (1, 2):
        wall, member_wall, cpu, _ = best[w]
        print(f"| {w} | {wall:.2f} | {args.members / wall:.3f} | {member_wall / wall:.2f} | {cpu / wall:.2f} | "
              f"{best[1][0] / wall:.2f}x |")
    print("members running at once = sum of member wall times / sweep wall time; "
          "cores used = CPU time of all members / sweep wall time")
    per_sweep, per_run = small_wall / args.small, run_case_wall / args.small
    print(f"\n2. overhead per member: {args.small} members of the 21-magnet experiment "
          f"({small.run.steps()} steps, friction), 1 worker (best of {args.repeat})")
    print("| per member | wall (s) |")
    print("|---|---|")
    print(f"| sweep wall / members | {per_sweep:.3f} |")
    print(f"| run_case (the run itself: deck, LAMMPS, measures, summary) | {per_run:.3f} |")
    print(f"| overhead of the sweep | {per_sweep - per_run:.3f} ({(per_sweep - per_run) / per_sweep:.0%}) |")


if __name__ == "__main__":
    main()
