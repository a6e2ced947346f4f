"""The end of a large sweep: writing its table (results.csv and results.parquet, `table.write_table`)
of 10^5-10^6 members, which the coordinator does alone after the last member (issue 28: 10^6
members end to end within 10 s on a GPU machine), wall time, this tree against a reference commit
in the same run.

The rows are real: a sweep of --sample thermal replicas of the 21-magnet experiment with friction
(bench_sweep.py's, --engine cpu) runs once, its table's parts (`table.Rows`, as the workers sent
them) are kept (their fields: lists and arrays, which each tree makes its Rows of, whatever
its pickling), and repeated with the members' numbers shifted to make --members rows. Each tree
writes the same parts in a fresh Python (alternating, --repeat times); the files must be the same
bytes.

    python benchmarks/bench_table_write.py [--members 100000,1000000] [--sample 2000] [--repeat 3] [--reference a876be1]
"""

from __future__ import annotations

import argparse
import os
import pickle
import statistics
import subprocess
import sys
import tempfile
from datetime import datetime, timezone
from pathlib import Path

from bench_per_member import tree_of
from bench_sweep import ROOT, write_sweep

# Keeps the table's parts of a sweep (argv: sweep file, output folder, where to pickle the parts).
KEEP = """import pickle, sys
from pylmp_lattice.sweep import table
write = table.write_table
def kept(root, parts, beside=None):
    pickle.dump([vars(p) for p in parts], open(sys.argv[3], "wb"))  # (fields: each tree makes its Rows)
    return write(root, parts, beside)
table.write_table = kept
from pylmp_lattice.sweep import load_sweep, run_sweep
run_sweep(load_sweep(sys.argv[1]), sys.argv[2], workers=2, engine="cpu", progress=False)
"""

# Writes the parts (argv: the pickle, members, output folder): its wall time and the files' digests.
WRITE = """import dataclasses, hashlib, pickle, sys, time
from pathlib import Path
import pandas, pyarrow.parquet  # noqa: F401 (imported before: the coordinator has them by then)
from pylmp_lattice.sweep import table
parts = [table.Rows(**fields) for fields in pickle.load(open(sys.argv[1], "rb"))]
n0, want = sum(map(len, parts)), int(sys.argv[2])
parts = [dataclasses.replace(p, index=p.index + k * n0) for k in range(-(-want // n0)) for p in parts]
out = Path(sys.argv[3])
start = time.perf_counter()
table.write_table(out, parts)
wall = time.perf_counter() - start
digest = hashlib.sha256((out / "results.csv").read_bytes() + (out / "results.parquet").read_bytes()).hexdigest()
print(f"written {sum(map(len, parts))} {wall:.4f} {digest[:16]}")
"""


def python(tree: Path, code: str, args: list[str]) -> str:
    done = subprocess.run([sys.executable, "-c", code, *args], capture_output=True, text=True,
                          env=os.environ | {"PYTHONPATH": str(tree)})
    if done.returncode != 0:
        raise SystemExit(f"under {tree}: {done.stderr[-2000:]}")
    return done.stdout


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--members", default="100000,1000000")
    p.add_argument("--sample", type=int, default=2000, help="members of the sweep whose rows are repeated")
    p.add_argument("--repeat", type=int, default=3)
    p.add_argument("--reference", default="a876be1", help="commit of the reference tree")
    args = p.parse_args()
    sizes = [int(n) for n in args.members.split(",")]
    with tempfile.TemporaryDirectory(prefix=".bench_table_write.") as tmp:
        tmp = Path(tmp)
        trees = {args.reference: tree_of(args.reference, tmp / "reference"), "this tree": ROOT}
        sweep = write_sweep(tmp, args.sample, 0.02, friction=True)
        parts = tmp / "parts.pickle"
        python(ROOT, KEEP, [str(sweep), str(tmp / "sweep"), str(parts)])
        walls: dict = {}
        digests: dict = {}
        for n in sizes:
            for k in range(args.repeat):
                for name, tree in trees.items():
                    out = tmp / f"out-{n}-{k}-{name}"
                    out.mkdir()
                    _, rows, wall, digest = python(tree, WRITE, [str(parts), str(n), str(out)]).split()
                    walls.setdefault((name, n), []).append(float(wall))
                    digests.setdefault(n, set()).add(digest)
                    for f in out.iterdir():
                        f.unlink()
    print(f"{datetime.now(timezone.utc):%Y-%m-%d %H:%M} UTC; {os.cpu_count()} cores; load {os.getloadavg()[0]:.1f}; "
          f"rows of a {args.sample}-member sweep repeated; wall seconds, median of {args.repeat} (least in brackets)")
    print(f"| members | {' | '.join(trees)} | ratio | same bytes |")
    print("|---|---|---|---|---|")
    for n in sizes:
        ref, new = (walls[name, n] for name in trees)
        print(f"| {n} | {statistics.median(ref):.3f} ({min(ref):.3f}) | {statistics.median(new):.3f} ({min(new):.3f}) | "
              f"{statistics.median(ref) / statistics.median(new):.2f}x | {'yes' if len(digests[n]) == 1 else 'NO'} |")


if __name__ == "__main__":
    main()
