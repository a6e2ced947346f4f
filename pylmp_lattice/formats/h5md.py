"""A run's trajectory as an H5MD file (HDF5 in the layout of nongnu.org/h5md, version 1.1).

The deck writes binary LAMMPS dumps (`bindump`); `write_file` turns them, block by block,
into an H5MD file (a run's traj.h5md), and `read_group` reads it back in user units, whole or a
few particles:

    h5md/                         version [1, 1]; author; creator pylmp_lattice <version>
    particles/trajectory/         every magnet, every run.output_interval
        box                       dimension 3, boundary none none none
        id (N,)                   magnet numbers (1 is the impactor)
        species (N,)              1, 2, ...: one per distinct mass, in increasing mass
        mass (N,)                 kg
        position/value (F, N, 3)  nm; position/step (F,); position/time (F,) ps
        velocity/value (F, N, 3)  m/s; step and time are position's
        force/value (F, N, 3)     N: the total force, friction included (magnet 1, whose motion the
                                  drive imposes: the chain's push and friction, not m a)
    particles/trajectory_fine/    the same for the output.fine magnets, every output.fine_interval
    observables/                  one value per frame of particles/trajectory (its step, time)
        kinetic_energy, potential_energy, total_energy   J (the log's thermo rows)
        friction_work             J, the energy friction has dissipated (runs with friction)
        min_gap                   nm, the smallest gap x_(n+1) - x_n
        dt                        ps, the interval between frames
    parameters/pylmp_lattice      attribute case: the case as TOML text

Units are the engine's SI ones, lengths in nm and times in ps (`units.H5MD_UNITS`), each named
in its dataset's `unit` attribute. y and z are kept as zeros, so that readers of 3D
trajectories take the file as it is. `MDAnalysis.Universe("traj.h5md")` opens it: its H5MD
reader knows only some units (hence nm and ps), infers the atoms from the group
"trajectory" and reads the first group by name (hence the names), and takes every
observable of a frame into `ts.data`, where `dt` is the frame interval it reports (hence
observables at the frames, and dt in ps, its time unit). It reads no masses (no topology):
`Universe("topology.psf", "traj.h5md")`, with the PSF file written beside this one (`psf`),
has them (in u) with plain MDAnalysis; so has `Universe("traj.h5md")` once
`pylmp_lattice.mdanalysis` is imported, which registers a topology parser for H5MD files.
Either way MDAnalysis warns about nothing. The datasets are chunked by blocks of frames and particles, one component a chunk,
and compressed with byte shuffling (output.compression: lzf, h5py's fast filter, by
default; gzip for readers that use the HDF5 library without h5py); a few particles read back
without decompressing the others.
"""

from __future__ import annotations

import contextlib
import getpass
import logging
import os
from importlib.metadata import PackageNotFoundError, version
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from . import psf
from .bindump import BinaryDump
from .dump import read_log
from .files import atomic_write
from ..errors import DumpFormatError, LatticeError, UsageError
from .layout import TOPOLOGY
from ..trajectory import Trajectory
from ..units import H5MD_UNITS, from_engine, to_engine, to_h5md

logger = logging.getLogger(__name__)  # "log" is write_file's LAMMPS log

GROUPS = {"chain": "trajectory", "fine": "trajectory_fine"}  # the package's names -> the file's
_FIELDS = (("position", "x", "length"), ("velocity", "vx", "velocity"), ("force", "fx", "force"))
# observables: name -> (thermo column of the log, quantity)
OBSERVABLES = {"kinetic_energy": ("KinEng", "energy"), "potential_energy": ("E_bond", "energy"),
               "total_energy": ("TotEng", "energy"), "friction_work": ("f_friction", "energy"),
               "min_gap": ("v_min_gap", "length")}
# SI size of each unit a file of this package names (files written before times were in ps: s)
_SI = {name: size for name, size in H5MD_UNITS.values()} | {"s": 1.0}
_CHUNK_VALUES, _CHUNK_FRAMES = 1 << 15, 1024  # 256 kB chunks, of up to 1024 frames
# The largest file written as an image in memory where no disk can be reserved (`write_file`):
# held twice there, HDF5's image and its copy, so at most 512 MB.
IMAGE_BYTES = 256e6


