"""The LAMMPS data file of one chain or of a batch of chains (atoms, masses, bonds for the
stock engine, velocities), and the deck's lines, shared by both engines, that set up the
system and read it."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..case import Case, check_name
from ..formats.layout import DATA, in_deck
from ..units import to_engine
from .engine_args import _num
from .kind import MAGNET_MASSES, per_atom_masses, uses_chain_engine

# Chains whose data lines are made by one %-format (bounds the format's temporaries)
CHAINS = 1024


def data_text(case: Case, per_atom: bool | None = None) -> str:
    """LAMMPS data file: atoms on the x axis (m), one type per distinct mass (kg); for the stock
    engine bonds i-(i+1) of type 1 and, with second neighbours, bonds i-(i+2) of type 2.

    Positions and masses include the chain's disorder and defect; a chain with thermal motion
    gets a Velocities section (m/s) for its free magnets. With per-atom masses (default
    `per_atom_masses(case)`) every magnet is type 1 and its mass is in the MAGNET_MASSES section."""
    return chains_data_text([case], per_atom)


def chains_data_text(cases: Sequence[Case], per_atom: bool | None = None, draws=None) -> str:
    """The data file of R chains of equal N (one case: `data_text`), written from their arrays
    (draws: the cases' `case_measures.chain_draws`, if drawn): chain r has atom IDs r N + 1 ..
    r N + N and molecule r + 1, and sits at y = r times the box height (its x values are those
    of its run alone). Atom types are the distinct masses of all chains; with per-atom masses,
    the distinct masses of their first magnets."""
    from ..case_measures import chain_draws  # (with the measures: a sweep's coordinator asks `kind` only)

    first, chains = cases[0], len(cases)
    n = first.chain.particles
    per_atom = per_atom_masses(first) if per_atom is None else per_atom
    draws = draws or chain_draws(cases)
    x = to_engine(draws.positions, "length")
    each = draws.masses
    masses, types = np.unique(each[:, :1] if per_atom else each, return_inverse=True)
    types = np.broadcast_to(types.reshape(chains, -1), (chains, n))
    v = to_engine(draws.velocities, "velocity")
    # The chain engine finds neighbours by atom ID: bonds would only make LAMMPS warn that no
    # bond style is set.
    pairs = [] if uses_chain_engine(first) else [(i, i + 1, 1) for i in range(n - 1)]
    if first.second_neighbour is not None:
        pairs += [(i, i + 2, 2) for i in range(n - 2)]
    # y and z are fixed walls one table length away: atoms never leave x, and no ghosts in y, z;
    # the chains lie one box height apart in y
    half = to_engine(first.table_range()[1], "length")
    height = half - -half
    ids = np.arange(1, n * chains + 1)
    bonds = [f"{k + 1 + r * len(pairs)} {kind} {r * n + i + 1} {r * n + j + 1}"
             for r in range(chains) for k, (i, j, kind) in enumerate(pairs)]
    atoms, magnet_masses, velocities = [], [], []
    moving = bool(np.any(v))  # a Velocities section has a line for every atom, or is left out
    # Each section's lines for CHAINS chains at a time from one %-format filled at C speed (%r:
    # repr, as f"{x!r}"). A chain's atom lines are a format of (ID, molecule, y) per atom, made
    # once per distinct x and types (a thermal batch has one).
    same = bool(np.all(x.view(np.uint64) == x[:1].view(np.uint64)) and np.all(types == types[0]))
    templates: dict[tuple, str] = {}
    for lo in range(0, chains, CHAINS):
        hi = min(chains, lo + CHAINS)
        part = ids[lo * n:hi * n].tolist()
        rows = [0] if same else range(lo, hi)
        formats = []
        for r in rows:
            key = (x[r].tobytes(), types[r].tobytes())
            if key not in templates:
                templates[key] = "\n".join(f"%d %d {t} {xi!r} %s 0" for t, xi in zip((types[r] + 1).tolist(),
                                                                                      x[r].tolist()))
            formats.append(templates[key])
        fill = [None] * (3 * len(part))
        fill[0::3], fill[1::3] = part, np.repeat(np.arange(lo + 1, hi + 1), n).tolist()
        fill[2::3] = np.repeat(np.array([_num(r * height) if r else "0" for r in range(lo, hi)], dtype=object), n).tolist()
        atoms.append("\n".join(formats * (hi - lo) if same else formats) % tuple(fill))
        if per_atom:
            ms = to_engine(each[lo:hi], "mass").ravel().tolist()
            magnet_masses.append("\n".join(["%d %r"] * len(part)) % _pairs(part, ms))
        if moving:
            velocities.append("\n".join(["%d %r 0 0"] * len(part)) % _pairs(part, v[lo:hi].ravel().tolist()))
    name = check_name(first.name)
    lines = [
        f"# {name}: {n} magnets on the x axis (LAMMPS units si)" if chains == 1 else
        f"# {name}: {chains} chains of {n} magnets on the x axis (LAMMPS units si)",
        "",
        f"{n * chains} atoms",
        f"{len(bonds)} bonds",
        f"{len(masses)} atom types",
        f"{pairs[-1][2] if pairs else 0} bond types",
        "",
        f"{_num(np.min(x[:, 0]) - half)} {_num(np.max(x[:, -1]) + half)} xlo xhi",
        f"{_num(-half)} {_num(-half + chains * height)} ylo yhi",
        f"{_num(-half)} {_num(half)} zlo zhi",
        "",
        "Masses",
        "",
        *(f"{i + 1} {_num(to_engine(m, 'mass'))}" for i, m in enumerate(masses)),
        "",
        "Atoms # bond",
        "",
        *atoms,
    ]
    for section, section_lines in (("Bonds", bonds), (MAGNET_MASSES, magnet_masses), ("Velocities", velocities)):
        if section_lines:
            lines += ["", section, "", *section_lines]
    return "\n".join(lines) + "\n"


def _pairs(ids: list, values: list) -> tuple:
    """(ids[0], values[0], ids[1], values[1], ...)."""
    out = [*ids, *values]
    out[0::2], out[1::2] = ids, values
    return tuple(out)


# Both engines: atoms of the bond style (the stock engine's data file has bonds) on the x axis
# of a 3D box, kept in the order they were read (the map finds chain neighbours by ID).
_SYSTEM = """\
units           si
dimension       3
boundary        s f f
atom_style      bond
atom_modify     map array sort 0 0.0"""


def _read_data(per_atom: bool) -> str:
    if not per_atom:
        return f"read_data       {in_deck(DATA)}"
    return ("# one mass per magnet (mass disorder) and one atom type: LAMMPS keeps arrays per pair of types\n"
            "fix             masses all property/atom rmass\n"
            f"read_data       {in_deck(DATA)} fix masses NULL {MAGNET_MASSES}")
