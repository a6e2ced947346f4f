"""A sweep's start-up: the command to its first member's start (issue 28: within 0.3 s for a
1000-member ensemble), as wall time and as the CPU of the two paths that lead to it, which a
loaded machine stretches less than the wall time.

The first member starts once two things have happened, side by side on idle cores: the command
(the coordinator) has read its arguments, started the workers' fork server, imported the sweep's
modules, read the sweep file, checked the disk, claimed the folder and enumerated and sent the
first task; and the fork server (a fresh Python started after the arguments are read) has
imported the package once (`pool.PRELOAD`; LAMMPS's libraries with engine lammps) and forked
the worker. Each run of `pylmp-lattice sweep` (--members thermal replicas of the 21-magnet
experiment with friction, --workers 2; engines interleaved) reports:

- start-up, wall: the command to the first member's "started", as bench_sweep.py measures it;
- S: the command's CPU when it starts the fork server; C: its CPU when it sends the first task;
  F: the fork server's CPU (its imports, and the forks of the workers);
- on idle cores the start-up would be about max(C, S + F), plus the worker's own start (forked,
  its task unpickled: a few tens of ms, not counted here).

The command runs with `--quiet` as the `pylmp-lattice` script runs it (`DRIVER`, a script, which
each worker runs again, as multiprocessing does a main script), noting S and C; and, for
reference, the CPU of Python and numpy's import in a fresh Python, best of --repeat, in the same
run.

With --reference COMMIT it also runs that commit's package, interleaved with this tree's (run by
run, engine by engine), so that both see the same load. Both then run from copies in the
temporary folder, the installed compiled libraries and Python's bytecode beside their sources,
as an installed package has them (neither compiles its sources on the way).

    python benchmarks/bench_startup.py [--members 1000] [--repeat 5] [--engines cpu,lammps] [--dir /tmp]
                                       [--reference main]
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
from datetime import datetime, timezone
from pathlib import Path

from bench_sweep import ROOT, import_cpu, run_sweep_command, write_sweep

# The pylmp-lattice script (pip's console script: it imports the command line, then runs it under
# the main guard; the workers run it again, as multiprocessing does a main script), noting S and C.
DRIVER = """import sys

from pylmp_lattice.cli import main

if __name__ == "__main__":
    import json, os, time
    from multiprocessing import forkserver
    from pylmp_lattice.sweep import pool
    marks, submit, start = {}, pool.Pool.submit, pool.start_forkserver
    def first_submit(self, task):
        marks.setdefault("C", time.process_time())
        return submit(self, task)
    def starting(*args, **kwargs):
        marks.setdefault("S", time.process_time())
        return start(*args, **kwargs)
    pool.Pool.submit, pool.start_forkserver = first_submit, starting
    code = main(sys.argv[1:])
    with open(f"/proc/{forkserver._forkserver._forkserver_pid}/stat") as f:
        marks["F"] = sum(map(int, f.read().rsplit(")", 1)[1].split()[11:13])) / os.sysconf("SC_CLK_TCK")
    print("startup-marks " + json.dumps(marks), file=sys.stderr)
    sys.exit(code)
"""


def tree_copy(commit: str | None, folder: Path) -> Path:
    """The package at `commit` (None: this tree's files as they are), with the installed compiled
    libraries and the bytecode of its sources, in `folder`."""
    folder.mkdir(parents=True)
    if commit is None:
        files = subprocess.run(["git", "-C", str(ROOT), "ls-files", "-z", "pylmp_lattice"], check=True,
                               capture_output=True).stdout.decode().split("\0")
        for name in filter(None, files):
            (folder / name).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(ROOT / name, folder / name)
    else:
        archive = subprocess.run(["git", "-C", str(ROOT), "archive", commit, "pylmp_lattice"], check=True,
                                 capture_output=True).stdout
        subprocess.run(["tar", "-x", "-C", str(folder)], input=archive, check=True)
    from pylmp_lattice.plugin import ENGINE, LIBRARY, library_file

    for name in (LIBRARY, ENGINE):
        shutil.copy2(library_file(name), folder / "pylmp_lattice" / "plugin" / name)
    subprocess.run([sys.executable, "-m", "compileall", "-q", str(folder / "pylmp_lattice")], check=True,
                   env=os.environ | {"PYTHONDONTWRITEBYTECODE": ""}, stdout=subprocess.DEVNULL)
    return folder


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--members", type=int, default=1000)
    p.add_argument("--repeat", type=int, default=5)
    p.add_argument("--engines", default="cpu,lammps")
    p.add_argument("--dir", type=Path, default=ROOT, help="where the sweeps write (a temporary folder inside it)")
    p.add_argument("--reference", metavar="COMMIT", help="also run this commit's package, interleaved with this tree's")
    args = p.parse_args()
    engines = args.engines.split(",")
    args.dir.mkdir(parents=True, exist_ok=True)  # (a folder named for this run: made, not a traceback)
    load = [os.getloadavg()[0]]
    floor = {"Python": import_cpu(["sys"], args.repeat), "numpy": import_cpu(["numpy"], args.repeat)}
    with tempfile.TemporaryDirectory(dir=args.dir, prefix=".bench_startup.") as tmp:
        trees = ({"this tree": tree_copy(None, Path(tmp) / "this"),
                  args.reference: tree_copy(args.reference, Path(tmp) / "reference")} if args.reference
                 else {"this tree": None})
        runs = {(t, e): [] for t in trees for e in engines}
        sweep = write_sweep(Path(tmp), args.members, 0.02, friction=True)
        driver = Path(tmp) / "pylmp-lattice"
        driver.write_text(DRIVER)
        run_sweep_command(sweep, Path(tmp) / "warm-up", 2, engines[0])  # the libraries read from disk once
        for k in range(args.repeat):
            for e in engines:
                for i, (t, tree) in enumerate(trees.items()):
                    load.append(os.getloadavg()[0])
                    env = dict(os.environ)
                    if tree is not None:
                        os.environ["PYTHONPATH"] = str(tree)
                    try:
                        s = run_sweep_command(sweep, Path(tmp) / f"{e}-{k}-{i}", 2, e,
                                              [sys.executable, str(driver)])
                    finally:
                        os.environ.clear()
                        os.environ.update(env)
                    marks = json.loads(s["stderr"].split("startup-marks ")[-1].splitlines()[0])
                    runs[t, e].append({"wall": s["startup"], **marks, "idle": max(marks["C"], marks["S"] + marks["F"])})
    load.append(os.getloadavg()[0])
    print(f"{datetime.now(timezone.utc):%Y-%m-%d %H:%M} UTC; {os.cpu_count()} cores; load average {min(load):.1f}-"
          f"{max(load):.1f}; {args.members} members of the 21-magnet experiment with friction, 2 workers; "
          f"medians of {args.repeat} runs (least in brackets), seconds")
    print("| tree | engine | start-up, wall | S: command, fork server started (CPU) "
          "| C: command, first task sent (CPU) | F: fork server (CPU) | max(C, S + F) |")
    print("|---|---|---|---|---|---|---|")
    for (t, e), rs in runs.items():
        cells = [f"{statistics.median(r[k] for r in rs):.3f} ({min(r[k] for r in rs):.3f})"
                 for k in ("wall", "S", "C", "F", "idle")]
        print(f"| {t} | {e} | " + " | ".join(cells) + " |")
    print(f"In a fresh Python, CPU, best of {args.repeat}: Python alone {floor['Python']:.3f} s, "
          f"importing numpy {floor['numpy']:.3f} s.")


if __name__ == "__main__":
    main()
