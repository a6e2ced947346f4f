"""Every bad input is refused with one line on stderr naming the field, exit 2, no traceback.

A fuzzer over the CLI, run in-process (`cli.main`), in a scratch working directory: broken
files (a folder, binary, empty, malformed TOML), wrong types, NaN and infinities, negative and
huge values, unknown keys and sections, bad `--set` syntax, unsafe names and data paths, and
bad arguments of the other commands. A sentinel file in the working directory and one in
`runs/other` must stay as they were, and nothing else may appear outside `runs/`.
"""

from __future__ import annotations

import copy
import datetime
import logging
import math
import os
import shutil
import warnings

import numpy as np
import pytest
import tomli_w

from pylmp_lattice.case import case_to_dict
from pylmp_lattice.cli import main

from conftest import make_case

CASE = case_to_dict(make_case(particles=10, velocity=1.0, duration=1.0)) | {"name": "ok"}
LONG_NAME = "n" * 300
INJECTION = "x\nshell touch INJECTED\nprint y"


def _set(path: str, value):
    """A mutation of CASE: the dotted field set to `value` (a section when `path` has no dot)."""
    def mutate(data):
        *sections, key = path.split(".")
        target = data
        for s in sections:
            if not isinstance(target.get(s), dict):
                target[s] = {}
            target = target[s]
        target[key] = value
    return mutate


