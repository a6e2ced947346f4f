"""Sweeps: the sweep file, member identity and seeds, the table, resume, failures, executors."""

from __future__ import annotations

import json
import logging
import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import tomli_w

from pylmp_lattice.cli import main
from pylmp_lattice.case import case_id, case_to_dict
from pylmp_lattice.errors import ConfigError
from pylmp_lattice.run_folder import RunFolder
from pylmp_lattice.sweep import (Sweep, load_results, load_sweep, member_seed, plot_replica_stats, replica_stats, run_sweep,
                                 write_replica_stats)
from pylmp_lattice.sweep.store import STATUS, Outcomes

from conftest import frame_of_dicts

BASE = """\
name = "small"
[chain]
particles = {particles}
mass = 1.084
r0 = 12.0
far_end = "fixed"
[force]
law = "power"
K = 413.8
b = 3.917
q = 3.0
[impactor]
profile = "constant"
velocity = 1.0
[run]
duration = {duration}
dt = 0.01
output_interval = {output}
"""
# Columns that legitimately differ between two runs of the same sweep.
TIMING = ["wall_time_s"]


def write_sweep(folder: Path, text: str, particles=8, duration=10.0, output=0.1) -> Path:
    (folder / "base.toml").write_text(BASE.format(particles=particles, duration=duration, output=output))
    (folder / "sweep.toml").write_text(text)
    return folder / "sweep.toml"


SIX = """\
base = "base.toml"
[grid]
"impactor.velocity" = [0.5, 1.0, 1.5]
"force.q" = [2.5, 3.0]
"""


def start_sweep(tmp_path: Path, duration: float, stderr):
    """The six-member sweep (12 magnets, `duration` ms each) as a command in its own process
    group, one worker: (command, sweep folder, process)."""
    path = write_sweep(tmp_path, SIX, particles=12, duration=duration, output=0.1)
    out = tmp_path / "out"
    cmd = [sys.executable, "-m", "pylmp_lattice.cli", "sweep", str(path), "-o", str(out), "--workers", "1", "--quiet"]
    return cmd, out, subprocess.Popen(cmd, start_new_session=True, stderr=stderr, text=True)


def member_statuses(out: Path) -> dict[Path, str]:
    """Member folder -> status, as a running sweep has written them so far."""
    found = {}
    for status in (out / "members").glob(f"*/{STATUS}"):
        try:
            found[status.parent] = json.loads(status.read_text())["status"]
        except (OSError, json.JSONDecodeError):  # being replaced right now
            pass
    return found


# ----------------------------------------------------------------------------- the sweep file

def test_members_are_the_grid_product_times_the_zip_with_replicas_innermost(tmp_path):
    path = write_sweep(tmp_path, """\
base = "base.toml"
replicas = 2
seed = 9
[set]
chain.thermal_velocity = 0.01
[grid]
"impactor.velocity" = [0.5, 1.0]
[zip]
"force.q" = [2.5, 3.0, 3.5]
"run.duration" = [10.0, 20.0, 30.0]
""")
    members = load_sweep(path).members()
    assert len(members) == 2 * 3 * 2
    assert [m.index for m in members] == list(range(12))
    first = members[0]
    assert first.params == {"impactor.velocity": 0.5, "force.q": 2.5, "run.duration": 10.0, "replica": 0,
                            "chain.seed": member_seed(9, 0)}
    assert members[5].params["force.q"] == 3.5 and members[5].params["run.duration"] == 30.0  # zip pairs
    assert members[5].case.run.duration == 30.0 and members[5].case.chain.thermal_velocity == 0.01
    assert [m.case.chain.seed for m in members] == [member_seed(9, i) for i in range(12)]
    assert len({m.id for m in members}) == 12
    assert [m.id for m in load_sweep(path).members()] == [m.id for m in members]  # the id is the case
    assert [m.id for m in members] == [case_id(m.case) for m in members]  # replicas' ids are derived, not built
    other_seed = Sweep(base=tmp_path / "base.toml", set={"chain.thermal_velocity": 0.01}, replicas=2, seed=10)
    assert {m.id for m in other_seed.members()}.isdisjoint(m.id for m in members)


def test_member_seeds_a_block_at_a_time_are_numpys_seed_sequence():
    """`seeds.member_seeds` and `member_seed` (array operations where they hold it) give NumPy's
    SeedSequence of every member: across blocks, blocks of one and a few, for sweep seeds of one
    to five words (with the index, up to and past the pool's 4), indices up to and past 2**32
    (NumPy's there)."""
    from pylmp_lattice.sweep.seeds import BLOCK, member_seeds

    def numpys(sweep_seed, index):
        return int(np.random.SeedSequence([sweep_seed, index]).generate_state(1, np.uint64)[0] >> 1)

    for sweep_seed in (0, 9, 2**32 - 1, 2**32, 2**63 - 1, 2**96 + 5, 2**128 + 7):
        for start, count in ((0, BLOCK + 3), (5, 1), (7, 3), (2**32 - 20, 20), (2**32 - 7, 7), (2**32 - 3, 6)):
            expected = [numpys(sweep_seed, i) for i in range(start, start + count)]
            assert list(member_seeds(sweep_seed, start, count)) == expected
            ends = [*range(min(count, 3)), *range(max(3, count - 3), count)]  # one at a time: its ends
            assert [member_seed(sweep_seed, start + i) for i in ends] == [expected[i] for i in ends]


