"""Turning a run's binary dumps into traj.h5md: by the runner once LAMMPS has ended, in the
folder it claimed (`convert_claimed`), or by the reader on its first read of a folder that still
holds them (`convert_dumps`: `RunFolder.trajectory`, e.g. after an interrupt or `lmp -in` by hand).

It never destroys: nothing happens while LAMMPS may still write the folder (see
`marker.status`), and the dumps are removed only after the H5MD file holds every frame they
hold, with the same last frame.
"""

from __future__ import annotations

import logging
from pathlib import Path

import numpy as np

from ..case import Case
from ..errors import LatticeError
from ..formats import layout
from ..formats.bindump import open_dump
from ..formats.files import DiskFull, free_bytes, refuse_links, replacing
from ..units import to_h5md
from . import marker
from .claim import Claimed

# HDF5's own bytes in traj.h5md beyond the dumps' values: its metadata, and up to a chunk of
# 256 kB (`h5md._CHUNK_VALUES` doubles) of padding for each of x, v, f (a 2 ms run of the
# experiment: 14 kB of dumps, a 100 kB file)
H5MD_OVERHEAD = 1 << 20

log = logging.getLogger(__name__)


def convert_dumps(folder: Path, case: Case) -> bool:
    """Convert the folder's binary dumps into traj.h5md when safe (no other process writes the
    folder: its lock is held meanwhile); whether it did."""
    if case.output.format != "h5md":
        return False
    refuse_links(folder, layout.RUN_FILES)  # the dumps it reads, the files it writes: never through a link
    if not marker.settled(folder):  # a writer we cannot see may go on
        return False
    with marker.claimed(folder):  # one converter at a time
        return _convert(folder, case)


def convert_claimed(claimed: Claimed) -> bool:
    """Convert the dumps of the run that just ended in the claimed folder (its runner holds the
    lock and recorded the end: nothing else to look at); whether it did. A batch of chains
    writes no binary dumps (one text dump of all chains, or only their front record)."""
    if len(claimed.cases) != 1 or claimed.cases[0].output.format != "h5md":
        return False
    return _convert(claimed.path, claimed.cases[0])


def _convert(folder: Path, case: Case) -> bool:
    from ..formats import h5md  # h5py on first need

    sources = {group: open_dump(folder / name) for group, name in layout.BINARY_GROUPS.items()
               if (folder / name).is_file()}
    sources = {group: dump for group, dump in sources.items() if dump.frames}
    if not sources:
        return False
    need = _check_room(folder, sources)
    log.info("%s: converting %d frames to %s", folder, sum(d.frames for d in sources.values()), layout.H5MD)
    with replacing(folder / layout.H5MD, part=folder / (layout.H5MD + ".part")) as partial:
        h5md.write_file(partial, _header(case), sources, folder / layout.LOG, reserve=need)
        for group, dump in sources.items():
            count, last = h5md.frame_count(partial, group)
            expected = to_h5md(dump.read(dump.frames - 1).data[-1, :, dump.column("x")], "length")
            if count != dump.frames or not np.allclose(last, expected, rtol=1e-12, atol=0):
                raise LatticeError(f"{folder}: the H5MD conversion of {dump.path.name} did not verify; kept it")
    for dump in sources.values():
        dump.path.unlink()
    return True


def _check_room(folder: Path, sources) -> int:
    """The bytes to reserve for traj.h5md: the binary dumps' size (it holds their x, v, f as
    doubles: at most that), the log's (its thermo rows become observables) and H5MD_OVERHEAD;
    DiskFull naming it, before HDF5 writes, if the disk has less free (HDF5 that ran out of
    space mid-file crashed the process: `h5md.write_file`)."""
    log_file = folder / layout.LOG
    need = sum(dump.path.stat().st_size for dump in sources.values()) + H5MD_OVERHEAD \
        + (log_file.stat().st_size if log_file.is_file() else 0)
    free = free_bytes(folder)
    if free < need:
        raise DiskFull(folder / layout.H5MD, f"converting the binary dumps needs up to {need / 1e6:.3g} MB, "
                       f"{free / 1e6:.3g} MB free; they are kept: free some space and run "
                       f"'pylmp-lattice summarize {folder}'")
    return need


def _header(case: Case):
    """The case's part of its H5MD file (`h5md.Header`)."""
    import tomli_w

    from ..case import case_to_dict
    from ..formats.h5md import Header

    return Header(case.name, tomli_w.dumps(case_to_dict(case)), case.chain.masses(), np.sort(np.asarray(case.output.fine, int)) - 1,
                  {"chain": case.run.output_interval, "fine": case.fine_interval()}, case.output.compression)