@dataclass(frozen=True)
class Header:
    """What an H5MD file says of its run besides the frames: the case's name and TOML text
    (user units), each magnet's mass (kg), the 0-based indices of the "fine" group's magnets,
    each group's frame interval (ms) and the compression filter (output.compression)."""

    name: str
    case_toml: str
    masses: np.ndarray
    fine: np.ndarray
    intervals: dict[str, float]
    compression: str


def write_file(target: Path, header: Header, dumps: dict[str, BinaryDump], log: Path | None = None, *,
               reserve: int) -> None:
    """Write an H5MD file at `target` from the run's binary dumps, {group: dump} with group
    "chain" (every magnet) or "fine" (the output.fine magnets), and the thermo rows of its
    `log` (LAMMPS's log file) as observables, and beside it the chain's topology (`psf`,
    layout.TOPOLOGY). The dumps are left as they are.

    HDF5 must never meet a full disk mid-file: writing through its own file it crashed the
    process (a segmentation fault on closing it), and through a Python file that failed its
    half-closed file stayed in HDF5's state and crashed a later close in the same process (the
    suite, after the full-disk test). So `reserve` bytes are allocated on the disk first (an
    OSError ENOSPC if they are not there) and HDF5 writes into them through a Python file,
    which is truncated at the end; where nothing can be reserved (a file system without
    fallocate), HDF5 writes an image in memory and Python writes it out. That holds the
    file twice in memory: a file that may be over IMAGE_BYTES (`reserve`, its size at most) is
    written by HDF5 straight into the file instead, with a warning that a disk filled meanwhile
    may crash the process (the caller keeps the dumps until the file verifies)."""
    import h5py

    masses = header.masses
    species = psf.species(masses)
    # beside it, its topology: what plain MDAnalysis needs for masses (see `psf`)
    atomic_write(Path(target).parent / TOPOLOGY, psf.psf_text(header.name, masses))
    with open(target, "w+b") as f:
        if reserve and _reserve(f.fileno(), reserve):
            with _released(f), h5py.File(f, "w") as h5:  # HDF5 closes the file first
                _write_h5md(h5, header, dumps, log, masses, species)
            return
        if reserve > IMAGE_BYTES:
            # named as the user will see it: the caller writes under a ".part" name first
            logger.warning("%s: up to %.3g MB, over the %.3g MB cap for writing through memory where no disk can be "
                           "reserved (no fallocate); HDF5 writes it directly, and a disk that fills meanwhile may "
                           "crash this process", Path(target).with_suffix("") if Path(target).suffix == ".part"
                           else target, reserve / 1e6, IMAGE_BYTES / 1e6)
            with h5py.File(f, "w") as h5:
                _write_h5md(h5, header, dumps, log, masses, species)
            return
        with h5py.File(f"{target}.image", "w", driver="core", backing_store=False) as h5:
            _write_h5md(h5, header, dumps, log, masses, species)
            h5.flush()
            image = h5.id.get_file_image()
        f.write(image)


def _write_h5md(h5, header: Header, dumps: dict[str, BinaryDump], log: Path | None, masses, species) -> None:
    """The H5MD file's groups written into the open h5py File `h5` (see `write_file`)."""
    _write_header(h5, header.case_toml)
    for group, dump in dumps.items():
        chosen = slice(None) if group == "chain" else header.fine
        _write_group(h5.require_group("particles").create_group(GROUPS[group]), dump, masses[chosen],
                     species[chosen], header.compression)
    # MDAnalysis reads observables at the frames of the first particle group
    first_group = next(iter(dumps))
    first = h5["particles"][GROUPS[first_group]]
    _write_observables(h5.create_group("observables"), first, log, header.intervals[first_group])


def _reserve(fd: int, size: int) -> bool:
    """Allocate `size` bytes of disk for the open file `fd` without changing its length (Linux
    fallocate, FALLOC_FL_KEEP_SIZE): HDF5's writes then need no new blocks. True if reserved;
    OSError ENOSPC if the disk has less free; False elsewhere, or on a file system without it."""
    import ctypes
    import errno

    try:
        fallocate = ctypes.CDLL(None, use_errno=True).fallocate
    except (OSError, AttributeError):
        return False
    fallocate.argtypes = [ctypes.c_int, ctypes.c_int, ctypes.c_int64, ctypes.c_int64]
    if fallocate(fd, 1, 0, size) != 0:
        code = ctypes.get_errno()
        if code not in (errno.EOPNOTSUPP, errno.ENOSYS):
            raise OSError(code, os.strerror(code))
        return False
    return True


