"""Reading what LAMMPS wrote: the text dump (output.format = "text") and the thermo log.

A run with text output writes its trajectory as

    dump traj all custom EVERY traj.dump id type mass x y z vx vy vz fx fy fz
    dump_modify traj sort id format float %.12g

so each frame is LAMMPS's standard 9 header lines (ITEM: TIMESTEP, ITEM: NUMBER OF ATOMS, ITEM:
BOX BOUNDS + 3 lines, ITEM: ATOMS) followed by one line per atom in id (chain) order: the
layout every dump reader takes (MDAnalysis's LAMMPSDUMP, OVITO, ASE). A frame's time is its
step times the run's time step, exactly as LAMMPS computes its `time` with a constant dt.
Dumps of older runs, written with `dump_modify time yes`, start each frame with two more lines
(ITEM: TIME and the time), which are read too. Readers return the file's numbers in LAMMPS
`units si`; `trajectory_from_dump` converts them to user units.

Two readers give the same arrays:
- "fast": reads the file once and parses the atom lines in one `numpy.loadtxt` call.
- "mdanalysis": MDAnalysis's LAMMPSDUMP reader, the reference (given a copy without the ITEM:
  TIME lines when the file has them). Its `positions`, `velocities` and `forces` are float32,
  and positions are shifted by the box origin, which it does not expose (shrink-wrapped boxes
  move it every frame), so they cannot be turned back into the file's numbers. We therefore
  take id, mass, x, vx and fx through its `additional_columns`, which it parses as float64
  from the file's text, unshifted and unconverted.

To open a text dump in MDAnalysis yourself: `Universe("traj.dump", format="LAMMPSDUMP",
dt=DT)`, with DT the run's time step in ps (it sets each frame's time to step * dt), then
convert its numbers from SI yourself (it reads no units from a dump).
"""

from __future__ import annotations

import logging
import re
import tempfile
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import DumpFormatError
from .layout import CONTACT_MARK, DUMP_COLUMNS, END_OF_RUN
from ..trajectory import Trajectory
from ..units import from_engine

logger = logging.getLogger(__name__)

READERS = ("fast", "mdanalysis")
_ATOMS_HEADER = f"ITEM: ATOMS {DUMP_COLUMNS}"


@dataclass(frozen=True)
class _Layout:
    """Where a frame's header lines are, counted from the frame's first line."""

    lines: int  # header lines per frame
    first: str  # the frame's first line
    step: int  # line of the step number (the time, if any, is on line 1)
    atoms: int  # line of the number of atoms
    header: int  # line of ITEM: ATOMS


_STANDARD = _Layout(9, "ITEM: TIMESTEP", 1, 3, 8)
_WITH_TIME = _Layout(11, "ITEM: TIME", 3, 5, 10)  # dump_modify time yes


@dataclass(frozen=True)
class DumpFrames:
    """A `dump traj` file as arrays in LAMMPS `units si`, atoms in id (chain) order.

    time (n_frames,)    s
    step (n_frames,)    timestep number
    id   (N,)           atom ids
    mass (N,)           kg
    x, v, f (n_frames, N)  position m, velocity m/s, force N (x components)
    """

    time: np.ndarray
    step: np.ndarray
    id: np.ndarray
    mass: np.ndarray
    x: np.ndarray
    v: np.ndarray
    f: np.ndarray

    @property
    def n_frames(self) -> int:
        """The number of frames read."""
        return len(self.time)


def read_dump(path: str | Path, reader: str = "fast", dt: float | None = None) -> DumpFrames:
    """Read a `dump traj` file; a truncated last frame (a stopped run) is dropped with a warning.

    dt: the run's time step, s; a frame's time is step * dt. Needed unless the file carries its
    times (ITEM: TIME lines, as older runs wrote them)."""
    if reader not in READERS:
        raise ValueError(f"reader: got {reader!r}; expected one of {', '.join(map(repr, READERS))}")
    path = Path(path)
    lines, layout, n_atoms, n_frames = _split_frames(path)
    per_frame = n_atoms + layout.lines
    starts = range(0, n_frames * per_frame, per_frame)
    step = np.array([int(lines[s + layout.step]) for s in starts], dtype=np.int64)
    if layout is _WITH_TIME:
        time = np.array([float(lines[s + 1]) for s in starts])
    elif dt is None:
        raise ValueError(f"dt: {path} has no ITEM: TIME lines; give the run's time step (s)")
    else:
        time = step * float(dt)  # LAMMPS's own time = atime + (step - atimestep) dt, atime = 0
    parse = _parse_fast if reader == "fast" else _parse_mdanalysis
    return DumpFrames(time, step, *parse(path, lines, layout, n_atoms, n_frames))


