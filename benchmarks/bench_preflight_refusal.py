"""Time and memory to build a huge case and have the preflight refuse it (issue 19).

    python benchmarks/bench_preflight_refusal.py

Each case runs in a fresh process (peak RSS is per process): N magnets of the paper's chain,
uniform or with disorder (relative std 0.01) of the masses, the gaps or both, normal or
uniform, built from its TOML form and refused by `preflight.check` as too large for this
machine. "time" is the build and the check (imports excluded); "drawn" counts the random masses
and gaps made meanwhile (Chain._series), against N per disordered series.
"""

from __future__ import annotations

import subprocess
import sys

CHILD = """
import resource, sys, time
from pylmp_lattice import preflight
from pylmp_lattice.case import Chain, case_from_dict
from pylmp_lattice.errors import ConfigError

drawn = 0
series = Chain._series
def counted(self, nominal, count, width, *args):
    global drawn
    for part in series(self, nominal, count, width, *args):
        drawn += len(part) if width else 0
        yield part
Chain._series = counted

chain = {"particles": int(float(sys.argv[1])), "mass": 1.084, "r0": 12.0}
kind = sys.argv[2]
if kind != "uniform":
    chain |= {"seed": 1} | {f"{field}_disorder": 0.01 for field in ("mass", "r0") if field in kind}
    chain |= {"disorder": "uniform"} if kind.endswith("uniform") else {}
start = time.perf_counter()
try:
    preflight.check(case_from_dict({"chain": chain, "force": {"K": 413.8, "b": 3.917, "q": 3.0},
                                    "impactor": {"velocity": 2.0}, "run": {"duration": 10.0}}), ".")
    refused = "no"
except ConfigError:
    refused = "yes"
print(f"{time.perf_counter() - start:.2f} {resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024:.0f} {refused} "
      f"{drawn}")
"""

CASES = (("1e8", "uniform"), ("1e7", "mass"), ("1e8", "mass"), ("1e8", "r0"), ("1e8", "mass+r0"),
         ("1e8", "mass uniform"), ("1e8", "mass+r0 uniform"))


def main() -> None:
    print(f"{'N':>5} {'chain (disorder)':18} {'time s':>7} {'peak RSS MB':>12} {'refused':>8} {'drawn':>10}")
    for n, kind in CASES:
        out = subprocess.run([sys.executable, "-c", CHILD, n, kind], capture_output=True, text=True, check=True)
        seconds, rss, refused, drawn = out.stdout.split()
        print(f"{n:>5} {kind:18} {seconds:>7} {rss:>12} {refused:>8} {int(drawn):>10}")


if __name__ == "__main__":
    main()
