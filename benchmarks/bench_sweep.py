"""A thermal ensemble of the paper's 21-magnet experiment: the sweep end to end against a plain
C loop doing the same integrations on the same number of workers, in one run.

1. Sweep: `pylmp-lattice sweep` (a fresh Python process, so start-up counts) of --members
   replicas of inputs/paper_experiment.toml (60 ms, dt = 12.5 us: 4800 steps of 21 magnets)
   with thermal motion (chain.thermal_velocity = --thermal m/s), keep = "measures",
   --workers 2, from the command to its exit. Start-up: the command to the first member's
   start (its record's "started", in members.json of its batch or its status.json). Each member gets its front measures and summary.
   Two variants: the case as shipped (Coulomb friction on the rod), and without friction.
2. Loop: benchmarks/ensemble_loop.c (gcc -O3): the same chains from the same initial states
   (each member's positions, thermal velocities, masses), the same velocity Verlet, drive and
   Coulomb stick-slip kick, split over --workers processes started together; from launching
   them to the last one's exit (state files written before). No measures, no output.
   Check: member 0 run alone with its trajectory kept; its final velocities must equal the
   loop's chain 0 to 1e-9 m/s (same equations, same operations).

Ratio = sweep wall time / loop wall time (the issue's target: at most 3).

With two sizes (--members 1000,4000) it also prints the marginal cost: the extra sweep time per
extra member against the loop's, (sweep(N2) - sweep(N1)) / (loop(N2) - loop(N1)), which leaves
out what every sweep pays once.

A floor, in the same run: the CPU that a sweep command of this design cannot avoid, over the
machine's cores. That is the engine's own CPU (LAMMPS's loop time x its CPU use) plus the imports
of the command's process (the package, pandas and pyarrow for the table, matplotlib for the
replica figure) and of the workers' fork server (the package, the engine's libraries), each
measured in a fresh Python. The work on the cases, files, table and figure is left out.

With --engine cpu (or gpu) the sweep's batches run on the chain kernel (`engines.road`); the
engine columns then read "-" (its log has no LAMMPS loop time) and the floor is the imports only.

    python benchmarks/bench_sweep.py [--members 1000[,4000]] [--workers 2] [--thermal 0.02] [--variants friction,frictionless] [--engine lammps|cpu|gpu]
"""

from __future__ import annotations

import argparse
import os
import re
import resource
import subprocess
import sys
import tempfile
import time
import tomllib
from datetime import datetime, timezone
from pathlib import Path

import numpy as np
import tomli_w

ROOT = Path(__file__).resolve().parent.parent
CASE = ROOT / "inputs" / "paper_experiment.toml"
LOOP = Path(__file__).resolve().parent / "ensemble_loop.c"


# The shipped thermal example's manufacturing scatter (inputs/sweep_thermal_experiment.toml), for
# the benchmarks' ensembles under disorder
DISORDER = '"chain.mass_disorder" = 0.01\n"chain.r0_disorder" = 0.005\n"chain.disorder" = "uniform"\n'


def write_sweep(folder: Path, members: int, thermal: float, friction: bool, particles: int | None = None,
                disorder: bool = False) -> Path:
    """The thermal ensemble's sweep file (and its base case) in `folder`; `particles`: magnets
    other than the experiment's 21; `disorder`: with the thermal example's mass and gap disorder."""
    base = tomllib.loads(CASE.read_text())
    if not friction:
        del base["friction"]
    if particles is not None:
        base["chain"]["particles"] = particles
    (folder / "base.toml").write_text(tomli_w.dumps(base))
    path = folder / "sweep.toml"
    path.write_text(f'base = "base.toml"\nreplicas = {members}\nseed = 2026\nkeep = "measures"\n'
                    f'[set]\n"chain.thermal_velocity" = {thermal}\n' + (DISORDER if disorder else ""))
    return path


# The CLI as `python -m pylmp_lattice.cli` runs it, saying on stderr, at its exit, its own CPU
# (the coordinator's, its threads included; not the fork server's or the workers').
COORDINATOR_CPU = ("import atexit, resource, sys\n"
                   "def said():\n"
                   "    u = resource.getrusage(resource.RUSAGE_SELF)\n"
                   "    print(f'coordinator-cpu {u.ru_utime + u.ru_stime:.3f}', file=sys.stderr)\n"
                   "atexit.register(said)\n"
                   "from pylmp_lattice.cli import main\n"
                   "sys.exit(main())")


