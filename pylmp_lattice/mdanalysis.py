"""MDAnalysis reads a run's traj.h5md alone with its masses and species: importing this
module registers a topology parser for H5MD files.

MDAnalysis's H5MD reader reads positions, velocities, forces, times and observables, but no
topology: without a parser, `Universe("traj.h5md")` has no masses and warns twice while it
fails to guess them. With MDAnalysis alone, give it the run's topology file (`psf`, written
beside traj.h5md):

    u = mda.Universe("runs/NAME/topology.psf", "runs/NAME/traj.h5md")

With this package installed, the file alone does. MDAnalysis registers every
`TopologyReaderBase` subclass under its `format`, so this class becomes the parser of every
H5MD file once this module is imported:

    import MDAnalysis as mda
    import pylmp_lattice.mdanalysis  # noqa: F401 (registers the parser)

    u = mda.Universe("runs/NAME/traj.h5md")
    u.atoms.masses        # u (1.084 g = 6.528e23 u)
    u.atoms.types         # the H5MD species, one per distinct mass: "1", "2", ...
    u.trajectory.dt       # the output interval, ps

It reads the H5MD elements `id`, `species` and `mass` of the particle group the H5MD reader
reads (the first), each when present, so other programs' H5MD files open as before, plus
whatever of these they hold.
"""

from __future__ import annotations

import h5py
import numpy as np
from MDAnalysis.core.topology import Topology
from MDAnalysis.core.topologyattrs import Atomids, Atomtypes, Masses, Resids, Resnums, Segids
from MDAnalysis.topology.base import TopologyReaderBase
from MDAnalysis.units import constants

# mass units an H5MD file may name -> u (MDAnalysis's mass unit); no unit: taken as u
_KG_PER_U = 1e-3 / constants["N_Avogadro"]
MASS_UNITS = {"kg": 1 / _KG_PER_U, "g": 1e-3 / _KG_PER_U, "u": 1.0, "amu": 1.0, "Da": 1.0}


class H5MDParser(TopologyReaderBase):
    """Atom ids, types (H5MD species) and masses (in u) from an H5MD file's particle group."""

    format = "H5MD"

    def parse(self, **kwargs) -> Topology:
        """The topology of the H5MD file (or open h5py.File): MDAnalysis's parser interface."""
        if isinstance(self.filename, h5py.File):
            return _topology(self.filename)
        with h5py.File(self.filename, "r") as h5:
            return _topology(h5)


def _topology(h5: h5py.File) -> Topology:
    group = h5["particles"][next(iter(h5["particles"]))]  # the group MDAnalysis's H5MD reader reads
    n = next(group[name]["value"].shape[1] for name in ("position", "velocity", "force") if name in group)
    ids = _element(group, "id")
    attrs = [Atomids(np.arange(1, n + 1) if ids is None else ids.astype(np.int64)),
             Resids(np.array([1])), Resnums(np.array([1])), Segids(np.array(["SYSTEM"], dtype=object))]
    species = _element(group, "species")
    if species is not None:
        attrs.append(Atomtypes(species.astype(str).astype(object)))
    mass = _element(group, "mass")
    if mass is not None:
        unit = group["mass"].attrs.get("unit", "u")
        unit = unit.decode() if isinstance(unit, bytes) else unit
        if unit not in MASS_UNITS:
            raise ValueError(f"{h5.filename}: mass unit {unit!r} unknown; expected one of {', '.join(MASS_UNITS)}")
        attrs.append(Masses(mass.astype(np.float64) * MASS_UNITS[unit]))
    return Topology(n, 1, 1, attrs=attrs)


def _element(group, name: str) -> np.ndarray | None:
    """A time-independent H5MD element (a dataset), or the first frame of a time-dependent one."""
    if name not in group:
        return None
    item = group[name]
    return item[()] if isinstance(item, h5py.Dataset) else item["value"][0]
