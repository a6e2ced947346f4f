"""Calibrate and check the preflight's file-size model against real runs (issue 19).

    python benchmarks/calibrate_preflight.py [--out DIR]

Runs small cases of different N, drives and output settings, measures every file of each
run folder, fits the motion-dependent constants of `preflight` (text: bytes more per line of a
moving and of an unevenly spaced magnet; H5MD: bytes per atom-frame moving and at rest, per
compression) by least squares, and prints a table of estimate / measured per file with the
current constants. The binary dump is measured before its conversion (LAMMPS run without
post-processing). Copy the fitted values into preflight/estimate.py when they move.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent.parent / "tests"))
from conftest import make_case  # noqa: E402

from pylmp_lattice import preflight  # noqa: E402
from pylmp_lattice.run_folder import RunFolder, layout, simulate  # noqa: E402
from pylmp_lattice.runner import run_embedded  # noqa: E402

CASES = {
    "40 moving, text": make_case(particles=40, duration=30.0, output={"format": "text"}),
    "200, text": make_case(particles=200, duration=30.0, output={"format": "text"}),
    "2000, text": make_case(particles=2000, duration=20.0, interval=1.0, output={"format": "text"}),
    "300 sine + fine, text": make_case(particles=300, duration=60.0, interval=0.5,
                                       impactor={"profile": "sine", "velocity": 2.0, "duration": 20.0},
                                       output={"format": "text", "fine": [2, 50, 100]}),
    "500 disorder, text": make_case(particles=500, duration=20.0, output={"format": "text"},
                                    chain={"mass_disorder": 0.01, "r0_disorder": 0.01, "seed": 2}),
    "40 moving, h5md lzf": make_case(particles=40, duration=30.0),
    "40 moving, h5md gzip": make_case(particles=40, duration=30.0, output={"compression": "gzip"}),
    "500 disorder, h5md lzf": make_case(particles=500, duration=20.0,
                                        chain={"mass_disorder": 0.01, "r0_disorder": 0.01, "seed": 2}),
    "2000, h5md lzf": make_case(particles=2000, duration=20.0, interval=0.5),
    "300 sine + fine, h5md lzf": make_case(particles=300, duration=60.0, interval=0.5,
                                           impactor={"profile": "sine", "velocity": 2.0, "duration": 20.0},
                                           output={"fine": [2, 50, 100]}),
    "500 disorder, h5md gzip": make_case(particles=500, duration=20.0, output={"compression": "gzip"},
                                         chain={"mass_disorder": 0.01, "r0_disorder": 0.01, "seed": 2}),
    "2000, h5md gzip": make_case(particles=2000, duration=20.0, interval=0.5, output={"compression": "gzip"}),
    "400, h5md none": make_case(particles=400, duration=20.0, output={"compression": "none"}),
}


def measure(case, folder: Path) -> dict[str, int]:
    """Every file's size: the binary dumps from a bare LAMMPS run, the rest from a full run."""
    sizes = {}
    if case.output.format == "h5md":
        raw = RunFolder.create(case, folder / "raw").path
        run_embedded(raw)
        sizes |= {name: (raw / name).stat().st_size for name in (layout.TRAJ_BIN, layout.FINE_BIN) if (raw / name).exists()}
    simulate(case, folder / "full", progress=False)
    sizes |= {p.name: p.stat().st_size for p in (folder / "full").iterdir()}
    return sizes


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path(tempfile.mkdtemp(prefix="calibrate-")))
    args = parser.parse_args()
    text_rows, text_rhs, h5md_rows = [], [], {}
    print(f"{'case':28} {'file':12} {'measured':>10} {'estimate':>10} {'ratio':>6}")
    for label, case in CASES.items():
        sizes = measure(case, args.out / label.replace(" ", "_").replace(",", ""))
        est = preflight.file_bytes(case)
        for name, value in est.items():
            if name in sizes:
                print(f"{label:28} {name:12} {sizes[name]:10d} {value:10.0f} {value / sizes[name]:6.3f}")
        sample = preflight._ChainSample(case)
        groups = [(layout.DUMP, preflight.frames(case), case.run.output_interval, None)]
        if case.output.fine:
            groups.append((layout.FINE_DUMP, preflight._fine_frames(case), case.fine_interval(),
                           np.asarray(case.output.fine)))
        if case.output.format == "text":
            for name, count, interval, atoms in groups:
                k = case.chain.particles if atoms is None else len(atoms)
                reached = sample.reached(count, interval, atoms)
                base = sample.text_bytes(count, interval, atoms) - reached * preflight.TEXT_MOVING_EXTRA \
                    - (count * k - reached) * sample.uneven * preflight.TEXT_UNEVEN_EXTRA
                text_rows.append([reached, (count * k - reached) * sample.uneven])
                text_rhs.append(sizes[name] - base)
        elif case.output.compression != "none":  # fit: bytes = reached m + uneven u + rest r + fixed
            row, fixed = np.zeros(2), preflight.H5MD_OVERHEAD
            for _, count, interval, atoms in groups:
                k = case.chain.particles if atoms is None else len(atoms)
                reached = sample.reached(count, interval, atoms)
                row += [reached, count * k - reached]
                fixed += preflight._h5md_group_bytes(case.output.compression, count, k, 0.0) \
                    - count * k * preflight.H5MD_BYTES[case.output.compression][1]
            h5md_rows.setdefault(case.output.compression, []).append((row, sizes[layout.H5MD] - fixed))
    fit = np.linalg.lstsq(np.array(text_rows), np.array(text_rhs), rcond=None)[0]
    print(f"\ntext: TEXT_MOVING_EXTRA = {fit[0]:.1f}, TEXT_UNEVEN_EXTRA = {fit[1]:.1f}")
    for compression, rows in h5md_rows.items():
        a = np.array([r for r, _ in rows])
        b = np.array([m for _, m in rows])
        fit = np.linalg.lstsq(a, b, rcond=None)[0]
        print(f"h5md {compression}: (moving, rest) = ({fit[0]:.1f}, {fit[1]:.1f})")


if __name__ == "__main__":
    main()
