"""The run folder: one home for its files, safe to overwrite, never destroyed by reading,
summarized whatever way the run ended, and runs that leave their process as they found it."""

from __future__ import annotations

import ast
import dataclasses
import json
import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest
import tomli_w

from pylmp_lattice.case import case_id, case_to_dict
from pylmp_lattice.cli import main
from pylmp_lattice.errors import ConfigError, ContactError
from pylmp_lattice.run_folder import RunFolder, execute, execute_batch, run_case, simulate, write_folder
from pylmp_lattice.run_folder.cases import read_cases, replicas_text
from pylmp_lattice.formats import layout
from pylmp_lattice.run_folder import marker
from pylmp_lattice.serialize import dumps

from conftest import held_elsewhere, make_case
from test_architecture import import_nodes

ROOT = Path(__file__).parent.parent
PACKAGE = ROOT / "pylmp_lattice"
INPUTS = ROOT / "inputs"
CLI = [sys.executable, "-m", "pylmp_lattice.cli"]
lammps = pytest.mark.lammps


def write_case(path: Path, case) -> Path:
    path.write_bytes(tomli_w.dumps(case_to_dict(case)).encode())
    return path


def sentinels(root: Path) -> list[Path]:
    """Files a run must never touch: one in the working directory, one in runs/other."""
    (root / "runs" / "other").mkdir(parents=True, exist_ok=True)
    files = [root / "SENTINEL", root / "runs" / "other" / "SENTINEL"]
    for f in files:
        f.write_text("keep me")
    return files


def numbers(tree, prefix=""):
    """The numeric leaves of a summary, keyed by their path."""
    if isinstance(tree, dict):
        for k, v in tree.items():
            yield from numbers(v, f"{prefix}.{k}")
    elif isinstance(tree, list):
        for i, v in enumerate(tree):
            yield from numbers(v, f"{prefix}[{i}]")
    elif isinstance(tree, (int, float)) and not isinstance(tree, bool):
        yield prefix, tree


# ---- one home for the layout, no import cycles


def _imports(path: Path) -> set[str]:
    """Modules of the package that a module imports, at any depth of its code."""
    module = ".".join(path.relative_to(ROOT).with_suffix("").parts).removesuffix(".__init__")
    package = module if path.name == "__init__.py" else module.rsplit(".", 1)[0]
    found = set()
    for node in import_nodes(path.read_text()):  # parsed once per session (test_architecture)
        if isinstance(node, ast.ImportFrom):
            base = package.split(".")
            base = base[: len(base) - node.level + 1] if node.level else []
            target = ".".join(base + ([node.module] if node.module else []))
            for alias in node.names:
                candidate = f"{target}.{alias.name}"
                found.add(candidate if _exists(candidate) else target)
        elif isinstance(node, ast.Import):
            found.update(a.name for a in node.names)
    return {m for m in found if m.startswith("pylmp_lattice") and _exists(m) and m != module}


def _exists(module: str) -> bool:
    path = ROOT.joinpath(*module.split("."))
    return path.with_suffix(".py").is_file() or (path / "__init__.py").is_file()


def test_the_package_has_no_import_cycle():
    graph = _import_graph()
    # a package's __init__ is not a dependency of its submodules' own code: follow modules only
    state: dict[str, int] = {}

    def visit(node, path):
        state[node] = 1
        for nxt in sorted(graph.get(node, ())):
            if state.get(nxt) == 1:
                raise AssertionError("import cycle: " + " -> ".join(path[path.index(nxt):] + [nxt]))
            if nxt not in state:
                visit(nxt, path + [nxt])
        state[node] = 2

    for node in sorted(graph):
        if node not in state:
            visit(node, [node])


def _import_graph() -> dict[str, set[str]]:
    return {".".join(p.relative_to(ROOT).with_suffix("").parts).removesuffix(".__init__"): _imports(p)
            for p in PACKAGE.rglob("*.py")}


# Modules the run path calls for values, as often as it needs one: the case and the laws it is
# made of, pure functions of values (units, the deck's text, preflight's size estimates, the summary's dict,
# the measures, the figure, the progress bar's callback, the log lines' form) and the formats of
# single files (binary and text dumps, H5MD and its PSF topology, the front record, run.json and
# the lock). They call only each other, never a stage (asserted below), as numpy or h5py would. Every other module is a
# stage of the run and is entered once: a new module on the path is a stage until listed here.
HELPERS = {"case", "lazy", "forcelaw", "impactor", "exact", "units", "errors", "log_lines", "serialize", "columnar",
           "trajectory", "ranks", "numbering", "table", "deck", "case_measures", "summary", "plots", "progress",
           "measures", "formats", "run_folder", "run_folder.marker", "run_folder.cases",
           "file_lock", "preflight.estimate", "overhead"}


def _helper(module: str) -> bool:
    name = module.removeprefix("pylmp_lattice.")
    return name in HELPERS or name.split(".")[0] in ("case", "measures", "formats", "deck")


