"""The chain's topology as a PSF file, so that plain MDAnalysis opens a run's trajectory with
its masses and without warnings:

    import MDAnalysis as mda
    u = mda.Universe("runs/NAME/topology.psf", "runs/NAME/traj.h5md")
    u.atoms.masses      # u (1.084 g = 6.528e23 u)
    u.trajectory.dt     # the output interval, ps

MDAnalysis's H5MD reader reads no topology, and a trajectory alone leaves its guessers nothing to
guess masses from (they warn). A topology file fills the gap; PSF (CHARMM's, in the NAMD flavour:
space-separated columns) is one that MDAnalysis, VMD and ParmEd read natively with masses in u.
The run's chain.data is no substitute: MDAnalysis reads its masses as u, but they are in kg
(LAMMPS `units si`), and with mass disorder they are in a section it does not read.

Atom n is magnet n (1 the impactor), in the order of the H5MD file's particles; type: the H5MD
species (1, 2, ...: one per distinct mass, in increasing mass); bonds: the nearest neighbours
n, n+1, the chain's gaps. Charges 0.
"""

from __future__ import annotations

import numpy as np
from scipy.constants import atomic_mass  # kg per u (CODATA)

from ..units import TO_SI

G_TO_U = TO_SI["mass"] / atomic_mass


def species(masses) -> np.ndarray:
    """1, 2, ...: one per distinct mass, in increasing mass (the H5MD file's `species`)."""
    return np.unique(np.asarray(masses, float), return_inverse=True)[1] + 1


def psf_text(name: str, masses) -> str:
    """A PSF of the chain with these masses (g, in chain order)."""
    masses = np.asarray(masses, float)
    n = masses.size
    # each line ends as its species's, formatted once (10^6 magnets: 1.0 s, 2.6 s line by line)
    ends = [f" CHAIN 1 CHAIN M {k} 0.0 {m * G_TO_U!r}" for k, m in enumerate(np.unique(masses).tolist(), 1)]
    atoms = [f"{i:8d}{ends[k]}" for i, k in enumerate((species(masses) - 1).tolist(), 1)]
    bonds = np.column_stack([np.arange(1, n), np.arange(2, n + 1)]).ravel().tolist()
    bond_lines = [("%8d" * len(line)) % tuple(line) for line in (bonds[k:k + 8] for k in range(0, len(bonds), 8))]
    return "\n".join([
        "PSF NAMD", "",
        "       2 !NTITLE",
        f" REMARKS pylmp_lattice {name}: {n} magnets in chain order, atom 1 the impactor",
        " REMARKS masses in u; the trajectory is traj.h5md", "",
        f"{n:8d} !NATOM", *atoms, "",
        f"{n - 1:8d} !NBOND: bonds", *bond_lines, "",
    ]) + "\n"
