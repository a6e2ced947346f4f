"""`pylmp-lattice sweep --engine gpu` from command to exit with the kernel left out, on any machine:
everything around the GPU kernel (start-up, estimate, tasks, workers' Python, table, replica
statistics and figure), this tree against a reference commit in the same run, alternating.

The GPU is stood in for in every process of the command (a sitecustomize.py on the path):
`engines.gpu.available` finds a device, and `gpu.run_arrays` (and `gpu.launch`) runs the host build of the same
kernel (`engines.cpu.run_arrays`, one thread) on the batch's first --tile chains and repeats
their results over the batch, so the kernel costs almost nothing while the measures keep their
scatter. LAMMPS is hidden (`import lammps` fails, as on the GPU machine's image, which has none)
and the user cache is a fresh folder, as on a fresh GPU machine. The members are bench_gpu.py's:
thermal replicas of the 21-magnet experiment with friction, 4800 steps. What the device adds
(CuPy's import, a CUDA context per worker, the launches one after another) is not here.

    python benchmarks/bench_gpu_road.py [--members 10000,100000] [--workers N] [--repeat 3] [--reference main] [--disorder]

The reference tree is `git archive` of the commit's package with this tree's compiled libraries
(pylmp_lattice/plugin/*.so), so both must share the kernel's ABI. Each row: median wall time of
--repeat runs (least in brackets), the coordinator's own CPU (median), and with --tile 0 (every
chain run by the host build: exact, slow) whether the tables (results.csv but wall_time_s and
folder) and replica_stats.csv and .png are the same bytes in every run; tiled, a member's
results are those of its batch's chain at its place modulo --tile, which differ where the trees
batch differently.
"""

from __future__ import annotations

import argparse
import hashlib
import io
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from datetime import datetime, timezone
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_per_member import tree_of  # noqa: E402
from bench_sweep import COORDINATOR_CPU, ROOT, write_sweep  # noqa: E402

THERMAL = 0.02  # m/s RMS, as bench_gpu.py
SHIM = '''import importlib.abc, importlib.machinery, os, sys
TILE = int(os.environ["BENCH_GPU_ROAD_TILE"])
def _run(a, *args, **kwargs):
    import dataclasses
    import numpy as np
    from pylmp_lattice.engines import cpu
    if not TILE or a.chains <= TILE:
        return cpu.run_arrays(a, 1)
    rows = np.arange(TILE)
    out = cpu.run_arrays(dataclasses.replace(a, chains=TILE, x=a.x[rows], v=a.v[rows], mass=a.mass[rows],
                                             levels=a.levels[rows]), 1)
    chain = np.arange(a.chains) % TILE
    def tiled(o):
        if o is None:
            return None
        if o.shape[0] == TILE:
            return o[chain]
        return o.reshape(TILE, a.n, *o.shape[1:])[chain].reshape(a.chains * a.n, *o.shape[1:])
    return tuple(map(tiled, out))
class _Ran:  # gpu.launch's Launched, its results made at once
    def __init__(self, out):
        self.out = out
    def result(self):
        return self.out
class _Finder(importlib.abc.MetaPathFinder):
    def find_spec(self, name, path, target=None):
        if name == "lammps" or name.startswith("lammps."):
            raise ModuleNotFoundError(f"No module named {name!r}")
        if name != "pylmp_lattice.engines.gpu":
            return None
        spec = importlib.machinery.PathFinder.find_spec(name, path)
        load = spec.loader.exec_module
        def exec_module(module):
            load(module)
            module.available = lambda: None
            module.run_arrays = _run
            module.launch = lambda a: _Ran(_run(a))
        spec.loader.exec_module = exec_module
        return spec
sys.meta_path.insert(0, _Finder())
'''


