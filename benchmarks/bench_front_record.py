"""Cost of the front record in a sweep's batch: many short chains in one LAMMPS instance.

The batch a sweep runs (sweep/batch.py): --members replicas of the 21-magnet experiment
(inputs/paper_experiment.toml, 60 ms = 4800 steps, friction) with 0.02 m/s thermal velocities,
as one deck (deck.render_replicas(cases, front=True)); --frictionless drops the [friction]
section, as bench_sweep.py's variant does. Its deck is run in this process, best of
--repeat, alternating:
  - with the front record (fix lattice/front, as the sweep runs it) and without it (the fix
    and the dump of its record removed): LAMMPS's Loop time and this thread's CPU time in
    `run` (which a busy machine inflates less than wall time);
  - the whole deck through runner.run_deck, as the sweep calls it: its wall time beyond the
    Loop time (instance, read_data, setup, the record's dump, each chain's friction work).

    python benchmarks/bench_front_record.py [--members 500] [--repeat 3] [--frictionless]
"""

from __future__ import annotations

import argparse
import os
from datetime import datetime, timezone
import re
import tempfile
import time
from pathlib import Path

import tomli_w
import tomllib

from pylmp_lattice import deck as decks
from pylmp_lattice import engine
from pylmp_lattice.runner import run_deck
from pylmp_lattice.sweep import load_sweep

BASE = Path(__file__).resolve().parent.parent / "inputs" / "paper_experiment.toml"
THERMAL = 0.02  # m/s, the members' thermal velocity RMS


def batch_files(members: int, friction: bool, tmp: Path) -> dict[str, str]:
    """The files of the batch deck of `members` thermal replicas of the experiment."""
    base = tomllib.loads(BASE.read_text())
    if not friction:
        base.pop("friction")
    (tmp / "base.toml").write_text(tomli_w.dumps(base))
    (tmp / "sweep.toml").write_text(f'base = "base.toml"\nreplicas = {members}\nseed = 2026\nkeep = "measures"\n'
                                    f'[set]\n"chain.thermal_velocity" = {THERMAL}\n')
    cases = [member.case for member in load_sweep(tmp / "sweep.toml").iter_members()]
    return decks.render_replicas(cases, front=True)


def without_record(deck: str) -> str:
    return re.sub(r"^(fix +front .*|write_dump .*)$", "", deck, flags=re.MULTILINE)


def write(files: dict[str, str], folder: Path) -> Path:
    folder.mkdir()
    for name, text in files.items():
        (folder / name).write_text(text)
    return folder


def loop_times(folder: Path, deck: str) -> tuple[float, float]:
    """LAMMPS's Loop time and this thread's CPU time in `run` (s) of the deck up to its run."""
    before, run, _ = re.split(r"^(run +\d+)$", deck, maxsplit=1, flags=re.MULTILINE)
    log = folder / "log.lammps"
    with engine.instance(["-log", str(log), "-screen", "none", "-var", "dir", str(folder)]) as lmp:
        lmp.commands_string(before)
        cpu = time.thread_time()
        lmp.command(run)
        cpu = time.thread_time() - cpu
    return float(re.search(r"Loop time of (\S+)", log.read_text()).group(1)), cpu


def outside_loop(folder: Path) -> float:
    """Wall time of runner.run_deck beyond LAMMPS's Loop time (s)."""
    start = time.perf_counter()
    run_deck(folder)
    wall = time.perf_counter() - start
    return wall - float(re.search(r"Loop time of (\S+)", (folder / "log.lammps").read_text()).group(1))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--members", type=int, default=500)
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--frictionless", action="store_true")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        files = batch_files(args.members, not args.frictionless, Path(tmp))
        full = files[decks.DECK]
        runs = {"with": full, "without": without_record(full)}
        best = {name: (float("inf"), float("inf")) for name in runs}
        rest = float("inf")
        run_deck(write(files, Path(tmp) / "warm-up"))  # the first instance of a process loads MPI and the plugin
        for rep in range(args.repeat):
            for name, deck in runs.items():
                loop, cpu = loop_times(write(files, Path(tmp) / f"{name}-{rep}"), deck)
                best[name] = (min(best[name][0], loop), min(best[name][1], cpu))
            rest = min(rest, outside_loop(write(files, Path(tmp) / f"run_deck-{rep}")))
    (loop_on, cpu_on), (loop_off, cpu_off) = best["with"], best["without"]
    print(f"{args.members} chains x 21 magnets x 4800 steps, thermal {THERMAL} m/s, "
          f"{'no friction' if args.frictionless else 'friction'}; best of {args.repeat}; "
          f"{datetime.now(timezone.utc):%Y-%m-%d %H:%M} UTC, load average {os.getloadavg()[0]:.2f}")
    print("| front record | Loop time (s) | CPU in run (s) |\n|---|---|---|")
    print(f"| without | {loop_off:.3f} | {cpu_off:.3f} |")
    print(f"| with | {loop_on:.3f} | {cpu_on:.3f} |")
    print(f"| ratio | {loop_on / loop_off:.2f} | {cpu_on / cpu_off:.2f} |")
    print(f"\nrun_deck beyond the Loop time (instance, read_data, setup, dump, friction work): {rest:.3f} s")


if __name__ == "__main__":
    main()
