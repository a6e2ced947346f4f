"""What a run will need before it runs: its output size, memory and time on this machine
(`estimate`, `Estimate`; `file_bytes`, `frames`).

The estimates are linear models calibrated on this project's 2-core machine: each constant
below says on what (file sizes by `benchmarks/calibrate_preflight.py`); docs/guide.md, "A run
you can trust", sums them up. They lean high, and are meant to catch runs that are off by orders of magnitude, not to
predict to the second. `output_bytes` is the one place that knows what each output format
costs on disk.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass

import numpy as np

from ..case import Case, as_case
from ..deck import atom_types, per_atom_masses, records_front, uses_chain_engine
from ..errors import require_bool
from ..exact import weak_shock
from .. import overhead
from ..formats.layout import DATA, DUMP, FINE_BIN, FINE_DUMP, FRONT_BIN, H5MD, SECOND_TABLE, TABLE, TRAJ_BIN
from ..table import bond_table
from ..units import to_engine

# Sizes on disk, from the formats themselves where they are fixed, and calibrated (on this
# machine, 2026-11-24, `python benchmarks/calibrate_preflight.py`, which prints these values)
# where they depend on the motion:
# - text dump (%.12g, 12 columns): a line at rest is formatted exactly (id, type, mass, x, eight
#   "0"); a magnet the wave has reached writes TEXT_MOVING_EXTRA bytes more (x, vx, fx at 12
#   digits); a magnet whose two initial gaps differ in the last bit (rounding of the positions in
#   the data file) feels a force of ~1e-15 N from the start and writes TEXT_UNEVEN_EXTRA more.
TEXT_MOVING_EXTRA = 31.9
TEXT_UNEVEN_EXTRA = 36.7
# Header of a text frame (ITEM: TIME, TIMESTEP, NUMBER OF ATOMS, BOX BOUNDS, ATOMS) without its
# two numbers that grow with the run (the step and N).
TEXT_FRAME_HEADER = 262.0
# - binary dump (id x vx fx, 4 doubles per atom): a frame header of 159 bytes on one rank
#   (bindump's format: 8+10+4+4 magic, 8+8 step and atoms, 4+24+48 box, 4 columns, 4+2 "si",
#   1+8 time, 4+10 column names, 4 chunks, 4 chunk length).
BIN_FRAME_HEADER = 159.0
# - H5MD (x, v, f, 3 doubles per atom-frame before compression): bytes per atom-frame, by
#   output.compression, of a magnet the wave reached and of one at rest (x repeats, v and f
#   are 0 or a constant ~1e-15 from uneven gaps: they compress well).
H5MD_BYTES = {"lzf": (20.0, 2.9), "gzip": (18.3, 1.1)}
H5MD_OVERHEAD = 20e3
# - the front record (fix lattice/front, 7 doubles and an id per magnet) and the small files
#   (deck, log, case.toml, summary, figure).
FRONT_BYTES_PER_ATOM = 64.0
SMALL_FILES_BYTES = 150e3
# Magnets sampled to measure widths of formatted numbers and unequal gaps: bounded time and
# memory at any N.
SAMPLE = 100_000
# LAMMPS's per-rank memory for a chain ("Per MPI rank memory": 61 MB at 2e5 atoms), rounded up;
# plus per pair of atom types two arrays of doubles (measured: 15 bytes per type pair, +238 MB
# for 4000 types): one type per distinct mass, except with masses per magnet (deck.per_atom_masses).
ENGINE_BYTES_PER_ATOM = 400
ENGINE_BYTES_PER_TYPE_PAIR = 16
# Reading a text dump back (the figure reads it) holds the text, its lines and the arrays:
# 3.1 bytes per dump byte. H5MD is converted in blocks and read by columns: BLOCK_BYTES.
READ_BYTES_PER_DUMP_BYTE = 3.1
BLOCK_BYTES = 64e6
# Without the engine's front record the whole trajectory is read to measure: t, u, v, a.
TRAJECTORY_BYTES_PER_ATOM_FRAME = 4 * 8.0
# Python, numpy, LAMMPS and matplotlib loaded: 151 MB.
BASE_MEMORY_BYTES = 151e6
# Time: the engine's (`overhead.engine_seconds`); each written atom-frame 3.3e-6 s as text
# (writing, reading back) and 5e-7 s as H5MD (conversion); the command's start-up, writes,
# measures and figure (this machine's, `overhead`); all times the contention now.
SECONDS_PER_ATOM_FRAME = {"text": 3.3e-6, "h5md": 5e-7, "none": 0.0}


@dataclass(frozen=True)
class Estimate:
    """What a run will need: its files' bytes at the peak on disk, peak memory (bytes), wall time (s)."""

    frames: int
    files: dict[str, float]
    memory_bytes: float
    seconds: float

    @property
    def output_bytes(self) -> float:
        """Peak bytes on disk of the whole run folder."""
        return sum(self.files.values())

    def __str__(self) -> str:
        return (f"{self.frames} frames, output {_size(self.output_bytes)}, memory {_size(self.memory_bytes)}, "
                f"time {_duration(self.seconds)}")