# (mutation of CASE, the field the one-line message must name)
FIELD_MUTATIONS = [
    # names: identifiers only
    (_set("name", LONG_NAME), "name"),
    (_set("name", INJECTION), "name"),
    (_set("name", ""), "name"),
    (_set("name", ".."), "name"),
    (_set("name", "."), "name"),
    (_set("name", "../../x"), "name"),
    (_set("name", "/tmp/abs"), "name"),
    (_set("name", "a b"), "name"),
    (_set("name", "x&"), "name"),
    (_set("name", "${x}"), "name"),
    (_set("name", "x#y"), "name"),
    (_set("name", "x'y"), "name"),
    (_set("name", 5), "name"),
    (_set("name", ["a"]), "name"),
    # wrong types
    (_set("chain.particles", "ten"), "chain.particles"),
    (_set("chain.particles", 10.5), "chain.particles"),
    (_set("chain.particles", [10]), "chain.particles"),
    (_set("chain.mass", {"a": 1}), "chain.mass"),
    (_set("chain.mass", True), "chain.mass"),
    (_set("chain.mass", ["1", "2"]), "chain.mass"),
    (_set("impactor.velocity", datetime.date(2024, 1, 1)), "impactor.velocity"),
    (_set("run.duration", "1 ms"), "run.duration"),
    (_set("output.front", "yes"), "output.front"),
    (_set("output.fine", "all"), "output.fine"),
    (_set("output.fine", [1.5]), "output.fine"),
    (_set("force.law", ["power"]), "force.law"),
    (_set("force.law", 5), "force.law"),
    (_set("impactor.profile", {"x": 1}), "impactor.profile"),
    (_set("chain.far_end", "x" * 300), "chain.far_end"),
    (_set("chain.disorder", 1), "chain.disorder"),
    (_set("chain", 5), "chain"),
    (_set("run", "fast"), "run"),
    (_set("output", [1, 2]), "output"),
    (_set("second_neighbour.sign", "minus"), "second_neighbour.sign"),
    # NaN and infinities
    (_set("impactor.velocity", math.nan), "impactor.velocity"),
    (_set("impactor.velocity", math.inf), "impactor.velocity"),
    (_set("force.q", math.inf), "force.q"),
    (_set("force.K", math.nan), "force.K"),
    (_set("chain.mass", [1.0] * 9 + [math.nan]), "chain.mass"),
    (_set("run.dt", math.nan), "run.dt"),
    (_set("run.duration", -math.inf), "run.duration"),
    (_set("table.r_max", math.inf), "table.r_max"),
    (_set("friction.mu", math.nan), "friction.mu"),
    # zero, negative
    (_set("chain.particles", 2), "chain.particles"),
    (_set("chain.particles", -5), "chain.particles"),
    (_set("chain.r0", 0.0), "chain.r0"),
    (_set("run.dt", -0.01), "run.dt"),
    (_set("run.output_interval", 0), "run.output_interval"),
    (_set("table.points", 0), "table.points"),
    (_set("chain.seed", -1), "chain.seed"),
    (_set("output.fine", [0]), "output.fine"),
    (_set("output.fine", [11]), "output.fine"),
    # huge values
    (_set("chain.particles", 10**18), "chain.particles"),
    (_set("chain.particles", 2**63 - 1), "chain.particles"),
    (_set("run.duration", 1e300), "run.duration"),
    (_set("run.duration", 1e12), "run.duration"),
    (_set("run.dt", 1e-300), "run.dt"),  # more steps than LAMMPS runs at once: the step at fault, not the duration
    (_set("run.dt", 10.0), "run.dt"),  # longer than run.output_interval
    (_set("chain.r0", 1e100), "chain.r0"),  # the law's stiffness there is 0 in doubles: was a ZeroDivisionError
    (_set("chain.r0", 1e-320), "chain.r0"),  # below the normal doubles
    (_set("force.K", 1e-320), "chain.r0"),  # no gap where the stiffness is > 0
    (_set("table.points", 10**12), "table.points"),
    (_set("chain.mass_disorder", 1e300), "chain.seed"),
    (_set("chain.defect_index", 10**18), "chain.defect_index"),
    (lambda d: d["chain"].update(defect_index=5, defect_r0=1e300), "chain.defect_r0"),  # was a ZeroDivisionError
    (lambda d: d["chain"].update(defect_index=5, defect_r0=2**63 - 1), "chain.defect_r0"),  # was numpy's casting error
    (lambda d: d["chain"].update(thermal_velocity=1e300, seed=1), "chain.thermal_velocity"),  # was a ValueError
    # a long lattice that would need more magnets than LAMMPS can number
    (lambda d: (d["chain"].pop("particles"), d["chain"].update(far_end="long"), d["run"].update(duration=1e12)),
     "run.duration"),
    # unknown or missing keys and sections
    (_set("chain.colour", "red"), "chain.colour"),
    (_set("colour.red", 1), "colour"),
    (_set("x\ny", 1), "'x\\ny'"),
    (_set("chain.x\ny", 1), "chain.'x\\ny'"),
    (lambda d: d.pop("run"), "run"),
    (lambda d: d["chain"].pop("mass"), "chain.mass"),
    # data files: inside the case file's folder only, their text never echoed
    (lambda d: d.update(impactor={"profile": "measured", "file": "/etc/passwd"}), "impactor.file"),
    (lambda d: d.update(impactor={"profile": "measured", "file": "../outside.csv"}), "impactor.file"),
    (lambda d: d.update(impactor={"profile": "measured", "file": "escape.csv"}), "impactor.file"),  # a symlink out
    (lambda d: d.update(impactor={"profile": "measured", "file": "secret.txt"}), "impactor.file"),
    (lambda d: d.update(impactor={"profile": "measured", "file": "binary.csv"}), "impactor.file"),
    (lambda d: d.update(impactor={"profile": "measured", "file": "empty.csv"}), "impactor.file"),
    (lambda d: d.update(impactor={"profile": "measured", "file": "folder"}), "impactor.file"),
    (lambda d: d.update(impactor={"profile": "measured", "file": "missing.csv"}), "impactor.file"),
    (lambda d: d.update(impactor={"profile": "measured", "file": 5}), "impactor.file"),
    (lambda d: d.update(impactor={"profile": "measured", "file": ""}), "impactor.file"),
    (lambda d: d.update(force={"law": "sampled", "file": "/etc/hostname"}), "force.file"),
    (lambda d: d.update(force={"law": "sampled", "file": "secret.txt"}), "force.file"),
]
SECRET = "TOP-SECRET-LINE"


