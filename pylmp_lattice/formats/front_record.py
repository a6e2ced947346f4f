"""The engine's on-the-fly front record (fix lattice/front, file front.bin): its rows as arrays.

The fix applies the definitions of `measures.arrival_times` and `measures.first_peaks` to every
time step of every magnet and writes one binary dump frame at the end of the run (or where it
stopped): a row per atom, the columns `layout.FRONT_FIELDS`. This module reads that frame in
user units; what the rows mean for a case (its levels, its drive's own row) is
`case_measures.read_front_batch`'s.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import DumpFormatError
from ..units import from_engine
from .bindump import open_dump
from .layout import FRONT_FIELDS


@dataclass(frozen=True)
class FrontRows:
    """columns: {name: (R, N) array} for each of `layout.FRONT_FIELDS`, chain r's magnets in row
    r, in user units (ms, m/s, m/s^2); end_time: when the record was written, ms."""

    columns: dict[str, np.ndarray]
    end_time: float


def read_front_rows(path: str | Path, chains: int, particles: int) -> FrontRows:
    """The record in `path` of `chains` chains of `particles` magnets (atom IDs in chain order)."""
    dump = open_dump(path)
    if not dump.frames:  # written at the end of the run: a file without a whole frame was cut short
        raise DumpFormatError(f"{path}: holds no complete front record (cut short?); expected one frame of "
                              f"{chains * particles} magnets")
    if dump.atoms != chains * particles:
        raise DumpFormatError(f"{path}: holds {dump.atoms} magnets; expected {chains * particles}")
    frame = dump.read()
    # the last frame's columns `layout.FRONT_FIELDS` (engine units) of every atom in chain order
    return front_rows(frame.data[-1, :, 1:], frame.time[-1], chains, particles)


def front_rows(data: np.ndarray, end_time: float, chains: int, particles: int) -> FrontRows:
    """The record of a frame's rows `data` (atoms in chain order, the columns `layout.FRONT_FIELDS`,
    engine units, no id) written at `end_time` (s): what `read_front_rows` reads back of the frame
    a kernel engine writes from these arrays, bit for bit. Its columns are new arrays."""
    if data.shape != (chains * particles, len(FRONT_FIELDS)):
        raise DumpFormatError(f"a front record of {data.shape[0]} magnets and {data.shape[1]} columns; expected "
                              f"{chains * particles} and {len(FRONT_FIELDS)}")
    columns = {name: from_engine(data[:, k], quantity).reshape(chains, particles)
               for k, (name, quantity) in enumerate(FRONT_FIELDS)}
    return FrontRows(columns, float(from_engine(end_time, "time")))