def trajectory_from_dump(frames: DumpFrames) -> Trajectory:
    """The trajectory in user units: u from the first frame's positions, a = f / mass."""
    x0 = frames.x[0]
    return Trajectory(
        t=from_engine(frames.time, "time"),
        x0=from_engine(x0, "length"),
        u=from_engine(frames.x - x0, "length"),
        v=from_engine(frames.v, "velocity"),
        a=from_engine(frames.f / frames.mass, "acceleration"),
    )


def _split_frames(path: Path) -> tuple[list[str], _Layout, int, int]:
    """The file's lines, frame layout, atoms per frame and number of complete frames, every
    header checked."""
    try:
        text = path.read_text(encoding="ascii")
    except FileNotFoundError as err:
        raise FileNotFoundError(f"{path}: dump file not found") from err
    lines = text.split("\n")
    # The last element is "" after a final newline, or a line cut short: never a complete line.
    n_lines = len(lines) - 1
    layout = next((lay for lay in (_STANDARD, _WITH_TIME) if lines[0] == lay.first), None)
    if layout is None:
        raise DumpFormatError(f"{path}: got first line {lines[0]!r}; expected 'ITEM: TIMESTEP' (or 'ITEM: TIME')")
    if n_lines < layout.lines:
        raise DumpFormatError(f"{path}: no complete frame; expected {layout.lines} header lines")
    if lines[layout.header] != _ATOMS_HEADER:
        raise DumpFormatError(f"{path}: got {lines[layout.header]!r}; expected {_ATOMS_HEADER!r}")
    n_atoms = int(lines[layout.atoms])
    per_frame = n_atoms + layout.lines
    n_frames = n_lines // per_frame
    if n_frames == 0:
        raise DumpFormatError(f"{path}: no complete frame of {n_atoms} atoms")
    for k in range(n_frames):
        head = lines[k * per_frame : k * per_frame + layout.lines]
        if head[0] != layout.first or head[layout.atoms] != lines[layout.atoms] or head[layout.header] != _ATOMS_HEADER:
            raise DumpFormatError(
                f"{path}: frame {k} does not start at line {k * per_frame + 1}; "
                f"expected frames of {n_atoms} atoms with header {_ATOMS_HEADER!r}"
            )
    if n_lines > n_frames * per_frame or lines[-1]:
        logger.warning("%s: dropped a truncated last frame (kept %d frames)", path, n_frames)
    return lines, layout, n_atoms, n_frames


def _parse_fast(path: Path, lines: list[str], layout: _Layout, n_atoms: int, n_frames: int):
    per_frame = n_atoms + layout.lines
    starts = range(0, n_frames * per_frame, per_frame)
    atom_lines = [line for s in starts for line in lines[s + layout.lines : s + per_frame]]
    try:
        # Only the columns that vary are parsed for every frame: most of the time is float parsing.
        first = np.loadtxt(atom_lines[:n_atoms], usecols=(0, 2), ndmin=2)
        xvf = np.loadtxt(atom_lines, usecols=(3, 6, 9), ndmin=2)
    except ValueError as err:
        raise DumpFormatError(f"{path}: {err}") from err
    x, v, f = xvf.T.reshape(3, n_frames, n_atoms)
    return first[:, 0].astype(np.int64), first[:, 1], x, v, f


def _parse_mdanalysis(path: Path, lines: list[str], layout: _Layout, n_atoms: int, n_frames: int):
    from MDAnalysis.coordinates.LAMMPS import DumpReader

    per_frame = n_atoms + layout.lines
    skip = layout.lines - _STANDARD.lines  # the ITEM: TIME lines, if any
    x, v, f = (np.empty((n_frames, n_atoms)) for _ in range(3))
    with tempfile.TemporaryDirectory() as tmp:
        # A copy of the complete frames in the standard layout.
        copy = Path(tmp) / path.name
        with copy.open("w", encoding="ascii") as out:
            for s in range(0, n_frames * per_frame, per_frame):
                out.write("\n".join(lines[s + skip : s + per_frame]) + "\n")
        with warnings.catch_warnings():
            # It warns that it sets dt = 1 ps; we do not use its times.
            warnings.filterwarnings("ignore", message="Reader has no dt information")
            with DumpReader(str(copy), additional_columns=["id", "mass", "x", "vx", "fx"]) as reader:
                for i, ts in enumerate(reader):
                    x[i], v[i], f[i] = ts.data["x"], ts.data["vx"], ts.data["fx"]
                ts = reader[0]
                ids, mass = ts.data["id"].astype(np.int64), ts.data["mass"].copy()
    return ids, mass, x, v, f