def trace_module_entries(argv: list[str]) -> tuple[list[tuple[str, str, str]], list[str]]:
    """Run `main(argv)` under sys.setprofile (this thread; the embedded runner's LAMMPS thread
    runs inside one call to runner.run_deck) and return its entries, (caller module, callee
    module, function) for each call into a package module from another one, and its stays in
    the stages (helper frames count as their caller's).

    Every package module is imported before (a lazy import would run module code: frames named
    '<module>' are ignored anyway); a generator or context manager resumed is the same call."""
    import importlib
    import inspect
    import pkgutil

    import pylmp_lattice

    for info in pkgutil.walk_packages(pylmp_lattice.__path__, "pylmp_lattice."):
        if "plugin." not in info.name:  # the plugin's compiled module is not Python
            importlib.import_module(info.name)
    entries, stays, started = [], [], set()

    def package(frame):
        name = frame.f_globals.get("__name__", "")
        return name if name.startswith("pylmp_lattice") and frame.f_code.co_name != "<module>" else None

    def outer(frame, stage_only=False):
        while frame is not None and not ((m := package(frame)) and not (stage_only and _helper(m))):
            frame = frame.f_back
        return frame

    def profile(frame, event, arg):
        callee = package(frame) if event in ("call", "return") else None
        if callee is None:
            return
        if event == "call" and frame not in started:
            if frame.f_code.co_flags & inspect.CO_GENERATOR:
                started.add(frame)
            caller = outer(frame.f_back)
            if caller is None or package(caller) != callee:
                entries.append((caller and package(caller), callee, frame.f_code.co_name))
        stage = outer(frame if event == "call" else frame.f_back, stage_only=True)
        if stage is not None and (not stays or stays[-1] != package(stage)):
            stays.append(package(stage))

    sys.setprofile(profile)
    try:
        assert main(argv) == 0
    finally:
        sys.setprofile(None)
    return entries, stays


@lammps
def test_the_cli_run_path_enters_each_stage_once_and_only_calls_down(tmp_path, monkeypatch):
    """From `pylmp-lattice run` to its summary: each stage (cli, run_folder.execution,
    preflight.checks, run_folder.claim, run_folder.write, runner, run_folder.convert,
    run_folder.folder) is entered once, each from the road (run_folder.execution) alone,
    helpers call only helpers, and no call climbs (the callee never imports the caller). The
    folder is checked once: its place, its lock and whether it holds a run, each looked at
    by the claim alone. On befcb15 the path entered run_folder.folder 5 times from execution
    (create, running, record, convert, summarize) and runner twice; on 88ad055 it climbed back
    7 times, e.g. from bindump to simulation; on caa535b it checked the place three times
    (preflight, layout.make_place, write.check_target)."""
    monkeypatch.chdir(tmp_path)
    case = write_case(tmp_path / "case.toml", make_case(particles=40, duration=20.0))
    entries, stays = trace_module_entries(["run", str(case), "-o", "r", "--quiet"])
    short = lambda m: m and m.removeprefix("pylmp_lattice.")  # noqa: E731
    counts: dict[str, int] = {}
    for _, callee, _ in entries:
        counts[short(callee)] = counts.get(short(callee), 0) + 1
    report = (f"stays in the stages: {' -> '.join(map(short, stays))}\nentries: {counts}\n"
              + "\n".join(f"  {short(a)} -> {short(b)}.{f}" for a, b, f in entries if not _helper(b)))
    stages = {m: k for m, k in counts.items() if not _helper(m)}
    road = ["preflight.checks", "run_folder.claim", "run_folder.write", "runner", "run_folder.convert", "run_folder.folder"]
    assert stages == dict.fromkeys(["cli", "run_folder.execution", *road], 1), report
    callers = {short(b): short(a) for a, b, _ in entries if not _helper(b)}
    assert callers == {"cli": None, "run_folder.execution": "cli"} | dict.fromkeys(road, "run_folder.execution"), report
    looks = [(short(a), f) for a, b, f in entries
             if (short(b), f) in (("formats.layout", "check_place"), ("run_folder.marker", "claimed"),
                                  ("run_folder.marker", "is_run"))]
    assert looks == [("run_folder.claim", "check_place"), ("run_folder.claim", "claimed"),
                     ("run_folder.claim", "is_run")], report
    upward = [(a, b, f) for a, b, f in entries if a and _helper(a) and not _helper(b)]
    assert not upward, report
    graph = _import_graph()

    def below(module, seen=None):
        seen = set() if seen is None else seen
        for nxt in graph.get(module, ()):
            if nxt not in seen:
                seen.add(nxt)
                below(nxt, seen)
        return seen

    climbs = [(a, b, f) for a, b, f in entries if a and a in below(b)]
    assert not climbs, (climbs, report)
    execution = "pylmp_lattice.run_folder.execution"
    assert stays == ["pylmp_lattice.cli", execution,
                     *[x for stage in road for x in (f"pylmp_lattice.{stage}", execution)], "pylmp_lattice.cli"], report


