"""The main job before and after the compact output, and what output costs against the engine.

Table 1: `pylmp-lattice run inputs/paper_long_lattice.toml` end to end (wall time of the whole
command, as a user waits for it), with this package and with an older one installed in another
environment (--before: its Python), run alternately, best of --repeat; and the summary numbers of
both. Table 2: the main case run once on the chain engine (the default) for each output in
OUTPUTS (the main job's own, and every magnet every 0.1 ms as the older run wrote), timed stage
by stage: the engine's compute (LAMMPS's loop time without its Output section), LAMMPS writing
the binary frames (Output); then those frames turned into H5MD with each compression, and every
group read back whole; with the file sizes against the text dump of the older run. The stock
engine's compute is measured once for reference.

    git worktree add /tmp/before 884f0d8 && python3 -m venv /tmp/before/.venv \\
        && /tmp/before/.venv/bin/pip install /tmp/before
    python benchmarks/bench_output.py --before /tmp/before/.venv/bin/python [--repeat 3]

Each side runs the main job as its own checkout defines it (inputs/paper_long_lattice.toml):
at 884f0d8 a text dump of every magnet every 0.1 ms; now the output the figure needs.
"""

from __future__ import annotations

import argparse
import json
import re
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import h5py  # noqa: F401 - imported once here, so that the first conversion timed does not pay for it

import tomli_w

from pylmp_lattice.case import COMPRESSIONS, case_to_dict, load_case
from pylmp_lattice.run_folder import RunFolder
from pylmp_lattice.runner import run_embedded

CASE = Path(__file__).resolve().parent.parent / "inputs" / "paper_long_lattice.toml"
BEFORE = "884f0d8"  # the commit issue 6 measured from
# The main job's output as its input file asks (whole chain every 1 ms, four magnets every
# 0.1 ms), and the whole chain every 0.1 ms as at 884f0d8.
OUTPUTS = {"main job's": [], "every magnet every 0.1 ms": ["run.output_interval=0.1", "output.fine=[]"]}
KEYS = (("shock_velocity_plateau_m_per_s", "mean"), ("first_peak_velocity_plateau_m_per_s", "mean"),
        ("first_peak_velocity_over_V_I", None), ("linear_wave_speed_V0_m_per_s", None))


def end_to_end(python: str, case: Path, folder: Path) -> tuple[float, dict]:
    """Wall time of the CLI's main job in a fresh process, and its summary. The environment's own
    `pylmp-lattice` script, run outside the source tree, imports that environment's package."""
    cli = [str(Path(python).parent / "pylmp-lattice"), "run", str(case), "-o", str(folder), "--quiet"]
    start = time.perf_counter()
    subprocess.run(cli, check=True, cwd=folder.parent, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    return time.perf_counter() - start, json.loads((folder / "summary.json").read_text())


def engine_run(folder: Path, overrides: list[str]) -> tuple[float, float]:
    """One run of the main case with `overrides`, without conversion: (compute, LAMMPS output) in s."""
    run_embedded(RunFolder.create(load_case(CASE, overrides), folder).path)
    log = (folder / "log.lammps").read_text()
    loop = float(re.search(r"Loop time of (\S+)", log).group(1))
    output = float(re.search(r"^Output\s*\|\s*(\S+)", log, re.MULTILINE).group(1))
    return loop - output, output


def conversion(folder: Path, overrides: list[str], compression: str) -> dict:
    """The run's binary frames turned into H5MD with `compression`, and every group read back
    whole (s, bytes)."""
    case = load_case(CASE, overrides + [f'output.compression="{compression}"'])
    target = folder.parent / f"{folder.name}-{compression}"
    target.mkdir()
    for name in ("traj.bin", "fine.bin", "case.toml", "run.json", "log.lammps"):
        if (folder / name).exists():
            shutil.copy(folder / name, target / name)
    start = time.perf_counter()
    (target / "case.toml").write_bytes(tomli_w.dumps(case_to_dict(case)).encode())
    RunFolder(target).convert()
    convert = time.perf_counter() - start
    start = time.perf_counter()
    frames = len(RunFolder(target).trajectory().t)
    if case.output.fine:
        RunFolder(target).trajectory("fine")
    return {"convert": convert, "read": time.perf_counter() - start, "frames": frames,
            "bytes": (target / "traj.h5md").stat().st_size}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--before", required=True, help="Python of an environment with the older package")
    parser.add_argument("--before-case", type=Path, default=None,
                        help="the main job's input in the older checkout (default: beside --before's venv)")
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    cases = {"before": args.before_case or Path(args.before).parent.parent.parent / "inputs" / CASE.name,
             "after": CASE}
    times = {"before": [], "after": []}
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        for k in range(args.repeat):  # alternate, so that the machine's load hits both alike
            for label, python in (("before", args.before), ("after", sys.executable)):
                seconds, summary = end_to_end(python, cases[label], tmp / f"{label}{k}")
                times[label].append(seconds)
                if k == 0:
                    times[label + "_summary"] = summary
                    times[label + "_folder"] = tmp / f"{label}{k}"
        text_bytes = (times["before_folder"] / "traj.dump").stat().st_size
        stock = engine_run(tmp / "stock", ['run.engine="stock"'])
        outputs = {}
        for label, overrides in OUTPUTS.items():
            folder = tmp / label.split()[0]
            compute, write = engine_run(folder, overrides)
            outputs[label] = (compute, write, {c: conversion(folder, overrides, c) for c in COMPRESSIONS})
    before, after = min(times["before"]), min(times["after"])
    print(f"Main job end to end ({CASE.name}), best of {args.repeat}, seconds")
    print(f"| before | after | speed-up |\n|---|---|---|\n| {before:.2f} | {after:.2f} | {before / after:.1f}x |")
    print("\nSummary numbers, before and after")
    print("| quantity | before | after | relative difference |\n|---|---|---|---|")
    for key, sub in KEYS:
        b, a = times["before_summary"][key], times["after_summary"][key]
        b, a = (b[sub], a[sub]) if sub else (b, a)
        print(f"| {key}{'.' + sub if sub else ''} | {b} | {a} | {abs(a - b) / abs(b):.1e} |")
    print(f"\nOutput against the engine (chain engine, front record on; stock engine's compute "
          f"{stock[0]:.2f} s), seconds: LAMMPS writes binary frames, they become H5MD, every group is "
          f"read back; sizes against the text dump of the main job at {BEFORE} ({text_bytes / 1e6:.1f} MB)")
    print("| output | chain compute | compression | write | to H5MD | read back | write + read "
          "| / chain compute | / stock compute | MB | / text |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for label, (compute, write, by_compression) in outputs.items():
        for c, o in by_compression.items():
            io = write + o["convert"] + o["read"]
            print(f"| {label} ({o['frames']} frames) | {compute:.3f} | {c} | {write:.3f} | {o['convert']:.3f} "
                  f"| {o['read']:.3f} | {io:.3f} | {io / compute:.2f} | {io / stock[0]:.2f} "
                  f"| {o['bytes'] / 1e6:.1f} | {o['bytes'] / text_bytes:.3f} |")


if __name__ == "__main__":
    main()