def atom_frames(case: Case) -> int:
    """Atom-frames the run writes: every magnet each output_interval, the fine ones each fine_interval."""
    if case.output.format == "none":
        return 0
    return case.chain.particles * frames(case) + len(case.output.fine) * _fine_frames(case)


def _fine_frames(case: Case) -> int:
    return case.run.steps() // round(case.fine_interval() / case.run.dt) + 1 if case.output.fine else 0


def frames(case: Case) -> int:
    """Frames of the whole chain written, the first (t = 0) included; 0 without output."""
    return 0 if case.output.format == "none" else case.run.steps() // case.run.steps("output_interval") + 1


def output_bytes(case: Case) -> float:
    """Peak bytes on disk of the run folder."""
    return sum(file_bytes(case).values())


def file_bytes(case: Case) -> dict[str, float]:
    """Bytes of each file of the run folder at its peak on disk (an H5MD run: while the binary
    dump is converted, both exist). Keys are the run's file names; "small files" for the rest."""
    n, fmt = case.chain.particles, case.output.format
    chain = _ChainSample(case)
    lo, hi = case.table_range(chain.widest)  # not every gap: N draws would come before a refusal
    files = {DATA: chain.data_bytes(), TABLE: _table_bytes(case.force, lo, hi, case.table.points),
             "small files": SMALL_FILES_BYTES}
    if case.second_neighbour is not None:
        files[SECOND_TABLE] = _table_bytes(case.second_neighbour, 2 * lo, 2 * hi, case.table.points)
    if records_front(case):
        files[FRONT_BIN] = FRONT_BYTES_PER_ATOM * n
    groups = [(DUMP, TRAJ_BIN, frames(case), case.run.output_interval, None)]
    if case.output.fine:
        groups.append((FINE_DUMP, FINE_BIN, _fine_frames(case), case.fine_interval(),
                       np.asarray(case.output.fine)))
    if fmt == "text":
        for text_name, _, count, interval, atoms in groups:
            files[text_name] = chain.text_bytes(count, interval, atoms)
    elif fmt == "h5md":
        h5md = H5MD_OVERHEAD
        for _, bin_name, count, interval, atoms in groups:
            k = n if atoms is None else len(atoms)
            files[bin_name] = count * (BIN_FRAME_HEADER + 32.0 * k)
            h5md += _h5md_group_bytes(case.output.compression, count, k, chain.reached(count, interval, atoms))
        files[H5MD] = h5md
    return files