@dataclass(frozen=True)
class ThermoLog:
    """Thermo output of a LAMMPS log: one dict of columns per run, and the ERROR lines."""

    runs: list[dict[str, np.ndarray]]
    errors: list[str]


def read_log(path: str | Path) -> ThermoLog:
    """Thermo columns of every run in a log (thermo_style line output), including a run cut
    short by an ERROR, whose rows up to the error are kept.

    `lammps.formats.LogFile` is not used: it only keeps a run once its "Loop time" line is seen,
    so it loses the rows of the run that failed, which are the ones needed to see why.
    """
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8", errors="replace")
    except FileNotFoundError as err:
        raise FileNotFoundError(f"{path}: log file not found") from err
    runs, errors = [], []
    keys, rows = None, []
    for line in text.splitlines():
        if line.startswith("ERROR"):
            errors.append(line.strip())
        elif line.split()[:1] == ["Step"]:
            keys, rows = line.split(), []
        elif keys is not None:
            if line.startswith("Loop time of"):
                runs.append(_columns(keys, rows))
                keys = None
                continue
            fields = line.split()
            try:  # other lines inside a run (warnings) are skipped; nan and inf are kept
                values = [float(x) for x in fields]
            except ValueError:
                continue
            if len(values) == len(keys):
                rows.append(values)
    if keys is not None:
        runs.append(_columns(keys, rows))
    return ThermoLog(runs, errors)


def _columns(keys: list[str], rows: list[list[float]]) -> dict[str, np.ndarray]:
    table = np.array(rows, dtype=float).reshape(len(rows), len(keys))
    return {key: table[:, i] for i, key in enumerate(keys)}


@dataclass(frozen=True)
class Contact:
    """Two magnets touched: the deck's CONTACT line, in user units (1-based magnet numbers)."""

    magnets: tuple[int, int]
    gap_mm: float
    time_ms: float


_CONTACT = re.compile(r"^" + re.escape(CONTACT_MARK) + r" magnets (\d+) and (\d+) gap (\S+) m at t = (\S+) s", re.MULTILINE)


def find_contact(log_text: str) -> Contact | None:
    """The contact a run stopped at (the deck prints it into the log), or None."""
    m = _CONTACT.search(log_text)
    if m is None:
        return None
    i, j, gap, t = m.groups()
    return Contact((int(i), int(j)), float(from_engine(float(gap), "length")), float(from_engine(float(t), "time")))


_ERROR = re.compile(r"^ERROR.*$", re.MULTILINE)
_NUMBER = r"-?[\d.]+(?:[eE][-+]?\d+)?"


def error_line(text: str) -> str | None:
    """LAMMPS's first ERROR line in a log or its output (the line it starts; "ERROR on proc N"
    too), in user units and without its source location; None if there is none."""
    m = _ERROR.search(text)
    if m is None:
        return None
    # LAMMPS's "(src/...)" and a plugin's "(/path/to/fix.cpp:123)"
    line = re.sub(r"\s*\((?:src/[^)]*|[^()]*\.(?:cpp|h):\d+)\)", "", m.group().strip())
    # engine lengths (m) and times (s) -> mm and ms, e.g. "Bond length > table outer cutoff:
    # type 1 length 0.0130", the chain's "outside the table range [0, 0.036] m at t = 0.0027 s"
    line = re.sub(rf"\blength ({_NUMBER})", lambda m: f"length {_user(m[1], 'length')} mm", line)
    line = re.sub(rf"\[({_NUMBER}), ({_NUMBER})\] m\b",
                  lambda m: f"[{_user(m[1], 'length')}, {_user(m[2], 'length')}] mm", line)
    return re.sub(rf"\bt = ({_NUMBER}) s\b", lambda m: f"t = {_user(m[1], 'time')} ms", line)


def _user(text: str, quantity: str) -> str:
    return f"{from_engine(float(text), quantity):.6g}"


def log_ended(log_text: str) -> bool:
    """Whether LAMMPS finished the log (its last line of a run that ended, also after a soft stop)."""
    return END_OF_RUN in log_text
