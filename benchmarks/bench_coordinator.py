"""A sweep's coordinator, its CPU per member: the process that enumerates the members, sends the
tasks, makes the table's rows and writes results.csv and results.parquet, on the same cores as
its workers (issue 28's ensemble targets count it).

1. Whole: `run_sweep` of --members thermal replicas of the 21-magnet experiment with friction
   (bench_sweep.py's sweep, keep = "measures"), --workers 2, --engine cpu, in this process, with
   pandas, pyarrow and matplotlib imported before: this process's CPU over the run (the
   coordinator's, its threads included: the pool's, which unpickles the results) and its main
   thread's (`time.thread_time`), per member. The command's imports and the replica figure are
   left out (bench_startup.py and bench_sweep.py count them).
2. Parts, on the members and outcomes of that run, best of --repeat, CPU per member
   (`time.process_time`): the enumeration (`Sweep.iter_members` and each member's parameter point,
   as `_Coordinator._tasks` asks), the rows (`table.member_row` of each outcome), and the table
   written (`table.frame`, the CSV, the parquet).

It measures the tree on PYTHONPATH; run it for two trees one after the other (and again) to
compare them in one session.

    python benchmarks/bench_coordinator.py [--members 10000] [--repeat 3] [--engine cpu] [--dir /tmp]
"""

from __future__ import annotations

import argparse
import io
import os
import resource
import sys
import tempfile
import time
from datetime import datetime, timezone
from pathlib import Path

from bench_sweep import write_sweep


def process_cpu() -> float:
    usage = resource.getrusage(resource.RUSAGE_SELF)
    return usage.ru_utime + usage.ru_stime


def best(f, repeat: int) -> float:
    """The least CPU seconds of `repeat` calls of f."""
    times = []
    for _ in range(repeat):
        start = time.process_time()
        f()
        times.append(time.process_time() - start)
    return min(times)


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--members", type=int, default=10000)
    p.add_argument("--repeat", type=int, default=3)
    p.add_argument("--workers", type=int, default=2)
    p.add_argument("--engine", choices=("lammps", "cpu", "gpu"), default="cpu")
    p.add_argument("--dir", type=Path, default=Path(tempfile.gettempdir()))
    args = p.parse_args()

    import matplotlib.backends.backend_agg  # noqa: F401 - what the end of a sweep imports, imported before
    import pandas  # noqa: F401
    import pyarrow.parquet  # noqa: F401

    import pylmp_lattice
    from pylmp_lattice.sweep import load_sweep, run_sweep
    from pylmp_lattice.sweep.store import Outcomes
    from pylmp_lattice.sweep.table import frame, member_row

    try:  # a tree whose frame takes the rows as parts (`table.Rows`: a batch's, or a member's)
        from pylmp_lattice.sweep.table import Rows

        dict_frame = frame

        def frame(rows):
            return dict_frame([Rows.one(i, row) for i, row in enumerate(rows)])
    except ImportError:
        pass
    try:
        from pylmp_lattice.sweep.table import csv_text
    except ImportError:  # a tree before it: pandas called short_float per cell
        from pylmp_lattice.serialize import short_float

        def csv_text(df):
            return df.to_csv(index=False, float_format=short_float)

    with tempfile.TemporaryDirectory(dir=args.dir, prefix=".bench_coordinator.") as tmp:
        tmp = Path(tmp)
        sweep = load_sweep(write_sweep(tmp, args.members, 0.02, friction=True))
        load_before = os.getloadavg()[0]
        cpu, thread, wall = process_cpu(), time.thread_time(), time.time()
        run_sweep(sweep, tmp / "out", workers=args.workers, progress=False, engine=args.engine)
        cpu, thread, wall = process_cpu() - cpu, time.thread_time() - thread, time.time() - wall
        load_after = os.getloadavg()[0]

        members = list(sweep.iter_members())
        disk = Outcomes(tmp / "out")
        outcomes = [disk.get(m.id) for m in members]
        n = len(members)
        rows = [member_row(m.id, m.params, o["record"].get("batch"), o["record"], o["summary"])
                for m, o in zip(members, outcomes)]
        df = frame(rows)
        parts = {
            "enumeration": best(lambda: [m.point for m in sweep.iter_members()], args.repeat),
            "rows": best(lambda: [member_row(m.id, m.params, o["record"].get("batch"), o["record"], o["summary"])
                                  for m, o in zip(members, outcomes)], args.repeat),
            "frame": best(lambda: frame(rows), args.repeat),
            "csv": best(lambda: csv_text(df), args.repeat),
            "parquet": best(lambda: df.to_parquet(io.BytesIO(), index=False), args.repeat),
        }

    tree = Path(pylmp_lattice.__file__).resolve().parent.parent
    print(f"{datetime.now(timezone.utc):%Y-%m-%d %H:%M} UTC; {os.cpu_count()} cores; tree {tree}; {n} members, "
          f"{args.workers} workers, engine {args.engine}; load {load_before:.1f}, {load_after:.1f}")
    print("| sweep wall (s) | coordinator CPU (s) | per member (ms) | main thread (ms) | "
          + " | ".join(f"{k} (ms)" for k in parts) + " | parts (ms) |")
    print("|" + "---|" * (5 + len(parts)))
    print(f"| {wall:.2f} | {cpu:.2f} | {1e3 * cpu / n:.3f} | {1e3 * thread / n:.3f} | "
          + " | ".join(f"{1e3 * v / n:.4f}" for v in parts.values()) + f" | {1e3 * sum(parts.values()) / n:.3f} |")
    print("CPU per member. The parts are best of", args.repeat, "on this run's members and outcomes; the whole "
          "run also holds the pool's thread (results unpickled) and the table's writes every 30 s.", file=sys.stdout)


if __name__ == "__main__":
    main()