class _ChainSample:
    """The chain's first SAMPLE magnets as the data file and dumps format them, scaled to N."""

    def __init__(self, case: Case):
        self.case, chain = case, case.chain
        self.n = n = chain.particles
        k = min(n, SAMPLE)
        gaps, masses = chain.gaps(k - 1), chain.masses(k)  # mm, g
        self.widest = float(gaps.max())  # mm
        self.x = to_engine(np.concatenate([[0.0], np.cumsum(gaps)]), "length")  # m, as in the data file
        self.mass = to_engine(masses, "mass")  # kg, as in the data file
        self.per_atom = per_atom_masses(case)
        self.types = atom_types(case)
        # magnets whose two gaps differ in the engine's doubles feel a force from the first step
        spacing = np.diff(self.x)
        self.uneven = float(np.mean(spacing[1:] != spacing[:-1]))
        if chain.thermal_velocity or chain.r0_disorder:  # every free magnet moves from the start
            self.speed = math.inf
        elif case.impactor.peak_velocity() > 0:  # the front-speed bound of long_lattice_particles, magnets/ms
            r0, m = float(np.mean(gaps)), float(np.mean(masses))
            shock = weak_shock(case.force, r0, m)
            self.speed = (shock.c0 + 2 * max(1.0, shock.s) * case.impactor.peak_velocity()) / r0
        else:
            self.speed = 0.0

    def reached(self, count: int, interval: float, atoms=None) -> float:
        """Atom-frames the wave has reached, over `count` frames `interval` ms apart: magnet j
        (1-based) from t = (j - 1) / speed. atoms: the magnets written (None: all)."""
        if atoms is None:  # every magnet: the sum over frames of min(N, 1 + speed t), in closed form
            a = self.speed * interval
            if not math.isfinite(a):
                return float(count * self.n)
            rising = min(count, math.floor((self.n - 1) / a) + 1) if a > 0 else count
            return rising + a * rising * (rising - 1) / 2 + self.n * (count - rising)
        if not self.speed:
            return float(count * np.sum(atoms == 1))
        start = np.ceil((atoms - 1) / (self.speed * interval))
        return float(np.sum(np.clip(count - start, 0, count)))

    def data_bytes(self) -> float:
        """chain.data: header, masses, atoms, bonds (the stock engine's only) and velocities, as
        deck.data_text writes them."""
        n, case = self.n, self.case
        atoms = _digits(n) + n * (_digits(self.types) / self.types + _mean_len(repr, self.x) + 9)
        bonds = 0 if uses_chain_engine(case) else n - 1 + (n - 2 if case.second_neighbour is not None else 0)
        bond_lines = _digits(bonds) + bonds * 5 + 2 * _digits(n) if bonds else 0
        velocities = _digits(n) + n * 26 if case.chain.thermal_velocity else 0
        masses = _digits(n) + n * (1 + _mean_len(repr, self.mass) + 1) if self.per_atom else 0
        return 400 + self.types * 26 + atoms + bond_lines + velocities + masses

    def text_bytes(self, count: int, interval: float, atoms=None) -> float:
        """A text dump (DUMP_COLUMNS, %.12g): frame headers, lines at rest formatted exactly,
        TEXT_MOVING_EXTRA per atom-frame the wave reached, TEXT_UNEVEN_EXTRA for the uneven ones."""
        k = self.n if atoms is None else len(atoms)
        ids = _digits(self.n) / self.n if atoms is None else float(np.mean([len(str(a)) for a in atoms]))
        g12 = lambda v: f"{v:.12g}"  # noqa: E731
        rest = ids + _digits(self.types) / self.types + _mean_len(g12, self.mass) + _mean_len(g12, self.x) + 19
        reached = self.reached(count, interval, atoms)
        header = TEXT_FRAME_HEADER + len(str(self.case.run.steps())) + len(str(k))
        return (count * (header + k * rest) + reached * TEXT_MOVING_EXTRA
                + (count * k - reached) * self.uneven * TEXT_UNEVEN_EXTRA)