@pytest.fixture
def workdir(tmp_path, monkeypatch):
    """A scratch working directory with sentinels, data files and a folder outside it."""
    work = tmp_path / "work"
    (work / "runs" / "other").mkdir(parents=True)
    (work / "sentinel.txt").write_text("keep me\n")
    (work / "runs" / "other" / "sentinel.txt").write_text("keep me too\n")
    (tmp_path / "outside.csv").write_text("0,0\n1,1\n2,2\n3,3\n4,4\n")
    (work / "escape.csv").symlink_to(tmp_path / "outside.csv")
    (work / "secret.txt").write_text(f"{SECRET}\n1,2\n")
    (work / "binary.csv").write_bytes(bytes(range(256)) * 4)
    (work / "empty.csv").write_text("")
    (work / "folder").mkdir()
    monkeypatch.chdir(work)
    # cli.main sets up logging once per process; bind it to this test's captured stderr
    root = logging.getLogger()
    saved = root.handlers[:]
    root.handlers.clear()
    before = _snapshot(tmp_path)
    yield work
    root.handlers[:] = saved
    assert (work / "sentinel.txt").read_text() == "keep me\n"
    assert (work / "runs" / "other" / "sentinel.txt").read_text() == "keep me too\n"
    assert not list(tmp_path.rglob("INJECTED"))
    assert _snapshot(tmp_path) == before, "a refused input left files behind"


def _snapshot(root):
    """Every path under root but the inputs the tests write."""
    return sorted(str(p.relative_to(root)) for p in root.rglob("*") if p.name not in INPUT_FILES)


INPUT_FILES = {"case.toml", "sweep.toml", "broken.toml", "samples.csv"}


def refused(argv, capsys, field: str) -> str:
    """Run the CLI; assert exit 2 and exactly one stderr line that names `field`. Returns the line."""
    try:
        code = main([str(a) for a in argv])
    except SystemExit as done:  # a usage error, found by argparse
        code = done.code
    out, err = capsys.readouterr()
    assert code == 2, (code, err)
    assert err.count("\n") == 1 and err.endswith("\n"), err
    assert "Traceback" not in err
    assert f"error: {field}" in err, err
    assert len(err) < 250, err
    return err


def _write_case(data, path="case.toml"):
    with open(path, "wb") as f:
        tomli_w.dump(data, f)
    return path


@pytest.mark.parametrize("mutate, field", FIELD_MUTATIONS,
                         ids=[f"{i}-{field}" for i, (_, field) in enumerate(FIELD_MUTATIONS)])
def test_bad_field_in_a_case_file(workdir, capsys, mutate, field):
    data = copy.deepcopy(CASE)
    mutate(data)
    err = refused(["deck", _write_case(data)], capsys, field)
    assert SECRET not in err and "root:" not in err


@pytest.mark.parametrize("text, field, message", [
    ("0,0\n1,0.5\n2,nan\n3,1\n4,1\n", "impactor.file", "samples.csv: not a finite number in data row 3"),
    ("# t, u\n0,0\n1,inf\n2,1\n3,1\n", "impactor.file", "samples.csv: not a finite number in data row 2"),
    ("0,0\n2,0.5\n1,1\n3,1\n4,1\n", "impactor.t", "sample 3 (t = 1 ms) is not after sample 2 (t = 2 ms)"),
])
def test_a_measured_drive_s_bad_sample_is_named_by_its_row(workdir, capsys, text, field, message):
    """A measured impactor file with a nan, an inf or a time out of order: the row named, in
    plain numbers (was numpy's reprs of the values, or no row)."""
    (workdir / "samples.csv").write_text(text)
    data = copy.deepcopy(CASE) | {"impactor": {"profile": "measured", "file": "samples.csv"}}
    err = refused(["deck", _write_case(data)], capsys, field)
    assert message in err and "np." not in err


