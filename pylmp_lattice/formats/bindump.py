"""Reading LAMMPS binary dumps (`dump custom` into a *.bin file), in blocks of frames.

The deck writes its frames this way (fwrite of full doubles, no text formatting) and
`run_folder.convert` (`h5md.write_file`) turns them into the run's H5MD file. A frame, as LAMMPS 2025 writes it
(dump custom, format revision 2; see LAMMPS's tools/binary2txt.cpp), is, little-endian:

    int64 -10, char[10] "DUMPCUSTOM", int32 endian (1), int32 revision (2),
    int64 step, int64 atoms, int32 triclinic, int32 boundary[6], float64 box[6],
    int32 columns per atom, int32 length + unit-style text, uint8 time flag (+ float64 time),
    int32 length + column names, int32 chunks, then per chunk: int32 n, float64[n].

One rank writes one chunk per frame, and then every frame has the same size: the fast path
reads blocks of frames as one numpy record array. Several ranks write several chunks of
varying size; those frames are walked one by one. Values are in the deck's units (LAMMPS
`units si`); a frame cut short by a stopped run is dropped with a warning.
"""

from __future__ import annotations

import logging
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import DumpFormatError, UsageError
from ..trajectory import Trajectory
from ..units import from_engine

logger = logging.getLogger(__name__)

_MAGIC = b"DUMPCUSTOM"
_REVISION = 2
_BLOCK_BYTES = 1 << 25  # frames are read in blocks of about this size


@dataclass(frozen=True)
class Frames:
    """A block of frames: step (k,), time (k,) s, data (k, atoms, columns) in id order."""

    step: np.ndarray
    time: np.ndarray
    data: np.ndarray


