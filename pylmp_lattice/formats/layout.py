"""What a run folder holds: the one place that names a run's files and the columns LAMMPS writes,
and where a run (or sweep) folder may be (`check_place`).

A run folder (see `folder.RunFolder`) is written by the package and run by LAMMPS, in-process
or by `lmp -in in.lattice` by hand. Every other module takes these names from here.

The deck names its files through the LAMMPS variable `dir` (`variable dir index .`): run by
hand in the folder, they are `./NAME`; the embedded runner sets `-var dir FOLDER`, so the
calling process never changes its working directory.
"""

from __future__ import annotations

import os
import re
from pathlib import Path

from ..errors import UsageError, brief

# ---- written before the run (deck.render, write.write_folder)
DECK = "in.lattice"
DATA = "chain.data"
TABLE = "force.table"
SECOND_TABLE = "second.table"  # the second-neighbour law, when the case has one
IMPACTOR = "impactor.txt"  # a measured impactor's samples (fix lattice/impactor reads them)
OLD_IMPACTOR = "piston.txt"  # their name in runs of 0.1.0 and before: overwriting one removes it too
FRONT_LEVELS = "front_levels.txt"  # a batch of chains: each chain's front record levels, a row each
CASE = "case.toml"  # the case, user units; a folder with it and MARKER holds a run
REPLICAS = "replicas.toml"  # the cases of a batched-replica folder
MARKER = "run.json"  # the package's record of the folder: version, state, where a run stopped

# ---- written by LAMMPS
LOG = "log.lammps"
DUMP = "traj.dump"  # output.format = "text": every magnet
FINE_DUMP = "fine.dump"  # output.format = "text": the output.fine magnets
TRAJ_BIN = "traj.bin"  # output.format = "h5md": binary dumps, converted into H5MD after the run
FINE_BIN = "fine.bin"
FRONT_BIN = "front.bin"  # fix lattice/front's record, written at the end of the run
CHAIN_WORK = "chain_work.txt"  # a batch of chains with friction: each chain's friction work (J), a line each

# ---- written after the run
H5MD = "traj.h5md"
TOPOLOGY = "topology.psf"  # traj.h5md's topology (masses in u) for MDAnalysis, VMD: `psf`
SUMMARY = "summary.json"
FIGURE = "shock.png"
LOCK = "run.lock"  # held (flock) while a writer or runner of this package writes the folder (marker.claimed)

# ---- a sweep's folder (`sweep.store`): its members' run folders and batches, never a run's (`inside_sweep`)
SWEEP_FILE = "sweep.json"  # the sweep the folder holds
MEMBERS = "members"  # members/<id>/: a member run alone
BATCHES = "batches"  # batched members' shared files, and the tasks' lock files

# Every name a run of this package may write (with its temporary files): a folder holding any of
# them but no run is refused, and overwriting a run removes these and nothing else.
RUN_FILES = (DECK, DATA, TABLE, SECOND_TABLE, IMPACTOR, OLD_IMPACTOR, FRONT_LEVELS, CASE, REPLICAS, LOG, DUMP, FINE_DUMP, TRAJ_BIN,
             FINE_BIN, FRONT_BIN, CHAIN_WORK, H5MD, H5MD + ".part", TOPOLOGY, SUMMARY, FIGURE, MARKER,
             MARKER + ".tmp", LOCK)

# The particle groups of a trajectory ("chain": every magnet; "fine": the output.fine magnets)
# and their files, binary (output.format = "h5md", until converted) and text.
BINARY_GROUPS = {"chain": TRAJ_BIN, "fine": FINE_BIN}
TEXT_GROUPS = {"chain": DUMP, "fine": FINE_DUMP}
# What a run leaves besides its log: its trajectory in any form, and its front record.
OUTPUTS = (FRONT_BIN, H5MD, *TEXT_GROUPS.values(), *BINARY_GROUPS.values())

# ---- columns
DUMP_COLUMNS = "id type mass x y z vx vy vz fx fy fz"  # text dumps
BIN_COLUMNS = "id x vx fx"  # binary dumps: y, z stay 0, so a 1D frame is x, v and f along x
# fix lattice/front's per-atom columns, in order, and the quantity of each (for units.from_engine)
FRONT_FIELDS = (("start_time", "time"), ("arrival", "time"), ("peak_time", "time"),
                ("peak_velocity", "velocity"), ("peak_acceleration", "acceleration"), ("max_speed", "velocity"),
                ("pulse_arrival", "time"))
FRONT_COLUMNS = "id " + " ".join(f"f_front[{k}]" for k in range(1, len(FRONT_FIELDS) + 1))

# ---- lines the deck and LAMMPS print into the log
CONTACT_MARK = "CONTACT:"  # the deck's line when two magnets touched
END_OF_RUN = "Total wall time:"  # LAMMPS's last log line of a run that ended

DIR_VARIABLE = "dir"
# Characters a folder path may hold to go into a deck through ${dir}: LAMMPS splits a command at
# white space after substituting variables, and quotes, $ or & would start new syntax.
_DECK_SAFE = re.compile(r"[A-Za-z0-9_./+,:@%=~-]+")


def in_deck(name: str) -> str:
    """A run file as the deck names it."""
    return f"${{{DIR_VARIABLE}}}/{name}"


def deck_safe(path: str) -> bool:
    """Whether a folder path can be given to the deck as its `dir` variable."""
    return bool(_DECK_SAFE.fullmatch(path))


def deck_dir(folder: Path) -> str:
    """The folder as the deck's `dir` variable: relative to here if that is shorter and safe."""
    relative = os.path.relpath(folder)
    for path in (relative, str(folder)):
        if deck_safe(path):
            return path
    raise UsageError("output", f"got folder {str(folder)!r}; the embedded runner needs a path of letters, digits "
                                "and ._-+,:@%=~/ only (LAMMPS splits commands at spaces); choose another -o "
                                "or use the lmp runner (--runner lmp; runner = \"lmp\" in a sweep file)")


def as_path(value, name: str = "folder", what: str = "the path of the run's folder") -> Path:
    """`value` as a Path: UsageError naming `name` and saying `what` it takes where it is no path
    (None, a number, a case), one rule for every path a function of the package is given."""
    if not isinstance(value, (str, os.PathLike)):
        raise UsageError(name, f"got {brief(value)}; expected a str or Path: {what}")
    return Path(value)


def check_place(path: Path, what: str) -> None:
    """UsageError unless `path` may be the output folder of a `what` ("run", "sweep"): never the
    working directory, a parent of it or runs/ itself (they hold the user's files), nor a file,
    nor a symbolic link (its writes would land in the folder it names, wherever that is)."""
    path = Path(path)
    if path.is_symlink():
        raise UsageError("output", f"got {str(path)!r}: a symbolic link (to {os.readlink(path)!r}); give the folder "
                                    f"itself for the {what} (-o)")
    resolved, here = path.resolve(), Path.cwd().resolve()
    if resolved == here or resolved in here.parents or resolved == here / "runs":
        raise UsageError("output", f"got {str(path)!r}: the working directory, a parent of it or runs/; "
                                    f"choose a new folder for the {what} (-o)")
    if path.exists() and not path.is_dir():
        raise UsageError("output", f"got {str(path)!r}: a file, not a folder")


def inside_sweep(path: Path) -> Path | None:
    """The members/ or batches/ folder of a sweep (one beside a sweep.json) that is `path` or
    holds it, if any: what is written there passes for the sweep's members."""
    path = Path(path).resolve()
    return next((p for p in (path, *path.parents) if p.name in (MEMBERS, BATCHES) and (p.parent / SWEEP_FILE).is_file()),
                None)

