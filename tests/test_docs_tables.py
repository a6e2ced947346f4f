"""The tables of docs/reproduction.md and docs/literature.md are written by docs/tables.py from
the studies' stored outputs (docs/reproduction/*.json, docs/literature/*.csv): a number typed
into a table, or a study output updated without rewriting the table, fails here."""

from __future__ import annotations

import importlib.util
import json
import re
from pathlib import Path

import pytest

DOCS = Path(__file__).parent.parent / "docs"


def _tables():
    spec = importlib.util.spec_from_file_location("docs_tables", DOCS / "tables.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


tables = _tables()


@pytest.mark.parametrize("doc", ["reproduction.md", "literature.md", "../README.md"])
def test_every_generated_table_agrees_with_its_study(doc):
    text = (DOCS / doc).read_text()
    names = tables.marked(text)
    assert sorted(names) == sorted(n for n, (d, _) in tables.BLOCKS.items() if d == doc)
    rendered, changed = tables.render(text)
    assert changed == [], f"{doc}: tables {changed} differ from their studies; run python docs/tables.py"
    assert rendered == text


def test_a_number_that_differs_from_its_table_fails():
    """s7's 50 ms row as docs/reproduction.md showed it before the study moved (3.8882 for
    3.8884): the check names the table."""
    text = (DOCS / "reproduction.md").read_text()
    assert "| 50 ms | 3.8884 m/s" in text
    _, changed = tables.render(text.replace("| 50 ms | 3.8884 m/s", "| 50 ms | 3.8882 m/s"))
    assert changed == ["s7"]
    _, changed = tables.render(text.replace("1.701 | 1.882", "1.701 | 1.883"))
    assert changed == ["s8"]


@pytest.mark.parametrize("name", sorted(tables.BLOCKS))
def test_every_table_fails_on_a_changed_number(name):
    """In each generated table, the last digit of its first number changed (a stale or typed
    value): the check names that table and no other."""
    doc = tables.BLOCKS[name][0]
    text = (DOCS / doc).read_text()
    start = text.index(f"<!-- table {name}:")
    body_start = text.index("\n|---", start)  # the numbers are in the rows, not the header
    end = text.index(f"<!-- end table {name} -->")
    digit = re.search(r"\d(?=\D)", text[body_start + 5:end])
    at = body_start + 5 + digit.start()
    changed_text = text[:at] + str((int(text[at]) + 1) % 10) + text[at + 1:]
    _, changed = tables.render(changed_text)
    assert changed == [name]


def test_the_doc_shows_the_study_s_numbers():
    """Read back independently of the renderer: each s7 row's V_P is the stored plateau mean to
    4 decimals, and each dsw row's V_P limit the CSV's value to 5 significant figures."""
    runs = json.loads((DOCS / "reproduction" / "s7.json").read_text())["runs"]
    text = (DOCS / "reproduction.md").read_text()
    for run in runs:
        row = re.search(rf"^\| {run['T_r_ms']:g} ms \| ([0-9.]+) m/s", text, re.M)
        assert row and float(row[1]) == pytest.approx(run["V_P_plateau"]["mean"], abs=5e-5)
    lit = (DOCS / "literature.md").read_text()
    block = lit[lit.index("<!-- table dsw-paper-law"):lit.index("<!-- end table dsw-paper-law")]
    limits = [float(line.split("|")[3]) for line in block.splitlines() if re.match(r"^\| [0-9]", line)]
    import csv

    with open(DOCS / "literature" / "dsw_runs.csv", newline="") as f:
        csv_limits = [float(r["V_P_limit_m_per_s"]) for r in csv.DictReader(f)
                      if r["chain"] == "magnet q=3" and r["status"] == "done"]
    assert limits == pytest.approx(csv_limits, rel=1e-4) and len(limits) == 8
    # the run-length table: the 3 s first-peak limits, as dsw_lengths.csv gives them
    block = lit[lit.index("<!-- table dsw-lengths"):lit.index("<!-- end table dsw-lengths")]
    peaks = [float(line.split("|")[9]) for line in block.splitlines() if re.match(r"^\| [0-9]", line)]
    with open(DOCS / "literature" / "dsw_lengths.csv", newline="") as f:
        csv_peaks = [float(r["first_peak_limit_over_V_I"]) for r in csv.DictReader(f) if r["periods_T0"] == "128.0"]
    assert peaks == pytest.approx(csv_peaks, abs=5e-5) and len(peaks) == 8
    # the README's main job: V_P as the run's summary.json gives it
    summary = json.loads((DOCS / "reproduction" / "paper_long_lattice_summary.json").read_text())
    readme = (DOCS / "../README.md").read_text()
    shown = re.search(r"^\| shock velocity plateau V_P \(gaps 145-193\) \| ([0-9.]+) m/s", readme, re.M)
    assert float(shown[1]) == pytest.approx(summary["shock_velocity_plateau_m_per_s"]["mean"], abs=5e-4)


def test_the_script_checks_and_rewrites(tmp_path, monkeypatch, capsys):
    """--check exits 1 naming a stale table and leaves the file; without it the table is rewritten."""
    docs = tmp_path / "docs"
    docs.mkdir()
    for name in ("reproduction.md", "literature.md", "../README.md"):
        (docs / name).write_text((DOCS / name).read_text())
    monkeypatch.setattr(tables, "DOCS", docs)
    for sub in ("reproduction", "literature"):
        (docs / sub).symlink_to(DOCS / sub)
    stale = (docs / "reproduction.md").read_text().replace("| 5 ms | 3.9088", "| 5 ms | 3.9099")
    (docs / "reproduction.md").write_text(stale)
    readme = (tmp_path / "README.md").read_text().replace("| 3.913 m/s | 3.92 m/s", "| 3.92 m/s | 3.92 m/s")
    (tmp_path / "README.md").write_text(readme)
    assert tables.main(["--check"]) == 1
    err = capsys.readouterr().err
    assert "reproduction.md: table s7" in err and "README.md: table main-job" in err
    assert (docs / "reproduction.md").read_text() == stale
    assert tables.main([]) == 0 and tables.main(["--check"]) == 0
    assert (docs / "reproduction.md").read_text() == (DOCS / "reproduction.md").read_text()
    assert (tmp_path / "README.md").read_text() == (DOCS / "../README.md").read_text()


def test_the_hugoniot_tables_say_each_chain_s_units():
    """The fits table headed the Toda, LJ and Morse rows' c0 "(m/s)" while their numbers are in
    the models' reduced units (the points table says so in a units column): each fits row says
    its chain's units, as its points do, and no header says m/s."""
    import json

    lit = (DOCS / "literature.md").read_text()
    block = lit[lit.index("<!-- table hugoniot-fits"):lit.index("<!-- end table hugoniot-fits")].splitlines()
    assert block[1] == "| chain | units | c0 | s (weak shock) | 4s/3 | fit, all u_p | fit, lower half |"
    shown = {row.split(" | ")[0][2:]: row.split(" | ")[1] for row in block[3:]}
    points = json.loads((DOCS / "literature" / "hugoniot.json").read_text())["points"]
    assert shown == {p["chain"]: p["units"] for p in points} == {
        "magnet": "m/s, mm, N, mJ", "toda": "reduced, m = A = B = 1", "lj": "reduced, m = epsilon = sigma = 1",
        "morse": "reduced, m = D = 1, alpha r_e = 6"}