@dataclass(frozen=True)
class BinaryDump:
    """The layout of a binary dump file, from its first frame (see `open_dump`)."""

    path: Path
    columns: tuple[str, ...]
    atoms: int
    frames: int  # complete frames
    frame_dtype: np.dtype | None  # every frame alike (one chunk): its record type, else None

    def column(self, name: str) -> int:
        """The index of column `name` in each row; DumpFormatError naming the file without it."""
        try:
            return self.columns.index(name)
        except ValueError:
            raise DumpFormatError(f"{self.path}: no column {name!r}; it has {' '.join(self.columns)}") from None

    def blocks(self, start: int = 0, stop: int | None = None) -> Iterator[Frames]:
        """Frames [start, stop) in blocks of about 32 MB: 0 <= start <= stop <= frames (stop None:
        to the last), else UsageError naming `start` or `stop` and the range (a start past the end
        read nothing, a negative one failed in numpy as "Invalid argument")."""
        _check_frame("start", start, 0, self)
        _check_frame("stop", self.frames if stop is None else stop, start, self)
        stop = self.frames if stop is None else stop
        per_block = max(1, _BLOCK_BYTES // max(1, 8 * self.atoms * len(self.columns)))
        if self.frame_dtype is None:
            yield from _walk(self, start, stop, per_block)
            return
        for first in range(start, stop, per_block):
            count = min(per_block, stop - first)
            rec = np.fromfile(self.path, dtype=self.frame_dtype, count=count,
                              offset=first * self.frame_dtype.itemsize)
            _check_records(self, rec, first)
            yield Frames(rec["step"].copy(), rec["time"].copy(), _by_id(self, rec["data"], first))

    def read(self, start: int = 0, stop: int | None = None) -> Frames:
        """Frames [start, stop) as one block."""
        parts = list(self.blocks(start, stop))
        if not parts:
            return Frames(np.empty(0, np.int64), np.empty(0), np.empty((0, self.atoms, len(self.columns))))
        if len(parts) == 1:  # (a batch's front record: one frame of megabytes, not copied again)
            return parts[0]
        return Frames(*(np.concatenate([getattr(p, k) for p in parts]) for k in ("step", "time", "data")))


def _check_frame(name: str, index, low: int, dump: BinaryDump) -> None:
    """UsageError naming `name` unless `index` is an integer frame index in low .. dump.frames."""
    if isinstance(index, bool) or not isinstance(index, (int, np.integer)) or not low <= index <= dump.frames:
        raise UsageError(name, f"got {index!r}; expected an integer frame index in {low} .. {dump.frames} "
                               f"({dump.path.name} holds {dump.frames} frames)")


def open_dump(path: str | Path) -> BinaryDump:
    """The layout of a binary dump and its number of complete frames; 0 frames (and no columns)
    for a file without one, as a run leaves it when stopped before its first frame."""
    path = Path(path)
    try:
        size = path.stat().st_size
        with path.open("rb") as f:
            first = _read_frame(f, path, data=False)
            if first is None:
                return BinaryDump(path, (), 0, 0, None)
            if first.chunks > 1:  # several ranks: count the frames one by one
                frames = 1
                while _read_frame(f, path, data=False) is not None:
                    frames += 1
                return BinaryDump(path, first.columns, first.atoms, frames, None)
    except FileNotFoundError as err:
        raise FileNotFoundError(f"{path}: dump file not found") from err
    dtype = _frame_dtype(first)
    frames = size // dtype.itemsize
    if size % dtype.itemsize:
        logger.warning("%s: dropped a truncated last frame (kept %d frames)", path, frames)
    return BinaryDump(path, first.columns, first.atoms, frames, dtype)


def complete_bytes(path: str | Path) -> int:
    """How many bytes of a binary dump its whole frames take, walked frame by frame (a frame's
    size is its own: atom counts may change between frames, `dump_modify thresh` or atoms lost):
    its size, less a last frame cut short (a stopped run; a warning says so). DumpFormatError
    for a file that is no binary dump this module reads."""
    path = Path(path)
    end = 0
    with path.open("rb") as f:
        while _read_frame(f, path, data=False) is not None:
            end = f.tell()
    return end


_ROWS = 8192  # write_frame's block of rows (512 kB of 8 columns)


def write_frame(path: str | Path, step: int, time: float, columns: str, data: np.ndarray, ids: bool = False) -> None:
    """One frame (`columns`: names, the first "id"; data (atoms, columns)) as one rank of
    LAMMPS writes it (no box: an engine without one, `engines.road`), atomically. ids: data
    holds the columns after "id", whose values are 1 .. atoms (written beside them here)."""
    from .files import replacing

    data = np.ascontiguousarray(data, "<f8")
    names = columns.encode("ascii")
    atoms, ncol = data.shape[0], data.shape[1] + ids
    frame = _Frame(tuple(columns.split()), atoms, step, time, 1, 2, len(names), None)
    # the record's fields before its data, then the data as it is in memory (a batch's frame is
    # megabytes: no copy into the record)
    head = np.zeros(1, _frame_dtype(frame))  # (calloc: its data's pages are never touched)
    head["magic_len"], head["magic"], head["endian"], head["revision"] = -len(_MAGIC), _MAGIC, 1, _REVISION
    head["step"], head["atoms"], head["ncol"], head["unit_len"], head["unit"] = step, atoms, ncol, 2, b"si"
    head["time_flag"], head["time"], head["names_len"], head["names"] = 1, time, len(names), names
    head["chunks"], head["n"] = 1, atoms * ncol
    with replacing(path) as tmp, open(tmp, "r+b") as f:  # (atomic: see formats.files)
        f.write(head.view(np.uint8)[:head.dtype.fields["data"][1]].tobytes())
        if not ids:
            f.write(memoryview(data).cast("B"))
            return
        # the ids beside the data a block of rows at a time: a batch's whole frame made at once
        # (tens of MB, fresh pages each batch) took a sweep worker 2.9-3.5 us a member in 25 000-
        # member tasks on the dev VM, this 0.7-0.8
        block = np.empty((min(atoms, _ROWS), ncol))
        for lo in range(0, atoms, _ROWS):
            rows = block[:min(atoms - lo, _ROWS)]
            rows[:, 0] = np.arange(lo + 1, lo + 1 + len(rows))
            rows[:, 1:] = data[lo:lo + len(rows)]
            f.write(memoryview(rows).cast("B"))


@dataclass(frozen=True)
class _Frame:
    columns: tuple[str, ...]
    atoms: int
    step: int
    time: float
    chunks: int
    unit_len: int
    names_len: int
    values: np.ndarray | None  # (atoms, columns), when read


def _frame_dtype(frame: _Frame) -> np.dtype:
    """Record type of a one-chunk frame laid out like `frame`."""
    return np.dtype([
        ("magic_len", "<i8"), ("magic", "S10"), ("endian", "<i4"), ("revision", "<i4"),
        ("step", "<i8"), ("atoms", "<i8"), ("triclinic", "<i4"), ("boundary", "<i4", 6),
        ("box", "<f8", 6), ("ncol", "<i4"), ("unit_len", "<i4"), ("unit", f"S{frame.unit_len}"),
        ("time_flag", "u1"), ("time", "<f8"), ("names_len", "<i4"), ("names", f"S{frame.names_len}"),
        ("chunks", "<i4"), ("n", "<i4"), ("data", "<f8", (frame.atoms, len(frame.columns))),
    ])


def _read_frame(f, path: Path, data: bool = True) -> _Frame | None:
    """The frame at the file position (its values if `data`), leaving the position after it;
    None at the end of the file or at a frame cut short."""
    start = f.tell()

    def take(dtype, count=1):
        size = np.dtype(dtype).itemsize * count
        raw = f.read(size)
        if len(raw) < size:
            raise EOFError
        return np.frombuffer(raw, dtype, count)

    try:
        if int(take("<i8")[0]) != -len(_MAGIC) or f.read(len(_MAGIC)) != _MAGIC:
            raise DumpFormatError(f"{path}: not a LAMMPS dump custom binary file at byte {start}")
        endian, revision = take("<i4", 2)
        if endian != 1 or revision != _REVISION:
            raise DumpFormatError(f"{path}: got endian {endian}, revision {revision}; expected 1, {_REVISION}")
        step, atoms = (int(x) for x in take("<i8", 2))
        if take("<i4")[0]:
            raise DumpFormatError(f"{path}: triclinic boxes are not supported")
        take("<i4", 6), take("<f8", 6)  # boundary flags, box bounds
        ncol, unit_len = (int(x) for x in take("<i4", 2))
        f.read(unit_len)  # the unit style, written with `dump_modify units yes`
        if take("u1")[0] != 1:
            raise DumpFormatError(f"{path}: frames carry no time; expected `dump_modify ... time yes`")
        time = float(take("<f8")[0])
        names_len = int(take("<i4")[0])
        columns = tuple(take(f"S{names_len}")[0].decode("ascii").split())
        chunks = int(take("<i4")[0])
        parts, count = [], 0
        for _ in range(chunks):
            n = int(take("<i4")[0])
            if data:
                parts.append(take("<f8", n))
            elif len(f.read(8 * n)) < 8 * n:
                raise EOFError
            count += n
    except EOFError:
        if f.tell() > start:
            logger.warning("%s: dropped a truncated last frame at byte %d", path, start)
        return None
    if count != atoms * ncol or len(columns) != ncol:
        raise DumpFormatError(f"{path}: frame at byte {start} holds {count} values; expected {atoms} x {ncol}")
    values = np.concatenate(parts).reshape(atoms, ncol) if data else None
    return _Frame(columns, atoms, step, time, chunks, unit_len, names_len, values)


def _walk(dump: BinaryDump, start: int, stop: int, per_block: int) -> Iterator[Frames]:
    """Frames of several chunks (runs on several ranks), parsed one by one."""
    block = []
    with dump.path.open("rb") as f:
        for index in range(stop):
            frame = _read_frame(f, dump.path, data=index >= start)
            if index < start:
                continue
            block.append(frame)
            if len(block) == per_block or index == stop - 1:
                data = _by_id(dump, np.stack([b.values for b in block]), index + 1 - len(block))
                yield Frames(np.array([b.step for b in block]), np.array([b.time for b in block]), data)
                block = []


def _check_records(dump: BinaryDump, rec: np.ndarray, first: int) -> None:
    bad = (rec["magic"] != _MAGIC) | (rec["atoms"] != dump.atoms) | (rec["chunks"] != 1)
    if np.any(bad):
        k = first + int(np.argmax(bad))
        raise DumpFormatError(f"{dump.path}: frame {k} differs in layout from frame 0")


def _by_id(dump: BinaryDump, data: np.ndarray, first: int) -> np.ndarray:
    """The frames' rows, checked to be in id order (LAMMPS writes them so with `sort id`)."""
    ids = data[:, :, dump.column("id")]
    if np.any(np.diff(ids, axis=1) <= 0):
        raise DumpFormatError(f"{dump.path}: atoms not in id order in frames from {first}; "
                              "expected `dump_modify ... sort id`")
    return data


def read_trajectory(path: str | Path, mass: np.ndarray, particles=None) -> Trajectory:
    """A binary dump of x, vx, fx as a trajectory in user units, read as it is (nothing converted
    or removed: the file may still be growing). mass (kg) of the dump's atoms, for a = f / m;
    `particles` (0-based indices, increasing) keeps only those columns."""
    dump = open_dump(path)
    frames = dump.read()
    cols = slice(None) if particles is None else list(particles)
    x, v, f = (frames.data[:, cols, dump.column(c)] for c in ("x", "vx", "fx"))
    m = np.asarray(mass)[cols]
    return Trajectory(t=from_engine(frames.time, "time"), x0=from_engine(x[0], "length"),
                      u=from_engine(x - x[0], "length"), v=from_engine(v, "velocity"),
                      a=from_engine(f / m, "acceleration"))