def test_run_file_names_are_written_in_the_layout_module_only():
    names = {layout.SUMMARY, layout.CASE, layout.TRAJ_BIN, layout.FINE_BIN, layout.FRONT_BIN, layout.H5MD,
             layout.LOG, layout.DECK, layout.DATA, layout.TABLE, layout.MARKER, layout.FIGURE}
    offenders = []
    for path in PACKAGE.rglob("*.py"):
        if path == PACKAGE / "formats" / "layout.py":
            continue
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Constant) and isinstance(node.value, str) and node.value in names:
                offenders.append(f"{path.relative_to(ROOT)}:{node.lineno} {node.value!r}")
    assert not offenders, offenders


# ---- a batch of chains is a run folder too


def _thermal(seeds, **chain):
    return [make_case(particles=21, duration=10.0, interval=0.5, output={"format": "none"},
                      chain={"thermal_velocity": 0.02, "seed": s, **chain}) for s in seeds]


def test_a_batch_folder_holds_its_cases(tmp_path):
    """replicas.toml gives back each chain's case (its identity), when they differ in their
    seed, a field replica 0 sets and another does not, their name or their per-magnet masses;
    case.toml a single run's."""
    masses = make_case(particles=21, chain={"mass": tuple(1.0 + 0.01 * k for k in range(21))})
    at_rest = make_case(particles=21, duration=10.0, interval=0.5, output={"format": "none"})
    cases = [*_thermal([1, 2]), dataclasses.replace(at_rest, name="other")]
    (tmp_path / layout.REPLICAS).write_bytes(replicas_text(cases))
    assert [case_id(c) for c in read_cases(tmp_path)] == [case_id(c) for c in cases]
    heavier = [make_case(particles=21, chain={"mass": tuple(1.0 + 0.01 * k * r for k in range(21))}) for r in (1, 2)]
    (tmp_path / layout.REPLICAS).write_bytes(replicas_text(heavier))  # a column of per-magnet masses
    assert [case_id(c) for c in read_cases(tmp_path)] == [case_id(c) for c in heavier]
    many = replicas_text(_thermal(range(1, 301)))
    assert len(many) < len(replicas_text(_thermal([1]))) + 20 * 300  # a seed a chain, not a table
    write_folder(masses, tmp_path / "one")
    assert [case_id(c) for c in read_cases(tmp_path / "one")] == [case_id(masses)]
    with pytest.raises(ConfigError, match="expected a run folder"):
        read_cases(tmp_path / "one" / "nothing")


@lammps
@pytest.mark.parametrize("chains", [1, 3])
def test_a_batch_folder_and_a_single_run_folder_pass_the_same_checks(tmp_path, monkeypatch, chains):
    """One road: a single run (`execute`) and a batch of three chains (`execute_batch`) pass
    through the same records (running, finished), and their folders read the same
    through RunFolder: a run of this package, finished, its cases back, the deck as written,
    a front record; an overwrite is refused without --overwrite and replaces it with."""
    cases = _thermal(range(1, chains + 1))
    folder = tmp_path / "f"

    def road(cases, overwrite=False):
        return execute(cases[0], folder, overwrite=overwrite) if chains == 1 else execute_batch(cases, folder, overwrite=overwrite)

    states = []
    record = marker.record
    monkeypatch.setattr(marker, "record", lambda path, state, **details: (states.append(state),
                                                                          record(path, state, **details)))
    road(cases)
    assert states == ["running", "done"]
    run = RunFolder(folder)
    assert marker.is_run(folder) and run.status == "done" and not marker.locked(folder)
    assert [case_id(c) for c in run.cases] == [case_id(c) for c in cases]
    assert run.deck_changes() == {}
    written = marker.read(folder)
    assert written[marker.DECK_HASH] == marker.deck_hash((folder / layout.DECK).read_text())
    assert written.get(marker.CHAINS, 1) == chains
    assert (folder / layout.FRONT_BIN).stat().st_size > 0 and "Total wall time" in marker.log_text(folder)
    if chains == 1:
        assert run.case == cases[0] and run.front() is not None
    else:
        with pytest.raises(ConfigError, match="holds a batch of 3 chains"):
            run.case
    with pytest.raises(ConfigError, match="already holds a run"):
        road(cases)
    road(cases[::-1], overwrite=True)
    assert [case_id(c) for c in RunFolder(folder).cases] == [case_id(c) for c in cases[::-1]]
    assert RunFolder(folder).status == "done"


# ---- nothing outside the folder is written or deleted


@pytest.mark.parametrize("target", [".", "..", "runs/.."])
def test_overwrite_never_removes_the_working_directory_or_a_parent(tmp_path, monkeypatch, capsys, target):
    monkeypatch.chdir(tmp_path)
    files = sentinels(tmp_path)
    case = write_case(tmp_path / "case.toml", make_case(particles=10, duration=1.0))
    assert main(["deck", str(case), "-o", target, "--overwrite"]) == 2
    line, = capsys.readouterr().err.splitlines()
    assert line.startswith("pylmp-lattice: error: output: got") and "working directory" in line
    assert all(f.read_text() == "keep me" for f in files) and case.exists()