@pytest.mark.parametrize("setting, message", [
    (["chain.defect_index=5", "chain.defect_r0=1e300"],
     "chain.defect_r0: got 1e+300 mm, where the power law's stiffness -dF/dr is 0 N/mm; expected a gap where it is "
     "finite and > 0 (a chain at rest that carries waves): up to "),
    (["chain.defect_index=5", "chain.defect_r0=9223372036854775807"],
     "chain.defect_r0: got 9.22337e+18 mm; expected at most 5.004e+08 mm"),  # 1 mm * 1e-6 / 2.22e-16 / 9
    (["chain.thermal_velocity=1e300", "chain.seed=1"],
     "chain.thermal_velocity: got 1e+300 m/s; expected >= 0 and < 100 m/s (the smallest gap 1 mm / run.dt 0.01 ms"),
])
def test_extreme_chain_fields_are_refused_by_run_before_anything_is_written(workdir, capsys, setting, message):
    """The issue's repros on `run` itself (not only `deck` or --dry-run): one line with the range, exit 2."""
    data = copy.deepcopy(CASE)
    data["chain"]["r0"] = 1.0
    argv = ["run", _write_case(data), "-o", "runs/x"] + [a for s in setting for a in ("--set", s)]
    assert message in refused(argv, capsys, message.split(":")[0])


@pytest.mark.parametrize("content, field", [
    (None, "case"),  # a folder as the case file
    (b"", "chain"),  # empty: the first missing section
    (b"\xff\xfe\x00binary\x00" * 20, "case"),
    (b"[chain\nparticles = 10", "case"),
    (b"name = \n", "case"),
    (b"name = 'a'\nname = 'b'\n", "case"),
    (b"\x00" * 100, "case"),
])
def test_broken_case_file(workdir, capsys, content, field):
    path = workdir / "broken.toml"
    if content is None:
        path.mkdir()
    else:
        path.write_bytes(content)
    refused(["deck", path], capsys, field)


def test_special_files_as_the_case_file_are_not_read(workdir, capsys):
    refused(["deck", "/dev/zero"], capsys, "case")  # would never end if read
    refused(["deck", "missing.toml"], capsys, "case")


@pytest.mark.skipif(os.geteuid() == 0, reason="root reads any file")
def test_unreadable_case_file(workdir, capsys):
    path = _write_case(CASE)
    os.chmod(path, 0)
    refused(["deck", path], capsys, "case")


@pytest.mark.parametrize("args, field", [
    (["--name", LONG_NAME], "name"),
    (["--name", INJECTION], "name"),
    (["--name", ".."], "name"),
    (["--name", ""], "name"),
    (["--name", "../x"], "name"),
    (["--set", f"name={INJECTION}"], "--set"),
    (["--set", "name=.."], "name"),
    (["--set", f"name='{LONG_NAME}'"], "name"),
    (["--set", "name=\"x\\nshell touch INJECTED\""], "name"),
    (["--set", "impactor.velocity"], "--set"),
    (["--set", "a.b.c=1"], "--set"),
    (["--set", "=1"], "--set"),
    (["--set", ".velocity=1"], "--set"),
    (["--set", "impactor.velocity=1\nname='x'"], "--set"),
    (["--set", "impactor.velocity=nan"], "impactor.velocity"),
    (["--set", "impactor.velocity=inf"], "impactor.velocity"),
    (["--set", "impactor.velocity=[1,2]"], "impactor.velocity"),
    (["--set", "impactor.velocity="], "impactor.velocity"),
    (["--set", "chain.particles=1e30"], "chain.particles"),
    (["--set", "chain.particles=99999999999999999999"], "chain.particles"),
    (["--set", "chain=5"], "--set"),
    (["--set", "nonsense.key=1"], "nonsense"),
    (["--set", "impactor.file=/etc/passwd", "--set", "impactor.profile=measured"], "impactor.file"),
])
def test_bad_argument_of_a_case_command(workdir, capsys, args, field):
    refused(["deck", _write_case(CASE), *args], capsys, field)