def children_cpu() -> float:
    """CPU seconds of this process's finished children (and theirs, once waited for)."""
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def run_sweep_command(path: Path, out: Path, workers: int, engine: str = "lammps",
                      command: list[str] | None = None) -> dict:
    """The sweep as a user runs it (or as `command`, a Python command line that takes the CLI's
    arguments, runs it): wall time, start-up, first result, the table written, CPU (the
    coordinator's, and the workers' in their tasks), seconds, and the command's stderr."""
    cmd = [*(command or [sys.executable, "-c", COORDINATOR_CPU]), "sweep", str(path), "-o", str(out),
           "--workers", str(workers), "--quiet", "--engine", engine]
    cpu = children_cpu()
    start = time.time()
    done = subprocess.run(cmd, capture_output=True, text=True)
    wall = time.time() - start
    cpu = children_cpu() - cpu
    own = re.findall(r"^coordinator-cpu (\S+)$", done.stderr, re.M)
    if done.returncode != 0:
        raise SystemExit(f"sweep failed ({done.returncode}): {done.stderr}")
    from pylmp_lattice.sweep import load_results
    from pylmp_lattice.sweep.store import Outcomes

    disk = Outcomes(out)
    records = [disk.get(i)["record"] for i in load_results(out)["id"]]
    assert all(r["status"] == "done" for r in records)
    stamp = lambda key: min(datetime.fromisoformat(r[key]).timestamp() for r in records)  # noqa: E731
    batched = sum("batch" in r for r in records)
    tasks = sum(r["cpu_time_s"] for r in records)  # each member's share of its task's CPU
    # LAMMPS's own loop time of every batch (or member run alone), summed over the workers
    logs = [*(out / "batches").glob("*/log.lammps"), *(out / "members").glob("*/log.lammps")]
    found = [re.search(r"Loop time of (\S+).*?\n\s*\n?([\d.]+)% CPU use", p.read_text(), re.S) for p in logs]
    loops = [m.groups() for m in found if m is not None]  # a kernel engine's log has none
    engine = sum(float(t) for t, _ in loops) / workers
    engine_cpu = sum(float(t) * float(use) / 100 for t, use in loops)  # the engine's own CPU, contention aside
    return {"wall": wall, "startup": stamp("started") - start, "first": stamp("ended") - start,
            "table": (out / "results.parquet").stat().st_mtime - start, "cpu": cpu + tasks, "engine": engine,
            "engine_cpu": engine_cpu, "members": len(records), "batched": batched, "stderr": done.stderr,
            "coordinator": float(own[-1]) if own else float("nan")}


def package(child: bool = True) -> str:
    """Where the measured pylmp_lattice comes from: the one a command started here imports
    (child; its folder first on its path, as the sweep's `python -c`), else this process's;
    the installed copy unless PYTHONPATH, or the folder, names a tree."""
    if not child:
        import pylmp_lattice

        return str(Path(pylmp_lattice.__file__).resolve().parent)
    return subprocess.run([sys.executable, "-c", "import pathlib, pylmp_lattice; "
                           "print(pathlib.Path(pylmp_lattice.__file__).resolve().parent)"],
                          capture_output=True, text=True, check=True).stdout.strip()


def loop_states(sweep_path: Path):
    """Initial positions (m), velocities (m/s), masses (kg) of every member, and the first case."""
    from pylmp_lattice.sweep import load_sweep
    from pylmp_lattice.units import to_engine

    cases = [m.case for m in load_sweep(sweep_path).members()]
    x = np.array([to_engine(c.chain.positions(), "length") for c in cases])
    v = np.array([to_engine(c.chain.velocities(), "velocity") for c in cases])
    m = np.array([to_engine(c.chain.masses(), "mass") for c in cases])
    return cases, x, v, m


