"""What a thermo row at every frame costs (an H5MD run's observables come from them).

For each case, the deck is run in this process as written (a thermo row at every output
frame) and with `thermo` set back to 20 rows per run (the deck before the observables),
alternately, best of --repeat. The table gives the CPU time of each run (this process's, so
that other load on the machine counts less than in wall time) and their ratio.

    python benchmarks/bench_thermo.py [--repeat 3]
"""

from __future__ import annotations

import argparse
import re
import resource
import tempfile
from pathlib import Path

from pylmp_lattice.case import load_case
from pylmp_lattice.run_folder import RunFolder
from pylmp_lattice.formats.layout import DECK
from pylmp_lattice.runner import run_embedded

INPUTS = Path(__file__).resolve().parent.parent / "inputs"
# (case file, overrides): the main job; the paper's experiment dumped every step; every magnet
# of a 10^4-magnet chain every 10 steps
CASES = {"main job": ("paper_long_lattice.toml", []),
         "experiment, a frame every step": ("paper_experiment.toml", ["run.output_interval=0.0125"]),
         "10^4 magnets, a frame every 10 steps": ("paper_long_lattice.toml", [
             "chain.far_end='fixed'", "chain.particles=10000", "run.duration=20", "run.output_interval=0.1",
             "output.fine=[]"])}


def cpu_seconds() -> float:
    usage = resource.getrusage(resource.RUSAGE_SELF)
    return usage.ru_utime + usage.ru_stime


def run_cpu(folder: Path, thermo: int | None) -> float:
    """CPU time (s) of running the folder's deck, with `thermo` every that many steps if given."""
    deck = folder / DECK
    if thermo is not None:
        deck.write_text(re.sub(r"^thermo +\d+$", f"thermo          {thermo}", deck.read_text(), flags=re.M))
    start = cpu_seconds()
    run_embedded(folder)
    return cpu_seconds() - start


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    print("| case | magnets | frames | CPU, a thermo row every frame (s) | CPU, 20 rows (s) | ratio |")
    print("|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as tmp:
        for c, (label, (name, overrides)) in enumerate(CASES.items()):
            case = load_case(INPUTS / name, overrides)
            best = {"frames": float("inf"), "twenty": float("inf")}
            for k in range(args.repeat):
                for variant, thermo in (("frames", None), ("twenty", max(1, case.run.steps() // 20))):
                    folder = RunFolder.create(case, Path(tmp) / f"{variant}_{c}_{k}").path
                    best[variant] = min(best[variant], run_cpu(folder, thermo))
            frames = case.run.steps() // case.run.steps("output_interval") + 1
            print(f"| {label} | {case.chain.particles} | {frames} | {best['frames']:.3f} | {best['twenty']:.3f} | "
                  f"{best['frames'] / best['twenty']:.2f} |")


if __name__ == "__main__":
    main()
