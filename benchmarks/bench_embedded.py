"""Cost of the embedded runner's worker thread (which makes Ctrl-C stop a run within a step).

    PYTHONPATH=. python benchmarks/bench_embedded.py [--duration 100] [--repeat 3]

Runs the main case (inputs/paper_long_lattice.toml, shortened to --duration ms) alternately
(a) as a plain `lmp.file` call in the main thread, which no signal can interrupt, and
(b) through `runner.run_embedded` (instance created, run and closed in a worker thread, the
main thread polling for progress and signals), and prints the wall times and their ratio.
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from pathlib import Path

from pylmp_lattice.case import load_case
from pylmp_lattice.engine import new_lammps
from pylmp_lattice.run_folder import RunFolder
from pylmp_lattice.formats.layout import DECK, DIR_VARIABLE, LOG
from pylmp_lattice.runner import run_embedded

CASE = Path(__file__).parent.parent / "inputs" / "paper_long_lattice.toml"


def plain(folder: Path) -> None:
    lmp = new_lammps(["-log", str(folder / LOG), "-screen", "none", "-var", DIR_VARIABLE, str(folder)])
    lmp.file(str(folder / DECK))
    lmp.close()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--duration", type=float, default=100.0, help="ms of the main case")
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    case = load_case(CASE, [f"run.duration={args.duration}"])
    times = {"main thread (plain lmp.file)": [], "run_embedded (worker thread)": []}
    with tempfile.TemporaryDirectory() as tmp:
        for k in range(args.repeat):
            for (name, values), run in zip(times.items(), (plain, run_embedded)):
                folder = RunFolder.create(case, Path(tmp) / f"{k}-{len(values)}-{run.__name__}").path
                start = time.perf_counter()
                run(folder)
                values.append(time.perf_counter() - start)
    print(f"main case, {case.chain.particles} magnets, {case.run.steps()} steps, {args.repeat} runs each (median)")
    print(f"{'runner':<32} {'wall (s)':>9} {'ratio':>6}")
    base = statistics.median(next(iter(times.values())))
    for name, values in times.items():
        print(f"{name:<32} {statistics.median(values):9.2f} {statistics.median(values) / base:6.2f}")


if __name__ == "__main__":
    main()
