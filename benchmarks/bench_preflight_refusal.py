"""Time and memory to build a huge case and have the preflight refuse it (issue 19).

    python benchmarks/bench_preflight_refusal.py

Each case runs in a fresh process (peak RSS is per process): N magnets of the paper's chain,
uniform or with mass disorder, refused by `preflight.check` as too large for this machine.
"""

from __future__ import annotations

import subprocess
import sys

CHILD = """
import resource, sys, time
from pylmp_lattice import preflight
from pylmp_lattice.case import case_from_dict
from pylmp_lattice.errors import ConfigError
chain = {"particles": int(float(sys.argv[1])), "mass": 1.084, "r0": 12.0}
if sys.argv[2] == "disorder":
    chain |= {"mass_disorder": 0.01, "seed": 1}
start = time.perf_counter()
try:
    preflight.check(case_from_dict({"chain": chain, "force": {"K": 413.8, "b": 3.917, "q": 3.0},
                                    "impactor": {"velocity": 2.0}, "run": {"duration": 10.0}}), ".")
    refused = "no"
except ConfigError:
    refused = "yes"
print(f"{time.perf_counter() - start:.2f} {resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024:.0f} {refused}")
"""


def main() -> None:
    print(f"{'N':>8} {'chain':10} {'time s':>7} {'peak RSS MB':>12} refused")
    for n, kind in (("1e8", "uniform"), ("1e7", "disorder"), ("1e8", "disorder")):
        out = subprocess.run([sys.executable, "-c", CHILD, n, kind], capture_output=True, text=True, check=True)
        seconds, rss, refused = out.stdout.split()
        print(f"{n:>8} {kind:10} {seconds:>7} {rss:>12} {refused}")


if __name__ == "__main__":
    main()
