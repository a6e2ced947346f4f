"""The batch road's CPU per member at 10^4-10^5 members (--engine cpu): the coordinator's and a
worker's Python, this tree against a reference commit's, measured in the same run.

1. Coordinator: `pylmp-lattice sweep` of bench_sweep.py's thermal ensemble (replicas of
   inputs/paper_experiment.toml with friction, keep = "measures", chain.thermal_velocity =
   0.02) with --engine cpu --workers 2, run as `python -c` of bench_sweep.COORDINATOR_CPU under
   each tree: the command's own CPU (its threads included, the workers' not), per member, and
   per extra member between the sizes (start-up, imports and the replica figure left out).
2. Worker: the coordinator's second task of a 10^4-member sweep (`_Coordinator._tasks`, about
   1000 members: what one instance holds), pickled as the pool sends it, then unpickled and run
   by `batch.run_task` in a fresh process, its results pickled, as a pool worker does (after
   the first task, which warms it up): its CPU less the engine's (`engines.cpu.run_arrays`,
   one thread), per member.

Ratio = reference / this tree (above 1: this tree spends less). Each size runs the reference
first, then this tree, in turn (--repeat times, the least CPU kept).

    python benchmarks/bench_per_member.py [--members 10000,100000] [--reference 434a71e] [--repeat 1] [--workers 2]
"""

from __future__ import annotations

import argparse
import os
import re
import subprocess
import sys
import tempfile
import time
from datetime import datetime, timezone
from pathlib import Path

from bench_sweep import COORDINATOR_CPU, write_sweep

ROOT = Path(__file__).resolve().parent.parent
# bench_sweep.COORDINATOR_CPU, also saying how often the table was written (`Table.write`: the
# writes while the sweep runs depend on its wall time, which the machine's load stretches)
COUNTED = ("import atexit, sys\n"
           "from pylmp_lattice.sweep import table\n"
           "writes, write = [], table.Table.write\n"
           "def counted(self, *args):\n"
           "    writes.append(1)\n"
           "    return write(self, *args)\n"
           "table.Table.write = counted\n"
           "atexit.register(lambda: print(f'table-writes {len(writes)}', file=sys.stderr))\n") + COORDINATOR_CPU

WORKER = """
import pickle, sys, time
from pathlib import Path
from pylmp_lattice.engines import cpu
from pylmp_lattice.sweep import execute, load_sweep
from pylmp_lattice.sweep.batch import run_task
from pylmp_lattice.sweep.pool import Pool

sweep, out = execute._with_engine(load_sweep(sys.argv[1]), "cpu"), Path(sys.argv[2])
(out / "members").mkdir(parents=True)
coordinator = execute._Coordinator(sweep, out, Pool(None, 2), execute._StopSignals(), False, False, sweep.count())
tasks = coordinator._tasks()
warm, task = next(tasks), next(tasks)
engine = [0.0]
run = cpu.run_arrays
def timed(*args, **kwargs):
    start = time.process_time()
    try:
        return run(*args, **kwargs)
    finally:
        engine[0] += time.process_time() - start
cpu.run_arrays = timed
run_task(pickle.loads(pickle.dumps(warm)))
blob, engine[0] = pickle.dumps(task), 0.0
start = time.process_time()
results = run_task(pickle.loads(blob))
pickle.dumps(results)  # as the pool sends them back
total = time.process_time() - start
members = sum(len(r) if hasattr(r, "index") else 0 if hasattr(r, "text") else 1 for r in results)  # (a Note: none)
print(f"worker {members} {total:.4f} {engine[0]:.4f}")
"""


def tree_of(commit: str, folder: Path) -> Path:
    """The package source at `commit` (git archive of this repository), in `folder`."""
    folder.mkdir(parents=True)
    archive = subprocess.run(["git", "-C", str(ROOT), "archive", commit, "pylmp_lattice"], check=True,
                             capture_output=True).stdout
    subprocess.run(["tar", "-x", "-C", str(folder)], input=archive, check=True)
    return folder


def python(tree: Path, args: list[str], cwd: Path) -> str:
    """Run `python ARGS` with `tree`'s package; its stderr and stdout."""
    done = subprocess.run([sys.executable, *args], cwd=cwd, capture_output=True, text=True,
                          env=os.environ | {"PYTHONPATH": str(tree)})
    if done.returncode != 0:
        raise SystemExit(f"{args[:2]} under {tree} failed ({done.returncode}): {done.stderr[-2000:]}")
    return done.stdout + done.stderr