def test_overwrite_replaces_a_run_folder_and_nothing_outside_it(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    files = sentinels(tmp_path)
    case = write_case(tmp_path / "case.toml", make_case(particles=10, duration=1.0))
    assert main(["deck", str(case), "--name", "x"]) == 0
    (tmp_path / "runs" / "x" / layout.SUMMARY).write_text("{}")  # a stale summary must go
    assert main(["deck", str(case), "--name", "x"]) == 2  # a run is there: refused without --overwrite
    assert main(["deck", str(case), "--name", "x", "--overwrite"]) == 0
    assert not (tmp_path / "runs" / "x" / layout.SUMMARY).exists() and (tmp_path / "runs" / "x" / layout.DECK).exists()
    assert main(["deck", str(case), "-o", "runs", "--overwrite"]) == 2
    assert "runs/" in capsys.readouterr().err.splitlines()[-1]
    assert all(f.read_text() == "keep me" for f in files)


def test_a_folder_with_a_runs_file_names_but_no_run_is_refused(tmp_path, monkeypatch, capsys):
    """`run -o DIR` used to replace same-named files of a folder that holds no run."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "mine").mkdir()
    (tmp_path / "mine" / "chain.data").write_text("a user's own data file")
    case = write_case(tmp_path / "case.toml", make_case(particles=10, duration=1.0))
    for command in ("deck", "run"):
        assert main([command, str(case), "-o", "mine", "--overwrite"]) == 2
        line, = capsys.readouterr().err.splitlines()
        assert "output: mine holds chain.data but no run of this package" in line
    assert (tmp_path / "mine" / "chain.data").read_text() == "a user's own data file"


def test_overwrite_removes_the_runs_files_and_never_the_users(tmp_path, monkeypatch):
    """`run -o DIR --overwrite` twice used to delete DIR whole (shutil.rmtree): the user's files
    beside the run, their folders, and the case file being read."""
    monkeypatch.chdir(tmp_path)
    proj = tmp_path / "proj"
    (proj / "notes").mkdir(parents=True)
    (proj / "notes" / "notes.txt").write_text("mine")
    (proj / "thesis.tex").write_text("precious")
    case = write_case(proj / "mycase.toml", make_case(particles=10, duration=1.0))  # read from DIR itself
    assert main(["deck", str(case), "-o", "proj", "--overwrite"]) == 0  # no run there yet: written beside
    for stale in (layout.SUMMARY, layout.FIGURE, layout.MARKER + ".tmp", layout.H5MD + ".part"):
        (proj / stale).write_text("of the earlier run")
    assert main(["deck", str(case), "-o", "proj", "--overwrite"]) == 0
    left = {p.relative_to(proj).as_posix() for p in proj.rglob("*")}
    assert left == {"notes", "notes/notes.txt", "thesis.tex", "mycase.toml", layout.DECK, layout.DATA, layout.TABLE,
                    layout.CASE, layout.MARKER}
    assert (proj / "thesis.tex").read_text() == "precious" and (proj / "notes" / "notes.txt").read_text() == "mine"
    # a folder where a run writes a file: refused before anything is removed (it stopped half-way)
    (proj / layout.SUMMARY).mkdir()
    assert main(["deck", str(case), "-o", "proj", "--overwrite"]) == 2
    assert (proj / layout.CASE).is_file() and (proj / layout.DECK).is_file()


@lammps
def test_a_study_run_again_keeps_the_users_notes_in_its_run_folder(tmp_path):
    """Studies run their cases with overwrite=True (as `study NAME -o DIR` does): a note the
    user left in a run folder survives, and the run's own files are the new run's."""
    folder = tmp_path / "fig" / "case"
    run_case(make_case(particles=10, duration=1.0), folder, figure=False)
    (folder / "notes.txt").write_text("mine")
    (folder / layout.FIGURE).write_text("stale")  # the second run draws none: the old one must go
    run_case(make_case(particles=10, duration=2.0), folder, figure=False, overwrite=True)
    assert (folder / "notes.txt").read_text() == "mine" and not (folder / layout.FIGURE).exists()
    assert RunFolder(folder).case.run.duration == 2.0 and RunFolder(folder).status == "done"


# ---- summarize any folder


@lammps
def test_deck_run_by_hand_then_summarize_equals_the_cli_run(tmp_path):
    """pylmp-lattice deck CASE -o D && (cd D && lmp -in in.lattice) && pylmp-lattice summarize D
    gives the numbers of pylmp-lattice run CASE, to 1e-12 relative."""
    case = write_case(tmp_path / "case.toml", make_case(particles=60, duration=30.0, output={"fine": [2, 20]}))
    assert main(["run", str(case), "-o", str(tmp_path / "cli"), "--quiet"]) == 0
    assert main(["deck", str(case), "-o", str(tmp_path / "hand")]) == 0
    lmp = Path(sys.executable).parent / "lmp"
    subprocess.run([str(lmp), "-in", layout.DECK, "-screen", "none"], cwd=tmp_path / "hand", check=True)
    assert RunFolder(tmp_path / "hand").status == "done"
    assert main(["summarize", str(tmp_path / "hand")]) == 0
    cli, hand = (json.loads((tmp_path / d / layout.SUMMARY).read_text()) for d in ("cli", "hand"))
    a = {k: v for k, v in numbers(cli) if "wall_time" not in k}
    b = {k: v for k, v in numbers(hand) if "wall_time" not in k}
    assert a.keys() == b.keys() and len(a) > 10
    for key in a:
        assert b[key] == pytest.approx(a[key], rel=1e-12, abs=0), key
    assert (tmp_path / "hand" / layout.FIGURE).exists()
    # the summary names the trajectory file that stays: the dumps became traj.h5md first
    assert hand["files"]["trajectory"] == cli["files"]["trajectory"] == layout.H5MD
    assert not (tmp_path / "hand" / layout.TRAJ_BIN).exists()


@lammps
def test_reading_while_lmp_writes_loses_nothing(tmp_path):
    """A folder read while `lmp -in` runs in it is read as it stands (nothing converted or
    deleted); read again after the run, it has every frame."""
    case = write_case(tmp_path / "case.toml", make_case(particles=2000, duration=400.0, interval=1.0))
    assert main(["deck", str(case), "-o", str(tmp_path / "d")]) == 0
    folder = tmp_path / "d"
    lmp = subprocess.Popen([str(Path(sys.executable).parent / "lmp"), "-in", layout.DECK, "-screen", "none"],
                           cwd=folder)
    try:
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline:
            dump = folder / layout.TRAJ_BIN
            if dump.exists() and dump.stat().st_size > 0 and lmp.poll() is None:
                break
            time.sleep(0.02)
        during = RunFolder(folder)
        assert during.status == "running" and lmp.poll() is None, "lmp finished too soon for this test"
        early = during.trajectory()
        # summarizing would write partial numbers: refused, nothing written (it used to write them)
        assert main(["summarize", str(folder)]) == 2 and lmp.poll() is None, "lmp finished too soon for this test"
        assert not (folder / layout.SUMMARY).exists() and not (folder / layout.FIGURE).exists()
        assert (folder / layout.TRAJ_BIN).exists() and not (folder / layout.H5MD).exists()
    finally:
        assert lmp.wait(timeout=120) == 0
    after = RunFolder(folder).trajectory()
    assert len(after.t) == 401 and 1 <= len(early.t) <= len(after.t)
    np.testing.assert_array_equal(after.v[: len(early.t)], early.v)
    assert (folder / layout.H5MD).exists() and not (folder / layout.TRAJ_BIN).exists()


def test_summarize_refuses_a_folder_a_runner_still_writes(tmp_path, capsys):
    """The CLI and RunFolder.summarize refuse while a runner of this package holds the lock, or
    while a process writes a hand-run log that has no end yet; one line, exit 2, nothing written.
    A log that only changed lately (issue 27: "waits or says how long") is refused saying when."""
    case = write_case(tmp_path / "case.toml", make_case(particles=10, duration=1.0))
    folder = tmp_path / "d"
    assert main(["deck", str(case), "-o", str(folder)]) == 0
    capsys.readouterr()
    expected = f"pylmp-lattice: error: {folder}: still being written by LAMMPS; summarize it when the run ends"
    with held_elsewhere(folder / layout.LOCK):  # a runner in another process
        assert main(["summarize", str(folder)]) == 2
        assert capsys.readouterr().err.splitlines() == [expected]
        with pytest.raises(ConfigError, match="still being written by LAMMPS"):
            RunFolder(folder).summarize()
    marker.record(folder, marker.WRITTEN)  # as `deck` left it; then `lmp -in` by hand, not ended yet
    with open(folder / layout.LOG, "w") as writer:  # a process (here this one) writes the log
        writer.write("LAMMPS (22 Jul 2025)\nStep Time\n0 0\n")
        writer.flush()
        assert main(["summarize", str(folder)]) == 2
        assert capsys.readouterr().err.splitlines() == [expected]
        assert not (folder / layout.SUMMARY).exists() and not (folder / layout.FIGURE).exists()
    assert RunFolder(folder).status == "running"  # just changed: a writer /proc cannot see may go on
    # a plain `lmp -in in.lattice` just stopped: refused, saying how long until it counts as ended
    then = time.time() - 4.2
    os.utime(folder / layout.LOG, (then, then))
    assert main(["summarize", str(folder)]) == 2
    assert capsys.readouterr().err.splitlines() == [
        f"pylmp-lattice: error: {folder}: still being written by LAMMPS; its {layout.LOG} changed 4 s ago; "
        f"if no LAMMPS writes it any more, summarize again in {marker.QUIET - 4:.0f} s"]
    then = time.time() - marker.QUIET - 1
    os.utime(folder / layout.LOG, (then, then))
    assert RunFolder(folder).status == "interrupted"  # no process writes it any more


@lammps
def test_a_failed_figure_keeps_the_summary(tmp_path, monkeypatch, caplog):
    def broken(self):
        raise ValueError("no figure today")

    monkeypatch.setattr(RunFolder, "figure", broken)
    summary = run_case(make_case(particles=40, duration=30.0), tmp_path / "r")
    assert json.loads((tmp_path / "r" / layout.SUMMARY).read_text()) == json.loads(dumps(summary))
    assert summary["shock_velocity_plateau_m_per_s"]["mean"] > 1.6
    assert "figure" not in summary["files"] and "no figure (ValueError: no figure today)" in caplog.text


@lammps
def test_a_run_shorter_than_its_output_interval_draws_its_figure_without_profiles(tmp_path, caplog, monkeypatch):
    """One frame of trajectory (run.duration 0.05 ms < output_interval 0.1 ms): the figure is drawn
    with the front record's panels and says why the profiles are missing (it failed with
    "ValueError: t: got shape (1,)" before)."""
    from pylmp_lattice import plots

    said = []
    draw = plots.shock_figure
    monkeypatch.setattr(plots, "shock_figure", lambda *a, **k: (said.append(k.get("missing")), draw(*a, **k))[1])
    summary = run_case(make_case(particles=10, duration=0.05, interval=0.1), tmp_path / "r")
    assert summary["files"]["figure"] == layout.FIGURE and (tmp_path / "r" / layout.FIGURE).stat().st_size > 10_000
    assert said == ["one frame written: no profile to draw\n(run.duration 0.05 ms < run.output_interval 0.1 ms)"]
    assert "no figure" not in caplog.text
    said.clear()  # a run that stops (a contact at 68.56 ms) before its second frame at 80 ms: so it says
    with pytest.raises(ContactError):
        run_case(make_case(particles=21, velocity=2.0, duration=100.0, interval=80.0), tmp_path / "c")
    assert said == ["one frame written: no profile to draw\n(the run stopped before 80 ms)"]


@lammps
def test_a_run_stopped_by_contact_is_summarized_and_says_so(tmp_path, capsys):
    """Driven into its held end, a short chain touches: the run still writes summary.json (up to
    the contact, saying where) and its figure, prints that summary on stdout as a run does, and
    exits 1 with one line that names `summarize`; a later `summarize` gives the same numbers
    (issue 27, item 8)."""
    case = write_case(tmp_path / "case.toml", make_case(particles=21, velocity=2.0, duration=100.0))
    folder = tmp_path / "c"
    assert main(["run", str(case), "-o", str(folder), "--quiet"]) == 1
    out, err = capsys.readouterr()
    line, = err.splitlines()
    assert line.startswith("pylmp-lattice: error: magnets 19 and 20 touched"), err
    assert line.endswith(f"measured up to the contact in summary.json; redo it with `pylmp-lattice summarize {folder}`)")
    assert (folder / layout.FIGURE).stat().st_size > 10_000
    written = json.loads((folder / layout.SUMMARY).read_text())
    assert json.loads(out) == written
    assert written["status"] == "contact" and written["files"]["figure"] == layout.FIGURE
    stop = written["stopped"]
    assert stop["reason"] == "contact" and stop["magnets"] == [19, 20]
    assert stop["time_ms"] == pytest.approx(68.56, abs=1e-9) and stop["gap_mm"] < 0
    assert main(["summarize", str(folder), "--no-figure"]) == 0
    again = json.loads((folder / layout.SUMMARY).read_text())
    assert again.pop("wall_time_s") == written.pop("wall_time_s") and again == written


@lammps
@pytest.mark.slow
def test_ctrl_c_returns_within_2_s_and_the_folder_summarizes_up_to_the_stop(tmp_path):
    """A 6000 ms main case (4000 magnets): SIGINT once it writes; exit 130 within 2 s, then
    `summarize` reads every frame written up to the stop (converted by that first read)."""
    folder = tmp_path / "run"
    proc = subprocess.Popen(CLI + ["run", str(INPUTS / "paper_long_lattice.toml"), "-o", str(folder),
                                   "--set", "run.duration=6000", "--yes"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline:
        dump = folder / layout.TRAJ_BIN
        if dump.exists() and dump.stat().st_size > 10_000_000:
            break
        time.sleep(0.05)
    sent = time.monotonic()
    proc.send_signal(signal.SIGINT)
    out, err = proc.communicate(timeout=60)
    assert time.monotonic() - sent < 2.0, err
    assert proc.returncode == 130 and out == "" and "Traceback" not in err
    run = RunFolder(folder)
    assert run.status == "interrupted" and (folder / layout.TRAJ_BIN).exists()
    done = subprocess.run(CLI + ["summarize", str(folder), "--no-figure"], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    summary = json.loads(done.stdout)
    assert summary["stopped"]["reason"] == "interrupted"
    t_stop = summary["stopped"]["time_ms"]
    traj = RunFolder(folder).trajectory()
    assert 0 < traj.t[-1] <= t_stop + 1e-9 < traj.t[-1] + 1.0 + 2e-9  # frames 1 ms apart; summary.json's 15 digits
    assert (folder / layout.H5MD).exists() and not (folder / layout.TRAJ_BIN).exists()


# ---- the process is left as it was


@lammps
def test_a_run_in_a_thread_leaves_the_process_as_it_found_it(tmp_path, monkeypatch, capfd):
    """While a run goes on in a thread, the main thread's cwd, relative files and prints work."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "work").mkdir()
    monkeypatch.chdir(tmp_path / "work")
    here = Path.cwd()
    errors = []

    def job():
        try:
            run_case(make_case(particles=400, duration=300.0), tmp_path / "threaded", figure=False)
        except Exception as err:  # pragma: no cover - reported below
            errors.append(err)

    worker = threading.Thread(target=job)
    worker.start()
    written = 0
    while worker.is_alive():
        assert Path.cwd() == here
        with open("relative.txt", "a") as f:
            f.write("x")
        print("main thread line", flush=True)
        os.write(1, b"raw fd 1 line\n")
        written += 1
        time.sleep(0.01)
    worker.join()
    assert not errors and written > 3
    assert (here / "relative.txt").read_text() == "x" * written
    assert not (tmp_path / "threaded" / "relative.txt").exists()
    out, err = capfd.readouterr()
    assert out.count("main thread line") == written and out.count("raw fd 1 line") == written
    assert "raw fd 1 line" not in err
    assert (tmp_path / "threaded" / layout.SUMMARY).exists()


