"""`pylmp-lattice study thermal --quick`: ensembles of the long lattice under thermal motion and
mass disorder; the zero-noise point is the noise-free run."""

from __future__ import annotations

import dataclasses
import io
import json
from pathlib import Path

import numpy as np
import pytest

from pylmp_lattice import measures
from pylmp_lattice.case import load_case
from pylmp_lattice.run_folder import RunFolder, run_case
from pylmp_lattice.plots import pyplot
from pylmp_lattice.studies import STUDIES, write_study
from pylmp_lattice.studies.ensembles import thermal
from pylmp_lattice.studies.ensembles.thermal import MAGNET, VI, WINDOW_PERIODS

INPUTS = Path(__file__).parent.parent / "inputs"


@pytest.mark.lammps
def test_quick_thermal_study_and_its_noise_free_point(tmp_path):
    assert "thermal" in STUDIES
    result = thermal.run(tmp_path, quick=True)
    # its numbers and tables through the study writer; its figure drawn once at low resolution
    # (a PNG at 120 dpi and a PDF cost more; tests/test_figures.py checks the figure's style)
    write_study(dataclasses.replace(result, figure=None), tmp_path)
    result.figure.savefig(io.BytesIO(), format="png", dpi=30)
    pyplot().close(result.figure)
    data = json.loads((tmp_path / "thermal.json").read_text())
    assert data["quick"] is True and "[quick version]" in result.figure.get_suptitle()
    assert data["members"] == data["members_done"] == 1 + 2 * 2 + 2  # the noise-free point runs once
    assert set(data["quick_cannot_show"]) == {"stderr", "plateaus"} and "2 replicas (the full study: 8)" in \
        data["quick_cannot_show"]["stderr"]
    import pandas as pd

    table = pd.read_csv(tmp_path / "thermal_thermal.csv")  # each point's members run, failed ones and coverage
    assert table["failed"].tolist() == [0, 0, 0] and table["members"].tolist() == [1, 2, 2]
    np.testing.assert_allclose(table["V_P_m_per_s_coverage"], table["V_P_m_per_s_count"] / table["members"], rtol=1e-12)

    # the shipped long lattice, as long as the quick study, writing magnet 10 finely
    case = load_case(INPUTS / "paper_long_lattice.toml",
                     ["run.duration=150", f"output.fine=[{MAGNET}]", "output.fine_interval=0.1"])
    summary = run_case(case, tmp_path / "plain", figure=False)
    traj = RunFolder(tmp_path / "plain").trajectory("fine")
    span = max(0.2 * 150, WINDOW_PERIODS * 1e3 / summary["linear_frequency_f0_Hz"])
    eta = measures.steady_oscillation(traj.t, traj.v[:, 0], VI, (150 - span, 150)).energy_ratio
    quiet = data["noise_free"]
    assert quiet["V_P_m_per_s"] == summary["shock_velocity_plateau_m_per_s"]["mean"]
    assert quiet["first_peak_m_per_s"] == summary["first_peak_velocity_plateau_m_per_s"]["mean"]
    assert quiet["eta"] == pytest.approx(eta, rel=1e-14)  # the study's JSON: 15 digits
    for axis in ("against_thermal_rms", "against_mass_disorder"):
        first = data[axis][0]
        assert first["V_P_m_per_s"]["mean"] == quiet["V_P_m_per_s"] and first["members"] == 1

    # noisy points: two replicas each, with standard errors; V_P stays within 5 % of the noise-free
    # value up to 10 % thermal RMS (quick: measured +2.6 %), and the first peak near 2 V_I
    noisy = data["against_thermal_rms"][1:] + data["against_mass_disorder"][1:]
    assert all(p["members"] == 2 and p["first_peak_m_per_s"]["count"] == 2 for p in noisy)
    assert all(np.isfinite(p["first_peak_m_per_s"]["stderr"]) and p["first_peak_m_per_s"]["stderr"] > 0 for p in noisy)
    for p in noisy:
        assert p["V_P_m_per_s"]["mean"] == pytest.approx(quiet["V_P_m_per_s"], rel=0.05)
        assert p["first_peak_m_per_s"]["mean"] == pytest.approx(2 * VI, rel=0.05)
    assert [p["chain.thermal_velocity"] for p in data["against_thermal_rms"]] == [0.0, 0.04, 0.2]

    # the headline front speed: one gap window for every member (0.9 V0 150 ms / 12 mm = 18.0
    # gaps: gaps 9-18), defined for all of them, within 5 % of the noise-free run's; every
    # statistic states its coverage, marked below 90 % (the quick 5 % disorder point: 1 of 2 V_P
    # plateaus converged)
    assert data["front_window_gaps"] == [9, 18]
    assert quiet["front_speed_m_per_s"] == summary["front_speed_m_per_s"]["value"]
    for p in noisy:
        assert p["front_speed_m_per_s"]["count"] == p["members"] and p["front_speed_m_per_s"]["coverage"] == 1.0
        assert p["front_speed_m_per_s"]["mean"] == pytest.approx(quiet["front_speed_m_per_s"], rel=0.05)
        for name in ("V_P_m_per_s", "first_peak_m_per_s", "eta"):  # coverage: of the members run, failed ones too
            assert p[name]["coverage"] == p[name]["count"] / (p["members"] + p["failed"])
            assert p[name]["low_coverage"] == (p[name]["count"] < 0.9 * (p["members"] + p["failed"]))


def test_a_point_where_no_member_has_a_value_keeps_its_place_in_the_figure():
    """The 10 % disorder point's V_P plateau converged in none of its 8 members: a dotted line and
    "0/8" where it would be, not a point gone from the panel."""
    import pandas as pd

    from pylmp_lattice.sweep import replica_stats
    from pylmp_lattice.studies.ensembles.thermal import DISORDER, NAMES, THERMAL, VP

    rows = [{"id": f"{d}-{r}", THERMAL: 0.0, DISORDER: d, "replica": r, "status": "done",
             **{name: 3.9 + 0.01 * r for name in NAMES}} | ({VP: np.nan} if d == 0.1 else {})
            for d in (0.0, 0.05, 0.1) for r in range(8)]
    stats = replica_stats(pd.DataFrame(rows), list(NAMES))
    fig = thermal._figure(stats.iloc[:1], stats, stats.iloc[0], 1.6, quick=True)
    panel = fig.axes[5]  # (f): V_P against mass disorder
    dotted = [line for line in panel.lines if line.get_linestyle() == ":" and line.get_xdata()[0] == 10.0]
    assert len(dotted) == 1 and "0/8" in [t.get_text() for t in panel.texts]
    pyplot().close(fig)
