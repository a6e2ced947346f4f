"""The main job before and after the compact output, and what output costs against the engine.

Table 1: `pylmp-lattice run inputs/paper_long_lattice.toml` end to end (wall time of the whole
command, as a user waits for it), with this package and with an older one installed in another
environment (--before: its Python), run alternately, best of --repeat; and the summary numbers of
both. Table 2: one run of the same case through the package's layers, timed stage by stage:
the engine's compute (LAMMPS's loop time without its Output section), LAMMPS writing the binary
frames (Output), turning them into H5MD, and reading the whole trajectory back; and the file
sizes, against the text dump of the older run.

    git worktree add /tmp/before 884f0d8 && python3 -m venv /tmp/before/.venv \\
        && /tmp/before/.venv/bin/pip install /tmp/before
    python benchmarks/bench_output.py --before /tmp/before/.venv/bin/python [--repeat 3]
"""

from __future__ import annotations

import argparse
import json
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from pylmp_lattice.case import load_case
from pylmp_lattice.h5md import convert_run
from pylmp_lattice.runner import run_embedded, write_run_folder
from pylmp_lattice.simulation import load_trajectory

CASE = Path(__file__).resolve().parent.parent / "inputs" / "paper_long_lattice.toml"
KEYS = (("shock_velocity_plateau_m_per_s", "mean"), ("first_peak_velocity_plateau_m_per_s", "mean"),
        ("first_peak_velocity_over_V_I", None), ("linear_wave_speed_V0_m_per_s", None))


def end_to_end(python: str, folder: Path) -> tuple[float, dict]:
    """Wall time of the CLI's main job in a fresh process, and its summary. The environment's own
    `pylmp-lattice` script, run outside the source tree, imports that environment's package."""
    cli = [str(Path(python).parent / "pylmp-lattice"), "run", str(CASE), "-o", str(folder), "--quiet"]
    start = time.perf_counter()
    subprocess.run(cli, check=True, cwd=folder.parent, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    return time.perf_counter() - start, json.loads((folder / "summary.json").read_text())


def stages(folder: Path) -> dict:
    """One run of the main case, timed layer by layer (seconds), and its file sizes (bytes)."""
    case = load_case(CASE)
    run_embedded(write_run_folder(case, folder))
    log = (folder / "log.lammps").read_text()
    loop = float(re.search(r"Loop time of (\S+)", log).group(1))
    output = float(re.search(r"^Output\s*\|\s*(\S+)", log, re.MULTILINE).group(1))
    binary = (folder / "traj.bin").stat().st_size
    start = time.perf_counter()
    convert_run(case, folder)
    convert = time.perf_counter() - start
    start = time.perf_counter()
    traj = load_trajectory(case, folder)
    read = time.perf_counter() - start
    return {"compute": loop - output, "lammps_output": output, "convert": convert, "read": read,
            "frames": len(traj.t), "binary_bytes": binary, "h5md_bytes": (folder / "traj.h5md").stat().st_size}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--before", required=True, help="Python of an environment with the older package")
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    times = {"before": [], "after": []}
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        for k in range(args.repeat):  # alternate, so that the machine's load hits both alike
            for label, python in (("before", args.before), ("after", sys.executable)):
                seconds, summary = end_to_end(python, tmp / f"{label}{k}")
                times[label].append(seconds)
                if k == 0:
                    times[label + "_summary"] = summary
                    times[label + "_folder"] = tmp / f"{label}{k}"
        text_bytes = (times["before_folder"] / "traj.dump").stat().st_size
        s = stages(tmp / "stages")

    before, after = min(times["before"]), min(times["after"])
    print(f"Main job end to end ({CASE.name}), best of {args.repeat}, seconds")
    print(f"| before | after | speed-up |\n|---|---|---|\n| {before:.2f} | {after:.2f} | {before / after:.1f}x |")
    print("\nSummary numbers, before and after")
    print("| quantity | before | after | relative difference |\n|---|---|---|---|")
    for key, sub in KEYS:
        b, a = times["before_summary"][key], times["after_summary"][key]
        b, a = (b[sub], a[sub]) if sub else (b, a)
        print(f"| {key}{'.' + sub if sub else ''} | {b} | {a} | {abs(a - b) / abs(b):.1e} |")
    io = s["lammps_output"] + s["convert"] + s["read"]
    print(f"\nOutput against the engine, one run ({s['frames']} frames of 301 magnets), seconds")
    print("| engine compute | LAMMPS writes binary | to H5MD | read back | write + read | (write + read) / compute |")
    print("|---|---|---|---|---|---|")
    print(f"| {s['compute']:.2f} | {s['lammps_output']:.2f} | {s['convert']:.2f} | {s['read']:.2f} | {io:.2f} "
          f"| {io / s['compute']:.2f} |")
    print("\nTrajectory size, MB")
    print(f"| text dump (before) | binary frames | H5MD | H5MD / text |\n|---|---|---|---|\n"
          f"| {text_bytes / 1e6:.1f} | {s['binary_bytes'] / 1e6:.1f} | {s['h5md_bytes'] / 1e6:.1f} "
          f"| {s['h5md_bytes'] / text_bytes:.3f} |")


if __name__ == "__main__":
    main()
