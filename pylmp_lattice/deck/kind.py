"""Which deck a case gets: the engine that runs it, its masses (one atom type per distinct mass,
or a mass per magnet) and whether it records the front on the fly. The deck's modules, the
checks before a run, the sweep's batches and the kernel engines ask the same questions here."""

from __future__ import annotations

import numpy as np

from ..case import Case


# A chain with more distinct masses than this (mass disorder) gives every magnet its own mass
# (fix property/atom rmass, filled from the data file's MAGNET_MASSES section) under one atom
# type: LAMMPS keeps arrays per pair of atom types, 16 bytes a pair (+238 MB at 4000 types).
MAX_ATOM_TYPES = 16
MAGNET_MASSES = "MagnetMasses"


def per_atom_masses(case: Case) -> bool:
    """Whether the deck gives masses per magnet (one atom type) rather than one type per mass."""
    return bool(case.chain.mass_disorder) or (not np.isscalar(case.chain.mass)
                                               and len(set(case.chain.mass)) > MAX_ATOM_TYPES)


def atom_types(case: Case) -> int:
    """The deck's atom types: one with masses per magnet, else one per distinct mass (a set, not
    np.unique: that imports numpy.ma, tens of ms before a sweep's first task)."""
    mass = case.chain.mass
    return 1 if per_atom_masses(case) or np.isscalar(mass) else len(set(mass))


def uses_chain_engine(case: Case) -> bool:
    """`run.engine = "chain"`, unless second neighbours need the stock path's second bonds."""
    return case.run.engine == "chain" and case.second_neighbour is None


def records_front(case: Case) -> bool:
    """Whether the deck records front measures on the fly: asked for, and a drive to scale them."""
    return case.output.front and case.impactor.peak_velocity() > 0
