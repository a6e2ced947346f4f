"""Cost of the on-the-fly front record (fix lattice/front): LAMMPS's loop time with and without it.

Two cases on the default (chain) engine, no per-frame output: the main case (301 magnets,
600 ms: the front crosses two thirds of the chain) and a 10^4-magnet chain for 50 ms (the front
crosses the first few dozen magnets, the rest wait at rest). Best of --repeat, alternating.

    python benchmarks/bench_front.py [--repeat 3]
"""

from __future__ import annotations

import argparse
import re
import tempfile
from pathlib import Path

from pylmp_lattice.case import load_case
from pylmp_lattice.run_folder import RunFolder
from pylmp_lattice.runner import run_embedded

CASE = Path(__file__).resolve().parent.parent / "inputs" / "paper_long_lattice.toml"
CASES = {"main case, 301 magnets, 600 ms": [],
         "10^4 magnets, 50 ms": ['chain.far_end="fixed"', "chain.particles=10000", "run.duration=50"]}


def loop_time(folder: Path, overrides: list[str], front: bool) -> float:
    case = load_case(CASE, overrides + ['output.format="none"', f"output.front={str(front).lower()}"])
    run_embedded(RunFolder.create(case, folder).path)
    return float(re.search(r"Loop time of (\S+)", (folder / "log.lammps").read_text()).group(1))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    print("| case | loop without record (s) | with record (s) | ratio |\n|---|---|---|---|")
    with tempfile.TemporaryDirectory() as tmp:
        for k, (label, overrides) in enumerate(CASES.items()):
            times = {False: [], True: []}
            for rep in range(args.repeat):
                for front in times:
                    times[front].append(loop_time(Path(tmp) / f"{k}-{rep}-{front}", overrides, front))
            off, on = min(times[False]), min(times[True])
            print(f"| {label} | {off:.3f} | {on:.3f} | {on / off:.2f} |")


if __name__ == "__main__":
    main()