@lammps
@pytest.mark.slow
def test_lmp_ranks_die_with_a_killed_parent(tmp_path):
    """`--runner lmp --np 2`: SIGKILL the parent; mpiexec and its ranks stop within 5 s.

    A long run (about 2 min of engine time) that writes little: at 1 frame/ms it would need
    8.2 GB, which a CI disk shared with the rest of the suite did not always have (the run was
    refused before it started, and the test saw no children)."""
    folder = tmp_path / "run"
    proc = subprocess.Popen(CLI + ["run", str(INPUTS / "paper_long_lattice.toml"), "-o", str(folder),
                                   "--set", "run.duration=20000", "--set", "run.output_interval=1000",
                                   "--runner", "lmp", "--np", "2", "--yes"],
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 60
    while not (folder / layout.LOG).exists() and time.monotonic() < deadline and proc.poll() is None:
        time.sleep(0.05)
    time.sleep(1.0)
    children = _descendants(proc.pid)
    if proc.poll() is not None:
        pytest.fail(f"the run ended (exit {proc.returncode}) before it could be killed: {proc.stderr.read()}")
    assert any("mpiexec" in c or "lmp" in c for c in children.values()), children
    proc.kill()
    proc.wait()
    proc.stderr.close()
    deadline = time.monotonic() + 5
    while time.monotonic() < deadline and any(_alive(p) for p in children):
        time.sleep(0.1)
    assert not [cmd for p, cmd in children.items() if _alive(p)]


def _descendants(pid: int) -> dict[int, str]:
    """Every process below `pid`: {pid: command line}."""
    rows = {}
    for line in subprocess.run(["ps", "-eo", "pid=,ppid=,args="], capture_output=True, text=True).stdout.splitlines():
        p, pp, *cmd = line.split(None, 2)
        rows[int(p)] = (int(pp), cmd[0] if cmd else "")
    found, frontier = {}, {pid}
    while frontier:
        frontier = {p for p, (pp, _) in rows.items() if pp in frontier and p not in found}
        found.update({p: rows[p][1] for p in frontier})
    return found


def _alive(pid: int) -> bool:
    try:
        with open(f"/proc/{pid}/stat") as f:
            return f.read().split(")")[-1].split()[0] != "Z"
    except FileNotFoundError:
        return False


@pytest.mark.lammps
def test_a_run_s_folder_is_its_own_until_its_summary_is_written(tmp_path, monkeypatch):
    """After LAMMPS ends, the runner converts the dumps and writes the summary and figure with
    the folder's lock still held: another process's overwrite (here `deck --overwrite`) is
    refused, exit 2, and its `summarize` too, instead of deleting the dumps being converted or
    writing the same traj.h5md.part (which crashed the run)."""
    from pylmp_lattice.run_folder import execution

    case = make_case(particles=10, duration=2.0)
    toml = write_case(tmp_path / "case.toml", case)
    others = []
    original = execution.summarize_folder

    def summarize_while_others_try(path, **kwargs):
        assert (path / layout.H5MD).is_file() and not (path / layout.TRAJ_BIN).exists()  # converted under the lock
        for argv in (["deck", str(toml), "-o", str(path), "--overwrite"], ["summarize", str(path)]):
            done = subprocess.run([sys.executable, "-m", "pylmp_lattice.cli", *argv], capture_output=True, text=True)
            others.append((argv[0], done.returncode, done.stderr.strip()))
        return original(path, **kwargs)

    monkeypatch.setattr(execution, "summarize_folder", summarize_while_others_try)
    summary = run_case(case, tmp_path / "run", figure=False)
    assert [(name, code) for name, code, _ in others] == [("deck", 2), ("summarize", 2)], others
    assert all("still being written" in err for _, _, err in others)
    assert summary["particles"] == 10 and json.loads((tmp_path / "run" / layout.SUMMARY).read_text())["status"] == "done"
    assert not (tmp_path / "run" / layout.LOCK).exists()


def test_a_run_json_of_0_1_0_that_says_finished_reads_as_done(tmp_path):
    """One word for a run that ended normally, "done" (run folders and sweep members alike);
    run.json written before it said "finished", and such a folder still reads as done."""
    RunFolder.create(make_case(particles=10, duration=1.0), tmp_path)
    marker.record(tmp_path, marker.OLD_DONE)
    assert RunFolder(tmp_path).status == marker.DONE == "done"
    marker.record(tmp_path, marker.CONTACT)
    assert RunFolder(tmp_path).status == "contact"


@pytest.mark.parametrize("error, state", [(ValueError("a bug in an engine"), "failed"),
                                          (KeyboardInterrupt(), "interrupted")])
def test_an_engine_s_own_error_is_failed_and_a_signal_interrupted(tmp_path, error, state):
    """run.json after an engine raised: an error of its own (not Interrupted, a contact or a LAMMPS
    error) is "failed" with its line, never "interrupted" (which a sweep's resume redoes)."""
    from pylmp_lattice.run_folder import execute

    class Broken:
        nprocs = 1

        def check(self, path):
            pass

        def __call__(self, path, on_step=None):
            raise error

    with pytest.raises(type(error)):
        execute(make_case(particles=10, duration=1.0), tmp_path / "r", Broken())
    record = marker.read(tmp_path / "r")
    assert record["state"] == state
    assert record.get("error") == ("ValueError: a bug in an engine" if state == "failed" else None)


@lammps
def test_run_case_and_simulate_take_a_case_file_s_path(tmp_path):
    """`pl.run(path, ...)` as `pl.run(load_case(path), ...)` (it gave "'str' object has no
    attribute 'chain'"); anything else is refused in one line naming `case`."""
    from pylmp_lattice.case import load_case
    from pylmp_lattice.errors import UsageError

    path = write_case(tmp_path / "case.toml", make_case(particles=10, duration=5.0))
    by_path, by_case = run_case(str(path), tmp_path / "a", figure=False), run_case(load_case(path), tmp_path / "b", figure=False)
    assert {k: v for k, v in by_path.items() if k not in ("files", "wall_time_s")} \
        == {k: v for k, v in by_case.items() if k not in ("files", "wall_time_s")}
    assert simulate(path, tmp_path / "c").v.shape == simulate(load_case(path), tmp_path / "d").v.shape
    with pytest.raises(UsageError, match=r"^case: got 3; expected a Case or the path of a case file \(TOML\)$"):
        simulate(3, tmp_path / "e")


def test_summarize_refuses_a_deck_that_was_never_run(tmp_path, capsys, caplog):
    """`deck` then `summarize`: one line naming how to run it, exit 2, no summary.json (it wrote a
    summary of status "written" naming a log that did not exist: trial)."""
    from pylmp_lattice.cli import main

    folder = tmp_path / "k"
    assert main(["deck", str(Path(__file__).parent.parent / "inputs" / "paper_experiment.toml"), "-o", str(folder)]) == 0
    capsys.readouterr()
    assert main(["summarize", str(folder)]) == 2
    err = capsys.readouterr().err
    assert err == (f"pylmp-lattice: error: {folder}: holds no log.lammps and no output: a deck never run, or run with "
                   f"its log elsewhere or none; run it with: (cd {folder} && pylmp-lattice lmp -in in.lattice)\n"), err
    assert not (folder / layout.SUMMARY).exists()
    # output but no log (a deck run elsewhere without -log): summarized, with a warning naming what is not known
    simulate(make_case(particles=10, duration=5.0), tmp_path / "ran")
    (tmp_path / "ran" / layout.LOG).unlink()
    assert main(["summarize", str(tmp_path / "ran"), "--no-figure"]) == 0
    assert "no log.lammps" in caplog.text and "friction work are not known" in caplog.text


def test_a_path_that_is_no_run_folder_is_refused_not_read_as_a_deck_never_run(tmp_path):
    """A mistyped folder read as status "written" and summary None; a file as a folder failed in
    pathlib (NotADirectoryError); None as the path in pathlib (TypeError)."""
    from pylmp_lattice.errors import UsageError

    (tmp_path / "a_file").write_text("x")
    (tmp_path / "empty").mkdir()
    for name, why in (("missing", "no such folder"), ("a_file", "it is not a folder"), ("empty", "it has no case.toml")):
        folder = RunFolder(tmp_path / name)
        with pytest.raises(UsageError, match=rf"^folder: got '.*{name}'; expected a run folder \({why}\)$"):
            folder.status
        with pytest.raises(UsageError, match=r"^folder: got .*; expected a run folder"):
            folder.front()
    with pytest.raises(UsageError, match=r"^folder: got None; expected a str or Path: the path of a run folder$"):
        RunFolder(None)
    written = write_folder(make_case(particles=5, duration=1.0), tmp_path / "deck")
    assert RunFolder(str(written)).status == "written" and RunFolder(written).summary is None


def test_figure_of_a_deck_never_run_and_friction_work_without_friction_say_why(tmp_path):
    """figure() of a folder with no front failed as "'NoneType' object has no attribute
    'arrival'", friction_work() of a run without friction as KeyError 'f_friction'."""
    from pylmp_lattice.errors import UsageError

    folder = RunFolder.create(make_case(particles=5, duration=1.0), tmp_path / "deck")
    with pytest.raises(UsageError, match=r"deck: has no front to draw \(status written\): no front record and no "
                                         r"trajectory; run it first$"):
        folder.figure()
    with pytest.raises(UsageError, match=r"deck: its case has no \[friction\] section: no friction work to read$"):
        folder.friction_work()
