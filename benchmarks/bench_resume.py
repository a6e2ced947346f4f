"""A resumed sweep's read of its finished members, this tree against a reference commit's, in the
same run, on one sweep folder: bench_sweep.py's thermal ensemble (replicas of
inputs/paper_experiment.toml with friction, keep = "measures") of --members members, run to the
end once with this tree (--engine cpu, 2 workers: its batches hold members.json and, from this
tree on, members.arrow, which a tree before ignores). In a fresh Python per tree, best of
--repeat, CPU per member:

1. read: `store.Outcomes(DIR)._read()`, the batches' outcomes read (what the coordinator does
   first on resume);
2. resume: the coordinator's pass before any member would run: `_Coordinator._tasks()` drained
   (the members enumerated, found done, their rows set; no task is left), the read included;
3. table: then `table.frame` and `table.csv_text` of those rows (results.csv's text).

pandas and pyarrow are imported before (the coordinator needs them for the table anyway).
Ratio = reference / this tree (above 1: this tree spends less).

    python benchmarks/bench_resume.py [--members 20000] [--reference 434a71e] [--repeat 3]
"""

from __future__ import annotations

import argparse
import os
import re
import subprocess
import sys
import tempfile
from datetime import datetime, timezone
from pathlib import Path

from bench_per_member import python, tree_of
from bench_sweep import write_sweep

ROOT = Path(__file__).resolve().parent.parent

READ = """
import sys, time
from pathlib import Path
import pandas, pyarrow.ipc, pyarrow.parquet  # noqa: F401 - imported before (see the module)
from pylmp_lattice.sweep import execute, load_sweep, table
from pylmp_lattice.sweep.pool import Pool
from pylmp_lattice.sweep.store import Outcomes

sweep, out, repeat = execute._with_engine(load_sweep(sys.argv[1]), "cpu"), Path(sys.argv[2]), int(sys.argv[3])


def cpu(f):
    best = float("inf")
    for _ in range(repeat):
        start = time.process_time()
        f()
        best = min(best, time.process_time() - start)
    return best


def resume():
    coordinator = execute._Coordinator(sweep, out, Pool(None, 2), execute._StopSignals(), False, False, sweep.count())
    assert not list(coordinator._tasks()) and coordinator.kept == sweep.count()
    return coordinator


read = cpu(lambda: Outcomes(out)._read())
whole = cpu(resume)
parts = resume().table.parts
written = cpu(lambda: table.csv_text(table.frame(parts), parts))
print(f"resume {read:.4f} {whole:.4f} {written:.4f}")
"""


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--members", type=int, default=20000)
    p.add_argument("--reference", default="434a71e", help="commit of the reference tree")
    p.add_argument("--repeat", type=int, default=3)
    args = p.parse_args()

    with tempfile.TemporaryDirectory(prefix=".bench_resume.") as tmp:
        tmp = Path(tmp)
        trees = {"reference": tree_of(args.reference, tmp / "reference"), "this": ROOT}
        (tmp / "s").mkdir()
        sweep, out = write_sweep(tmp / "s", args.members, 0.02, friction=True), tmp / "out"
        python(ROOT, ["-m", "pylmp_lattice.cli", "sweep", str(sweep), "-o", str(out), "--engine", "cpu", "--workers", "2",
                      "--yes", "--quiet"], tmp)
        columns = len(list(out.glob("batches/*/members.arrow")))
        batches = len(list(out.glob("batches/*/members.json")))
        got = {}
        for name, tree in trees.items():
            text = python(tree, ["-c", READ, str(sweep), str(out), str(args.repeat)], tmp)
            got[name] = [float(x) for x in re.findall(r"^resume (\S+) (\S+) (\S+)$", text, re.M)[-1]]

    n = args.members
    print(f"{datetime.now(timezone.utc):%Y-%m-%d %H:%M} UTC; {os.cpu_count()} cores; load {os.getloadavg()[0]:.1f}; "
          f"reference {args.reference}, this tree {ROOT}; {n} members done in {batches} batches ({columns} with "
          f"members.arrow); CPU per member in us, best of {args.repeat}")
    print("| part | reference | this tree | ratio |")
    print("|---|---|---|---|")
    for k, part in enumerate(("read (`Outcomes._read`)", "resume (`_tasks()` drained, read included)",
                              "table (`frame` + `csv_text`)")):
        ref, new = got["reference"][k] / n * 1e6, got["this"][k] / n * 1e6
        print(f"| {part} | {ref:.1f} | {new:.1f} | {ref / new:.1f}x |")


if __name__ == "__main__":
    main()
