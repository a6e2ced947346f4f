"""ASE at the boundary: a run's trajectory as `ase.Atoms` frames, and a case from an `ase.Atoms` chain.

Numbers stay in this package's user units, which form one consistent system: positions in mm,
masses in g, velocities in mm/ms = m/s, so ASE's derived quantities come out consistent too
(`get_kinetic_energy()` in mJ). ASE labels its units Å, amu and eV; here they are not those,
and `atoms.info["units"]` says so. A chain of 12 mm gaps then shows in ASE's GUI or OVITO as
12 "Å" spacings, a readable picture, where a conversion to Å would put the magnets 1.2e8 Å apart.

The chain lies on the x axis (y = z = 0). Each frame carries its time in `info["time_ms"]`;
velocities are stored as ASE stores them (momenta = m v), and extxyz writes masses and momenta.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .case import Case, case_from_dict
from .errors import ConfigError, UsageError, require_bool
from .formats.files import refuse_link, replacing
from .formats.layout import as_path
from .trajectory import Trajectory

UNITS = "mm, g, ms (velocity m/s, energy mJ): pylmp_lattice user units, not ASE's"
# Element symbol of every magnet: ASE needs one; masses are set explicitly.
SYMBOL = "X"
# The files `write_trajectory` writes, by name ending: extended XYZ, ASE trajectory.
FORMATS = {".extxyz": "extxyz", ".traj": "traj"}


def to_atoms(traj: Trajectory, masses, every: int = 1) -> list:
    """Frames of a trajectory as a list of `ase.Atoms` (positions, masses, velocities, time).

    masses: g, one per particle (e.g. `case.chain.masses()`); every: keep every k-th frame.
    """
    from ase import Atoms

    masses = _masses(traj, masses)
    if isinstance(every, bool) or not isinstance(every, (int, np.integer)) or every < 1:
        raise ValueError(f"every: got {every!r}; expected an integer >= 1 (keep every k-th frame)")
    frames = []
    for k in range(0, len(traj.t), every):
        pos = np.zeros((len(traj.x0), 3))
        pos[:, 0] = traj.x0 + traj.u[k]
        vel = np.zeros_like(pos)
        vel[:, 0] = traj.v[k]
        atoms = Atoms([SYMBOL] * len(traj.x0), positions=pos, masses=masses, velocities=vel, pbc=False)
        atoms.info["time_ms"] = float(traj.t[k])
        atoms.info["units"] = UNITS
        frames.append(atoms)
    return frames


def write_trajectory(path: str | Path, traj: Trajectory, masses, every: int = 1, overwrite: bool = False) -> Path:
    """Write frames for ASE's GUI or OVITO: `.extxyz` (extended XYZ) or `.traj` (ASE trajectory).

    An existing file is replaced only with overwrite=True; the frames go through a temporary
    file renamed over `path` (never written through a link, an interrupted write keeps the old)."""
    from ase.io import write

    path = check_destination(path, overwrite)
    frames = to_atoms(traj, masses, every)
    with replacing(path) as part:
        write(part, frames, format=FORMATS[path.suffix])
    return path


def check_destination(path: str | Path, overwrite: bool, name: str = "path") -> Path:
    """`path` as the file `write_trajectory` may write; else UsageError naming `name` (the CLI's
    "--output"): a known ending, in an existing folder, no link or folder, not there unless
    overwrite."""
    path = as_path(path, name, "the file to write, as in write_trajectory(path, traj, masses)")
    require_bool(overwrite=overwrite)
    if path.suffix not in FORMATS:
        raise UsageError(name, f"got {path.name!r}; expected a file ending in {' or '.join(FORMATS)}")
    if not path.parent.is_dir():
        raise UsageError(name, f"{path.parent} is not a folder; expected an existing folder")
    refuse_link(path)
    if path.is_dir():
        raise UsageError(name, f"{path} is a folder; expected a file name")
    if path.exists() and not overwrite:
        raise UsageError(name, f"{path} exists; pass --overwrite (overwrite=True) to replace it, or choose another file")
    return path


def case_from_atoms(atoms, force: dict, impactor: dict, run: dict, friction: dict | None = None,
                    table: dict | None = None, name: str = "atoms") -> Case:
    """A case whose chain is `atoms`: x positions (mm) in chain order, masses (g) and, when
    any is nonzero, x velocities (m/s), so a run can start from a frame of another (`to_atoms`).
    The case keeps the gaps between the positions, not the positions: its magnet 1 starts at x = 0.

    The other sections are given as in a TOML case (user units), e.g.
    force = {"law": "power", "K": 413.8, "b": 3.917, "q": 3}. Atom 1 is the impactor (its
    motion is the impactor's drive) and the last atom is held (far_end = "fixed"; its velocity
    must be 0).
    """
    if not callable(getattr(atoms, "get_positions", None)):
        raise TypeError(f"atoms: got {type(atoms).__name__}; expected an ase.Atoms (its x positions, in chain order)")
    x = np.asarray(atoms.get_positions(), float)[:, 0]
    gaps = np.diff(x)
    if len(x) < 3 or not np.all(gaps > 0):
        raise ConfigError("atoms", f"got {len(x)} atoms with x gaps {_show(gaps)} mm; expected >= 3 atoms "
                                   "in increasing x (chain order)")
    chain = {"particles": len(x), "mass": [float(m) for m in atoms.get_masses()], "r0": [float(g) for g in gaps],
             "far_end": "fixed"}
    v = np.asarray(atoms.get_velocities(), float)[:, 0]
    if np.any(v):
        chain["velocity"] = [float(u) for u in v]
    data = {
        "name": name,
        "chain": chain,
        "force": dict(force),
        "impactor": dict(impactor),
        "run": dict(run),
    }
    if friction is not None:
        data["friction"] = dict(friction)
    if table is not None:
        data["table"] = dict(table)
    return case_from_dict(data)


def _masses(traj, masses) -> np.ndarray:
    """The masses (g) of a trajectory's magnets, one per column: one value for all, or (N,) of
    finite values > 0; else an error naming `traj` or `masses`."""
    if not isinstance(traj, Trajectory):
        raise TypeError(f"traj: got {type(traj).__name__}; expected a Trajectory (e.g. RunFolder.trajectory())")
    try:
        values = np.asarray(masses, float)
    except (TypeError, ValueError):
        values = None
    if values is None or values.shape not in ((), traj.x0.shape) or not np.all(np.isfinite(values) & (values > 0)):
        got = f"{type(masses).__name__} of shape {values.shape}" if values is not None and values.ndim else repr(masses)[:40]
        raise ValueError(f"masses: got {got}; expected finite masses > 0 in g, one "
                         f"value or one per magnet, shape {traj.x0.shape} (e.g. case.chain.masses())")
    return np.broadcast_to(values, traj.x0.shape)


def _show(values: np.ndarray) -> str:
    return np.array2string(values, precision=4, threshold=6)