def run(tree: Path, shim: Path, sweep: Path, out: Path, workers: int | None, tile: int, cache: Path) -> tuple[float, float]:
    """The command's wall time and its own CPU; out holds its files."""
    env = os.environ | {"PYTHONPATH": f"{tree}{os.pathsep}{shim}", "BENCH_GPU_ROAD_TILE": str(tile),
                        "XDG_CACHE_HOME": str(cache), "MPLCONFIGDIR": str(cache / "matplotlib")}
    cmd = [sys.executable, "-c", COORDINATOR_CPU, "sweep", str(sweep), "-o", str(out), "--engine", "gpu", "--yes",
           "--quiet", *(["--workers", str(workers)] if workers else [])]
    start = time.perf_counter()
    done = subprocess.run(cmd, cwd=sweep.parent, env=env, capture_output=True, text=True)
    wall = time.perf_counter() - start
    if done.returncode != 0:
        raise SystemExit(f"under {tree}: exit {done.returncode}: {done.stderr[-2000:]}")
    said = [line for line in done.stderr.splitlines() if line.startswith("coordinator-cpu")]
    return wall, float(said[-1].split()[1])


def digest(out: Path) -> str:
    """sha256 of results.csv without its wall_time_s and folder columns (a batch's folder is named by
    its first member: other task sizes, other folders), and of replica_stats.csv and .png."""
    import pandas as pd

    table = pd.read_csv(out / "results.csv", dtype=str, keep_default_na=False).drop(columns=["wall_time_s", "folder"])
    text = io.StringIO()
    table.to_csv(text, index=False)
    h = hashlib.sha256(text.getvalue().encode())
    for name in ("replica_stats.csv", "replica_stats.png"):
        h.update((out / name).read_bytes())
    return h.hexdigest()[:16]


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--members", default="10000,100000")
    p.add_argument("--workers", type=int, default=None, help="the sweep's --workers (default: one per core)")
    p.add_argument("--repeat", type=int, default=3)
    p.add_argument("--reference", default="main", help="commit of the reference tree")
    p.add_argument("--tile", type=int, default=64, help="chains the host build runs; their results repeated (0: all)")
    p.add_argument("--disorder", action="store_true", help="members with the thermal example's mass and gap disorder")
    args = p.parse_args()
    with tempfile.TemporaryDirectory(prefix=".bench_gpu_road.") as tmp:
        tmp = Path(tmp)
        reference = tree_of(args.reference, tmp / "reference")
        for lib in (ROOT / "pylmp_lattice" / "plugin").glob("*.so"):
            shutil.copy2(lib, reference / "pylmp_lattice" / "plugin" / lib.name)
        trees = {args.reference: reference, "this tree": ROOT}
        shim = tmp / "shim"
        shim.mkdir()
        (shim / "sitecustomize.py").write_text(SHIM)
        walls: dict = {}
        cpus: dict = {}
        digests: dict = {}
        for n in map(int, args.members.split(",")):
            folder = tmp / f"sweep-{n}"
            folder.mkdir()
            sweep = write_sweep(folder, n, THERMAL, friction=True, disorder=args.disorder)
            for k in range(-1, args.repeat):  # -1: a warm-up of each tree, not counted (matplotlib's font cache)
                for name, tree in trees.items():
                    out = folder / f"out-{k}-{name.replace(' ', '_')}"
                    wall, cpu = run(tree, shim, sweep, out, args.workers, args.tile, tmp / f"cache-{k}-{name}")
                    if k >= 0:
                        walls.setdefault((name, n), []).append(wall)
                        cpus.setdefault((name, n), []).append(cpu)
                        digests.setdefault(n, set()).add(digest(out))
                    shutil.rmtree(out)
    print(f"{datetime.now(timezone.utc):%Y-%m-%d %H:%M} UTC; {os.cpu_count()} cores; load {os.getloadavg()[0]:.1f}; "
          f"--workers {args.workers or os.cpu_count()}; {'under disorder; ' if args.disorder else ''}"
          f"the GPU kernel stood in for (see the module); wall seconds, "
          f"median of {args.repeat} (least), coordinator CPU median")
    print(f"| members | {args.reference} | this tree | {args.reference} / this tree | coordinator CPU | same outputs |")
    print("|---|---|---|---|---|---|")
    for n in sorted(digests):
        ref, new = (walls[name, n] for name in trees)
        cref, cnew = (statistics.median(cpus[name, n]) for name in trees)
        print(f"| {n} | {statistics.median(ref):.2f} ({min(ref):.2f}) | {statistics.median(new):.2f} ({min(new):.2f}) | "
              f"{statistics.median(ref) / statistics.median(new):.2f}x | {cref:.2f} -> {cnew:.2f} | "
              f"{'-' if args.tile else 'yes' if len(digests[n]) == 1 else 'NO'} |")


if __name__ == "__main__":
    main()