@pytest.mark.parametrize("args, field", [
    (["--np", "0"], "--np"),
    (["--np", "abc"], "argument --np"),
    (["--runner", "ssh"], "argument --runner"),
    (["--bogus"], "unrecognized arguments"),
])
def test_bad_option_of_run(workdir, capsys, args, field):
    refused(["run", _write_case(CASE), "--runner", "lmp", *args], capsys, field)


def test_export_bad_arguments(workdir, capsys):
    refused(["export", "runs/other", "-o", "missing/dir/t.extxyz"], capsys, "--output")
    refused(["export", "runs/other", "-o", "t.extxyz", "--every", "0"], capsys, "--every")
    for folder in ("nowhere", "folder", "sentinel.txt", "runs/other"):
        refused(["export", folder, "-o", "t.extxyz"], capsys, "folder")
        refused(["summarize", folder], capsys, "folder")
    refused(["study", "nonsense"], capsys, "argument NAME")
    refused([], capsys, "the following arguments are required")


def test_output_that_is_a_file_is_refused_before_any_work(workdir, capsys):
    _write_case(CASE)
    with open("sweep.toml", "wb") as f:
        tomli_w.dump({"base": "case.toml"}, f)
    refused(["sweep", "sweep.toml", "-o", "sentinel.txt"], capsys, "--output")
    refused(["study", "s3", "--quick", "-o", "sentinel.txt"], capsys, "--output")
    refused(["run", "case.toml", "-o", "sentinel.txt"], capsys, "--output")


@pytest.mark.parametrize("folder", ["a b", "x$y", 'q"r', "c#d", "e&"])
def test_run_folder_the_deck_cannot_name_is_refused_before_anything_is_written(workdir, capsys, folder):
    """The embedded runner gives the deck its folder as a LAMMPS variable: white space, quotes,
    $, # or & would split or change the commands (--runner lmp runs in the folder instead)."""
    refused(["run", _write_case(CASE), "-o", folder, "--quiet"], capsys, "output")
    assert not (workdir / folder).exists()


def test_paths_with_control_characters_stay_one_line(workdir, capsys):
    refused(["deck", "x\ny.toml"], capsys, "case")
    refused(["deck", _write_case(CASE), "-o", "sentinel.txt"], capsys, "--output")


@pytest.mark.parametrize("sweep, field", [
    ({"base": "case.toml", "grid": {"name": [INJECTION, "b"]}}, "grid.name"),
    ({"base": "case.toml", "set": {"name": INJECTION}}, "set.name"),
    ({"base": "case.toml", "grid": {"name": [LONG_NAME]}}, "grid.name"),
    ({"base": "case.toml", "grid": {"impactor.file": ["/etc/passwd"]}, "set": {"impactor.profile": "measured"}},
     "grid.impactor.file"),
    ({"base": "/etc/hostname"}, "base"),
    ({"base": "../outside.csv"}, "base"),
    ({"base": "folder"}, "base"),
    ({"base": 5}, "base"),
    ({"base": "case.toml", "grid": [1, 2]}, "grid"),
    ({"base": "case.toml", "replicas": 0}, "replicas"),
    ({"base": "case.toml", "colour": 1}, "colour"),
])
def test_bad_sweep_file(workdir, capsys, sweep, field):
    _write_case(CASE)
    with open("sweep.toml", "wb") as f:
        tomli_w.dump(sweep, f)
    refused(["sweep", "sweep.toml", "-o", "runs/sweep", "--workers", "1", "--quiet"], capsys, field)


def test_broken_sweep_file(workdir, capsys):
    (workdir / "sweep.toml").write_bytes(b"\xff\xfe binary")
    refused(["sweep", "sweep.toml", "-o", "runs/sweep"], capsys, "sweep")
    refused(["sweep", "folder", "-o", "runs/sweep"], capsys, "sweep")


def test_a_case_file_given_for_a_sweep_is_named_so(workdir, capsys):
    _write_case(CASE)
    line = refused(["sweep", "case.toml", "-o", "runs/sweep"], capsys, "sweep")
    assert "case.toml is a case file" in line and 'base = "case.toml"' in line and not (workdir / "runs" / "sweep").exists()