def run_loop(exe: Path, tmp: Path, cases, x, v, m, workers: int) -> tuple[float, float, np.ndarray]:
    """The C loop over all chains on `workers` processes; (wall time, CPU time, final velocities)."""
    from pylmp_lattice.units import to_engine

    case = cases[0]
    fr = case.friction
    law = case.force
    args = [str(case.run.steps()), repr(to_engine(case.run.dt, "time")),
            repr(law.K * to_engine(1.0, "length") ** law.q), repr(to_engine(law.b, "length")), repr(law.q),
            repr(to_engine(case.impactor.velocity, "velocity")), repr(to_engine(case.impactor.duration, "time")),
            repr(fr.mu if fr else 0.0), repr(fr.p if fr else 0.0), repr(to_engine(fr.g, "acceleration") if fr else 0.0)]
    parts = np.array_split(np.arange(len(cases)), workers)
    files = []
    for k, part in enumerate(parts):
        state, final = tmp / f"state{k}.bin", tmp / f"final{k}.bin"
        state.write_bytes(np.concatenate([x[part].ravel(), v[part].ravel(), m[part].ravel()]).astype("<f8").tobytes())
        files.append((part, state, final))
    cpu = children_cpu()
    start = time.time()
    procs = [subprocess.Popen([str(exe), str(len(part)), str(x.shape[1]), *args, str(state), str(final)],
                              stdout=subprocess.PIPE, text=True) for part, state, final in files]
    for p in procs:
        p.communicate()
        assert p.returncode == 0
    wall = time.time() - start
    final = np.concatenate([np.fromfile(f, "<f8").reshape(len(part), -1) for part, _, f in files])
    return wall, children_cpu() - cpu, final


def check_member_zero(case, final_v: np.ndarray, tmp: Path) -> float:
    """Largest |v| difference, m/s, between member 0 run alone (trajectory kept) and the loop."""
    import dataclasses

    from pylmp_lattice.run_folder import simulate

    kept = dataclasses.replace(case, output=dataclasses.replace(case.output, format="h5md"))
    traj = simulate(kept, tmp / "member0")
    return float(np.max(np.abs(traj.v[-1, 1:-1] - final_v[1:-1])))


# What the command's process loads (the table's pandas and pyarrow, the figure's matplotlib), and
# what the workers' fork server loads (pool.PRELOAD: the package and the engine's libraries).
COORDINATOR = ("pylmp_lattice.cli", "pylmp_lattice.sweep.execute", "pandas", "pyarrow.parquet", "matplotlib.figure",
               "matplotlib.backends.backend_agg")


def import_cpu(modules, repeat: int = 3) -> float:
    """CPU seconds of a fresh Python that imports `modules` (best of `repeat`)."""
    best = float("inf")
    for _ in range(repeat):
        cpu = children_cpu()
        subprocess.run([sys.executable, "-c", "import " + ", ".join(modules)], check=True)
        best = min(best, children_cpu() - cpu)
    return best


