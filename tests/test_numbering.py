"""One numbering wherever a user sees a magnet or gap number (`numbering`): magnet 1 is the
impactor, gap n lies between magnets n and n+1, ranges are inclusive. Pinned on a synthetic
front whose slow gap is known, and on the main job: its summary says V_P = 3.91308 m/s over
gaps 145-193, and the API's plateau and the fig3 study's JSON and tables say the same."""

from __future__ import annotations

import csv
import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose

from pylmp_lattice import measures
from pylmp_lattice.case import load_case
from pylmp_lattice.errors import ConfigError
from pylmp_lattice.numbering import entries, number
from pylmp_lattice.plots import pyplot
from pylmp_lattice.run_folder import execute, run_case
from pylmp_lattice.run_folder.folder import RunFolder
from pylmp_lattice.studies.long_lattice import analyse
from pylmp_lattice.studies.output import write_study
from pylmp_lattice.columnar import rows
from pylmp_lattice.summary import _maxima

from conftest import make_case

MAIN_CASE = Path(__file__).resolve().parents[1] / "inputs" / "paper_long_lattice.toml"
R0 = 12.0  # mm


def test_number_and_entries_convert_between_array_entries_and_numbers():
    values = np.arange(10) * 10  # entry i is magnet (or gap) i + 1
    assert number(0) == 1 and number(np.int64(144)) == 145 and isinstance(number(np.int64(3)), int)
    assert values[entries(3, 5)].tolist() == [20, 30, 40]  # magnets 3, 4 and 5, inclusive
    assert values[entries(1, 10)].tolist() == values.tolist()


def test_a_late_magnet_is_named_by_its_gaps_as_the_paper_counts():
    """Magnets 1..30 at x = (n - 1) r0 reached at t_n = n - 1 ms, except magnet 8, 0.5 ms late:
    gap 7 (magnets 7 and 8) is crossed slowly, gap 8 (magnets 8 and 9) fast."""
    arrival = np.arange(30.0)
    arrival[7] += 0.5  # magnet 8
    vp = measures.propagation_velocity(arrival, R0)
    assert_allclose(vp[entries(7, 8)], [R0 / 1.5, R0 / 0.5])
    assert rows(_maxima(vp[None]))[0]["gap"] == 8
    front = measures.Front(arrival, vp, peaks=None, slowest_linear_speed=10.0)  # flags V_P < 9 m/s: 8 m/s
    assert front.flags()["below_linear_speed_gaps"] == [7]
    # the plateau of the last quarter of the 29 gaps: gaps 22 to 29, all at r0 / 1 ms
    plateau = measures.trailing_plateau(vp)
    assert (plateau.first, plateau.last, plateau.mean) == (22, 29, R0)
    assert vp[entries(plateau.first, plateau.last)].size == 8 == 29 - 22 + 1
    # fitted over magnets 2-7 (on time) the front moves at r0 per ms; over 7-9 it does not
    assert measures.fit_propagation_velocity(arrival, np.arange(30) * R0, 2, 7).velocity == pytest.approx(R0)
    assert measures.fit_propagation_velocity(arrival, np.arange(30) * R0, 7, 9).residual_rms > 0.1


@pytest.mark.lammps
def test_the_main_job_summary_api_and_study_agree_on_gaps_145_to_193(tmp_path):
    case = load_case(MAIN_CASE)
    summary = run_case(case, tmp_path / "main", figure=False)
    plateau = summary["shock_velocity_plateau_m_per_s"]
    assert (plateau["first_gap"], plateau["last_gap"]) == (145, 193)
    assert plateau["mean"] == pytest.approx(3.91308, abs=5e-6)
    peaks = summary["first_peak_velocity_plateau_m_per_s"]
    assert (peaks["first_magnet"], peaks["last_magnet"]) == (146, 194)  # behind gaps 145-193
    assert summary["particles_reached_by_front"] == 194

    # the API: the same window from the run's front, numbered the same way
    folder = RunFolder(tmp_path / "main")
    api = measures.trailing_plateau(folder.front().accepted_velocity)
    assert (api.first, api.last) == (145, 193) and round(api.mean, 5) == plateau["mean"]

    # the fig3 study on the run's trajectory: its JSON and tables use the same numbers
    traj = folder.trajectory()
    result = analyse("fig3", "main job", traj, case, 2.0, case.run.duration, quick=True, zone=False)
    # the numbers and tables only: saving the figure (PNG and PDF) took 2/3 of this test, and
    # tests/test_figures.py checks fig3's figure
    pyplot().close(result.figure)
    files = write_study(dataclasses.replace(result, figure=None), tmp_path / "study")
    data = json.loads(files["json"].read_text())
    study = data["V_P_plateau_m_per_s"]
    assert (study["first_gap"], study["last_gap"]) == (145, 193)
    # from arrivals interpolated between 1 ms frames, not every step: 3.91386 m/s, 2e-4 above
    assert study["mean"] == pytest.approx(plateau["mean"], rel=5e-4)
    fit = data["V_P_fitted_over_plateau_window"]
    assert (fit["first_magnet"], fit["last_magnet"]) == (145, 194)  # the magnets on either side
    with open(files["table particles"]) as fh:
        rows = {int(r["n"]): r for r in csv.DictReader(fh)}
    vp = measures.propagation_velocity(measures.arrival_times(traj.t, traj.v, 2.0), case.chain.gaps())
    for gap in (1, 145, 193):  # row n holds V_P over gap n, between magnets n and n+1
        assert float(rows[gap]["V_P_gap_n_to_n+1_m_per_s"]) == pytest.approx(vp[gap - 1], rel=1e-12)
    assert float(rows[1]["arrival_ms"]) == pytest.approx(0.0, abs=1e-9)  # magnet 1, the impactor, moves first


@pytest.mark.lammps
def test_a_trajectory_is_selected_by_magnet_number(tmp_path):
    """RunFolder.trajectory(magnets=...) takes the paper's numbers: magnet n is column n - 1 of
    the whole chain, and in the fine group the column of magnet n among output.fine."""
    case = make_case(particles=30, duration=5.0, interval=0.5, output={"fine": [2, 7, 12], "fine_interval": 0.1})
    run = execute(case, tmp_path / "r")
    whole, fine = run.trajectory(), run.trajectory("fine")
    pair = run.trajectory("chain", magnets=[2, 12])
    assert np.array_equal(pair.v, whole.v[:, [1, 11]]) and np.array_equal(pair.x0, whole.x0[[1, 11]])
    assert np.array_equal(run.trajectory("fine", magnets=[7]).v, fine.v[:, [1]])
    assert np.max(np.abs(pair.v[:, 0])) > 0.5  # magnet 2, next to the impactor (2 m/s), moves
    assert pair.x0[1] - pair.x0[0] == pytest.approx(10 * 12.0)  # magnets 2 and 12: 10 gaps of r0
    # the separation of the selected columns: magnets 2 and 12, 10 gaps of r0 = 12 mm at rest
    assert pair.gaps().shape == (len(pair.t), 1) and pair.gaps()[0, 0] == pytest.approx(10 * 12.0)
    for group, bad in (("chain", [0]), ("chain", [31]), ("chain", [12, 7]), ("fine", [3]), ("chain", 10),
                       ("chain", [1.5]), ("chain", "12"), ("chain", [True])):
        with pytest.raises(ConfigError, match=r"^magnets: got"):
            run.trajectory(group, magnets=bad)
