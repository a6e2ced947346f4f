"""The files a deck reads besides its data file: the force tables (nearest and second
neighbours, `table.bond_table`) and the measured drive's samples."""

from __future__ import annotations

import numpy as np

from ..case import Case
from ..formats.layout import IMPACTOR, SECOND_TABLE, TABLE
from ..impactor import Measured
from ..table import bond_table
from .engine_args import _num, impactor_samples


def _tables(case: Case, table: bool = True) -> dict[str, str]:
    """The files besides the deck and the data file: the potential table(s) (the nearest
    neighbours' only with `table`: a batch of chains whose fix has the exact law reads none),
    the measured drive."""
    lo, hi = case.table_range()
    files = {TABLE: bond_table(case.force, lo, hi, case.table.points, float(np.mean(case.chain.r0)))} if table else {}
    if isinstance(case.impactor, Measured):
        files[IMPACTOR] = impactor_samples_text(case.impactor)
    if case.second_neighbour is not None:
        lo2, hi2 = case.second_table_range()
        files[SECOND_TABLE] = bond_table(case.second_neighbour, lo2, hi2, case.table.points,
                                         2 * float(np.mean(case.chain.r0)))
    return files


def impactor_samples_text(imp: Measured) -> str:
    """Samples for `fix lattice/impactor` (`impactor_samples`)."""
    t, y = impactor_samples(imp)
    unit = "m" if imp.column == "u" else "m/s"
    return f"# measured impactor motion: t [s], {imp.column} [{unit}]\n" + "".join(f"{_num(a)} {_num(b)}\n" for a, b in zip(t, y))