POOL = [math.nan, math.inf, -math.inf, -1, 0, 0.0, 1, 2.5, 1e308, -1e308, 2**63 - 1, -(2**63), True, False, "",
        "x" * 300, "long", "a\nb", "../x", [], [math.nan], [1, 2, 3], [[1]], ["a"], {}, {"a": 1},
        datetime.date(2024, 1, 1), datetime.datetime(2024, 1, 1, 12, 0)]


def _paths(data, prefix=""):
    for key, value in data.items():
        yield f"{prefix}{key}"
        if isinstance(value, dict):
            yield from _paths(value, f"{prefix}{key}.")


@pytest.mark.parametrize("seed", range(int(os.environ.get("FUZZ_SEEDS", 6))))
def test_random_mutations_never_crash(workdir, capsys, seed):
    """Random values of every TOML type in random fields (and new ones), 1-3 at a time: each
    case is accepted (exit 0) or refused with one line and exit 2; nothing else."""
    rng = np.random.default_rng(seed)
    full = case_to_dict(make_case(particles=10, velocity=1.0, duration=1.0,
                                  friction={"mu": 0.2}, output={"fine": [2, 3]}))
    paths = list(_paths(full)) + ["chain.extra", "table.extra", "second_neighbour.K", "impactor.file"]
    for trial in range(40):
        data = copy.deepcopy(full)
        for _ in range(rng.integers(1, 4)):
            _set(paths[rng.integers(len(paths))], POOL[rng.integers(len(POOL))])(data)
        path = _write_case(data)
        try:
            with warnings.catch_warnings():  # a warning would be a second line on stderr
                warnings.simplefilter("error")
                code = main(["deck", path, "-o", f"runs/t{seed}-{trial}"])
        except Exception as err:  # noqa: BLE001 - the point: no exception escapes main
            pytest.fail(f"{type(err).__name__}: {err} for {data}")
        err = capsys.readouterr().err
        assert code in (0, 2), (code, err, data)
        assert code == 0 or (err.count("\n") == 1 and "Traceback" not in err), (err, data)
        shutil.rmtree(f"runs/t{seed}-{trial}", ignore_errors=True)


def test_a_flag_or_folder_is_a_usage_error_and_a_case_field_a_config_error(tmp_path):
    """UsageError names a flag, folder or argument; a ConfigError raised as such names a case
    field; both are bad input (a UsageError is a ConfigError: the CLI's exit 2). Every raise
    in the package that names a flag ("-o", "--np") or the output folder is a UsageError."""
    import ast
    from pathlib import Path

    from pylmp_lattice.errors import ConfigError, UsageError
    from pylmp_lattice.preflight import check
    from pylmp_lattice.run_folder import execute

    case = make_case(particles=10, duration=1.0)
    with pytest.raises(UsageError, match=r"^--np: got 0; expected an integer >= 1$"):
        check(case, tmp_path, nprocs=0)
    with pytest.raises(UsageError, match=r"^--np: got 2; several ranks need --runner lmp$"):
        execute(case, tmp_path / "run", nprocs=2)
    with pytest.raises(ConfigError, match=r"^chain.mass: ") as info:
        make_case(chain={"mass": -1.0})
    assert type(info.value) is ConfigError and issubclass(UsageError, ConfigError)

    package = Path(__file__).resolve().parents[1] / "pylmp_lattice"
    wrong = []
    for path in package.rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text())):
            if (isinstance(node, ast.Call) and getattr(node.func, "id", None) == "ConfigError" and node.args
                    and isinstance(node.args[0], ast.Constant) and isinstance(node.args[0].value, str)
                    and (node.args[0].value.startswith("-") or node.args[0].value in ("output", "folder"))):
                wrong.append(f"{path.relative_to(package)}:{node.lineno}")
    assert wrong == [], f"ConfigError naming a flag or folder (raise UsageError): {wrong}"