def coordinator_cpu(tree: Path, sweep: Path, out: Path, workers: int) -> tuple[float, float, int]:
    """The sweep command's own CPU seconds, its wall time and how often it wrote the table."""
    start = time.time()
    text = python(tree, ["-c", COUNTED, "sweep", str(sweep), "-o", str(out), "--workers", str(workers),
                         "--engine", "cpu", "--yes", "--quiet"], out.parent)
    return (float(re.findall(r"^coordinator-cpu (\S+)$", text, re.M)[-1]), time.time() - start,
            int(re.findall(r"^table-writes (\S+)$", text, re.M)[-1]))


def worker_cpu(tree: Path, sweep: Path, out: Path) -> tuple[float, float]:
    """A worker's CPU per member: all of it, and the engine's."""
    members, total, engine = re.findall(r"^worker (\S+) (\S+) (\S+)$", python(tree, ["-c", WORKER, str(sweep), str(out)],
                                                                               out.parent), re.M)[-1]
    return float(total) / int(members), float(engine) / int(members)


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--members", default="10000,100000")
    p.add_argument("--reference", default="434a71e", help="commit of the reference tree")
    p.add_argument("--repeat", type=int, default=1)
    p.add_argument("--workers", type=int, default=2)
    args = p.parse_args()
    sizes = [int(n) for n in args.members.split(",")]

    with tempfile.TemporaryDirectory(prefix=".bench_per_member.") as tmp:
        tmp = Path(tmp)
        trees = {"reference": tree_of(args.reference, tmp / "reference"), "this": ROOT}
        for tree in trees.values():  # compiled before: no run pays for it (the first one did)
            subprocess.run([sys.executable, "-m", "compileall", "-q", str(tree / "pylmp_lattice")], check=True)
        sweeps = {}
        for n in sorted({*sizes, 10000}):
            (tmp / f"s{n}").mkdir()
            sweeps[n] = write_sweep(tmp / f"s{n}", n, 0.02, friction=True)
        coordinator = {}  # (tree, n) -> (cpu s, wall s, table writes)
        worker = {}  # tree -> (CPU per member, the engine's)
        for k in range(args.repeat):
            for name, tree in trees.items():
                got = worker_cpu(tree, sweeps[10000], tmp / f"w-{name}-{k}")
                worker[name] = min(worker.get(name, got), got)
            for n in sizes:
                for name, tree in trees.items():
                    got = coordinator_cpu(tree, sweeps[n], tmp / f"o-{name}-{n}-{k}", args.workers)
                    coordinator[name, n] = min(coordinator.get((name, n), got), got)

    print(f"{datetime.now(timezone.utc):%Y-%m-%d %H:%M} UTC; {os.cpu_count()} cores; load {os.getloadavg()[0]:.1f}; "
          f"reference {args.reference}, this tree {ROOT}; --engine cpu, {args.workers} workers; CPU per member in us")
    print("| part | members | reference | this tree | ratio |")
    print("|---|---|---|---|---|")
    for n in sizes:
        ref, new = (coordinator[name, n][0] / n * 1e6 for name in trees)
        print(f"| coordinator (command's CPU / members) | {n} | {ref:.1f} | {new:.1f} | {ref / new:.1f}x |")
    if len(sizes) > 1:
        a, b = sizes[0], sizes[-1]
        ref, new = ((coordinator[name, b][0] - coordinator[name, a][0]) / (b - a) * 1e6 for name in trees)
        print(f"| coordinator, per extra member | {a}-{b} | {ref:.1f} | {new:.1f} | {ref / new:.1f}x |")
    (ref, ref_engine), (new, new_engine) = worker["reference"], worker["this"]
    print(f"| worker, less the engine (one task) | ~1000 | {1e6 * (ref - ref_engine):.1f} | {1e6 * (new - new_engine):.1f} "
          f"| {(ref - ref_engine) / (new - new_engine):.1f}x |")
    print(f"| worker's engine (one thread) | ~1000 | {1e6 * ref_engine:.1f} | {1e6 * new_engine:.1f} | "
          f"{ref_engine / new_engine:.2f}x |")
    for n in sizes:
        (_, ref_wall, ref_writes), (_, wall, writes) = (coordinator[name, n] for name in trees)
        print(f"sweep at {n}: wall reference {ref_wall:.1f} s, this tree {wall:.1f} s; table written "
              f"{ref_writes} and {writes} times")


if __name__ == "__main__":
    main()
