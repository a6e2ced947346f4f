"""The friction calibration rig of Fig. S4, kept as a script for old commands; the study itself
is `pylmp_lattice.studies.paper.s4` (the same as `pylmp-lattice study s4 [-o DIR] [--quick]`).

    python analysis/friction_calibration.py [-o OUTDIR] [--quick]
"""

from __future__ import annotations

import argparse
from pathlib import Path

from pylmp_lattice.errors import ConfigError
from pylmp_lattice.serialize import dumps
from pylmp_lattice.studies import run_study


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("-o", "--output", type=Path, default=Path("runs/friction_calibration"))
    parser.add_argument("--quick", action="store_true")
    args = parser.parse_args(argv)
    try:
        result = run_study("s4", args.output, quick=args.quick)
    except ConfigError as err:  # bad input (the output folder): one line and exit 2, as the command line has it
        parser.exit(2, f"{parser.prog}: error: {err}\n")
    print(dumps(result.numbers["rig"]))
    print(f"figure: {args.output / 's4.png'}")


if __name__ == "__main__":
    main()
