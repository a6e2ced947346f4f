"""The road's cost for a batch of chains, engine excluded: `run_folder.execute_batch` (claim,
write with replicas.toml, run.json records, convert) with a no-op engine, against the floor, its
deck alone (`deck.render_replicas` and its files written atomically, as sweep/batch.py did
before the batch went through the road), in the same process, alternating.

A task of --members replicas of inputs/paper_experiment.toml (21 magnets, chain.thermal_velocity
= 0.02 m/s, output.format = "none"), as bench_batch_python.py runs it. CPU time (process_time:
a loaded machine's waits left out) and wall time, ms per member, the fastest of --repeat.

    python benchmarks/bench_batch_folder.py [--members 300] [--repeat 40]
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import shutil
import tempfile
import time
from datetime import datetime, timezone
from pathlib import Path

import pylmp_lattice as pl
from pylmp_lattice import deck
from pylmp_lattice.formats.files import atomic_write
from pylmp_lattice.run_folder import execute_batch

CASE = Path(__file__).resolve().parent.parent / "inputs" / "paper_experiment.toml"


class NoEngine:
    """An engine that runs nothing: the road's own work alone."""

    nprocs = 1

    def check(self, path):
        pass

    def __call__(self, path, on_step=None):
        pass


def floor(cases, folder: Path) -> None:
    for name, text in deck.render_replicas(cases, front=True).items():
        atomic_write(folder / name, text)


def road(cases, folder: Path) -> None:
    execute_batch(cases, folder, NoEngine())


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--members", type=int, default=300)
    parser.add_argument("--repeat", type=int, default=40)
    args = parser.parse_args()
    base = pl.load_case(CASE, ["chain.thermal_velocity=0.02", "chain.seed=1", "output.format=none"])
    cases = [dataclasses.replace(base, chain=dataclasses.replace(base.chain, seed=i + 1)) for i in range(args.members)]
    work = Path(tempfile.mkdtemp(prefix="bench_batch_folder_"))
    best = {way: [float("inf"), float("inf")] for way in ("floor", "road")}
    try:
        for k in range(args.repeat):
            for way, fn in (("floor", floor), ("road", road)):
                folder = work / f"{way}{k}"
                cpu, wall = time.process_time(), time.perf_counter()
                folder.mkdir()
                fn(cases, folder)
                cpu, wall = time.process_time() - cpu, time.perf_counter() - wall
                best[way] = [min(best[way][0], cpu), min(best[way][1], wall)]
    finally:
        shutil.rmtree(work, ignore_errors=True)
    n = args.members
    print(f"# {datetime.now(timezone.utc):%Y-%m-%d %H:%M} UTC, load average {os.getloadavg()[0]:.2f}; "
          f"{n} members of {CASE.name}, fastest of {args.repeat}")
    print(f"{'way':<8}{'CPU ms/member':>15}{'wall ms/member':>16}")
    for way, (cpu, wall) in best.items():
        print(f"{way:<8}{1e3 * cpu / n:>15.4f}{1e3 * wall / n:>16.4f}")
    (fc, fw), (rc, rw) = best["floor"], best["road"]
    print(f"road / floor: CPU {rc / fc:.3f}, wall {rw / fw:.3f}; the road beyond the floor: "
          f"{1e3 * (rc - fc):.2f} ms CPU, {1e3 * (rw - fw):.2f} ms wall a batch")


if __name__ == "__main__":
    main()
