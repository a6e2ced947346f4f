"""Time the two dump readers on the same LAMMPS dump and check that they agree.

    PYTHONPATH=. python benchmarks/bench_readers.py [--atoms 1000] [--frames 2000] [--dump FILE]

Without --dump, LAMMPS writes a dump of a harmonic chain with random (thermal-like) velocities,
so that every x, vx, fx value carries 12 digits as in a real shock run.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from dataclasses import fields
from pathlib import Path

import numpy as np

from pylmp_lattice.formats.dump import DUMP_COLUMNS, READERS, read_dump
from pylmp_lattice.engine import new_lammps


def write_chain_dump(path: Path, n_atoms: int, n_frames: int) -> None:
    spacing = 0.01  # m
    lmp = new_lammps(["-screen", "none", "-log", "none"])
    try:
        lmp.commands_string(
            f"""
            units si
            atom_style bond
            boundary s f f
            region box block 0 {n_atoms * spacing} -0.01 0.01 -0.01 0.01
            create_box 1 box bond/types 1 extra/bond/per/atom 2
            mass 1 0.002
            """
        )
        lmp.commands_list([f"create_atoms 1 single {(i + 0.1) * spacing} 0 0" for i in range(n_atoms)])
        lmp.commands_list([f"create_bonds single/bond 1 {i} {i + 1}" for i in range(1, n_atoms)])
        lmp.commands_string(
            f"""
            bond_style harmonic
            bond_coeff 1 50.0 {spacing}
            velocity all create 1.45e20 4928 dist gaussian
            velocity all set NULL 0 0
            fix nve all nve
            timestep 1e-5
            dump traj all custom 1 {path} {DUMP_COLUMNS}
            dump_modify traj sort id time yes format float %.12g
            run {n_frames - 1}
            """
        )
    finally:
        lmp.close()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--atoms", type=int, default=1000)
    parser.add_argument("--frames", type=int, default=2000)
    parser.add_argument("--dump", type=Path, help="an existing dump to read instead")
    args = parser.parse_args()

    with tempfile.TemporaryDirectory() as tmp:
        path = args.dump
        if path is None:
            path = Path(tmp) / "traj.dump"
            start = time.perf_counter()
            write_chain_dump(path, args.atoms, args.frames)
            print(f"LAMMPS wrote {path.stat().st_size / 1e6:.0f} MB in {time.perf_counter() - start:.1f} s")

        seconds, results = {}, {}
        for reader in READERS:
            start = time.perf_counter()
            results[reader] = read_dump(path, reader=reader)
            seconds[reader] = time.perf_counter() - start

    reference = results["mdanalysis"]
    for reader, frames in results.items():
        for field in fields(frames):
            if not np.array_equal(getattr(frames, field.name), getattr(reference, field.name)):
                raise SystemExit(f"{reader} and mdanalysis differ in {field.name}")
    n_frames, n_atoms = reference.x.shape
    print(f"{n_frames} frames x {n_atoms} atoms; both readers give identical arrays")
    print(f"{'reader':<12} {'seconds':>8} {'frames/s':>10} {'atom-frames/s':>14} {'ratio':>6}")
    for reader, s in seconds.items():
        ratio = seconds["mdanalysis"] / s
        print(f"{reader:<12} {s:8.2f} {n_frames / s:10.0f} {n_frames * n_atoms / s:14.3g} {ratio:6.1f}")


if __name__ == "__main__":
    main()
