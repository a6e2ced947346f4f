"""`pylmp-lattice study dsw --quick` end to end: the paper's chain at V_I = 0.5 V* and 1.5 V*
for 17 linear periods (400 ms), through the CLI, the sweep layer and the study writer; the
full numbers are in docs/literature.md."""

from __future__ import annotations

import json

import pytest

from pylmp_lattice import theory
from pylmp_lattice.cli import main
from pylmp_lattice.forcelaw import PowerLaw

pytestmark = pytest.mark.lammps


@pytest.mark.slow  # 33 s: the quick study plus its run-length runs (17 and 34 periods)
def test_dsw_quick(tmp_path, caplog):
    with caplog.at_level("WARNING"):
        assert main(["study", "dsw", "--quick", "-o", str(tmp_path)]) == 0
    assert "1 of 2 runs have V_I above V*, outside the theory's domain" in caplog.text
    data = json.loads((tmp_path / "dsw.json").read_text())
    assert data["quick"] is True and "quick" in data["title"]
    assert {p.name for p in tmp_path.iterdir()} >= {"dsw.png", "dsw.pdf", "dsw_runs.csv", "dsw_chains.csv"}
    chain = data["chains"]["magnet q=3"]
    v_star = theory.critical_velocity(PowerLaw(), 1.084, 12.0)
    assert chain["V_star_theory_m_per_s"] == pytest.approx(0.880652, rel=1e-6) == v_star
    below, above = data["runs"]
    assert below["V_I_m_per_s"] == pytest.approx(0.5 * v_star, rel=1e-5) and below["status"] == "done"
    assert below["lead_speed_m_per_s"] == pytest.approx(theory.predict(PowerLaw(), 1.084, 12.0,
                                                                       below["V_I_m_per_s"]).lead_speed, rel=1e-12)
    # below V*: V_P (its A - C/n limit) within 0.5 % (measured -0.13 %), f within 1 % (-0.76 %
    # after 400 ms; it closes in as the wake decays), the wake next to the piston within 0.1 %
    assert abs(below["V_P_limit_vs_lead"]) < 0.005
    assert abs(below["f_vs_theory"]) < 0.01
    assert abs(below["mean_gap_vs_theory"]) < 1e-3 and abs(below["mean_force_vs_theory"]) < 1e-3
    assert below["wake"] == "decays" and above["wake"] == "persists"
    assert below["theory_in_domain"] is True and above["theory_in_domain"] is False
    # the measured deviations on each side of V*, as the chain's numbers
    assert chain["largest_V_P_limit_deviation_below_V_star"] == pytest.approx(abs(below["V_P_limit_vs_lead"]), rel=1e-12)
    assert chain["largest_V_P_limit_deviation_above_V_star"] == pytest.approx(abs(above["V_P_limit_vs_lead"]), rel=1e-12)
    assert chain["largest_wake_frequency_deviation_above_V_star"] == pytest.approx(abs(above["f_vs_theory"]), rel=1e-12)
    assert chain["largest_decaying_V_I_m_per_s"] < v_star < chain["smallest_persisting_V_I_m_per_s"]
    # first peaks approach 2 V_I: the limit of A - C/n within 1 %
    assert below["first_peak_limit_over_V_I"] == pytest.approx(2.0, rel=0.01)
    # run length: the same V_I for 17 and 34 periods; the 17-period rows are the runs above, and
    # the limits barely move (measured: V_P limit by 2.6e-4, first-peak limit by 2.4e-3)
    lengths = data["run_length"]
    assert lengths["periods_T0"] == [17.0, 34.0] and len(lengths["runs"]) == 4
    short = [r for r in lengths["runs"] if r["periods_T0"] == 17.0]
    assert [r["V_P_limit_m_per_s"] for r in short] == [below["V_P_limit_m_per_s"], above["V_P_limit_m_per_s"]]
    assert all(r["status"] == "done" for r in lengths["runs"])
    longer = [r for r in lengths["runs"] if r["periods_T0"] == 34.0]
    assert longer[0]["duration_ms"] == pytest.approx(2 * short[0]["duration_ms"], rel=1e-12)
    assert longer[0]["particles_reached"] > short[0]["particles_reached"]
    assert 0 < lengths["largest_relative_change_V_P_limit"] < 1e-3
    assert 0 < lengths["largest_relative_change_first_peak_limit"] < 5e-3
    assert (tmp_path / "dsw_lengths.csv").exists()
