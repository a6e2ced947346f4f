"""A batch of R chains of equal length in one deck (chain engine): which cases may share one
(`replica_batch`, `replica_range`), its files (`render_replicas`), and each chain's front
levels when they differ."""

from __future__ import annotations

import dataclasses
import operator
import re
from collections.abc import Sequence

import numpy as np

from ..case import Case
from ..errors import ConfigError
from ..formats.layout import CHAIN_WORK, DATA, DECK, FRONT_LEVELS, in_deck
from .data import chains_data_text
from .engine_args import _law_args, front_levels_rows
from .kind import per_atom_masses, records_front, uses_chain_engine
from .script import deck_text
from .tables import _tables


def render_replicas(cases: Sequence[Case], front: bool = False, draws=None, chain_files: bool = True) -> dict[str, str]:
    """R cases as R independent chains in one deck (chain engine): {file name: text}.

    The cases may differ only in their [chain] (masses, gaps, and what else the data file
    holds), with the same number of magnets N and, for a tabulated law, the same table range
    (`replica_range`; with the exact law the fix guards every chain's gaps with the narrowest
    of their ranges, so that no chain runs on past its own: a batch stopped there runs its
    members alone, each to its own outcome). Replica r (from 0)
    has atom IDs r N + 1 .. r N + N, its own impactor (the first) and held end (the last),
    and sits at y = r times the box height: its x values are those of its single run, so
    its trajectory is bit for bit the one-by-one run's. The batch writes a text dump of all
    chains (no fine output, no front record); read it back with RunFolder.replicas.
    With `front` it writes no per-frame output, only the front record of every atom (one
    front.bin; replica r's rows are its atoms), as each case alone would with output.format
    = "none", each chain with its own levels (`case_measures.chain_front_levels`). draws: the
    cases' `case_measures.chain_draws`, if drawn. Without `chain_files`, no data file and no
    levels file, only the deck that reads them (for an engine that takes the chains as arrays:
    these texts, some 25 floats a chain, are most of a batch's files' cost).
    """
    first = cases[0]
    batch = replica_batch(cases)
    # one text dump of all chains (the H5MD conversion and the front record are per chain), or
    # with `front` the front record alone (the fix's record is per atom)
    output = dict(format="none", fine=(), front=True) if front else dict(format="text", fine=(), front=False)
    batch = dataclasses.replace(batch, output=dataclasses.replace(first.output, **output))
    per_atom = any(per_atom_masses(case) for case in cases)
    files = {DECK: (deck_text(batch, replicas=len(cases), per_atom=per_atom)
                    + (_chain_work_lines() if front and first.friction else "")),
             **({DATA: chains_data_text(cases, per_atom, draws)} if chain_files else {}),
             **_tables(batch, table=_law_args(first.force) is None)}
    rows = front_levels_rows(cases, draws) if front and records_front(batch) else None
    if rows is not None and np.any(rows != rows[0]):  # the chains' levels differ: fix lattice/front reads one row per chain
        if chain_files:
            files[FRONT_LEVELS] = _levels_text(rows)
        files[DECK] = _FRONT_FIX.sub(lambda m: f"{m.group(0)} length {first.chain.particles} levels "
                                               f"{in_deck(FRONT_LEVELS)}", files[DECK], count=1)
    return files


def replica_batch(cases: Sequence[Case]) -> Case:
    """The case that R replicas share in one batch (`render_replicas`, the engines): replica 0's,
    with the narrowest table range of all; ConfigError if they differ beyond what a batch allows."""
    first = cases[0]
    first_range = replica_range(first)
    tabulated = first_range is not None  # of every replica: their laws are first's (checked below)
    outside = _OUTSIDE_CHAIN(first)
    if not uses_chain_engine(first):  # (of the run and second neighbours: each replica's, once equal outside [chain])
        raise ConfigError("run.engine", "replica 0: batched replicas need the chain engine (and no second neighbours)")
    for r, case in enumerate(cases):
        if _OUTSIDE_CHAIN(case) != outside:  # (a tuple's == tries `is` first: a sweep's replicas share these objects)
            raise ConfigError("replicas", f"replica {r} differs from replica 0 outside [chain]")
        if case.chain.particles != first.chain.particles or (tabulated and case.table_range() != first_range):
            raise ConfigError("replicas", f"replica {r}: N and the table range must equal replica 0's")
    table = dataclasses.replace(first.table, r_max=min(case.table_range()[1] for case in cases))
    return dataclasses.replace(first, table=table)


def replica_range(case: Case) -> tuple[float, float] | None:
    """The table range (mm) that chains batched with this case must share: its own when the law
    is tabulated; None when fix lattice/chain has the law exactly (the range then only guards
    the gaps, and a chain's widest drawn gap sets its upper end: gap disorder draws another
    for every seed)."""
    return case.table_range() if _law_args(case.force) is None else None


# What of a case reaches its deck beyond the data file and the front levels, as one tuple:
# everything but the chain, whose N and table range render_replicas checks (its name is in
# comments only).
_OUTSIDE_CHAIN = operator.attrgetter(*(f.name for f in dataclasses.fields(Case) if f.name not in ("chain", "name")))


# fix lattice/front's line in a deck, its levels as groups (pulse_floor optional)
_FRONT_FIX = re.compile(r"^fix +front +all +lattice/front +start (\S+) front (\S+) drop (\S+) pulse_drop (\S+)"
                        r"(?: pulse_floor (\S+))?", re.MULTILINE)


def front_levels_file(cases: Sequence[Case], draws=None) -> str | None:
    """fix lattice/front's levels file for a batch of chains, one row per chain, each the levels
    its deck alone passes the fix (`_output_lines`); None when all chains have the same levels
    (draws: the cases' `case_measures.chain_draws`, if drawn)."""
    rows = front_levels_rows(cases, draws)
    return None if np.all(rows == rows[0]) else _levels_text(rows)


def _levels_text(rows: np.ndarray) -> str:
    return "# start front drop pulse_drop pulse_floor, one chain per row (SI)\n" + "".join(
        f"{a!r} {b!r} {c!r} {d!r} {e!r}\n" for a, b, c, d, e in rows.tolist())


def _chain_work_lines() -> str:
    """After a batched run with friction: each chain's friction work (J, the fix's vector entry
    2 + chain), one line per chain in CHAIN_WORK, written by the fix in one command."""
    return f"""
# ---- 7. Each chain's friction work (J), one line per chain
fix_modify      chain write_work {in_deck(CHAIN_WORK)}
"""
