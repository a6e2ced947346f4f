"""Cost of fix lattice/friction: wall time of the same run with and without it.

A chain of N magnets (paper force law, r0 = 12 mm, bond_style table spline), magnet 1
pushed at 2 m/s by fix move, magnet N held, the rest integrated by fix nve. Two cases:
"impact" starts from rest (the paper's set-up: most magnets wait ahead of the wave, and
the fix skips unloaded magnets at rest), "all moving" gives every magnet a random
velocity (sd 0.5 m/s) first, the worst case, where every magnet needs its friction limit
every step. Each case runs without friction and with the fix in its two ways of getting
the neighbour forces: "law bond" (the bond table's single(), the default) and "law power"
(the analytic law). The runs differ only in the friction fix. Times are LAMMPS's
"Loop time" (setup excluded), best of --repeat runs each, interleaved so that noise hits
all alike; ratios are to the frictionless run.

    python benchmarks/bench_friction.py [--atoms 10000] [--steps 2000] [--repeat 3]
"""

from __future__ import annotations

import argparse
import re
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

from pylmp_lattice.plugin import plugin_file

K, B, Q, MASS, R0 = 413.8e-9, 3.917e-3, 3.0, 1.084e-3, 12e-3
BIN = Path(sys.executable).parent


def write_inputs(folder: Path, atoms: int) -> None:
    r = np.linspace(1e-3, 40e-3, 20000)
    rows = "\n".join(
        f"{i + 1} {x:.17g} {K / (2 * (x + B) ** 2):.17g} {K / (x + B) ** 3:.17g}" for i, x in enumerate(r)
    )
    (folder / "magnet.table").write_text(f"MAGNET\nN {len(r)} EQ {R0}\n\n{rows}\n")
    x = R0 * np.arange(atoms)
    lines = [
        f"chain\n\n{atoms} atoms\n{atoms - 1} bonds\n1 atom types\n1 bond types\n",
        f"-0.05 {x[-1] + 0.05} xlo xhi\n-0.01 0.01 ylo yhi\n-0.01 0.01 zlo zhi\n",
        f"Masses\n\n1 {MASS}\n\nAtoms # bond\n",
        "\n".join(f"{i + 1} 1 1 {xi:.17g} 0 0" for i, xi in enumerate(x)),
        "\nBonds\n",
        "\n".join(f"{i + 1} 1 {i + 1} {i + 2}" for i in range(atoms - 1)),
    ]
    (folder / "chain.data").write_text("\n".join(lines) + "\n")


# the fix line of each run, by name; None: no friction
FRICTION = {
    "none": None,
    "law bond": "fix fric mobile lattice/friction 0.285 0.012 9.81 law bond 1",
    "law power": f"fix fric mobile lattice/friction 0.285 0.012 9.81 law power {K!r} {B!r} {Q!r}",
}


def deck(atoms: int, steps: int, friction: str | None, moving: bool) -> str:
    fric = friction or ""
    kick = "variable vr atom normal(0,0.5,4321)\nvelocity mobile set v_vr NULL NULL units box" if moving else ""
    return f"""units si
atom_style bond
atom_modify map array
boundary s f f
comm_modify cutoff 0.05
read_data chain.data
plugin load {plugin_file()}
bond_style table spline 20000
bond_coeff 1 magnet.table MAGNET
timestep 1e-5
group impactor id 1
group held id {atoms}
group mobile id 2:{atoms - 1}
{kick}
fix push impactor move linear 2.0 0 0 units box
fix hold held setforce 0 0 0
fix nve mobile nve
{fric}
thermo {steps}
run {steps}
"""


def loop_time(folder: Path, text: str) -> float:
    (folder / "in.bench").write_text(text)
    done = subprocess.run(
        [str(BIN / "lmp"), "-in", "in.bench", "-log", "none"],
        cwd=folder, capture_output=True, text=True, check=False,
    )
    found = re.search(r"Loop time of ([0-9.eE+-]+)", done.stdout)
    if done.returncode != 0 or not found:
        raise RuntimeError(f"lmp failed:\n{done.stdout[-2000:]}\n{done.stderr[-2000:]}")
    return float(found.group(1))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--atoms", type=int, default=10_000)
    parser.add_argument("--steps", type=int, default=2000)
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    print(
        f"{'case':>10} {'N':>7} {'steps':>6} {'no friction [s]':>16} "
        f"{'law bond [s]':>13} {'ratio':>6} {'law power [s]':>14} {'ratio':>6}"
    )
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        write_inputs(folder, args.atoms)
        for case, moving in (("impact", False), ("all moving", True)):
            times = {name: [] for name in FRICTION}
            for _ in range(args.repeat):
                for name, fix in FRICTION.items():
                    times[name].append(loop_time(folder, deck(args.atoms, args.steps, fix, moving)))
            plain, bond, power = (min(times[name]) for name in FRICTION)
            print(
                f"{case:>10} {args.atoms:>7} {args.steps:>6} {plain:>16.3f} "
                f"{bond:>13.3f} {bond / plain:>6.2f} {power:>14.3f} {power / plain:>6.2f}"
            )
    print(f"(best of {args.repeat} runs each)")

if __name__ == "__main__":
    main()
