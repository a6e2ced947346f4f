"""Command line: `pylmp-lattice run|deck|sweep|study|info`. Errors are one line on stderr, never a traceback."""

from __future__ import annotations

import argparse
import json
import logging
import sys
from pathlib import Path

from .errors import ConfigError, LatticeError

EXIT_RUN_ERROR = 1
EXIT_BAD_INPUT = 2
EXIT_INTERRUPTED = 130  # 128 + SIGINT


def main(argv: list[str] | None = None) -> int:
    parser = _parser()
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(message)s")
    try:
        return args.func(args)
    except ConfigError as err:
        print(f"pylmp-lattice: error: {err}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except (LatticeError, OSError) as err:  # a failed run, or a file that cannot be read/written
        print(f"pylmp-lattice: error: {err}", file=sys.stderr)
        return EXIT_RUN_ERROR


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="pylmp-lattice", description="Shock waves in 1D nonlinear lattices with LAMMPS.")
    sub = p.add_subparsers(required=True, metavar="COMMAND")

    run = sub.add_parser("run", help="write the deck, run it, post-process, print a summary")
    _case_args(run)
    run.add_argument("--runner", choices=("embedded", "lmp"), default="embedded",
                     help="LAMMPS Python module in-process (default) or the lmp executable")
    run.add_argument("--np", type=int, default=1, help="MPI ranks (lmp runner only)")
    run.add_argument("--quiet", action="store_true", help="hide LAMMPS's progress output")
    run.set_defaults(func=_run)

    deck = sub.add_parser("deck", help="write a deck that runs with `lmp -in in.lattice`")
    _case_args(deck)
    deck.set_defaults(func=_deck)

    sweep = sub.add_parser("sweep", help="run every member of a sweep file (resumable); write DIR/results.csv")
    sweep.add_argument("sweep", type=Path, help="sweep file (TOML: base, [set], [grid], [zip], replicas, seed, keep)")
    sweep.add_argument("-o", "--output", type=Path, required=True, help="sweep folder DIR")
    sweep.add_argument("--workers", type=int, help="local worker processes (default: one per core)")
    sweep.add_argument("--scheduler", metavar="ADDRESS", help="a Dask scheduler, e.g. tcp://HOST:PORT, instead of local workers")
    sweep.add_argument("--retry-failed", action="store_true", help="run members that failed before again")
    sweep.add_argument("--quiet", action="store_true", help="no progress bar")
    sweep.set_defaults(func=_sweep)

    study = sub.add_parser("study", help="reproduce a figure of the paper: NAME.json, CSV, NAME.png, NAME.pdf")
    study.add_argument("name", choices=_study_names(), metavar="NAME",
                       help="one of: " + ", ".join(_study_names()))
    study.add_argument("-o", "--output", type=Path, default=Path("runs/studies"), help="output folder (default: runs/studies)")
    study.add_argument("--quick", action="store_true", help="a small version (fewer, shorter runs)")
    study.set_defaults(func=_study)

    info = sub.add_parser("info", help="LAMMPS version, packages, plugin status")
    info.set_defaults(func=_info)
    return p


def _case_args(p):
    p.add_argument("case", type=Path, help="case file (TOML, user units mm, g, ms, N, m/s)")
    p.add_argument("-o", "--output", type=Path, help="run folder (default: runs/<case name>)")
    p.add_argument("--set", action="append", default=[], metavar="SECTION.KEY=VALUE",
                   help="override a case field, e.g. --set impactor.velocity=1.5 (repeatable)")


def _load(args):
    from .case import load_case

    case = load_case(args.case, args.set)
    return case, args.output or Path("runs") / case.name


def _run(args) -> int:
    from .simulation import run_case

    case, folder = _load(args)
    if args.np > 1 and args.runner != "lmp":
        raise ConfigError("--np", f"got {args.np}; several ranks need --runner lmp")
    print(f"case {case.name}: {case.chain.particles} magnets, {case.run.steps()} steps -> {folder}", file=sys.stderr)
    summary = run_case(case, folder, runner=args.runner, nprocs=args.np, echo=not args.quiet)
    print(json.dumps(summary, indent=2))
    return 0


def _deck(args) -> int:
    from .runner import write_run_folder

    case, folder = _load(args)
    write_run_folder(case, folder)
    print(f"wrote {folder}/in.lattice; run it with: cd {folder} && lmp -in in.lattice")
    return 0


def _sweep(args) -> int:
    try:
        from .sweep import load_sweep, run_sweep, write_replica_stats

        sweep = load_sweep(args.sweep)
        table = run_sweep(sweep, args.output, workers=args.workers, scheduler=args.scheduler,
                          retry_failed=args.retry_failed, progress=not args.quiet)
    except KeyboardInterrupt:
        print(f"pylmp-lattice: interrupted; finished members are kept in {args.output}; "
              "run the same command to resume", file=sys.stderr)
        return EXIT_INTERRUPTED
    failed = int((table["status"] == "failed").sum())
    print(f"{len(table)} members: {len(table) - failed} done, {failed} failed; table {args.output / 'results.csv'}",
          file=sys.stderr)
    if sweep.replicas > 1:
        write_replica_stats(args.output, table)
        print(f"mean and standard error over replicas: {args.output / 'replica_stats.csv'} and .png", file=sys.stderr)
    return EXIT_RUN_ERROR if failed else 0


def _study_names() -> list[str]:
    from .studies import STUDIES

    return list(STUDIES)


def _study(args) -> int:
    from .studies import run_study

    result = run_study(args.name, args.output, quick=args.quick)
    print(f"study {result.name}: wrote {args.output}/{result.name}.json")
    return 0


def _info(args) -> int:
    from .engine import new_lammps

    lmp = new_lammps(["-screen", "none", "-log", "none"])
    print(f"LAMMPS {lmp.version()} ({'MPI' if lmp.has_mpi_support else 'serial'})")
    print("packages: " + " ".join(lmp.installed_packages))
    lmp.close()
    try:
        from .plugin import plugin_file, plugin_styles

        print(f"plugin: {plugin_file()} loads, styles: {', '.join(plugin_styles())}")
    except (ImportError, LatticeError, OSError) as err:
        print(f"plugin: not available ({err})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