@contextlib.contextmanager
def _released(f):
    """Free the reserved blocks beyond the end of the file once HDF5 has written it."""
    try:
        yield
    finally:
        f.flush()
        os.ftruncate(f.fileno(), os.fstat(f.fileno()).st_size)


def frame_count(path: str | Path, group: str) -> tuple[int, np.ndarray | None]:
    """Frames of a group in an H5MD file and its last frame's positions (engine's SI units,
    nm for lengths), to verify a conversion before its source is removed."""
    import h5py

    with h5py.File(path, "r") as h5:
        value = h5["particles"][GROUPS[group]]["position"]["value"]
        return value.shape[0], (value[-1, :, 0] if value.shape[0] else None)


def read_group(path: str | Path, group: str = "chain", particles=None) -> Trajectory:
    """The trajectory of a group in user units; `particles` (0-based indices into the group,
    increasing) reads only those columns. Accelerations are force / mass, also magnet 1's,
    whose motion the drive imposes (`RunFolder.trajectory` gives its drive's acceleration). DumpFormatError naming the file where it is no H5MD
    file of this layout (damaged, cut short, another program's)."""
    layout = (f"particles/{GROUPS.get(group, group)} with {', '.join(n for n, _, _ in _FIELDS)}, time and mass, "
              "each with its unit")
    with _open(path, layout) as h5:
        held = [name for name, key in GROUPS.items() if key in h5["particles"]]
        if group not in held:
            raise UsageError("group", f"got {group!r}; {path} holds {', '.join(held) or 'no group'}")
        g = h5["particles"][GROUPS[group]]
        cols = slice(None) if particles is None else list(particles)
        x, v, f = (_si(g[name]["value"], g[name]["value"][:, cols, 0]) for name, _, _ in _FIELDS)
        t, m = _si(g["position"]["time"], g["position"]["time"][:]), _si(g["mass"], g["mass"][cols])
    x = from_engine(x, "length")
    return Trajectory(t=from_engine(t, "time"), x0=x[0].copy(), u=x - x[0], v=from_engine(v, "velocity"),
                      a=from_engine(f / m, "acceleration"))


def read_observables(path: str | Path) -> dict[str, np.ndarray]:
    """The observables of an H5MD file in user units (energies mJ, min_gap mm, dt ms), and
    their frames' time "t" (ms). DumpFormatError naming the file where it is no H5MD file of
    this layout (damaged, cut short, another program's)."""
    quantity = {name: q for name, (_, q) in OBSERVABLES.items()} | {"dt": "time"}
    layout = f"observables/ with some of {', '.join(quantity)}, each a value and a time with their unit"
    with _open(path, layout) as h5:
        if "observables" not in h5:
            raise LatticeError(f"{path}: no observables (an older file: its thermo is in the run's log)")
        obs = h5["observables"]
        if not len(obs):
            raise KeyError("observables/ holds none")  # (said as a group missing is: `_open`)
        out = {name: from_engine(_si(obs[name]["value"], obs[name]["value"][:]), quantity[name]) for name in obs}
        first = next(iter(obs.values()))
        out["t"] = from_engine(_si(first["time"], first["time"][:]), "time")
    return out


@contextlib.contextmanager
def _open(path: str | Path, layout: str):
    """An H5MD file, open for reading, for a block that reads `layout` of it (what a run's file
    holds there, said in errors). DumpFormatError naming the file where HDF5 cannot open it (cut
    short, or no HDF5 file: h5py's message alone named no file; a missing one stays a
    FileNotFoundError), and where the block meets h5py's KeyError (a group, dataset or
    attribute missing: the file is not of this layout) or a unit not named here."""
    import h5py

    try:
        h5 = h5py.File(path, "r")
    except FileNotFoundError:
        raise
    except OSError as err:
        raise DumpFormatError(f"{path}: HDF5 cannot open it ({err}); expected an H5MD file as a run writes it "
                              "(traj.h5md), whole") from None
    with h5:
        try:
            yield h5
        except KeyError as err:
            raise DumpFormatError(f"{path}: {err.args[0] if err.args else err}; expected a run's H5MD file: "
                                  f"{layout}") from None


