"""The potential table: LAMMPS's interpolated force and energy against the exact law."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from pylmp_lattice import deck
from pylmp_lattice.engine import new_lammps
from pylmp_lattice.forcelaw import PowerLaw
from pylmp_lattice.run_folder import RunFolder

from conftest import OTHER_LAWS, make_case, make_law_case


def _read_back(case, tmp_path, monkeypatch):
    """LAMMPS's own F and U from the case's table (bond_write), r in mm, U in mJ, F in N."""
    case = dataclasses.replace(case, run=dataclasses.replace(case.run, engine="stock"))  # the engine with bonds
    folder = RunFolder.create(case, tmp_path).path
    lo, hi = case.table_range()
    setup = deck.deck_text(case).split("# ---- 3.")[0]  # the deck's system and force law
    monkeypatch.chdir(folder)
    lmp = new_lammps(["-screen", "none", "-log", "none"])
    lmp.commands_string(setup)
    # 99991 points: mostly between the table's nodes, where interpolation error is largest; both
    # ends 1 nm inside the table (at its last node LAMMPS's lookup can read past the table: the
    # last value came back NaN or 2e12 N in two CI runs of 2026-11-26)
    n = 99991
    lmp.command(f"bond_write 1 {n} {lo * 1e-3 + 1e-9} {hi * 1e-3 - 1e-9} readback.txt CHECK")
    lmp.close()
    data = np.loadtxt(folder / "readback.txt", skiprows=5)
    return data[:, 1] * 1e3, data[:, 2] * 1e3, data[:, 3]


@pytest.mark.lammps
def test_lammps_reads_back_the_law_within_1e_6(tmp_path, monkeypatch):
    r_mm, e_mJ, f_N = _read_back(make_case(particles=5), tmp_path, monkeypatch)
    law = PowerLaw()
    assert np.max(np.abs(f_N / law.force(r_mm) - 1)) < 1e-6
    # energy consistent with the force: U differences, relative to U
    assert np.max(np.abs(e_mJ / law.energy(r_mm) - 1)) < 1e-6



@pytest.mark.lammps
@pytest.mark.parametrize("law", OTHER_LAWS)
def test_lammps_reads_back_the_other_laws(tmp_path, monkeypatch, law):
    """Toda, LJ, Morse and FPUT through the same table: F and U within 1e-6 of their largest
    value on the table's range (they cross zero, so not relative pointwise)."""
    case = make_law_case(law, particles=5)
    r_mm, e_mJ, f_N = _read_back(case, tmp_path, monkeypatch)
    f, e = case.force.force(r_mm), case.force.energy(r_mm)
    assert np.max(np.abs(f_N - f)) < 1e-6 * np.max(np.abs(f))
    assert np.max(np.abs(e_mJ - e)) < 1e-6 * np.max(np.abs(e))


def test_table_is_consistent_f_equals_minus_du_dr():
    law = PowerLaw()
    r = np.linspace(0, 36, 100001)
    f_numeric = -np.gradient(law.energy(r), r)
    assert np.max(np.abs(f_numeric[1:-1] / law.force(r[1:-1]) - 1)) < 1e-6
