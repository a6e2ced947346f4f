"""The worker's Python per batched member: one task of a thermal ensemble, in this process.

A task of --members replicas of inputs/paper_experiment.toml (21 magnets, 60 ms, 4800 steps,
chain.thermal_velocity = --thermal m/s, keep = "measures"; --disorder: with the shipped thermal
example's mass and gap disorder) runs as one batch through `sweep.batch.run_task`, as a pool
worker runs it (its replicas as the coordinator sends them: `Sweep.iter_runs`). Each stage is timed by wrapping the function
that does it (wall time, perf_counter; see --clock):

    cases      spec.member_cases: the members' cases (a point's replicas share its first)
    render     deck.render_replicas: the deck, the chains' data file and levels
    engine     runner.run_deck: LAMMPS (its own Loop time from log.lammps beside it); with
               --engine cpu, engines.cpu.run_arrays: the chain kernel on --threads cores
    record     case_measures.read_front_batch: the front record and the drive's measures
    summaries  summary.summary_columns (summary.summaries before): every member's summary
    store      store.write_table (store.write_batch before): members.json and members.arrow
    other      the task's wall time minus all of the above (folders, files, bookkeeping)

Python = task - engine. --clock cpu times with this process's CPU time (all its threads:
the engine's too) instead of wall time, which other processes on a loaded machine disturb less. A warm-up task of 5 members runs first (imports, caches: a pool worker
has them after its first task). Both variants: the case as shipped (friction) and without.
On an older tree (e.g. the reference commit, run with its own environment) the stages it lacks
show "-" and count in "other".

    python benchmarks/bench_batch_python.py [--members 500] [--thermal 0.02] [--repeat 3] [--engine lammps|cpu] [--threads 1] [--clock wall|cpu] [--disorder]
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import sys
import tempfile
import time
from datetime import datetime, timezone
from pathlib import Path


from pylmp_lattice import case_measures, deck, runner, summary
from pylmp_lattice.engines import cpu
from pylmp_lattice.sweep import batch, load_sweep, store
from pylmp_lattice.sweep.spec import Replicas

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_sweep import write_sweep  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
CASE = ROOT / "inputs" / "paper_experiment.toml"
# (label, module, attribute): the functions timed, where the task looks them up
STAGES = [("cases", batch, "member_cases"), ("render", deck, "render_replicas"), ("engine", runner, "run_deck"),
          ("record", case_measures, "read_front_batch"), ("summaries", summary, "summaries"),
          ("summaries", summary, "summary_columns"), ("store", batch, "write_batch"), ("store", batch, "write_table")]
# (a stage's function by its name on older trees: summaries and write_batch; a tree has one or the other)


def task(folder: Path, members: int, thermal: float, friction: bool, engine: str = "lammps",
         threads: int | None = None, disorder: bool = False) -> batch.Task:
    folder.mkdir(parents=True)
    write_sweep(folder, members, thermal, friction, disorder=disorder)
    sweep = load_sweep(folder / "sweep.toml")
    root = folder / "out"
    (root / store.MEMBERS).mkdir(parents=True)
    return batch.Task(str(root), tuple(part for run in sweep.iter_runs() for part in  # as the coordinator sends them:
                                       ([run] if isinstance(run, Replicas) else run)),  # a point's replicas as columns
                      sweep.runner, engine, threads)


CLOCK = time.perf_counter


def timed_run(t: batch.Task) -> dict[str, float]:
    """Run the task with its stages timed; seconds per stage, the task's and the engine's Loop."""
    engine = ("engine", cpu, "run_arrays") if t.engine == "cpu" else ("engine", runner, "run_deck")
    stages = [(label, module, name) for label, module, name in STAGES[:2] + [engine] + STAGES[3:]
              if hasattr(module, name)  # (an older tree)
              and not (name == "summaries" and hasattr(module, "summary_columns"))]
    spent = {label: 0.0 for label, *_ in stages}
    originals = [(module, name, getattr(module, name)) for _, module, name in stages]

    def wrap(label, fn):
        def timed(*args, **kwargs):
            start = CLOCK()
            try:
                return fn(*args, **kwargs)
            finally:
                spent[label] += CLOCK() - start
        return timed

    for (label, module, name), (_, _, fn) in zip(stages, originals):
        setattr(module, name, wrap(label, fn))
    try:
        start = CLOCK()
        results = batch.run_task(t)
        spent["task"] = CLOCK() - start
    finally:
        for module, name, fn in originals:
            setattr(module, name, fn)
    if isinstance(results[0], dict):  # a tree before table.Rows: a result per member
        assert {r["record"]["status"] for r in results} == {"done"} and "batch" in results[0]["record"], "not batched"
    else:  # the batch's rows (`table.Rows`), and no member alone (a `batch.Note` says why not)
        notes = [r.text for r in results if hasattr(r, "text")]
        assert len(results) == 1 and set(results[0].columns["status"]) == {"done"}, f"not batched {notes}"
    [log] = Path(t.root).glob(f"{store.BATCHES}/*/log.lammps")
    loop = re.search(r"Loop time of (\S+)", log.read_text())  # (LAMMPS's; none for the kernel)
    spent["loop"] = float(loop[1]) if loop else float("nan")
    return spent


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--members", type=int, default=500)
    parser.add_argument("--thermal", type=float, default=0.02)
    parser.add_argument("--repeat", type=int, default=3, help="tasks per variant; the fastest is shown")
    parser.add_argument("--engine", choices=("lammps", "cpu"), default="lammps", help="the batches' engine")
    parser.add_argument("--threads", type=int, default=1, help="the cpu engine's cores (a sweep's worker: cores / workers)")
    parser.add_argument("--clock", choices=("wall", "cpu"), default="wall", help="wall time, or this process's CPU time")
    parser.add_argument("--disorder", action="store_true", help="with the shipped thermal example's mass and gap disorder")
    args = parser.parse_args()
    global CLOCK
    CLOCK = time.process_time if args.clock == "cpu" else time.perf_counter
    work = Path(tempfile.mkdtemp(prefix="bench_batch_python_"))
    try:
        timed_run(task(work / "warm", 5, args.thermal, True, args.engine, args.threads, args.disorder))
        rows = {}
        for friction in (True, False):
            runs = [timed_run(task(work / f"{friction}{k}", args.members, args.thermal, friction, args.engine, args.threads,
                                   args.disorder))
                    for k in range(args.repeat)]
            rows["friction" if friction else "frictionless"] = min(runs, key=lambda r: r["task"] - r["engine"])
    finally:
        shutil.rmtree(work, ignore_errors=True)
    print(f"# {datetime.now(timezone.utc):%Y-%m-%d %H:%M} UTC, load average {os.getloadavg()[0]:.2f}; "
          f"{args.members} members of {CASE.name}, thermal {args.thermal} m/s"
          f"{', mass and gap disorder' if args.disorder else ''}, engine {args.engine}, "
          f"fastest of {args.repeat}")
    n = args.members
    labels = list(dict.fromkeys(label for label, *_ in STAGES if label != "engine"))
    print(f"{'variant':<13}" + "".join(f"{label:>10}" for label in labels)
          + f"{'other':>9}{'Python':>9}  {'engine s':>9}{'(Loop)':>8}{'task s':>8}")
    print(f"{'':<13}" + "".join(f"{'ms/member':>10}" for _ in labels) + f"{'':>9}{'ms/memb':>9}")
    for variant, r in rows.items():
        python = r["task"] - r["engine"]
        other = python - sum(r.get(label, 0.0) for label in labels)
        print(f"{variant:<13}" + "".join(f"{1e3 * r[label] / n:>10.3f}" if label in r else f"{'-':>10}" for label in labels)
              + f"{1e3 * other / n:>9.3f}{1e3 * python / n:>9.3f}  {r['engine']:>9.3f}{r['loop']:>8.3f}{r['task']:>8.3f}")


if __name__ == "__main__":
    main()