def _si(dataset, values: np.ndarray) -> np.ndarray:
    """A dataset's values in SI, from the unit its attribute names."""
    size = _SI[dataset.attrs["unit"]]
    return values if size == 1.0 else values * size


def _write_header(h5, case_toml: str) -> None:
    h5.create_group("h5md").attrs["version"] = np.array([1, 1])
    h5["h5md"].create_group("author").attrs["name"] = getpass.getuser()
    creator = h5["h5md"].create_group("creator")
    creator.attrs["name"] = "pylmp_lattice"
    try:
        creator.attrs["version"] = version("pylmp_lattice")
    except PackageNotFoundError:
        creator.attrs["version"] = "unknown"
    h5.create_group("parameters/pylmp_lattice").attrs["case"] = case_toml


def _write_group(g, dump, masses: np.ndarray, species: np.ndarray, compression: str) -> None:
    """Stream the dump's frames into a particle group, converting to the file's units."""
    n = dump.atoms
    g["mass"] = to_h5md(to_engine(masses, "mass"), "mass")
    g["mass"].attrs["unit"] = H5MD_UNITS["mass"][0]
    g["species"] = species.astype(np.int32)
    box = g.create_group("box")
    box.attrs["dimension"] = 3
    box.attrs["boundary"] = np.array([b"none"] * 3)
    filters = {} if compression == "none" else {"compression": compression, "shuffle": True}
    # One component a chunk: y and z are never written, so HDF5 stores no chunk for them and
    # reads its fill value, 0. Chunks hold up to 1024 frames, and more particles when there are
    # fewer frames: HDF5 compresses whole chunks, so a chunk must not be mostly empty.
    frames = max(1, min(_CHUNK_FRAMES, dump.frames))
    chunks = (frames, min(n, max(32, _CHUNK_VALUES // frames)), 1)
    values = {name: g.create_dataset(f"{name}/value", shape=(0, n, 3), maxshape=(None, n, 3), dtype="f8",
                                      chunks=chunks, **filters) for name, _, _ in _FIELDS}
    step = g.create_dataset("position/step", shape=(0,), maxshape=(None,), dtype="i8", chunks=(4096,))
    time = g.create_dataset("position/time", shape=(0,), maxshape=(None,), dtype="f8", chunks=(4096,))
    time.attrs["unit"] = H5MD_UNITS["time"][0]
    for name, _, _ in _FIELDS[1:]:  # H5MD lets elements share step and time (hard links)
        g[f"{name}/step"], g[f"{name}/time"] = step, time
    for name, _, quantity in _FIELDS:
        values[name].attrs["unit"] = H5MD_UNITS[quantity][0]
    done = 0
    for block in dump.blocks():
        k = len(block.step)
        for ds in (*values.values(), step, time):
            ds.resize(done + k, axis=0)
        step[done:], time[done:] = block.step, to_h5md(block.time, "time")
        for name, column, quantity in _FIELDS:
            values[name][done:, :, 0] = to_h5md(block.data[:, :, dump.column(column)], quantity)
        if done == 0:
            g["id"] = block.data[0, :, dump.column("id")].astype(np.int64)
        done += k


def _write_observables(obs, group, log: Path | None, interval: float) -> None:
    """The log's thermo rows at the group's frames (NaN where a frame has none) and the frame
    interval `interval` (ms), as H5MD time series sharing the group's step and time."""
    step = group["position"]["step"][:]
    runs = read_log(log).runs if log is not None and log.exists() else []
    columns = runs[-1] if runs else {}
    series = {}
    if "Step" in columns:
        # the deck prints a thermo row at every frame's step
        row_of = {int(s): i for i, s in enumerate(columns["Step"])}
        rows = np.array([row_of.get(int(s), -1) for s in step], dtype=np.int64)
        for name, (column, quantity) in OBSERVABLES.items():
            if column in columns:
                values = np.where(rows >= 0, columns[column][rows], np.nan)
                series[name] = (to_h5md(values, quantity), H5MD_UNITS[quantity][0])
    series["dt"] = (np.full(len(step), to_h5md(to_engine(interval, "time"), "time")), H5MD_UNITS["time"][0])
    for name, (values, unit) in series.items():
        obs[f"{name}/value"] = values
        obs[f"{name}/value"].attrs["unit"] = unit
        obs[f"{name}/step"], obs[f"{name}/time"] = group["position"]["step"], group["position"]["time"]