def lammps(value: float, spec: str) -> str:
    """LAMMPS's engine time, or "-" where none ran (a kernel engine)."""
    return format(value, spec) if value else "-"


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--members", default="1000", help="one size, or two (N1,N2) for the marginal cost")
    p.add_argument("--workers", type=int, default=2)
    p.add_argument("--thermal", type=float, default=0.02, help="m/s RMS")
    p.add_argument("--variants", default="friction,frictionless")
    p.add_argument("--engine", choices=("lammps", "cpu", "gpu"), default="lammps")
    p.add_argument("--dir", type=Path, default=ROOT, help="where the sweeps write (a temporary folder inside it)")
    args = p.parse_args()
    sizes = [int(n) for n in args.members.split(",")]
    args.dir.mkdir(parents=True, exist_ok=True)  # (a folder named for this run: made, not a traceback)
    if len(sizes) > 2 or sizes != sorted(set(sizes)) or sizes[0] < 1:
        p.error(f"--members: got {args.members}; expected N or N1,N2 with 1 <= N1 < N2")

    with tempfile.TemporaryDirectory(dir=args.dir, prefix=".bench_sweep.") as tmp:
        tmp = Path(tmp)
        exe = tmp / "ensemble_loop"
        subprocess.run(["gcc", "-O3", "-o", str(exe), str(LOOP), "-lm"], check=True)
        from pylmp_lattice.sweep.pool import PRELOAD

        imports = {"coordinator": import_cpu(COORDINATOR), "workers": import_cpu(PRELOAD)}
        warm = tmp / "warm-up"  # not reported: the first sweep of a session reads the libraries from disk
        warm.mkdir()
        run_sweep_command(write_sweep(warm, 2 * args.workers, args.thermal, friction=True), warm / "out", args.workers, args.engine)
        rows = []
        for variant in args.variants.split(","):
            for members in sizes:
                folder = tmp / f"{variant}-{members}"
                folder.mkdir()
                path = write_sweep(folder, members, args.thermal, friction=variant == "friction")
                load_before = os.getloadavg()[0]
                sweep = run_sweep_command(path, folder / "out", args.workers, args.engine)
                cases, x, v, m = loop_states(path)
                loop_wall, loop_cpu, final = run_loop(exe, folder, cases, x, v, m, args.workers)
                error = check_member_zero(cases[0], final[0], folder)
                assert error < 1e-9, f"the loop and the engine differ by {error} m/s"
                rows.append((variant, members, sweep, loop_wall, loop_cpu, error, load_before, os.getloadavg()[0]))

    print(f"{datetime.now(timezone.utc):%Y-%m-%d %H:%M} UTC; machine: {os.cpu_count()} cores; members of the 21-magnet experiment "
          f"(4800 steps, thermal {args.thermal} m/s), {args.workers} workers, engine {args.engine}; pylmp_lattice from "
          f"{package()}")
    print("| variant | members | sweep wall (s) | per member (ms) | start-up (s) | first result (s) | table written (s) "
          "| members batched | engine, per worker (s) | C loop wall (s) | engine / loop | sweep / loop, wall | sweep CPU (s) "
          "| C loop CPU (s) | sweep / loop, CPU | coordinator CPU (s), per member (ms) | loop vs engine, member 0 (m/s) "
          "| load before, after |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for variant, members, s, loop_wall, loop_cpu, error, before, after in rows:
        print(f"| {variant} | {members} | {s['wall']:.2f} | {1e3 * s['wall'] / s['members']:.2f} | {s['startup']:.2f} | "
              f"{s['first']:.2f} | {s['table']:.2f} | {s['batched']}/{s['members']} | {lammps(s['engine'], '.2f')} | {loop_wall:.3f} | "
              f"{lammps(s['engine'] / loop_wall, '.1f')}x | "
              f"{s['wall'] / loop_wall:.1f}x | {s['cpu']:.2f} | {loop_cpu:.3f} | {s['cpu'] / loop_cpu:.1f}x | "
              f"{s['coordinator']:.2f}, {1e3 * s['coordinator'] / s['members']:.3f} | "
              f"{error:.1e} | {before:.1f}, {after:.1f} |")
    print("start-up: the command to the first member's start; first result: to the first member done; table "
          "written: the command to results.parquet (the command then writes the replica statistics and figure). "
          "Engine: LAMMPS's loop time of every instance (log.lammps), summed, over the workers. Sweep CPU: the "
          "coordinator's and the workers' in their tasks (not the fork server's imports). Coordinator CPU: the "
          "command's own process (its imports, members, tasks, table, replica statistics and figure).")
    if len(sizes) == 2:
        print()
        print(f"| variant | marginal: sweep / loop, wall, from {sizes[0]} to {sizes[1]} members "
              "| sweep per extra member (ms) | loop per extra member (ms) |")
        print("|---|---|---|---|")
        for variant in args.variants.split(","):
            (_, n1, s1, l1, *_), (_, n2, s2, l2, *_) = [r for r in rows if r[0] == variant]
            print(f"| {variant} | {(s2['wall'] - s1['wall']) / (l2 - l1):.1f}x | {1e3 * (s2['wall'] - s1['wall']) / (n2 - n1):.3f} "
                  f"| {1e3 * (l2 - l1) / (n2 - n1):.3f} |")
    print()
    cores = os.cpu_count()
    print(f"A floor in the same run: the CPU that no sweep command of this design can avoid, over the {cores} cores. "
          f"Imports, best of 3 in a fresh Python: the command's {imports['coordinator']:.2f} s "
          f"({', '.join(COORDINATOR)}), the workers' fork server's {imports['workers']:.2f} s (pool.PRELOAD). "
          "Engine: each instance's Loop time x its CPU use (log.lammps). Left out: the cases, data files, "
          "summaries, table and figure themselves.")
    print()
    print("| variant | members | engine CPU (s) | + imports (s) | floor, wall (s) | floor / loop | sweep / loop "
          "| floor CPU / loop CPU |")
    print("|---|---|---|---|---|---|---|---|")
    for variant, members, s, loop_wall, loop_cpu, *_ in rows:
        cpu = s["engine_cpu"] + imports["coordinator"] + imports["workers"]
        print(f"| {variant} | {members} | {s['engine_cpu']:.2f} | {imports['coordinator'] + imports['workers']:.2f} | "
              f"{cpu / cores:.2f} | {cpu / cores / loop_wall:.1f}x | {s['wall'] / loop_wall:.1f}x | {cpu / loop_cpu:.1f}x |")
    print("floor CPU / loop CPU: the same comparison in CPU seconds, which another process on the machine "
          "disturbs less than wall time (the loop's processes run in parallel, so its wall time is about its CPU "
          "over the workers)")


if __name__ == "__main__":
    main()
