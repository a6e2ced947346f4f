"""The literature studies (harmonic, toda, hugoniot) end to end, shrunk to one or two short runs,
through the sweep layer and the study writer; their full numbers are in docs/literature.md."""

from __future__ import annotations

import dataclasses
import io
import json

import pytest

from pylmp_lattice.plots import pyplot
from pylmp_lattice.studies import run_study, write_study
from pylmp_lattice.studies.literature import harmonic, hugoniot, toda

pytestmark = pytest.mark.lammps


@pytest.mark.slow
def test_harmonic_study(tmp_path, monkeypatch):
    """One u_p, 150 ms: max error over particles 1-30 < 1e-5 u_p, the first peak at n = 10 as the
    exact one to 1e-6, V_P within 2 % of c0."""
    monkeypatch.setattr(harmonic, "QUICK", ((0.1,), 150.0))
    run_study("harmonic", tmp_path, quick=True)
    data = json.loads((tmp_path / "harmonic.json").read_text())
    row = data["runs"][0]
    assert row["max_error_magnets_2_31_over_u_p"] < 1e-5
    assert row["front_speed_V_P_m_per_s"] == pytest.approx(data["c0_m_per_s"], rel=0.02)
    assert {p.name for p in tmp_path.iterdir()} >= {"harmonic.png", "harmonic.pdf", "harmonic_runs.csv"}
    assert (tmp_path / "harmonic" / "results.csv").exists()  # it ran through the sweep layer


@pytest.mark.slow
def test_toda_study(tmp_path, monkeypatch):
    """One soliton (k = 1) and one piston (u_p = 1, 50 time units): speed within 1e-4 of
    sinh(k)/k, the wake within 1e-3 of (1 + u_p/2)^2; re-running resumes (no run repeated)."""
    monkeypatch.setattr(toda, "QUICK", ((1.0,), (1.0,), 50.0))
    run_study("toda", tmp_path, quick=True)
    data = json.loads((tmp_path / "toda.json").read_text())
    assert abs(data["solitons"][0]["relative_error"]) < 1e-4
    assert abs(data["pistons"][0]["relative_error_exp_minus_r"]) < 1e-3
    status = next((tmp_path / "toda" / "pistons" / "members").iterdir()) / "status.json"
    before = status.stat().st_mtime_ns
    run_study("toda", tmp_path, quick=True)
    assert status.stat().st_mtime_ns == before


def test_hugoniot_study(tmp_path, monkeypatch):
    """The Toda chain at u_p = 1 for 40 ms: the mean state's Rankine-Hugoniot particle velocity
    within 2 % of u_p, the front within 2 % of the exact lead soliton, faster than the R-H speed."""
    monkeypatch.setattr(hugoniot, "QUICK", {"toda": ((1.0,), 40.0)})
    result = hugoniot.run(tmp_path, quick=True)
    # its numbers through the study writer; its figure drawn once at low resolution (the PNG at
    # 120 dpi and the PDF took half this test; tests/test_figures.py checks the figure's style)
    write_study(dataclasses.replace(result, figure=None), tmp_path)
    result.figure.savefig(io.BytesIO(), format="png", dpi=30)
    pyplot().close(result.figure)
    point = json.loads((tmp_path / "hugoniot.json").read_text())["points"][0]
    assert point["rankine_hugoniot_u_p_m_per_s"] == pytest.approx(1.0, rel=0.02)
    assert point["U_s_m_per_s"] == pytest.approx(point["lead_soliton_speed_m_per_s"], rel=0.02)
    assert point["U_s_m_per_s"] > point["rankine_hugoniot_D_m_per_s"]
