"""The study framework: registry, strict-JSON/CSV/figure writer, the `study` command."""

from __future__ import annotations

import csv
import json
import math

import numpy as np
import pytest

from pylmp_lattice.cli import main
from pylmp_lattice.serialize import dumps, jsonable
from pylmp_lattice.studies import STUDIES, StudyResult, run_study, write_study


def test_jsonable_is_strict():
    data = {"x_mm": np.float64("nan"), "n": np.int64(3), "a": np.array([1.0, np.inf]), "ok": np.bool_(True)}
    assert jsonable(data) == {"x_mm": None, "n": 3, "a": [1.0, None], "ok": True}
    text = dumps(data)
    assert "NaN" not in text and "Infinity" not in text
    with pytest.raises(TypeError):
        jsonable(object())


def test_writer_files(tmp_path):
    from pylmp_lattice.plots import pyplot

    fig = pyplot().figure()
    fig.gca().plot([0, 1], [0, 1])
    result = StudyResult("demo", {"v_m_per_s": float("nan"), "t_ms": 1.5},
                         tables={"peaks": {"n": [1, 2], "v_m_per_s": [0.5, float("nan")]}}, figure=fig)
    files = write_study(result, tmp_path)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["demo.json", "demo.pdf", "demo.png", "demo_peaks.csv"]
    data = json.loads((tmp_path / "demo.json").read_text(), parse_constant=lambda c: pytest.fail(c))
    assert data["v_m_per_s"] is None and data["t_ms"] == 1.5 and data["study"] == "demo"
    assert data["files"]["png"] == "demo.png"
    rows = list(csv.reader(open(files["table peaks"])))
    assert rows == [["n", "v_m_per_s"], ["1", "0.5"], ["2", ""]]
    # a second write replaces the files whole and leaves no partial file behind
    write_study(result, tmp_path)
    assert not list(tmp_path.glob(".*partial"))


def test_writer_rejects_ragged_table(tmp_path):
    with pytest.raises(ValueError, match="different lengths"):
        write_study(StudyResult("bad", {}, tables={"t": {"a": [1, 2], "b": [1]}}), tmp_path)


def test_unknown_study_is_a_usage_error(capsys):
    with pytest.raises(SystemExit) as exit_:
        main(["study", "nope"])
    assert exit_.value.code == 2
    with pytest.raises(ValueError, match="choose one of"):
        run_study("nope")


@pytest.mark.lammps
@pytest.mark.slow
def test_s4_quick(tmp_path):
    """Energy balance of the rig: the mechanical energy lost equals the friction work (2e-7 in
    the full study; bound 1e-5), and the magnet stays between the fixed ones."""
    assert "s4" in STUDIES
    assert main(["study", "s4", "-o", str(tmp_path), "--quick"]) == 0
    data = json.loads((tmp_path / "s4.json").read_text())
    assert [row["r1_mm"] for row in data["rig"]] == [249.5, 30.1]
    assert data["max_abs_energy_balance_relative_error"] < 1e-5
    for row in data["rig"]:
        assert 0 < row["final_position_mm"] < row["r1_mm"] and row["half_cycles"] >= 1
        assert math.isfinite(row["friction_work_mJ"]) and row["friction_work_mJ"] > 0
    assert (tmp_path / "s4.png").stat().st_size > 0 and (tmp_path / "s4_rig.csv").exists()