def test_csv_floats_are_short_floats_made_by_column():
    """results.csv's float cells: what pandas writes with `short_float` per cell, for floats of
    up to 17 digits, whole, tiny, huge and missing ones, a column name given twice."""
    from pylmp_lattice.serialize import short_float
    from pylmp_lattice.sweep.table import csv_text

    rng = np.random.default_rng(1)
    values = [0.0, -0.0, 1.0, 1e15, 1e16, 123456789012345.6, 0.1 + 0.2, 1 / 3, 5e-324, 1.7976931348623157e308, 2.81,
              64.52499999999999, np.nan, -1234567890123.5, *rng.normal(0, 1e3, 200), *np.round(rng.normal(0, 9, 200), 4)]
    df = pd.DataFrame({"id": [f"m{i}" for i in range(len(values))], "x": values, "y": values[::-1],
                       "n": range(len(values)), "s": ["a,b", None] * (len(values) // 2)})
    df.columns = ["id", "x", "y", "n", "x"]
    df.isetitem(4, values)
    assert csv_text(df) == df.to_csv(index=False, float_format=short_float)


@pytest.mark.parametrize("mixed", [False, True])
def test_the_table_of_rows_as_columns_is_the_table_of_rows_as_dicts(mixed):
    """`table.frame` of batches' rows as columns (`batch_rows`) and members' own rows is what
    pandas makes of the rows as dicts, and `csv_text` with the measures' texts the workers made
    is what pandas writes. mixed: a row set again later, a member without measures, a measure
    some rows lack, one that is a whole number in one batch and a float in the other (the
    workers' texts do not fit then: the coordinator makes those rows' own)."""
    from pylmp_lattice.serialize import short_float
    from pylmp_lattice.columnar import columns
    from pylmp_lattice.sweep.csv_cells import text_fits
    from pylmp_lattice.sweep.table import Rows, _lines, batch_rows, csv_text, frame, member_row

    rng = np.random.default_rng(3)
    record = {"status": "done", "error": None, "wall_time_s": 0.0123}
    def summary(k, batch):
        out = {"n": 21, "v": {"mean": float(rng.normal()), "ok": bool(k % 2)}, "e": float(rng.normal()) * 1e-5,
               "gap": (k if batch == 0 else k + 0.5) if mixed else k, "files": {"log": "x"}, "note": "a,b",
               "lab": None if batch == 0 else 2.5}
        return out | ({"extra": 1.5} if mixed and batch == 1 else {})
    parts, rows = [], {}
    for batch, indices in enumerate(([0, 1, 2], [4, 5])):
        ids = [f"m{i}" for i in indices]
        params = [{"replica": i, "chain.seed": 10**18 + i} for i in indices]
        sums = [summary(i, batch) for i in indices]
        parts += batch_rows(indices, ids, params, f"batches/b{batch}", record, columns(sums))
        rows |= {i: member_row(m, p, f"batches/b{batch}", record, s) for i, m, p, s in zip(indices, ids, params, sums)}
    assert len(parts) == 2 and all(p.text is not None for p in parts)
    if mixed:
        failed = {"status": "failed", "error": 'bad "q", here', "wall_time_s": 0.0}
        for i in (3, 1):
            rows[i] = member_row(f"m{i}", {"replica": i, "chain.seed": 10**18 + i}, None, failed, None)
            parts.append(Rows.one(i, rows[i]))
    expected = frame_of_dicts(rows)
    df = frame(parts)
    pd.testing.assert_frame_equal(df, expected)
    assert list(map(text_fits(df), parts[:2])) == [not mixed] * 2  # the workers' texts are used where they fit
    assert csv_text(df, parts) == csv_text(df) == expected.to_csv(index=False, float_format=short_float)
    lines = _lines(parts)  # the CSV written from the workers' lines alone, before the table is made
    assert (lines is None) == mixed
    assert mixed or "".join(lines) == expected.to_csv(index=False, float_format=short_float)


def test_rows_go_through_a_pickle_whole_and_a_column_of_one_value_once():
    """A batch's rows (`table.Rows`) sent through a pickle, as a worker sends them: every column
    the same values of the same types (numpy arrays the same bytes: -0.0, NaN and the dtype kept),
    and a column of one value repeated costs that value once, not 8 bytes a member."""
    import pickle

    from pylmp_lattice.sweep.table import Rows

    n = 5000
    columns = {"id": [f"m{i}" for i in range(n)], "status": ["done"] * n, "wall_time_s": np.full(n, 0.5),
               "v": np.arange(n) * 0.1, "z": np.full(n, -0.0), "gone": np.full(n, np.nan), "k": np.full(n, 7),
               "ok": np.ones(n, dtype=bool), "one": np.full(n, 2.5)}
    columns["one"][-1] = np.nextafter(2.5, 3.0)  # differs in its last bit only: not one value
    rows = Rows(np.arange(n), (), tuple(columns)[2:], columns, "text")
    sent = pickle.dumps(rows)
    back = pickle.loads(sent)
    assert back.text == "text" and back.index.tolist() == list(range(n)) and list(back.columns) == list(columns)
    for key, column in columns.items():
        got = back.columns[key]
        if isinstance(column, list):
            assert got == column, key
        else:
            assert got.dtype == column.dtype and got.tobytes() == column.tobytes() and got.flags.writeable, key
    # the ids (about 10 bytes each), the index and the two columns of distinct values: 34 bytes a
    # row; each of the repeated columns would add 8 more (1 the flags), 67 in all
    assert len(sent) < 40 * n
    # a strided column, and objects: sent as they are
    odd = {"every": np.full(2 * n, 3.0)[::2], "objects": np.array(["a"] * n, dtype=object)}
    back = pickle.loads(pickle.dumps(Rows(np.arange(n), (), ("every", "objects"), odd)))
    assert back.columns["every"].tolist() == [3.0] * n and back.columns["objects"].tolist() == ["a"] * n


def test_a_column_of_one_value_is_one_value_to_the_bit():
    """`row_text` makes the cell of a column of one value once: -0.0 beside 0.0, or two NaNs of
    other bits, are not one value to it (each cell its own text); a column of NaN is empty cells."""
    from pylmp_lattice.sweep.csv_cells import row_text

    other_nan = np.frombuffer(np.uint64(0x7FF8000000000001).tobytes(), dtype=np.float64)[0]
    columns = [["a", "b", "c"], np.array([0.0, -0.0, 0.0]), np.full(3, np.nan), np.array([np.nan, other_nan, 1.0]),
               np.array([2.5, 2.5, 2.5]), ["x", "x", "x"], [None, None, None]]
    assert row_text(columns) == "a,0.0,,,2.5,x,\nb,-0.0,,,2.5,x,\nc,0.0,,1.0,2.5,x,"


def test_the_swept_values_columns_are_their_flat_params_made_a_column_at_a_time():
    """`table._flat_columns` of the params' columns is `columns` of each member's `flat_params`
    (a section's fields as dotted keys, in order), or None where a cell is a list or an empty
    section (flat_params' JSON text, a key that vanishes) and the members' own dicts decide."""
    from pylmp_lattice.columnar import columns
    from pylmp_lattice.sweep.table import _flat_columns, flat_params

    seed = 10**18
    scalar = [{"impactor.velocity": 1.5, "replica": k, "chain.seed": seed + k} for k in range(4)]
    section = [{"force": {"law": "power", "q": 3.0 + k}, "replica": k} for k in range(3)]
    nested = [{"a": {"b": {"c": k, "d": None}}, "e": "x,y"} for k in range(3)]
    for params in (scalar, section, nested, [scalar[0]] * 3):
        assert _flat_columns(columns(params)) == columns([flat_params(p) for p in params])
    assert list(_flat_columns(columns(section))["cols"]) == ["force.law", "force.q", "replica"]
    for params in ([{"x": [1, 2]}, {"x": [3]}], [{"s": {}}, {"s": {}}], [{"s": {"a": 1}}, {"s": 2}]):
        assert _flat_columns(columns(params)) is None


def test_the_workers_lines_make_the_csv_in_any_order_and_with_rows_set_again():
    """`csv_text` of batches' rows that came out of order, one whose rows another batch set
    again later (its lines are split, the later ones kept), a cell quoted: what pandas writes."""
    from pylmp_lattice.serialize import short_float
    from pylmp_lattice.columnar import columns
    from pylmp_lattice.sweep.table import _lines, _placed, _tiled, batch_rows, csv_text, frame

    rng = np.random.default_rng(5)
    record = {"status": "done", "error": None, "wall_time_s": 0.5}
    parts, batches = [], []
    for batch, indices in enumerate(([3, 4, 5], [0, 1, 2], [6], [1, 2])):  # the last sets rows 1 and 2 again
        params = [{"replica": i, "tag": "a,b" if i % 2 else "c"} for i in indices]
        sums = [{"v": float(rng.normal()) * 10 ** float(rng.integers(-8, 17)), "n": int(rng.integers(0, 9)),
                 "ok": bool(rng.integers(0, 2))} for _ in indices]
        parts += batch_rows(indices, [f"m{i}" for i in indices], params, f"batches/b{batch}", record, columns(sums))
        batches.append({i: {"id": f"m{i}", **p, "status": "done", "error": None, "folder": f"batches/b{batch}",
                            "wall_time_s": 0.5, **s} for i, p, s in zip(indices, params, sums)})
    assert all(p.text is not None for p in parts)
    for k in (3, 4):  # in one piece each (their lines joined as they came); one batch set again
        rows = {}
        for batch in batches[:k]:
            rows |= batch
        expected = pd.DataFrame([rows[i] for i in sorted(rows)])
        df = frame(parts[:k])
        assert (_tiled(_placed(parts[:k])[1]) is None) == (k == 4)
        pd.testing.assert_frame_equal(df, expected)
        assert csv_text(df, parts[:k]) == csv_text(df) == expected.to_csv(index=False, float_format=short_float)
        lines = _lines(parts[:k])  # alone only where no row is set again
        assert (lines is None) == (k == 4)
        assert k == 4 or "".join(lines) == expected.to_csv(index=False, float_format=short_float)


def test_a_running_sweep_s_table_is_not_rewritten_when_its_end_is_nearer_or_its_rows_have_not_doubled(tmp_path):
    """Table.flush(total): the last rows due sooner, at the rate they came, than `every` seconds:
    no write (the end writes them); due later, written. Then again only once the rows have
    doubled, or LONGEST seconds after the last write."""
    from pylmp_lattice.sweep.table import CSV, LONGEST, Table, member_row

    table = Table(tmp_path, every=30.0)
    record = {"status": "done", "error": None, "wall_time_s": 1.0}
    for i in range(10):
        table.set(i, member_row(f"m{i}", {}, "members/a", record, {"x": 1.5}))
    table.started = table.written = time.monotonic() - 60  # 10 rows in 60 s: 6 s a row
    table.flush(total=14)  # 4 rows left: 24 s, before the next write
    assert table.dirty
    table.flush(total=16)  # 6 rows left: 36 s
    assert not table.dirty
    for i in range(10, 19):  # 9 more rows since: not yet twice the 10 written, unless LONGEST s passed
        table.set(i, member_row(f"m{i}", {}, "members/a", record, {"x": 1.5}))
    table.written -= 60
    table.flush()
    assert table.dirty
    table.written -= LONGEST
    table.flush()
    assert not table.dirty
    for i in range(19, 38):  # 38 rows: twice the 19 written
        table.set(i, member_row(f"m{i}", {}, "members/a", record, {"x": 1.5}))
        table.written = time.monotonic() - 60
        table.flush()
        assert table.dirty == (i < 37)
    assert len((tmp_path / CSV).read_text().splitlines()) == 39


def test_a_running_sweep_s_table_is_written_no_sooner_than_ten_times_its_last_write_took(tmp_path):
    """Table.flush: due `every` seconds after the last write, and not before 10 times what that
    write took (a large table's write holds up the coordinator)."""
    from pylmp_lattice.sweep.table import CSV, Table, member_row

    table = Table(tmp_path, every=0.0)
    record = {"status": "done", "error": None, "wall_time_s": 1.0}
    table.set(0, member_row("a", {}, "members/a", record, {"x": 1.5}))
    table.write()
    table.set(1, member_row("b", {}, "members/b", record, {"x": 2.5}))
    table.took = 3600.0  # as if the last write took an hour
    table.flush()
    assert table.dirty and len((tmp_path / CSV).read_text().splitlines()) == 2
    table.took = 0.0
    table.flush()
    assert not table.dirty and (tmp_path / CSV).read_text().splitlines()[1:] == ["a,done,,members/a,1.0,1.5",
                                                                                 "b,done,,members/b,1.0,2.5"]


def test_sections_as_tables_and_identical_members_run_once(tmp_path, caplog):
    """... and say so in one line (study thermal printed 14 "member N is the same case" lines)."""
    caplog.set_level("INFO", logger="pylmp_lattice")
    write_sweep(tmp_path, "")
    sweep = Sweep(base=tmp_path / "base.toml",
                  grid={"force": [{"law": "linear", "k": 0.5, "r_free": 30.0},
                                  {"law": "power", "K": 413.8, "b": 3.917, "q": 3.0}],
                        "impactor.velocity": [1.0, 1.0]})
    members = sweep.members()  # 4 combinations, 2 distinct cases
    assert [(m.index, m.case.force.law) for m in members] == [(0, "linear"), (2, "power")]
    assert members[1].params == {"force": {"law": "power", "K": 413.8, "b": 3.917, "q": 3.0}, "impactor.velocity": 1.0}
    assert [r.getMessage() for r in caplog.records] == [
        "2 members are the same case as earlier ones (members 1, 3); each case runs once"]
    assert len(sweep.members()) == 2 and len(caplog.records) == 1  # said once (a study enumerates, then runs)
    again = Sweep(base=tmp_path / "base.toml", grid=sweep.grid)  # once per sweep, not per process
    assert len(again.members()) == 2 and len(caplog.records) == 2


def test_sweep_from_python_accepts_a_case(case_factory):
    case = case_factory(particles=8, duration=10.0)
    members = Sweep(base=case, grid={"impactor.velocity": [1.0, 2.0]}).members()
    assert [m.case.impactor.velocity for m in members] == [1.0, 2.0]
    assert members[0].case.chain == case.chain
    long = case_factory(particles=None, duration=100.0, chain={"far_end": "long"})
    slow, fast = (m.case for m in Sweep(base=long, grid={"impactor.velocity": [1.0, 3.0]}).members())
    assert slow.chain.particles < fast.chain.particles  # a long lattice is sized per member


@pytest.mark.parametrize(
    "text, field",
    [
        ('base = "base.toml"\nreplica = 3\n', "replica: unknown key; expected one of base"),
        ('base = "base.toml"\n[grid]\n"impactor.velocty" = [1.0]\n', "grid.impactor.velocty: unknown key; expected one of velocity"),
        ('base = "base.toml"\n[set]\n"colour.hue" = 1\n', "set.colour.hue: unknown section"),
        ('base = "base.toml"\n[grid]\n"force.law" = ["linear"]\n',
         "grid.force.law: makes the base case's force.K an unknown key; sweep the whole section instead"),
        ('base = "base.toml"\n[grid]\n"impactor.velocity" = []\n', "grid.impactor.velocity: empty list"),
        ('base = "base.toml"\n[grid]\n"impactor.velocity" = 1.0\n', "grid.impactor.velocity: got 1.0; expected a list"),
        ('base = "base.toml"\n[zip]\n"impactor.velocity" = [1.0, 2.0, 3.0]\n"run.duration" = [10.0, 20.0]\n',
         "zip.run.duration: got 2 values; expected 3 like zip.impactor.velocity"),
        ('base = "missing.toml"\n', "base: file not found"),
        ('[grid]\n"impactor.velocity" = [1.0]\n', "base: missing"),
        ('base = "base.toml"\nreplicas = 3\n', "replicas: got 3; no member has a random chain"),
        # a misspelt field is named before replicas are found to need a random chain, and a key
        # inside a swept section by its own name
        ('base = "base.toml"\nreplicas = 2\n[grid]\n"chain.partcles" = [21]\n', "grid.chain.partcles: unknown key"),
        ('base = "base.toml"\n[grid]\nforce = [{law = "power", K = 413.8, b = 3.917, q = 3.0, bogus = 1}]\n',
         "grid.force.bogus: unknown key; expected one of K, b, q"),
        ('base = "base.toml"\nkeep = "nothing"\n', "keep: got 'nothing'; choose one of all, measures"),
        # a bad [set] value would fail every member: refused before any starts
        ('base = "base.toml"\nreplicas = 2\n[set]\n"chain.thermal_velocity" = "0.02 m/s"\n',
         "set.chain.thermal_velocity: got '0.02 m/s'; expected a number"),
        # a swept value of a kind its field never takes fails every member that has it: the file's error
        ('base = "base.toml"\n[grid]\n"impactor.velocity" = [1.0, "fast"]\n',
         "grid.impactor.velocity: got 'fast'; expected a number"),
        ('base = "base.toml"\n[grid]\n"chain.thermal_velocity" = [0.01, true]\n"chain.seed" = [1]\n',
         "grid.chain.thermal_velocity: got True; expected a number"),
        ('base = "base.toml"\n[zip]\n"run.duration" = [10.0, 20.0]\nfriction = [{mu = 0.1}, {mu = "x"}]\n',
         "zip.friction: got 'x'; expected a number (for friction.mu)"),
        # one seed for every replica: one chain, run once (the ensemble collapsed to a member)
        ('base = "base.toml"\nreplicas = 2\n[set]\n"chain.thermal_velocity" = 0.02\n"chain.seed" = 5\n',
         "set.chain.seed: with replicas = 2, every replica would have this seed"),
        ('base = "base.toml"\nreplicas = 2\n[set]\n"chain.thermal_velocity" = 0.02\n[grid]\n"chain.seed" = [5, 6]\n',
         "grid.chain.seed: with replicas = 2, every replica would have this seed"),
        ('base = "base.toml"\n[set]\n"impactor.velocity" = -1.0\n[grid]\n"run.duration" = [10.0, 20.0]\n',
         "set.impactor.velocity: got -1.0 m/s; expected > 0"),
        ('base = "base.toml"\n[set]\n"run.dt" = 0.03\n', "set: makes the base case invalid (run.duration: got 10.0 ms"),
        # two values for one field in one member: one would be dropped silently
        ('base = "base.toml"\n[grid]\nfriction = [{mu = 0.1, p = 0.0, g = 9.81}]\n"friction.mu" = [0.2, 0.3]\n',
         "grid.friction.mu: also swept as grid.friction; a field can be swept once"),
        ('base = "base.toml"\n[grid]\n"impactor.velocity" = [1.0]\n[zip]\n"impactor.velocity" = [2.0]\n',
         "zip.impactor.velocity: also swept as grid.impactor.velocity"),
        # keep = "measures" means no trajectories: a format asking for them contradicts it
        ('base = "base.toml"\nkeep = "measures"\n[set]\n"output.format" = "h5md"\n',
         'set.output.format: keep = "measures" sets output.format = "none"'),
        ('base = "base.toml"\nkeep = "measures"\n[grid]\noutput = [{format = "text"}]\n',
         'grid.output: keep = "measures" sets output.format = "none"'),
    ],
)
def test_bad_sweep_file_is_one_line_naming_the_field_exit_2(tmp_path, capsys, text, field):
    path = write_sweep(tmp_path, text)
    assert main(["sweep", str(path), "-o", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith(f"pylmp-lattice: error: {field}"), err
    assert not (tmp_path / "out").exists()  # no member started


@pytest.mark.parametrize("address", ["file:///etc/passwd", "tcp://;rm -rf x", "localhost:8786"])
def test_a_scheduler_address_that_is_none_is_one_line_exit_2(tmp_path, capsys, address):
    """Refused before any Dask client exists (one made of a bad address once hung the suite)."""
    path = write_sweep(tmp_path, SIX)
    assert main(["sweep", str(path), "-o", str(tmp_path / "out"), "--scheduler", address]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith(f"pylmp-lattice: error: --scheduler: got {address!r}"), err


@pytest.mark.lammps
def test_overwrite_by_a_sweep_without_replicas_leaves_no_replica_statistics(tmp_path):
    """The replica statistics of the sweep that --overwrite replaced describe another table."""
    write_sweep(tmp_path, THERMAL.format(replicas=2), particles=8, duration=5.0)
    (tmp_path / "single.toml").write_text('base = "base.toml"\nkeep = "measures"\n[grid]\n"impactor.velocity" = [1.0]\n')
    out = tmp_path / "out"
    assert main(["sweep", str(tmp_path / "sweep.toml"), "-o", str(out), "--quiet"]) == 0
    assert (out / "replica_stats.csv").exists()
    assert main(["sweep", str(tmp_path / "single.toml"), "-o", str(out), "--quiet", "--overwrite"]) == 0
    assert not list(out.glob("replica_stats.*"))


def test_invalid_members_are_recorded_failed_and_retried_only_when_asked(tmp_path, capsys):
    """Bad parameters fail their members without running (no engine needed); others go on."""
    path = write_sweep(tmp_path, 'base = "base.toml"\n[grid]\n"impactor.velocity" = [-1.0, -2.0]\n')
    out = tmp_path / "out"
    assert main(["sweep", str(path), "-o", str(out), "--quiet"]) == 1
    table = load_results(out)
    assert list(table["status"]) == ["failed", "failed"]
    assert table["error"][0] == "impactor.velocity: got -1.0 m/s; expected > 0"
    status = out / table["folder"][0] / STATUS
    before = status.stat().st_mtime_ns
    main(["sweep", str(path), "-o", str(out), "--quiet"])
    assert status.stat().st_mtime_ns == before  # a failure is not retried by default
    main(["sweep", str(path), "-o", str(out), "--quiet", "--retry-failed"])
    assert status.stat().st_mtime_ns != before
    assert pd.read_csv(out / "results.csv")["error"][1] == "impactor.velocity: got -2.0 m/s; expected > 0"



def test_a_resumed_sweep_says_how_many_members_it_kept(tmp_path, caplog, monkeypatch):
    """Members whose outcome is on disk are kept, and the run says how many (no engine needed:
    the members fail on their parameters). Each run says where its time went: since the command
    started in a process of a few seconds, since the sweep started in an older one."""
    from pylmp_lattice import overhead

    path = write_sweep(tmp_path, 'base = "base.toml"\n[grid]\n"impactor.velocity" = [-1.0, -2.0]\n')
    caplog.set_level("INFO", logger="pylmp_lattice")
    monkeypatch.setattr(overhead, "process_age", lambda: 5.0)  # a command of 5 s as the sweep starts
    run_sweep(load_sweep(path), tmp_path / "out", workers=1, progress=False)
    assert "before this run" not in caplog.text
    said = re.search(r"out: (\S+) s since the command started: the first task sent at (\S+) s, the last members done "
                     r"at (\S+) s, the table written at (\S+) s", caplog.text)
    total, sent, done, written = map(float, said.groups())
    assert 5.0 <= sent <= done <= written == total
    caplog.clear()
    monkeypatch.setattr(overhead, "process_age", lambda: 3600.0)  # a notebook's hour-old process
    run_sweep(load_sweep(path), tmp_path / "again", workers=1, progress=False)
    total, sent = map(float, re.search(r"again: (\S+) s since the sweep started: the first task sent at (\S+) s",
                                       caplog.text).groups())
    assert 0 <= sent <= total < 60
    caplog.clear()
    run_sweep(load_sweep(path), tmp_path / "out", workers=1, progress=False)
    assert ("out: 2 of 2 members had an outcome before this run (0 done, 2 failed): kept, not run again "
            "(--retry-failed runs the failed ones)") in caplog.text


# ----------------------------------------------------------------------------- statistics

def test_replica_stats_mean_and_standard_error(tmp_path):
    rng = np.random.default_rng(0)
    rows = [{"id": f"{v}-{r}", "impactor.velocity": v, "replica": r, "chain.seed": 100 + r, "status": "done",
             "error": None, "folder": "x", "wall_time_s": 1.0, "V": v + rng.normal()} for v in (1.0, 2.0) for r in range(5)]
    rows.append(rows[0] | {"id": "f", "status": "failed", "V": 1e9})  # failed members do not count
    rows.append(rows[0] | {"id": "i", "V": np.inf})  # nor infinite values (counted apart)
    table = pd.DataFrame(rows)
    stats = replica_stats(table, ["V"])
    assert list(stats["n"]) == [6, 5] and list(stats["failed"]) == [1, 0] and list(stats["V.count"]) == [5, 5]
    assert np.isfinite(stats["V.mean"]).all()
    values = table[(table["impactor.velocity"] == 2.0) & (table["status"] == "done")]["V"].to_numpy()
    row = stats[stats["impactor.velocity"] == 2.0].iloc[0]
    assert row["V.mean"] == pytest.approx(np.mean(values), rel=1e-12)
    assert row["V.sem"] == pytest.approx(np.std(values, ddof=1) / np.sqrt(5), rel=1e-12)
    import matplotlib.pyplot as plt

    ax = plot_replica_stats(stats, "impactor.velocity", "V")
    bars = ax.containers[0]
    np.testing.assert_allclose(bars.lines[0].get_ydata(), stats["V.mean"])
    plt.close(ax.figure)
    write_replica_stats(tmp_path, table, ["V"])
    pd.testing.assert_frame_equal(pd.read_csv(tmp_path / "replica_stats.csv"), stats)
    assert (tmp_path / "replica_stats.png").stat().st_size > 0


# ----------------------------------------------------------------------------- running

def _comparable(table: pd.DataFrame) -> pd.DataFrame:
    return table.drop(columns=TIMING)


@pytest.mark.lammps
@pytest.mark.slow
def test_local_pool_and_dask_cluster_give_identical_tables(tmp_path):
    from distributed import LocalCluster

    sweep = load_sweep(write_sweep(tmp_path, SIX))
    local = run_sweep(sweep, tmp_path / "local", workers=2, progress=False)
    assert len(local) == 6 and set(local["status"]) == {"done"}
    assert local["shock_velocity_max_m_per_s.value"].notna().all()
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                      dashboard_address=None) as cluster:
        assert cluster.scheduler_address.startswith("tcp://127.0.0.1:")
        dask = run_sweep(sweep, tmp_path / "dask", scheduler=cluster.scheduler_address, progress=False)
    pd.testing.assert_frame_equal(_comparable(local), _comparable(dask))
    pd.testing.assert_frame_equal(_comparable(load_results(tmp_path / "dask")), _comparable(dask))
    csv = pd.read_csv(tmp_path / "local" / "results.csv")
    assert list(csv.columns) == list(local.columns)
    assert list(csv.columns[:7]) == ["id", "impactor.velocity", "force.q", "status", "error", "folder", "wall_time_s"]
    record = json.loads((tmp_path / "dask" / dask["folder"][0] / STATUS).read_text())
    assert record["status"] == "done" and record["provenance"]["lammps"] and record["started"] < record["ended"]


@pytest.mark.lammps
@pytest.mark.slow
def test_sigkill_then_rerun_resumes_without_rerunning_finished_members(tmp_path):
    """The whole process group is killed, as a batch system's wall-time limit does."""
    cmd, out, proc = start_sweep(tmp_path, duration=40.0, stderr=subprocess.DEVNULL)

    def done_folders():
        return [folder for folder, status in member_statuses(out).items() if status == "done"]

    deadline = time.time() + 120
    while len(done_folders()) < 2 and time.time() < deadline and proc.poll() is None:
        time.sleep(0.02)
    os.killpg(proc.pid, signal.SIGKILL)
    proc.wait()
    finished = done_folders()
    assert 2 <= len(finished) < 6, "the kill must land mid-sweep"
    before = {f: (f.stat().st_mtime_ns, f.read_bytes()) for d in finished for f in d.iterdir()}

    assert subprocess.run(cmd, stderr=subprocess.DEVNULL).returncode == 0
    table = load_results(out)
    assert len(table) == 6 and set(table["status"]) == {"done"}
    after = {f: (f.stat().st_mtime_ns, f.read_bytes()) for d in finished for f in d.iterdir()}
    assert after == before  # finished members were not run again: their files are untouched


@pytest.mark.lammps
def test_failing_member_is_recorded_and_the_others_finish(tmp_path):
    """V_I = 30 m/s drives the impactor through the 8-magnet chain (84 mm) within 3 ms."""
    path = write_sweep(tmp_path, 'base = "base.toml"\nkeep = "measures"\n[grid]\n"impactor.velocity" = [1.0, 30.0, 1.5]\n')
    out = tmp_path / "out"
    assert main(["sweep", str(path), "-o", str(out), "--workers", "2", "--quiet"]) == 1
    table = load_results(out)
    assert list(table["status"]) == ["done", "failed", "done"]
    assert table["error"][1].startswith("magnets ") and "touched" in table["error"][1] and "\n" not in table["error"][1]
    assert table["error"].isna()[[0, 2]].all()
    kept = sorted(p.name for p in (out / table["folder"][0]).iterdir())
    # keep = "measures": no trajectory written, the measures from the engine's record
    assert "summary.json" in kept and "front.bin" in kept and not {"traj.h5md", "traj.bin", "traj.dump"} & set(kept)


@pytest.mark.lammps
@pytest.mark.slow
def test_thermal_replicas_reproduce_differ_and_have_the_requested_rms(tmp_path):
    """Frame 0 of each member's trajectory is what LAMMPS started from.

    The mean of v^2 over R replicas of n free magnets has relative standard error
    sqrt(2/(R (n-1))) (= 0.24 here); the test allows 3 of those."""
    v_rms, replicas, particles = 0.05, 4, 12
    text = f'base = "base.toml"\nreplicas = {replicas}\nseed = 1\n[set]\n"chain.thermal_velocity" = {v_rms}\n'
    sweep = load_sweep(write_sweep(tmp_path, text, particles=particles))
    first = run_sweep(sweep, tmp_path / "a", workers=2, progress=False)
    again = run_sweep(sweep, tmp_path / "b", workers=2, progress=False)
    pd.testing.assert_frame_equal(_comparable(first), _comparable(again))  # same seed: the same numbers
    assert first["chain.seed"].nunique() == replicas
    assert first["shock_velocity_max_m_per_s.value"].nunique() == replicas  # different seeds: different runs
    v2 = []
    for member in sweep.members():
        traj = RunFolder(tmp_path / "a" / "members" / member.id).trajectory()
        np.testing.assert_allclose(traj.v[0, 1:-1], member.case.chain.velocities()[1:-1], rtol=1e-9)
        v2.append(np.mean(traj.v[0, 1:-1] ** 2))
    tol = 3 * np.sqrt(2 / (replicas * (particles - 3)))
    assert abs(np.mean(v2) / v_rms**2 - 1) < tol
    stats = replica_stats(first)
    assert stats["n"].tolist() == [replicas]
    assert stats["shock_velocity_max_m_per_s.value.sem"][0] > 0


def test_example_sweep_file_is_valid():
    members = load_sweep(Path(__file__).parent.parent / "inputs" / "sweep_thermal_experiment.toml").members()
    assert len(members) == 12 and all(m.case is not None for m in members)
    assert {m.case.chain.particles for m in members} == {21}
    assert len({m.case.chain.seed for m in members}) == 12


def test_one_coordinator_per_sweep_folder(tmp_path, capsys, caplog):
    import fcntl

    caplog.set_level(logging.INFO)

    path = write_sweep(tmp_path, SIX)
    out = tmp_path / "out"
    out.mkdir()
    held = os.open(out, os.O_RDONLY)  # the lock is on the folder itself: no lock file left behind
    try:
        fcntl.flock(held, fcntl.LOCK_EX | fcntl.LOCK_NB)
        assert main(["sweep", str(path), "-o", str(out)]) == 2
    finally:
        os.close(held)
    assert "-o: another sweep is running in" in capsys.readouterr().err
    assert not [r for r in caplog.records if " members (" in r.getMessage()]  # refused before the estimate is said
    assert list(out.iterdir()) == []


def test_tasks_pause_the_cyclic_collector_and_leave_it_as_they_found_it():
    """The collector is off while any task of this process runs (threads share it), and back
    as it was once the last one ends: on if it was on, off if it was off."""
    import gc
    import threading

    from pylmp_lattice.sweep import batch

    seen, inner_started, outer_may_end = [], threading.Event(), threading.Event()

    def other_task():
        with batch._collector_paused():
            inner_started.set()
            outer_may_end.wait(5)
            seen.append(gc.isenabled())

    assert gc.isenabled()
    with batch._collector_paused():
        thread = threading.Thread(target=other_task)
        thread.start()
        inner_started.wait(5)
        seen.append(gc.isenabled())
    seen.append(gc.isenabled())  # the other task still runs
    outer_may_end.set()
    thread.join(5)
    assert seen == [False, False, False] and gc.isenabled()
    gc.disable()
    try:
        with batch._collector_paused():
            pass
        assert not gc.isenabled()
    finally:
        gc.enable()


def test_copies_of_a_task_take_turns_on_its_lock_and_no_lock_file_stays(tmp_path):
    """As Dask may run a task twice: copy B waits for copy A; A removes the lock file as it lets
    go, and a copy C that came after the removal holds a new file: B, woken on the removed file,
    waits for C rather than running beside it. A lock file that no one holds (its worker was
    killed) is removed at the end of a sweep; one still held is left to its holder."""
    import fcntl
    import threading

    from pylmp_lattice.sweep import store

    path_of = lambda: list((tmp_path / "batches").glob("task-*.lock"))  # noqa: E731
    log, release_a = [], threading.Event()

    def copy(name, until=None):
        with store.task_lock(tmp_path, ["m1", "m2"]):
            log.append(f"{name} in")
            if until is not None:
                until.wait(10)
            log.append(f"{name} out")

    a = threading.Thread(target=copy, args=("A", release_a))
    a.start()
    while log != ["A in"]:
        time.sleep(0.01)
    b = threading.Thread(target=copy, args=("B",))
    b.start()
    time.sleep(0.3)  # B waits on A's file
    [lock] = path_of()
    lock.unlink()  # as A does when it lets go; then C takes a new file before B wakes
    c = os.open(lock, os.O_RDWR | os.O_CREAT)
    fcntl.flock(c, fcntl.LOCK_EX)
    release_a.set()
    a.join()
    time.sleep(0.3)
    assert log == ["A in", "A out"]  # B woke on the removed file and now waits for C
    lock.unlink()
    os.close(c)
    b.join(10)
    assert log == ["A in", "A out", "B in", "B out"] and path_of() == []

    stale, held = tmp_path / "batches" / "task-0.lock", tmp_path / "batches" / "task-1.lock"
    stale.touch()
    fd = os.open(held, os.O_RDWR | os.O_CREAT)
    fcntl.flock(fd, fcntl.LOCK_EX)
    store.remove_stale_locks(tmp_path)
    os.close(fd)
    assert path_of() == [held]


def test_atomic_write_leaves_old_content_or_new_never_a_part(tmp_path, monkeypatch):
    from pylmp_lattice.sweep import store

    target = tmp_path / STATUS
    store.atomic_write(target, '{"status": "running"}')

    def killed(src, dst):
        raise KeyboardInterrupt  # the process stops between writing the new file and the rename

    monkeypatch.setattr(store.os, "replace", killed)
    with pytest.raises(KeyboardInterrupt):
        store.atomic_write(target, '{"status": "done"}')
    assert target.read_text() == '{"status": "running"}'
    assert [p.name for p in tmp_path.iterdir()] == [STATUS]  # no temporary file left behind


# ----------------------------------------------------------------------------- batched members

THERMAL = """\
base = "base.toml"
replicas = {replicas}
seed = 5
keep = "measures"
[set]
"chain.thermal_velocity" = 0.02
"""


@pytest.mark.lammps
@pytest.mark.parametrize("friction, gaps", [(False, False), (True, False), (False, True)])
def test_batched_members_have_the_measures_of_the_member_run_alone(tmp_path, monkeypatch, friction, gaps):
    """Five thermal replicas run as one batch (one LAMMPS instance, one front record); each
    member's summary equals, bit for bit, the summary of its case run alone with run_case
    (with friction: its friction work too, the fix's entry for its chain; with gap disorder,
    chains whose table ranges differ: the exact law needs no table)."""
    from concurrent.futures import ThreadPoolExecutor

    from pylmp_lattice.run_folder import run_case
    from pylmp_lattice.sweep import batch

    monkeypatch.setattr(batch, "FRICTION_PER_CHAIN", True)
    monkeypatch.setattr(batch, "LEVELS_PER_CHAIN", True)
    text = THERMAL.format(replicas=5) + ('"friction.mu" = 0.285\n"friction.p" = 0.012\n"friction.g" = 9.81\n' if friction else "")
    text += '"chain.r0_disorder" = 0.005\n' if gaps else ""
    sweep = load_sweep(write_sweep(tmp_path, text, particles=12, duration=40.0))
    assert len({m.case.table_range() for m in sweep.members()}) == (5 if gaps else 1)
    with ThreadPoolExecutor(1) as pool:  # in this process: the plugin's abilities show in batch's flags
        table = run_sweep(sweep, tmp_path / "out", executor=pool, slots=1, progress=False)
    assert set(table["status"]) == {"done"} and len(table) == 5
    disk = Outcomes(tmp_path / "out")
    records = [disk.get(i)["record"] for i in table["id"]]
    if "batch" not in records[0] and not (batch.FRICTION_PER_CHAIN and batch.LEVELS_PER_CHAIN):
        pytest.skip("this plugin build lacks each chain's friction work or front levels: members ran alone")
    assert len({r["batch"] for r in records}) == 1  # one instance ran them all
    assert set(table["folder"]) == {records[0]["batch"]} and not list((tmp_path / "out" / "members").glob("*"))
    assert table["particles_reached_by_front"].min() >= 8  # the front crossed most of the chain
    for member in sweep.members()[:3]:
        alone = run_case(member.case, tmp_path / "alone" / member.id, figure=False)
        batched = disk.get(member.id)["summary"]
        assert _measures(batched) == _measures(alone)
        assert ("friction_dissipated_energy_mJ" in batched) == friction
    assert table["shock_velocity_max_m_per_s.value"].nunique() == 5  # five different chains


def _measures(summary: dict) -> dict:
    """A summary's measures (all but `table.NOT_MEASURES`) as strict JSON, as members.json holds them."""
    from pylmp_lattice.serialize import jsonable
    from pylmp_lattice.sweep.table import NOT_MEASURES

    return {k: v for k, v in jsonable(summary).items() if k not in NOT_MEASURES}


def test_member_cases_are_the_cases_of_their_dicts(tmp_path):
    """A point's replicas take its first case with their own seed (spec.member_cases): the
    same cases as built from their dicts, and a replica whose draw is invalid still fails."""
    from pylmp_lattice.case import case_from_dict
    from pylmp_lattice.sweep.spec import member_cases

    text = THERMAL.format(replicas=30) + '"chain.mass_disorder" = 0.45\n[grid]\n"impactor.velocity" = [1.0, 1.5]\n'
    members = load_sweep(write_sweep(tmp_path, text)).members()
    fresh = load_sweep(tmp_path / "sweep.toml").members()[30:]  # the second point, its first invalid: none built
    for group in (members, fresh):
        cases = member_cases(group)
        expected = []
        for m in group:
            try:
                expected.append(case_from_dict(m.data))
            except ConfigError:
                expected.append(None)
        assert cases == expected and [m.case for m in group] == cases
        assert 0 < cases.count(None) < len(group) // 2  # a draw may give a mass <= 0 (1 % per magnet) or too small for dt
        assert {m.error.split(":")[0] for m in group if m.case is None} <= {"chain.mass_disorder", "run.dt"}


def test_thermal_replicas_share_their_point_s_case_but_not_its_velocities(tmp_path):
    """Without disorder a replica is its point's first case with its own seed (`spec._reseeded`:
    nothing else is checked again): equal to the case built from its dict, with that case's
    masses, gaps and velocities bit for bit, and one parameter point (`Member.point`) per point."""
    from pylmp_lattice.case import case_from_dict
    from pylmp_lattice.sweep import spec
    from pylmp_lattice.sweep.spec import member_cases

    text = THERMAL.format(replicas=6) + '[grid]\n"impactor.velocity" = [1.0, 1.5]\n'
    members = load_sweep(write_sweep(tmp_path, text)).members()
    cases = member_cases(members)
    for m, case in zip(members, cases):
        built = case_from_dict(m.data)
        assert case == built and case.chain.seed == m.params["chain.seed"]
        for name in ("masses", "gaps", "velocities"):
            assert getattr(case.chain, name)().tobytes() == getattr(built.chain, name)().tobytes(), (m.index, name)
    assert len({case.chain.velocities().tobytes() for case in cases}) == 12
    assert [m.point for m in members] == [members[0].point] * 6 + [members[6].point] * 6
    assert members[0].point != members[6].point
    with pytest.raises(ConfigError, match="chain.seed"):
        spec._reseeded(cases[0], -1)


def test_a_point_s_replicas_come_in_runs_with_the_same_members_and_tasks(tmp_path, monkeypatch):
    """A point's replicas are enumerated RUN at a time (the coordinator's first task goes out
    before the point's 10^6 identities are made): runs of 5 give the members (numbers,
    identities, seeds, parameters) and the tasks (their members, in order) of one run a point,
    also where a replica repeats an earlier member's case (one run alone, the rest kept)."""
    from pylmp_lattice.sweep import execute, seeds, spec
    from pylmp_lattice.sweep.pool import Pool
    from pylmp_lattice.sweep.spec import Replicas

    text = THERMAL.format(replicas=12) + '[grid]\n"impactor.velocity" = [1.0, 1.5]\n'
    sweep = load_sweep(write_sweep(tmp_path, text))

    def enumerated():
        runs = list(sweep.iter_runs())
        members = [(m.index, m.id, m.params) for run in runs for m in run]
        coordinator = execute._Coordinator(sweep, tmp_path, Pool(None, 2), execute._StopSignals(), False, False,
                                           sweep.count())
        return runs, members, [[m.id for m in t.each()] for t in coordinator._tasks()]

    whole, members, tasks = enumerated()
    assert [len(r) for r in whole] == [1, 11, 1, 11] and len({m[1] for m in members}) == 24
    monkeypatch.setattr(spec, "RUN", 5)
    runs, *rest = enumerated()
    assert [len(r) for r in runs] == [1, 5, 5, 1, 1, 5, 5, 1] and all(isinstance(r, Replicas) for r in runs[1:3])
    assert rest == [members, tasks]
    # seeds 1, 2, 3, 1, 2, 3, ... by member: a point's members past its third repeat the first three's cases
    monkeypatch.setattr(seeds, "member_seeds", lambda seed, start, count: [(start + k) % 3 + 1 for k in range(count)])
    runs, *chunked = enumerated()
    assert [len(r) for r in runs] == [1, 2, 1, 2] and [m[0] for m in chunked[0]] == [0, 1, 2, 12, 13, 14]
    monkeypatch.setattr(spec, "RUN", 10**6)
    assert list(enumerated()[1:]) == chunked


def test_replicas_identities_are_made_where_they_are_asked_for_and_are_their_cases(tmp_path, monkeypatch):
    """A new sweep's coordinator makes no replica's identity (a worker does, for the members it
    runs): the tasks it sends hold none, and the identities made from them are each member's
    `case_id` (its case built whole, an independent hash). Two points of the same case (a swept
    value repeated) whose replicas draw the same seeds are the same members: counted once."""
    import pickle

    from pylmp_lattice.case import case_id
    from pylmp_lattice.sweep import execute, seeds
    from pylmp_lattice.sweep.pool import Pool
    from pylmp_lattice.sweep.spec import Replicas

    sweep = load_sweep(write_sweep(tmp_path, THERMAL.format(replicas=6) + '[grid]\n"impactor.velocity" = [1.0, 1.5]\n'))
    coordinator = execute._Coordinator(sweep, tmp_path, Pool(None, 2), execute._StopSignals(), False, False,
                                       sweep.count())
    tasks = list(coordinator._tasks())
    parts = [p for t in tasks for p in t.members if isinstance(p, Replicas)]
    assert len(parts) == 2 and not any("ids" in p.__dict__ for p in parts)
    sent = [pickle.loads(pickle.dumps(p)) for p in parts]
    assert [len(p.ids) for p in sent] == [5, 5]
    for part in sent:
        for member in part:
            member.build_from(part.first.case, member.params["chain.seed"])
            assert member.id == case_id(member.case), member.index
    assert len({m.id for p in sent for m in p} | {m.id for t in tasks for m in t.each()}) == 12

    # where the seed's place in the case text is not found (a plain function of the seed), the
    # coordinator makes the ids itself and sends them: the same members and tasks
    from pylmp_lattice.sweep import spec

    made = spec.seeded_hashes
    monkeypatch.setattr(spec, "seeded_hashes", lambda data: (lambda seed, hashes=made(data): hashes(seed)))
    tasks = list(execute._Coordinator(sweep, tmp_path, Pool(None, 2), execute._StopSignals(), False, False,
                                      sweep.count())._tasks())
    parts = [pickle.loads(pickle.dumps(p)) for t in tasks for p in t.members if isinstance(p, Replicas)]
    assert [p.identity for p in parts] == [None, None] and [p.ids for p in parts] == [p.ids for p in sent]
    monkeypatch.setattr(spec, "seeded_hashes", made)

    twice = load_sweep(write_sweep(tmp_path, THERMAL.format(replicas=4) + '[grid]\n"impactor.velocity" = [1.0, 1.0]\n'))
    monkeypatch.setattr(seeds, "member_seeds", lambda seed, start, count: [start % 4 + k + 1 for k in range(count)])
    members = twice.members()
    assert [m.index for m in members] == [0, 1, 2, 3] and len({m.id for m in members}) == 4


def test_tasks_are_shared_evenly_by_the_workers_within_an_instance_s_limit(tmp_path, monkeypatch):
    from pylmp_lattice.sweep import blocks, execute
    from pylmp_lattice.sweep.pool import Pool

    sweep = load_sweep(write_sweep(tmp_path, THERMAL.format(replicas=200), particles=12, duration=20.0))

    def sizes(slots):
        coordinator = execute._Coordinator(sweep, tmp_path, Pool(None, slots), execute._StopSignals(), False, False,
                                           sweep.count())
        tasks = list(coordinator._tasks())
        assert [m.index for t in tasks for m in t.each()] == list(range(200))
        return [len(t.each()) for t in tasks]

    assert sizes(2) == [100, 100]
    assert sizes(3) == [67, 67, 66]
    # three points of 40 on 2 workers: each point in two tasks (3 tasks: one worker would run 80)
    grid = load_sweep(write_sweep(tmp_path, THERMAL.format(replicas=40) + '[grid]\n"impactor.velocity" = [1.5, 2.0, 2.5]\n',
                                  particles=12, duration=20.0))
    coordinator = execute._Coordinator(grid, tmp_path, Pool(None, 2), execute._StopSignals(), False, False, grid.count())
    assert [len(t.each()) for t in coordinator._tasks()] == [20] * 6
    # an instance holds at most 30 of these members (12 magnets): 8 tasks' worth, 4 per worker, the
    # last ones smaller (at most a quarter of what is left for each worker, at least 25 // TAIL)
    monkeypatch.setattr(blocks, "MAX_ATOM_STEPS", 30 * 12 * sweep.members()[0].case.run.steps())
    assert sizes(2) == [25] * 5 + [19, 14, 11, 8, 6, 6, 6, 5] and blocks.TAIL == 4
    # resumed with 180 done on disk, the first ones or the last ones: the 20 left, shared by both
    # workers (the sizes come from what the folder holds, before any member is enumerated)
    monkeypatch.setattr(execute.Outcomes, "at_most", lambda self: 180)  # what the folder holds
    for done in (range(180), range(20, 200)):
        coordinator = execute._Coordinator(sweep, tmp_path, Pool(None, 2), execute._StopSignals(), False, False,
                                           sweep.count())
        ids = {m.id for m in sweep.members() if m.index in done}  # their outcomes on disk, as Outcomes gives them
        coordinator.disk.get = lambda i, ids=ids: {"record": {"status": "done"}, "summary": None} if i in ids else None
        coordinator.disk.none_of = ids.isdisjoint
        assert [len(t.each()) for t in coordinator._tasks()] == [10, 10]
        assert coordinator.kept == 180


# ----------------------------------------------------------------------------- integrity

def test_numpy_values_are_the_python_numbers_they_hold(tmp_path):
    """A sweep made in Python from numpy values (`list(np.arange(...))`, an array, np.int64 seed
    and replicas) is the sweep of the same Python numbers: same identity and members, and its
    description is JSON (np.int64 stopped run_sweep at sweep.json with a TypeError; a numpy
    seed was refused as "got np.int64(5); expected an integer >= 0")."""
    write_sweep(tmp_path, "")
    base = tmp_path / "base.toml"
    made = Sweep(base=base, set={"chain.thermal_velocity": np.float64(0.01)}, replicas=np.int64(2), seed=np.int64(5),
                 grid={"chain.particles": list(np.arange(8, 12, 2)), "impactor.velocity": np.array([1.0, 1.5])})
    plain = Sweep(base=base, set={"chain.thermal_velocity": 0.01}, replicas=2, seed=5,
                  grid={"chain.particles": [8, 10], "impactor.velocity": [1.0, 1.5]})
    assert json.loads(json.dumps(made.describe())) == plain.describe()
    assert made.identity() == plain.identity() and made.count() == 8
    assert [(m.id, m.params) for m in made.members()] == [(m.id, m.params) for m in plain.members()]


def test_one_and_one_point_zero_are_one_member(tmp_path):
    write_sweep(tmp_path, "")
    members = Sweep(base=tmp_path / "base.toml", grid={"impactor.velocity": [1, 1.0, 2]}).members()
    assert [m.params["impactor.velocity"] for m in members] == [1, 2]


@pytest.mark.parametrize("text, message", [
    ('[set]\n"impactor.velocity" = 1.0\n[grid]\n"impactor.velocity" = [1.0, 2.0]\n',
     "grid.impactor.velocity: also given in [set] as 'impactor.velocity'; a field is set or swept, not both"),
    ('[set]\nimpactor = {velocity = 1.0}\n[zip]\n"impactor.velocity" = [1.0]\n', "zip.impactor.velocity: also given in [set]"),
    ('[grid]\n"impactor.velocity" = [1.0, nan]\n', "grid.impactor.velocity: got nan; expected a finite number"),
    ('[set]\n"chain.thermal_velocity" = inf\n', "set.chain.thermal_velocity: got inf; expected a finite number"),
    # a seed past the range (it said "expected an integer >= 0")
    ('seed = 9223372036854775808\n', "seed: got 9223372036854775808; expected an integer in [0, 2**63 - 1]"),
])
def test_a_field_set_and_swept_or_a_non_finite_value_is_refused(tmp_path, capsys, text, message):
    path = write_sweep(tmp_path, 'base = "base.toml"\n' + text)
    assert main(["sweep", str(path), "-o", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith(f"pylmp-lattice: error: {message}"), err


def test_a_grid_over_1e5_members_needs_yes_and_is_counted_before_enumeration(tmp_path, capsys, monkeypatch):
    from pylmp_lattice.sweep import spec

    values = ", ".join(f"{1 + i * 1e-3}" for i in range(400))
    path = write_sweep(tmp_path, f'base = "base.toml"\n[grid]\n"impactor.velocity" = [{values}]\n'
                                 f'"run.duration" = [{values.replace("1.", "10.")}]\n')
    built, original = [], spec.Sweep._member
    monkeypatch.setattr(spec.Sweep, "_member", lambda self, *a: built.append(a) or original(self, *a))
    assert load_sweep(path).count() == 160_000
    from pylmp_lattice import preflight

    monkeypatch.setattr(preflight, "free_disk", lambda folder: 1e15)  # past the disk check (155 GB: test_hostile)
    assert main(["sweep", str(path), "-o", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert "160000 members" in err and "error: --yes: the sweep has 160000 members (over 100000); pass --yes" in err
    assert len(built) <= 1  # the estimate looks at the first member only


def test_a_folder_holding_another_sweep_is_refused_unless_overwrite(tmp_path, capsys, caplog):
    path = write_sweep(tmp_path, 'base = "base.toml"\n[grid]\n"impactor.velocity" = [-1.0]\n')
    out = tmp_path / "out"
    assert main(["sweep", str(path), "-o", str(out), "--quiet"]) == 1  # one invalid member: failed
    other = tmp_path / "other.toml"
    other.write_text('base = "base.toml"\n[grid]\n"impactor.velocity" = [-3.0]\n')
    capsys.readouterr()
    caplog.clear()
    with caplog.at_level("INFO", logger="pylmp_lattice"):
        assert main(["sweep", str(other), "-o", str(out)]) == 2
    assert " members (" not in caplog.text  # no estimate said before the refusal
    err = capsys.readouterr().err
    assert err.startswith(f"pylmp-lattice: error: -o: {out} holds a different sweep (sweep.json)") and err.count("\n") == 1
    assert list(load_results(out)["impactor.velocity"]) == [-1.0]  # untouched
    assert main(["sweep", str(other), "-o", str(out), "--quiet", "--overwrite"]) == 1
    assert list(load_results(out)["impactor.velocity"]) == [-3.0]  # the table is this sweep's
    assert main(["sweep", str(other), "-o", str(out), "--quiet"]) == 1  # the same sweep resumes


@pytest.mark.parametrize("target", [".", "runs", "a_run", "a_sweep/members", "a_sweep/members/new", "a_sweep/batches",
                                    "a_sweep/batches/x/new"])
def test_the_sweep_folder_follows_the_run_folder_rules(tmp_path, monkeypatch, capsys, target):
    """`sweep -o` used to accept the working directory, runs/ itself and a run's folder, which
    `run -o` refuses, and a folder inside another sweep's members: one line naming the output folder,
    exit 2, nothing written."""
    monkeypatch.chdir(tmp_path)
    path = write_sweep(tmp_path, 'base = "base.toml"\n[grid]\n"impactor.velocity" = [-1.0]\n')
    (tmp_path / "runs").mkdir()
    for sub in ("members", "batches/x"):
        (tmp_path / "a_sweep" / sub).mkdir(parents=True)
    (tmp_path / "a_sweep" / "sweep.json").write_text("{}")
    assert main(["deck", "base.toml", "-o", "a_run"]) == 0
    before = sorted(tmp_path.rglob("*"))
    capsys.readouterr()
    assert main(["sweep", str(path), "-o", target, "--quiet", "--overwrite"]) == 2
    line, = capsys.readouterr().err.splitlines()
    assert line.startswith("pylmp-lattice: error: output: ") and (target in line), line
    assert sorted(tmp_path.rglob("*")) == before
    with pytest.raises(ConfigError, match="^output: "):
        run_sweep(load_sweep(path), target)


def test_a_done_member_without_a_summary_that_parses_is_run_again(tmp_path, monkeypatch):
    """The coordinator trusts `done` only with a summary that parses (no engine: the run is faked)."""

    ran = []

    def fake_run_case(case, folder, **kwargs):
        ran.append(Path(folder).name)
        (Path(folder) / "case.toml").write_text(tomli_w.dumps(case_to_dict(case)))  # the member's case: its identity
        summary = {"case": case.name, "V": case.impactor.velocity}
        (Path(folder) / "summary.json").write_text(json.dumps(summary))
        return summary

    monkeypatch.setattr("pylmp_lattice.run_folder.run_case", fake_run_case)
    path = write_sweep(tmp_path, 'base = "base.toml"\n[grid]\n"impactor.velocity" = [1.0, 2.0, 3.0]\n')
    sweep, out = load_sweep(path), tmp_path / "out"
    from concurrent.futures import ThreadPoolExecutor

    def run():
        with ThreadPoolExecutor(1) as pool:  # in this process, so that the fake applies
            return run_sweep(sweep, out, executor=pool, slots=1, progress=False)

    assert list(run()["V"]) == [1.0, 2.0, 3.0] and len(ran) == 3
    folders = [out / "members" / m.id for m in sweep.members()]
    (folders[0] / "summary.json").unlink()
    (folders[1] / "summary.json").write_text("{not json")
    table = run()
    assert ran[3:] == [folders[0].name, folders[1].name]  # the third stays done
    assert list(table["status"]) == ["done"] * 3 and list(table["V"]) == [1.0, 2.0, 3.0]


def test_errors_name_member_folders_relative_to_the_sweep(tmp_path):
    from pylmp_lattice.errors import RunError
    from pylmp_lattice.sweep.batch import one_line

    err = RunError("Bond length > table outer cutoff", tmp_path / "members" / "abc")
    assert one_line(err, tmp_path) == "Bond length > table outer cutoff (files kept in members/abc)"


def test_git_commit_is_read_from_the_clone_pip_installed_from(tmp_path, monkeypatch):
    from pylmp_lattice.sweep import store

    clone = Path(__file__).resolve().parents[1]
    if not (clone / ".git").exists():
        pytest.skip("not a git checkout")
    monkeypatch.setattr(store, "__file__", str(tmp_path / "site-packages" / "pylmp_lattice" / "sweep" / "store.py"))

    class Dist:
        def read_text(self, name):
            return json.dumps({"url": clone.as_uri(), "dir_info": {}}) if name == "direct_url.json" else None

    monkeypatch.setattr("importlib.metadata.distribution", lambda name: Dist())
    head = subprocess.run(["git", "-C", str(clone), "rev-parse", "HEAD"], capture_output=True, text=True).stdout.strip()
    assert store._git_commit().startswith(head)


@pytest.mark.lammps
def test_a_failed_batch_runs_its_members_alone(tmp_path, monkeypatch):
    """A batch that stops (e.g. one chain's magnets touch) gives each member its own outcome:
    its members run again one by one (here the batch is made to fail; the runs alone succeed)."""
    from concurrent.futures import ThreadPoolExecutor

    from pylmp_lattice import runner
    from pylmp_lattice.errors import ContactError

    original = runner.run_embedded

    def batch_fails(folder, **kwargs):
        if "batches" in Path(folder).parts:
            raise ContactError((3, 4), 1.0, -0.01, Path(folder))
        return original(folder, **kwargs)

    monkeypatch.setattr(runner, "run_embedded", batch_fails)
    sweep = load_sweep(write_sweep(tmp_path, THERMAL.format(replicas=3), particles=12, duration=10.0))
    with ThreadPoolExecutor(1) as pool:  # in this process, so that the failing runner applies
        table = run_sweep(sweep, tmp_path / "out", executor=pool, slots=1, progress=False)
    assert list(table["status"]) == ["done"] * 3
    records = [json.loads((tmp_path / "out" / f / STATUS).read_text()) for f in table["folder"]]
    assert not any("batch" in r for r in records)  # each ran alone
    assert all((tmp_path / "out" / f / "log.lammps").exists() for f in table["folder"])


def test_a_batch_whose_record_cannot_be_read_runs_its_members_alone(tmp_path, monkeypatch, caplog):
    """A batch that ran but whose measures fail to read (a damaged front record, say) is not a
    lost worker: its members run alone and are done, and the log says why."""
    from concurrent.futures import ThreadPoolExecutor

    from pylmp_lattice.sweep import batch

    def damaged(*args):
        raise ValueError("front.bin: truncated")

    monkeypatch.setattr(batch, "_summaries", damaged)
    sweep = load_sweep(write_sweep(tmp_path, THERMAL.format(replicas=3), particles=12, duration=10.0))
    with ThreadPoolExecutor(1) as pool:  # in this process, so that the patch applies
        table = run_sweep(sweep, tmp_path / "out", executor=pool, slots=1, progress=False)
    assert list(table["status"]) == ["done"] * 3
    assert table["shock_velocity_max_m_per_s.value"].notna().all()
    records = [json.loads((tmp_path / "out" / f / STATUS).read_text()) for f in table["folder"]]
    assert not any("batch" in r for r in records)  # each ran alone
    assert "its measures could not be read (ValueError: front.bin: truncated); its members run alone" in caplog.text


@pytest.mark.lammps
def test_a_script_without_the_main_guard_is_told_why_its_workers_fail(tmp_path):
    """The local workers import the calling script again (multiprocessing's forkserver): an
    unguarded run_sweep there stops with the remedy, not with a second sweep on the folder."""
    write_sweep(tmp_path, "", particles=8, duration=5.0)
    script = tmp_path / "script.py"
    script.write_text("from pylmp_lattice.sweep import Sweep, run_sweep\n"
                      "sweep = Sweep(base='base.toml', set={'chain.thermal_velocity': 0.02}, replicas=2, keep='measures')\n"
                      "run_sweep(sweep, 'out', workers=1, progress=False)\n")
    done = subprocess.run([sys.executable, str(script)], cwd=tmp_path, capture_output=True, text=True, timeout=120)
    assert "put the script's code under `if __name__ == \"__main__\":`" in done.stderr
    assert "another sweep is running" not in done.stderr


def _sleep_after_marking(path: str) -> str:
    Path(path).touch()
    time.sleep(30)
    return "slept"


def test_a_process_pool_the_caller_gave_gets_the_first_stop_as_sigint(tmp_path):
    """Local pools are told through their stop pipe; a caller's ProcessPoolExecutor has none, so
    its workers get SIGINT (their members stop at the engine's next step), not a kill later."""
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor

    from pylmp_lattice.sweep.pool import Pool

    marker = tmp_path / "started"
    # spawned, not forked from this process: a fork would inherit its signal handlers and MPI
    # state (a forked child that exits can break this process's later LAMMPS instances)
    with ProcessPoolExecutor(1, mp_context=multiprocessing.get_context("spawn")) as executor:
        future = executor.submit(_sleep_after_marking, str(marker))
        deadline = time.monotonic() + 30
        while not marker.exists():
            assert time.monotonic() < deadline
            time.sleep(0.01)
        Pool(executor, 1).on_signal(1)
        with pytest.raises(KeyboardInterrupt):
            future.result(timeout=20)


@pytest.mark.lammps
def test_a_guarded_script_may_run_a_sweep_in_a_child_process(tmp_path):
    """Only the child's import of the script is refused: a function of a guarded script that a
    spawned child runs may call run_sweep (the reviewer's false positive)."""
    write_sweep(tmp_path, "", particles=8, duration=5.0)
    script = tmp_path / "script.py"
    script.write_text(
        "import sys\nfrom concurrent.futures import ThreadPoolExecutor\nfrom multiprocessing import get_context\n"
        "from pylmp_lattice.sweep import Sweep, run_sweep\n\n"
        "def job():\n"
        "    sweep = Sweep(base='base.toml', grid={'impactor.velocity': [1.0]}, keep='measures')\n"
        "    with ThreadPoolExecutor(1) as pool:\n"
        "        assert list(run_sweep(sweep, 'out', executor=pool, progress=False)['status']) == ['done']\n\n"
        "if __name__ == '__main__':\n"
        "    child = get_context('spawn').Process(target=job)\n"
        "    child.start()\n    child.join()\n    sys.exit(child.exitcode)\n")
    done = subprocess.run([sys.executable, str(script)], cwd=tmp_path, capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr


@pytest.mark.parametrize("disorder", [{}, {"chain.mass_disorder": 0.01}, {"chain.r0_disorder": 0.005}])
def test_a_thousand_replicas_on_two_workers_are_two_tasks_of_500(disorder):
    """Tasks are as large as an instance allows (blocks.MAX_*): 1000 members of the 21-magnet
    experiment (2.1e4 atoms, 1.0e8 atom-steps) are one task of 500 per worker, with mass
    disorder too (masses per magnet: at most one atom type per chain)."""
    from pylmp_lattice.sweep.execute import _Blocks

    root = Path(__file__).resolve().parents[1]
    sweep = Sweep(base=root / "inputs" / "paper_experiment.toml", set={"chain.thermal_velocity": 0.02, **disorder},
                  replicas=1000, seed=1, keep="measures")
    first = next(sweep.iter_members())
    assert _Blocks(1000, 2, 1, 1000).next_size(first) == 500


def test_the_estimate_counts_batched_members_by_their_atom_steps(monkeypatch):
    """A batched member shares its instance's cost per step: 1000 members of the 21-magnet
    experiment are 1e8 atom-steps, about 0.47 s of engine time on one core (4.7 ns per
    atom-step; a 500-chain batch measured 0.33 s with friction, docs/performance.md) and 0.23 s
    of the worker's Python, not the 10 s that 1000 instances would take; run alone (also a
    batchable member that is its point's only one), each pays the machine's member_s more. The
    sweep's own start-up (sweep_s) and each task's (member_s and its steps) come on top: the
    12-member example said "about 0.005 s" and took 3 s (issue 27 item 9)."""
    from pylmp_lattice import overhead
    from pylmp_lattice.overhead import Overheads
    from pylmp_lattice.sweep.execute import _estimate

    monkeypatch.setattr(overhead, "contention", lambda: 1.0)  # the machine's load does not move the numbers
    root = Path(__file__).resolve().parents[1]
    thermal = {"chain.thermal_velocity": 0.02}
    batched = Sweep(base=root / "inputs" / "paper_experiment.toml", set=thermal, replicas=1000, keep="measures")
    costs = Overheads()  # the defaults (conftest: never measured in the tests)
    members = 1000 * (4.7e-9 * 21 * 4800 + 2.3e-4)  # 0.70 s
    expected = costs.sweep_s + members + costs.member_s + 1.3e-6 * 4800  # one task: a point's 1000 replicas
    assert _estimate(batched, 1000, 1) == f"about {expected:.2g} s on 1 worker (batched), if all are like the first"
    alone = Sweep(base=root / "inputs" / "paper_experiment.toml", set=thermal, replicas=10, keep="all")
    assert "(each run alone)" in _estimate(alone, 10, 1)
    points = Sweep(base=root / "inputs" / "paper_experiment.toml", grid={"impactor.velocity": [1.0, 2.0]},
                   keep="measures")  # batchable cases, but a task holds one point: each runs alone
    assert "(each run alone)" in _estimate(points, 2, 1)


def test_members_a_lost_worker_never_started_have_no_folder_in_the_table(tmp_path):
    """A task whose worker is lost before its members wrote anything: they are interrupted, and
    their rows name no folder (none exists on disk), so that a script reading the table finds
    every folder it names."""
    from concurrent.futures import Executor, Future

    class Lost(Executor):
        def submit(self, fn, *args, **kwargs):
            future = Future()
            future.set_exception(RuntimeError("the worker died"))
            return future

    sweep = load_sweep(write_sweep(tmp_path, THERMAL.format(replicas=3), particles=12, duration=10.0))
    table = run_sweep(sweep, tmp_path / "out", executor=Lost(), slots=1, progress=False)
    assert list(table["status"]) == ["interrupted"] * 3
    assert table["folder"].isna().all(), list(table["folder"])


@pytest.mark.lammps
def test_a_stop_while_a_batch_is_measured_interrupts_its_members(tmp_path, monkeypatch, caplog):
    """A stop signal after the batch's engine ended, while its record is read: its members are
    interrupted (redone on resume), as when the stop comes during the run; no warning that its
    measures could not be read, and none runs alone."""
    import signal
    import threading
    from concurrent.futures import ThreadPoolExecutor

    from pylmp_lattice.errors import Interrupted
    from pylmp_lattice.sweep import batch, signals

    def stopped(*args):
        raise Interrupted(signal.SIGINT)

    monkeypatch.setattr(batch, "_summaries", stopped)
    monkeypatch.setattr(signals, "STOP", threading.Event())  # this process's stop flag, for this test only
    sweep = load_sweep(write_sweep(tmp_path, THERMAL.format(replicas=3), particles=12, duration=10.0))
    with ThreadPoolExecutor(1) as pool:
        table = run_sweep(sweep, tmp_path / "out", executor=pool, slots=1, progress=False)
    assert list(table["status"]) == ["interrupted"] * 3
    assert "could not be read" not in caplog.text
    assert not list((tmp_path / "out" / "batches").iterdir()) and not list((tmp_path / "out" / "members").iterdir())


@pytest.mark.lammps
def test_a_batch_stopped_by_its_narrowest_range_runs_its_members_alone(tmp_path, monkeypatch):
    """Chains whose ranges differ (gap disorder) share the narrowest in a batch: a gap beyond it
    stops the batch, and each member then runs alone, to the outcome of its own range (here the
    batch's range is cut to 1.002 times the widest gap: a thermal chain's gap crosses it)."""
    import re
    from concurrent.futures import ThreadPoolExecutor

    from pylmp_lattice import deck

    original = deck.render_replicas

    def narrow(cases, front=False, draws=None, chain_files=True):
        files = original(cases, front, draws, chain_files)
        files[deck.DECK] = re.sub(r"(range \S+ )(\S+)", lambda m: m.group(1) + repr(float(m.group(2)) / 2.995),
                                  files[deck.DECK])
        return files

    monkeypatch.setattr(deck, "render_replicas", narrow)
    text = THERMAL.format(replicas=3) + '"chain.r0_disorder" = 0.005\n'
    sweep = load_sweep(write_sweep(tmp_path, text, particles=12, duration=40.0))
    with ThreadPoolExecutor(1) as pool:
        table = run_sweep(sweep, tmp_path / "out", executor=pool, slots=1, progress=False)
    assert list(table["status"]) == ["done"] * 3
    assert all(f.startswith("members/") for f in table["folder"])  # each alone, after the batch stopped


@pytest.mark.lammps
def test_members_whose_decks_differ_beyond_the_chain_run_alone(tmp_path):
    """A task's members share a parameter point, so they are batched by N and table range alone;
    members that still differ elsewhere (here the drive, in a task made by hand) are refused by
    the batch's deck and each runs alone, with the outcome of its own run."""
    from pylmp_lattice.sweep.batch import Task, run_task

    text = THERMAL.format(replicas=2) + '[grid]\n"impactor.velocity" = [1.0, 1.5]\n'
    sweep = load_sweep(write_sweep(tmp_path, text, particles=12, duration=10.0))
    (tmp_path / "out" / "members").mkdir(parents=True)
    results = run_task(Task(str(tmp_path / "out"), tuple(sweep.members()), sweep.runner))
    assert [r["record"]["status"] for r in results] == ["done"] * 4
    assert not any("batch" in r["record"] for r in results)  # each ran alone
    assert all((tmp_path / "out" / "members" / r["id"] / "summary.json").exists() for r in results)


@pytest.mark.lammps
def test_members_of_a_batch_file_that_does_not_parse_are_run_again(tmp_path):
    """Batched members are done only with the batch's members.json that parses, as a member
    alone only with its summary.json: a damaged file makes them run again, with equal measures."""
    from concurrent.futures import ThreadPoolExecutor

    sweep = load_sweep(write_sweep(tmp_path, THERMAL.format(replicas=3), particles=12, duration=10.0))
    out = tmp_path / "out"

    def run():
        with ThreadPoolExecutor(1) as pool:
            return run_sweep(sweep, out, executor=pool, slots=1, progress=False)

    first = run()
    [path] = list(out.glob("batches/*/members.json"))
    if set(first["folder"]) != {f"batches/{path.parent.name}"}:
        pytest.skip("this plugin build cannot batch these members: they ran alone")
    ended = json.loads(path.read_text())["ended"]
    path.write_text(path.read_text()[:-100])  # cut, as a full disk would leave it (were it not atomic)
    assert Outcomes(out).get(first["id"][0]) is None
    again = run()
    assert json.loads(path.read_text())["ended"] > ended  # run again, not taken from the damaged file
    pd.testing.assert_frame_equal(_comparable(again), _comparable(first))


@pytest.mark.lammps
def test_batched_chains_keep_their_own_front_levels(tmp_path, monkeypatch):
    """Front levels that depend on each chain (its noise: 5 sigma is above 1 % of V_I here) go to
    fix lattice/front's per-chain levels file, each row the levels of the chain's deck alone;
    each batched member's summary still equals its run alone."""
    from concurrent.futures import ThreadPoolExecutor

    from pylmp_lattice import deck
    from pylmp_lattice.run_folder import run_case
    from pylmp_lattice.sweep import batch

    monkeypatch.setattr(batch, "LEVELS_PER_CHAIN", True)
    sweep = load_sweep(write_sweep(tmp_path, THERMAL.format(replicas=4), particles=12, duration=40.0))
    alone = [deck._FRONT_FIX.search(deck.deck_text(m.case)).groups() for m in sweep.members()]
    assert len({row[0] for row in alone}) == 4
    files = deck.render_replicas([m.case for m in sweep.members()], front=True)
    assert "front_levels.txt" in files and " length 12 levels ${dir}/front_levels.txt" in files["in.lattice"]
    rows = [tuple(line.split()) for line in files["front_levels.txt"].splitlines()[1:]]
    assert rows == [row[:4] + (row[4] or "0.0",) for row in alone]
    with ThreadPoolExecutor(1) as pool:  # in this process, so that the levels apply
        table = run_sweep(sweep, tmp_path / "out", executor=pool, slots=1, progress=False)
    disk = Outcomes(tmp_path / "out")
    if not batch.LEVELS_PER_CHAIN:  # set by the batch's refusal, in this process
        pytest.skip("this plugin build has no per-chain front levels: members ran alone")
    assert all("batch" in disk.get(m)["record"] for m in table["id"])  # any other failure ran them alone
    for member in sweep.members():
        alone = run_case(member.case, tmp_path / "alone" / member.id, figure=False)
        batched = disk.get(member.id)["summary"]
        assert _measures(batched) == _measures(alone)


@pytest.mark.lammps
def test_an_older_plugin_s_refusal_of_write_work_is_recognised():
    """A plugin built before `fix_modify chain write_work` refuses it with LAMMPS's message for an
    unknown fix_modify keyword; batch.NO_CHAIN_WORK must match it (then friction members run one
    per instance), as shown here on a stock fix that has no such keyword."""
    from pylmp_lattice import engine
    from pylmp_lattice.sweep import batch

    with engine.instance(["-log", "none", "-screen", "none"]) as lmp:
        with pytest.raises(Exception) as refused:
            lmp.commands_string("units si\nregion b block 0 1 0 1 0 1\ncreate_box 1 b\nmass 1 1\n"
                                "create_atoms 1 single 0.5 0.5 0.5\nfix chain all nve\nfix_modify chain write_work x")
    assert batch.NO_CHAIN_WORK in str(refused.value)


def test_the_folder_says_at_most_how_many_members_are_done_before_any_is_read(tmp_path):
    """Outcomes.at_most: members done in a batch file plus member folders (finished or not), each
    counted once; it sizes a resumed sweep's tasks before enumerating its members."""
    from pylmp_lattice.sweep.store import BATCHES, MEMBERS, Outcomes, write_batch

    for name in ("a", "d"):
        (tmp_path / MEMBERS / name).mkdir(parents=True)
    batch = tmp_path / BATCHES / "a"
    batch.mkdir(parents=True)
    write_batch(batch, {"status": "done"}, [{"id": i, "index": k, "params": {}, "chain": k, "case": {},
                                             "summary": {"particles": 21}} for k, i in enumerate("abc")])
    disk = Outcomes(tmp_path)
    assert disk.at_most() == 4  # a, b, c batched; d's own folder
    assert disk.get("b")["summary"] == {"particles": 21} and disk.get("d") is None  # d never finished


def test_a_batch_s_members_json_is_strict_and_reads_back_each_member_s_summary(tmp_path):
    """write_batch makes every value strict JSON column by column (NaN and infinities null,
    numpy values plain, a column of mixed dicts and None value by value) and read_batch gives
    each member's summary back as `serialize.jsonable` of it would read."""
    from pylmp_lattice.serialize import jsonable
    from pylmp_lattice.sweep.store import BATCH_FILE, read_batch, write_batch

    summaries = [{"a": 1.5, "b": float("nan"), "c": {"mean": np.float64(2.0), "flag": np.bool_(True)},
                  "d": None, "e": [1, float("inf")], "f": "x"},
                 {"a": float("-inf"), "b": 3, "c": None, "d": {"value": float("nan")}, "e": (2, 3.0), "f": "y"}]
    write_batch(tmp_path, {"status": "done"}, [{"id": i, "index": k, "params": {"p": k}, "chain": k, "case": {},
                                                "summary": s} for k, (i, s) in enumerate(zip("ab", summaries))])
    text = (tmp_path / BATCH_FILE).read_text()
    assert "NaN" not in text and "Infinity" not in text
    back = read_batch(tmp_path / BATCH_FILE)
    assert [back[i]["summary"] for i in "ab"] == [json.loads(json.dumps(jsonable(s))) for s in summaries]
    assert back["b"]["summary"]["a"] is None and back["a"]["summary"]["c"] == {"mean": 2.0, "flag": True}


def test_a_batch_s_members_json_is_json_dumps_of_its_columns_and_its_floats_are_the_csv_s(tmp_path):
    """members.json, its columns of finite floats written from their texts (`store._json`), is
    byte for byte json.dumps of the record and the strict columns; the CSV cells made of those
    texts (`csv_cells.float_cells`) are those made of the numbers (`csv_cells.array_texts`), and
    members.arrow and the table's arrays made of the floats' arrays (`store.Floats`) are those
    made of the values."""
    from pylmp_lattice.sweep.columns_file import COLUMNS_FILE, write_columns
    from pylmp_lattice.sweep.store import BATCH_FILE, write_batch
    from pylmp_lattice.sweep.csv_cells import array_texts, float_cells
    from pylmp_lattice.sweep.table import _packed

    rng = np.random.default_rng(4)
    values = [*rng.normal(size=40).tolist(), 1e-300, 1.0000000000000002, -0.0, 1e22, 123456.78901234567, 5.0]
    summaries = [{"v": v, "w": {"mean": 2.0 * v, "n": k, "ok": k % 2 == 0}, "x": float("nan") if k == 3 else v,
                  "t": "é\"q" if k else "a,b", "l": [k, k + 1]} for k, v in enumerate(values)]
    record = {"status": "done", "engine": "cpu", "provenance": {"host": "ü", "cores": 2}, "wall_time_s": 0.25}
    texts: dict = {}
    columns = write_batch(tmp_path, record, [{"id": f"m{k}", "index": k, "params": {"p": k / 3}, "chain": k,
                                              "case": {"chain": {"seed": k}}, "summary": s}
                                             for k, s in enumerate(summaries)], texts)
    want = json.dumps({**record, "columns": columns}, allow_nan=False, separators=(",", ":")) + "\n"
    assert (tmp_path / BATCH_FILE).read_text() == want
    summary = columns["cols"]["summary"]["cols"]
    assert {id(summary["v"]["rows"]), id(summary["w"]["cols"]["mean"]["rows"])} <= set(texts)
    assert id(summary["x"]["rows"]) not in texts  # a NaN: null in the JSON, its own texts
    for column in (summary["v"]["rows"], summary["w"]["cols"]["mean"]["rows"], columns["cols"]["params"]["cols"]["p"]["rows"]):
        assert float_cells(column, texts) == array_texts(np.array(column))
    assert any(len(t) > 16 for t in texts[id(summary["v"]["rows"])].cells)  # a long repr: made short for the CSV
    # members.arrow of the floats' arrays made once is the file made of the values
    plain = tmp_path / "plain"
    plain.mkdir()
    write_columns(plain, record, columns, (tmp_path / BATCH_FILE).read_bytes())
    assert (plain / COLUMNS_FILE).read_bytes() == (tmp_path / COLUMNS_FILE).read_bytes()
    column = summary["w"]["cols"]["mean"]["rows"]
    assert _packed(column, texts) is texts[id(column)].array and np.array_equal(_packed(column), _packed(column, texts))


def test_a_column_s_float_texts_made_once_per_value_are_each_value_s_repr():
    """store._float_texts (a text per distinct value where a column repeats its values) gives
    repr of each value: -0.0 beside 0.0 (equal values, other texts), NaN, subnormals, 17 digits."""
    from pylmp_lattice.sweep.store import _float_texts

    rng = np.random.default_rng(5)
    few = [1.5, 2.25, 1e-05, 1e22, 5e-324, 0.1 + 0.2, float("nan"), 123456.78901234567]
    for values in ([few[k] for k in rng.integers(0, len(few), 3000)],  # few values: a text per value
                   [(-0.0, 0.0, 1.5)[k] for k in rng.integers(0, 3, 3000)],  # both zeros: repr of each
                   rng.normal(size=3000).tolist(),  # all distinct
                   [*rng.normal(size=1000).tolist(), *[2.5] * 5000]):  # judged from the first 1000
        assert _float_texts(values) == list(map(repr, values))


def test_a_batch_s_columns_of_one_shared_value_are_written_as_those_of_equal_values(tmp_path):
    """Members that share a case's values (one object in every row: `columnar.columns`' `same`)
    get the members.json, members.arrow and table cells (`table.batch_rows`) that the same
    values in objects of their own get, byte for byte, and those made value by value: json.dumps
    of the columns, members.arrow made without knowing them shared (`columns_file._array`): each
    kind of value, a non-finite float (null), a list of gap numbers, an int beyond Arrow's
    int64 (no members.arrow)."""
    from pylmp_lattice.sweep.columns_file import COLUMNS_FILE, write_columns
    from pylmp_lattice.sweep.store import BATCH_FILE, write_batch
    from pylmp_lattice.sweep.table import batch_rows

    def copied(value):  # an equal value, no object shared (floats and texts made again)
        if isinstance(value, dict):
            return {k: copied(v) for k, v in value.items()}
        if isinstance(value, list):
            return [copied(v) for v in value]
        return float(repr(value)) if type(value) is float else "".join(list(value)) if type(value) is str else value

    shared = {"mass": 1.084, "r0": -0.0, "v": 2.81e-05, "big": 1e22, "law": "power", "ok": True, "n": 21,
              "none": None, "gaps": [2, 12], "empty": [], "nan": float("nan"), "inf": float("inf"),
              "section": {"q": 3.0, "name": "a,b"}}
    record = {"status": "done", "engine": "cpu"}
    for big in (False, True):
        case = shared | ({"seed": 2**70} if big else {})
        written = {}
        for name, cases in (("shared", [case] * 5), ("copied", [copied(case) for _ in range(5)])):
            folder = tmp_path / f"{name}{big}"
            folder.mkdir()
            texts: dict = {}
            columns = write_batch(folder, record, [{"id": f"m{k}", "index": k, "params": {"p": k}, "chain": k, "case": c,
                                                    "summary": {"x": k / 3, "c": c}} for k, c in enumerate(cases)], texts)
            [rows] = batch_rows(list(range(5)), [f"m{k}" for k in range(5)], [{"p": k} for k in range(5)], "batches/m0",
                                record, columns["cols"]["summary"], texts)
            arrow = folder / COLUMNS_FILE
            written[name] = ((folder / BATCH_FILE).read_bytes(), arrow.read_bytes() if arrow.exists() else None,
                             rows.text)
            text = json.dumps({**record, "columns": columns}, allow_nan=False, separators=(",", ":")) + "\n"
            assert written[name][0] == text.encode()
            plain = folder / "plain"
            plain.mkdir()
            write_columns(plain, record, columns, written[name][0])  # value by value
            assert written[name][1] == ((plain / COLUMNS_FILE).read_bytes() if not big else None)
        assert written["shared"] == written["copied"]
        assert (written["shared"][1] is None) == big  # 2**70: not exact in Arrow, members.json alone
        assert b'"nan":{"rows":[null,null,null,null,null]}' in written["shared"][0]


def _typed(value):
    """A value with the type of each number, flag and text beside it (1 == 1.0 == True in Python)."""
    if isinstance(value, dict):
        return {k: _typed(v) for k, v in value.items()}
    if isinstance(value, list):
        return [_typed(v) for v in value]
    return type(value).__name__, value


def test_a_batch_s_members_arrow_is_its_members_json_s_columns_and_counts_only_beside_it(tmp_path):
    """write_batch writes members.arrow before members.json where every column is exact in
    Arrow; read back (`read_batch`) each member's outcome is what the JSON gives, each type
    kept. It does not count beside another members.json (its digest) or damaged, and is not
    written for a column of whole and fractional numbers (1 and 2.5: the JSON keeps them apart)."""
    from pylmp_lattice.sweep.columns_file import COLUMNS_FILE, read_columns
    from pylmp_lattice.sweep.store import BATCH_FILE, read_batch, write_batch

    summaries = [{"a": 1.5, "n": 2, "ok": True, "t": "x,y", "gaps": [1, 2], "none": None, "m": {"v": 2.0, "f": None}},
                 {"a": float("nan"), "n": 3, "ok": False, "t": None, "gaps": [], "none": None, "m": {"v": -0.0, "f": 1.25}}]
    members = [{"id": i, "index": k, "params": {"replica": k, "chain.seed": 2**62 + k}, "chain": k,
                "case": {"x": [1.0, 2]}, "summary": s} for k, (i, s) in enumerate(zip("ab", summaries))]
    record = {"status": "done", "error": None, "wall_time_s": 0.5, "batch": "batches/a"}
    write_batch(tmp_path, record, members)
    text = (tmp_path / BATCH_FILE).read_bytes()
    found = read_columns(tmp_path, text)
    assert found is not None and found[0] == record
    columns = json.loads(text)["columns"]["cols"]
    assert _typed(found[1]) == _typed({"cols": {k: v for k, v in columns.items() if k != "case"}})
    outcomes = read_batch(tmp_path / BATCH_FILE)
    (tmp_path / COLUMNS_FILE).rename(tmp_path / "kept")
    assert _typed(read_batch(tmp_path / BATCH_FILE)) == _typed(outcomes)  # from the JSON alone: the same
    (tmp_path / "kept").rename(tmp_path / COLUMNS_FILE)
    (tmp_path / BATCH_FILE).write_bytes(text.replace(b'"x,y"', b'"x,z"'))  # another members.json
    assert read_columns(tmp_path, (tmp_path / BATCH_FILE).read_bytes()) is None
    assert read_batch(tmp_path / BATCH_FILE)["a"]["summary"]["t"] == "x,z"
    (tmp_path / BATCH_FILE).write_bytes(text)
    (tmp_path / COLUMNS_FILE).write_bytes((tmp_path / COLUMNS_FILE).read_bytes()[:200])  # damaged
    assert read_columns(tmp_path, text) is None and _typed(read_batch(tmp_path / BATCH_FILE)) == _typed(outcomes)
    (tmp_path / COLUMNS_FILE).unlink()
    write_batch(tmp_path, record, [m | {"summary": m["summary"] | {"n": 2.5 if m["id"] == "b" else 1}} for m in members])
    assert not (tmp_path / COLUMNS_FILE).exists() and read_batch(tmp_path / BATCH_FILE)["a"]["summary"]["n"] == 1


def test_sweep_files_are_readable_as_the_umask_says(tmp_path):
    """Tables and records are written through a temporary file (mkstemp makes it the owner's
    alone); they end with the mode a plain open() gives under the process's umask."""
    from pylmp_lattice.formats.files import UMASK, atomic_write

    atomic_write(tmp_path / "results.csv", "id\n")
    assert (tmp_path / "results.csv").stat().st_mode & 0o777 == 0o666 & ~UMASK


@pytest.mark.lammps
@pytest.mark.parametrize("module", ["pylmp_lattice.cli", "pylmp_lattice"])
def test_a_sweep_run_as_a_module_says_why_members_failed_without_warnings(tmp_path, module):
    """`python -m pylmp_lattice[.cli] sweep`, local workers: a swept value out of range fails its
    member (checked per member: a field's range may depend on the others), and the command's last
    lines say why, from the table's error column; no worker warns that multiprocessing ran the
    command's module again (runpy's RuntimeWarning, once per worker, with -m pylmp_lattice.cli)."""
    base = Path(__file__).resolve().parents[1] / "inputs" / "paper_experiment.toml"
    sweep = tmp_path / "s.toml"
    sweep.write_text(f'base = "{base}"\nkeep = "measures"\n[set]\n"run.duration" = 3.0\n'
                     '[grid]\n"impactor.velocity" = [1.0, -2.0, 60.0]\n')
    out = tmp_path / "out"
    done = subprocess.run([sys.executable, "-m", module, "sweep", str(sweep), "-o", str(out), "--quiet",
                           "--workers", "1"], capture_output=True, text=True, timeout=120)
    assert done.returncode == 1, done.stderr
    assert "3 members: 1 done, 2 failed" in done.stderr
    assert "pylmp-lattice: failed: impactor.velocity: got -2.0 m/s; expected > 0" in done.stderr
    # 60 m/s: magnets 1 and 2 touch at 2.5 ms; the line's paths work from where the command ran
    contact = next(line for line in done.stderr.splitlines() if "touched" in line)
    assert f"files kept in {out}/members/" in contact and f"`pylmp-lattice summarize {out}/members/" in contact
    assert "Warning" not in done.stderr, done.stderr


def test_the_failure_lines_group_members_failed_alike(tmp_path, capsys):
    """Errors the same but for the member's own folder are one reason, said once with its count and
    an example whose folder is given from here; a user's own path named "members/..." is kept."""
    from pylmp_lattice.cli import _say_failures

    same = "output: got folder 'members/{}'; the embedded runner needs a path"
    errors = [same.format("0123456789abcdef"), same.format("fedcba9876543210"), "force.file: members/drive.csv: not found",
              "a", "b"]
    _say_failures(errors, tmp_path / "sw")
    lines = capsys.readouterr().err.splitlines()
    assert lines == [f"pylmp-lattice: failed (2 members, e.g.): {same.format('0123456789abcdef')}".replace(
                         "'members/", f"'{tmp_path / 'sw'}/members/"),
                     "pylmp-lattice: failed: force.file: members/drive.csv: not found",
                     "pylmp-lattice: failed: a",
                     "pylmp-lattice: failed: and 1 other reason (the table's error column)"]


def test_the_failure_lines_group_contacts_whatever_their_numbers(capsys, tmp_path):
    """Magnets touching at other pairs, gaps and times are one reason (a trial's sweep listed
    three contacts apart, then 'and 5 other reasons'); a field's name keeps its digits."""
    from pylmp_lattice.cli import _say_failures

    contact = "magnets {} and {} touched (gap -{} mm) at t = {} ms (files kept in members/{})"
    errors = [contact.format(1, 2, 0.1036, 2.5125, "0123456789abcdef"), contact.format(19, 20, 0.0375, 68.56, "fedcba9876543210"),
              contact.format(3, 4, 1e-3, 1.5, "00112233445566ff"), "chain.r0_disorder: got 2 ; expected < 1",
              "chain.r1_disorder: got 2 ; expected < 1"]
    _say_failures(errors, tmp_path / "sw")
    lines = capsys.readouterr().err.splitlines()
    assert lines[0].startswith("pylmp-lattice: failed (3 members, e.g.): magnets 1 and 2 touched (gap -0.1036 mm)")
    assert lines[1:] == ["pylmp-lattice: failed: chain.r0_disorder: got 2 ; expected < 1",  # (r0, r1: names, not numbers)
                         "pylmp-lattice: failed: chain.r1_disorder: got 2 ; expected < 1"]
    _say_failures(["LAMMPS stopped at step 1234.", "LAMMPS stopped at step 99."], tmp_path / "sw")  # a full stop ends a number
    assert capsys.readouterr().err == "pylmp-lattice: failed (2 members, e.g.): LAMMPS stopped at step 1234.\n"


@pytest.mark.parametrize("base", [3, [1], None])
def test_a_sweep_s_base_of_another_kind_is_refused_in_one_line(base):
    """Sweep(base=3) in Python ended in "expected str, bytes or os.PathLike object, not int" from
    pathlib; it is now a ConfigError naming base and what it takes."""
    with pytest.raises(ConfigError) as info:
        Sweep(base=base)
    assert str(info.value) == (f"base: got {base!r}; expected a Case, a dict of case sections or the path of a case "
                               "file (TOML)")


def test_the_sweep_api_names_a_mistaken_argument(tmp_path):
    """run_sweep(sweep, None) failed in pathlib, load_results of a folder without a table in
    pandas (FileNotFoundError 8 frames deep), replica_stats(None) as an AttributeError (trial3's
    notes): each is now a UsageError naming the argument."""
    from pylmp_lattice.errors import UsageError

    path = write_sweep(tmp_path, SIX)
    with pytest.raises(UsageError, match=r"^root: got None; expected a str or Path: the sweep's folder$"):
        run_sweep(load_sweep(path), None, progress=False)
    with pytest.raises(UsageError, match=r"^root: got '.*none'; expected a sweep's folder \(it has no results.csv nor "
                                         r"results.parquet\)$"):
        load_results(tmp_path / "none")
    with pytest.raises(UsageError, match=r"^table: got NoneType; expected a sweep's table"):
        replica_stats(None)


def _members(summaries: list) -> list[dict]:
    return [{"id": f"m{k}", "index": k, "params": {"replica": k}, "chain": k, "case": {}, "summary": s}
            for k, s in enumerate(summaries)]


def test_a_batch_member_without_a_summary_is_not_done(tmp_path):
    """A batch's member whose summary is not a table (null) has no outcome; the others stand
    (mutation: every row of a batch counted done survived)."""
    from pylmp_lattice.sweep.store import read_batch, write_batch

    folder = tmp_path / "batches" / "m0"
    folder.mkdir(parents=True)
    write_batch(folder, {"status": "done", "batch": "batches/m0"}, _members([{"v": 1.5}, None, {"v": 2.5, "w": 1}]))
    found = read_batch(folder / "members.json")
    assert sorted(found) == ["m0", "m2"]
    assert found["m0"]["summary"] == {"v": 1.5} and found["m2"]["summary"] == {"v": 2.5, "w": 1}
    assert Outcomes(tmp_path).get("m1") is None and Outcomes(tmp_path).get("m2")["record"]["index"] == 2


@pytest.mark.parametrize("status", ["interrupted", "failed", "running"])
def test_a_batch_whose_record_is_not_done_holds_no_outcome(tmp_path, status):
    """members.json counts only where its record says "done" (members.arrow beside it or not):
    a batch file of another state leaves its members to run again (mutation: the record's
    status unread survived)."""
    from pylmp_lattice.sweep.store import read_batch, write_batch

    (tmp_path / "batches" / "m0").mkdir(parents=True)
    write_batch(tmp_path / "batches" / "m0", {"status": status, "batch": "batches/m0"}, _members([{"v": 1.5}] * 2))
    assert (tmp_path / "batches" / "m0" / "members.arrow").is_file()
    assert read_batch(tmp_path / "batches" / "m0" / "members.json") == {}
    assert Outcomes(tmp_path).get("m0") is None and Outcomes(tmp_path).to_keep() == 0


def _serial():
    """An executor that runs each task at once, in this thread (its slots: as the caller says)."""
    from concurrent.futures import Executor, Future

    class Serial(Executor):
        def submit(self, fn, *args, **kwargs):
            future = Future()
            future.set_result(fn(*args, **kwargs))
            return future
    return Serial()


@pytest.mark.lammps
def test_members_a_lost_worker_finished_are_read_back_done(tmp_path):
    """A worker lost after its task wrote every outcome (it died before it reported them): the
    members are read back from the disk, "done" in the table with their batch's folder and
    measures, not "interrupted" (mutation: `_from_disk` ignoring what the disk holds survived)."""
    from concurrent.futures import Executor, Future

    class LostAfterWriting(Executor):
        def submit(self, fn, *args, **kwargs):
            fn(*args, **kwargs)  # the task runs to its end: its outcomes are on disk
            future = Future()
            future.set_exception(RuntimeError("the worker died before it reported"))
            return future

    sweep = load_sweep(write_sweep(tmp_path, THERMAL.format(replicas=3), particles=12, duration=10.0))
    out = tmp_path / "out"
    table = run_sweep(sweep, out, executor=LostAfterWriting(), slots=1, progress=False)
    [path] = list(out.glob("batches/*/members.json"))
    assert list(table["status"]) == ["done"] * 3
    assert list(table["folder"]) == [f"batches/{path.parent.name}"] * 3
    kept = run_sweep(sweep, out, executor=_serial(), slots=1, progress=False)  # resumed: all kept, as read back
    pd.testing.assert_frame_equal(_comparable(table), _comparable(kept))


@pytest.mark.lammps
def test_a_resume_puts_the_rows_of_a_batch_after_the_first_at_their_own_members(tmp_path):
    """Four replicas in two tasks of two (two slots): the first batch's members.json lost, a
    resume runs those two again and keeps the second batch's, whose rows must be its own
    members' (places 2 and 3 of the point), bit for bit those of the first run (mutation: the
    kept rows put at places 0, 1 survived: every kept batch so far was the point's first)."""
    sweep = load_sweep(write_sweep(tmp_path, THERMAL.format(replicas=4), particles=12, duration=10.0))
    out = tmp_path / "out"
    first = run_sweep(sweep, out, executor=_serial(), slots=2, progress=False)
    folders = list(dict.fromkeys(first["folder"]))
    if len(folders) != 2 or not all(f.startswith("batches/") for f in folders):
        pytest.skip(f"not two batches: {folders}")
    assert list(first["folder"]) == [folders[0]] * 2 + [folders[1]] * 2
    (out / folders[0] / "members.json").unlink()
    again = run_sweep(sweep, out, executor=_serial(), slots=2, progress=False)
    assert list(again["id"]) == list(first["id"]) and list(again["folder"])[2:] == [folders[1]] * 2  # (0, 1: run alone)
    pd.testing.assert_frame_equal(_comparable(again).drop(columns="folder"), _comparable(first).drop(columns="folder"))


@pytest.mark.lammps
def test_a_task_run_again_keeps_its_member_done_alone_and_runs_each_other_member_s_own_case(tmp_path):
    """Dask runs a task again (its worker retired) after one of its members was done alone: that
    member is kept (its folder untouched) and the others run, each with its own case, all done
    (mutation: the members left paired with the cases of the task's first members survived)."""
    from pylmp_lattice.sweep.batch import Rows, Task, run_task

    sweep = load_sweep(write_sweep(tmp_path, THERMAL.format(replicas=3), particles=12, duration=10.0))
    out = tmp_path / "out"
    out.mkdir()
    (first,), rest = list(sweep.iter_runs())  # the point's first member, then its other replicas
    ids = [first.id, *rest.ids]
    [alone] = run_task(Task(str(out), (first,), sweep.runner))
    assert alone["id"] == ids[0] and alone["record"]["status"] == "done"
    status = out / "members" / ids[0] / STATUS
    before = status.read_bytes(), status.stat().st_mtime_ns
    results = run_task(Task(str(out), (first, rest), sweep.runner))
    done = {}
    for result in results:
        if isinstance(result, Rows):
            done |= dict(zip(result.columns["id"], result.columns["status"]))
        elif isinstance(result, dict):
            done[result["id"]] = result["record"]["status"]
    assert done == dict.fromkeys(ids, "done")
    assert (status.read_bytes(), status.stat().st_mtime_ns) == before  # kept, not run again
    for m in rest:  # each member's outcome is its own case's (its seed)
        assert Outcomes(out).get(m.id)["record"]["params"]["chain.seed"] == m.params["chain.seed"]
    (tmp_path / "alone").mkdir()
    [last] = run_task(Task(str(tmp_path / "alone"), (rest.take([1]),), sweep.runner))  # the last member alone
    assert _measures(Outcomes(out).get(ids[2])["summary"]) == _measures(last["summary"])


def test_a_member_stopped_by_a_signal_is_interrupted_on_disk(tmp_path, monkeypatch):
    """A member whose run a stop signal ends: its status.json says "interrupted" (with its end),
    not "running" forever (mutation: `_stopped` without its write survived)."""
    import threading

    from pylmp_lattice import run_folder
    from pylmp_lattice.errors import Interrupted
    from pylmp_lattice.sweep import member, signals
    from pylmp_lattice.sweep.spec import member_cases
    from pylmp_lattice.sweep.store import read_status

    def stopped(*args, **kwargs):
        raise Interrupted(signal.SIGINT)

    monkeypatch.setattr(run_folder, "run_case", stopped)
    monkeypatch.setattr(signals, "STOP", threading.Event())  # this process's stop flag, for this test only
    sweep = load_sweep(write_sweep(tmp_path, SIX))
    m = next(iter(sweep.iter_runs()))[0]
    [case] = member_cases([m])
    result = member.run_member(tmp_path, m, case, "embedded", "2025-01-01T00:00:00.000+00:00")
    record = read_status(tmp_path / "members" / m.id)
    assert result["record"]["status"] == record["status"] == "interrupted"
    assert record["id"] == m.id and "ended" in record
    assert Outcomes(tmp_path).get(m.id) is None  # run again on resume