def _h5md_group_bytes(compression: str, count: int, k: int, reached: float) -> float:
    """A particle group of the H5MD file: x, v, f as h5md writes them (chunks of up to 1024
    frames and _CHUNK_VALUES values; uncompressed, whole chunks are stored), step and time in
    chunks of 4096, id and mass."""
    frames_per_chunk = max(1, min(1024, count))
    atoms_per_chunk = min(k, max(32, (1 << 15) // frames_per_chunk))
    step_time = 16.0 * 4096 * -(-count // 4096)
    if compression == "none":
        padded = -(-count // frames_per_chunk) * frames_per_chunk * -(-k // atoms_per_chunk) * atoms_per_chunk
        return 24.0 * padded + step_time + 16.0 * k
    moving, rest = H5MD_BYTES[compression]
    return reached * moving + (count * k - reached) * rest + step_time + 16.0 * k


def _digits(n: int) -> float:
    """Characters of the numbers 1..n written in decimal."""
    total, low = 0, 1
    while low <= n:
        total += (min(n, 10 * low - 1) - low + 1) * len(str(low))
        low *= 10
    return float(total)


def _mean_len(fmt, values: np.ndarray) -> float:
    """Mean length of `values` formatted (up to 2000 of them, evenly spaced)."""
    return float(np.mean([len(fmt(float(v))) for v in values[:: max(1, len(values) // 2000)]]))


def _table_bytes(law, lo: float, hi: float, points: int) -> float:
    """The table's size from a 1000-point rendering of it: header plus the measured line length."""
    k = min(points, 1000)
    text = bond_table(law, lo, hi, k, lo)
    header = text.index("\n1 ") + 1
    return header + (len(text) - header) * points / k


def estimate(case: Case | str | os.PathLike, nprocs: int = 1, measure: bool = False) -> Estimate:
    """What running `case` on `nprocs` ranks will take before it runs: frames, the size of every
    output file, memory and wall time, from the case alone (nothing is drawn or written). The
    time is the command's, start to exit, with this machine's start-up (`overhead`: measured
    now, once, if `measure` and not cached). `pl.estimate`; `check` refuses a run that does
    not fit this machine. `case`: a Case or the path of its TOML file (read as `load_case` reads it)."""
    require_bool(measure=measure)  # "no" would measure
    case = as_case(case)
    n, steps, fmt = case.chain.particles, case.run.steps(), case.output.format
    files = file_bytes(case)
    types = atom_types(case)
    memory = BASE_MEMORY_BYTES + ENGINE_BYTES_PER_ATOM * n + ENGINE_BYTES_PER_TYPE_PAIR * (types + 1) ** 2
    dump = files.get(DUMP, 0.0)
    memory += READ_BYTES_PER_DUMP_BYTE * dump if fmt == "text" else BLOCK_BYTES if fmt == "h5md" else 0.0
    if not case.output.front:
        memory += TRAJECTORY_BYTES_PER_ATOM_FRAME * atom_frames(case)
    seconds = overhead.overheads(measure).run_s + overhead.engine_seconds(n, steps, nprocs)
    seconds = overhead.contention() * (seconds + SECONDS_PER_ATOM_FRAME[fmt] * atom_frames(case))
    return Estimate(frames(case), files, memory, seconds)


def _size(n: float) -> str:
    units = ("B", "kB", "MB", "GB", "TB", "PB", "EB")
    k = 0
    while abs(n) >= 1000 and k < len(units) - 1:
        n, k = n / 1000, k + 1
    return f"{n:.3g} {units[k]}"


def _duration(seconds: float) -> str:
    if seconds < 120:  # 2 digits below 99.5 s (.2g of 100-119 is "1e+02")
        return f"{seconds:.2g} s" if seconds < 99.5 else f"{seconds:.0f} s"
    if seconds < 7200:
        return f"{seconds / 60:.3g} min"
    return f"{seconds / 3600:.3g} h"
