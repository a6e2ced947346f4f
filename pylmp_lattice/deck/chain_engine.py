"""Sections 1-4 of the chain engine's deck: one plugin fix (fix lattice/chain) does the whole
time step of one chain or of a batch of chains, split among ranks by `processors`."""

from __future__ import annotations

from ..case import Case
from ..formats.layout import CONTACT_MARK, TABLE, in_deck
from ..table import KEYWORD
from ..units import to_engine
from .data import _SYSTEM, _read_data
from .engine_args import _impactor_args, _law_args, _num


def _processors(replicas: int) -> str:
    """How several ranks split the chains: one chain into slabs along x (neighbouring slabs
    exchange their edge positions every step); a batch by whole chains (stacked in y), so
    that no rank exchanges anything but the contact flag."""
    if replicas > 1:
        return ("# domains along y only: each rank owns whole chains; no reverse communication of forces\n"
                "processors      1 * 1")
    return ("# domains along x only; no reverse communication of forces (every force is set by its owner)\n"
            "processors      * 1 1")


def _chain_sections(case: Case, replicas: int, per_atom: bool) -> str:
    """Sections 1-4 of the chain engine: one fix lattice/chain does the whole time step.

    `replicas` > 1: the data file holds that many chains of N magnets, IDs in blocks of N."""
    n = case.chain.particles
    lo, hi = case.table_range()
    lo_si, hi_si = to_engine(lo, "length"), to_engine(hi, "length")
    law = _law_args(case.force)
    source = (f"# F from the exact {case.force.law} law" if law else
              "# F from the table's clamped cubic spline, as bond_style table spline reads it")
    chains = f" length {n}" if replicas > 1 else ""
    each = " of each chain" if replicas > 1 else ""
    with_friction = ", Coulomb friction (exact stick-slip)" if case.friction else ""
    fr = case.friction
    friction = (f" &\n                friction {_num(fr.mu)} {_num(fr.p)} {_num(to_engine(fr.g, 'acceleration'))}"
                if fr else "")
    return f"""\
# ---- 1. The chain{"s: " + str(replicas) + " chains of" if replicas > 1 else ":"} {n} magnets on the x axis
{_SYSTEM}
{_processors(replicas)}
newton          off
{_read_data(per_atom)}
# Ghosts must reach across the longest separation on several ranks.
comm_modify     cutoff {_num(1.05 * hi_si)}
# fix lattice/chain finds neighbours by atom ID: the data file has no bonds, and without
# bonds or a pair style LAMMPS builds no neighbour lists; it only redistributes atoms among
# ranks every 100 steps.
# The fix sets every force itself: LAMMPS clears forces only for the (empty) group none.
group           none empty
atom_modify     first none
neigh_modify    every 100 delay 0 check no include none

# ---- 2-4. Force law {case.force!r}, impactor, held end{with_friction}, contact guard
# One plugin fix does the whole step: nearest-neighbour forces, velocity Verlet, the
# impactor's prescribed motion (particle 1{each}), the held far end (particle {n}){with_friction}.
# It checks every gap at every step: a contact prints '{CONTACT_MARK} magnets I and J ...' and
# stops the run; a gap outside [{lo:g}, {hi:g}] mm stops it with an error. Its scalar is the
# potential energy (part of pe through fix_modify energy yes).
{source}
fix             chain all lattice/chain law {law or f"table {in_deck(TABLE)} {KEYWORD}"} &
                impactor {_impactor_args(case.impactor)} &
                range {_num(lo_si)} {_num(hi_si)}{chains}{friction}
fix_modify      chain energy yes
variable        min_gap equal f_chain[2]"""
