"""Hostile input (issue 27): links planted where the package or LAMMPS writes, runs written into
a sweep's folders, full disks, and a sweep's base case outside its folder.

Every test that plants links checks that nothing outside the folder changed: the outside
folder's names, link texts and contents are compared before and after. Runs are the 21-magnet
experiment cut to 2 ms (a second each).
"""

from __future__ import annotations

import errno
import json
import os
import pickle
import shutil
from concurrent.futures import Executor, Future, ThreadPoolExecutor
from pathlib import Path

import pytest

from pylmp_lattice.cli import main
from pylmp_lattice.errors import ConfigError
from pylmp_lattice.formats import files, layout
from pylmp_lattice.sweep import store
from pylmp_lattice.sweep.table import FILES as TABLE_FILES

INPUTS = Path(__file__).resolve().parents[1] / "inputs"
EXPERIMENT = INPUTS / "paper_experiment.toml"
SHORT = ["--set", "run.duration=2", "--quiet"]
SWEEP_NAMES = (store.SWEEP_FILE, store.MEMBERS, store.BATCHES, *TABLE_FILES)


def snapshot(folder: Path) -> dict:
    """Every entry under `folder`: a link's text, a file's bytes, a folder as such."""
    out = {}
    for path in sorted(folder.rglob("*")):
        key = str(path.relative_to(folder))
        out[key] = ("link", os.readlink(path)) if path.is_symlink() else ("dir",) if path.is_dir() \
            else ("file", path.read_bytes())
    return out


@pytest.fixture
def outside(tmp_path):
    """A folder beside the one under attack, holding a file the links point at."""
    folder = tmp_path / "outside"
    folder.mkdir()
    (folder / "x").write_text("the user's own file\n")
    return folder


def plant(folder: Path, name: str, outside: Path, dangling: bool) -> Path:
    """folder/name as a link to outside/x (or, dangling, to a name outside that does not exist)."""
    link = folder / name
    files.remove_tree(link)
    link.symlink_to(outside / (f"new-{name}" if dangling else "x"))
    return link


def cli(capsys, *args) -> tuple[int, str]:
    rc = main([str(a) for a in args])
    return rc, capsys.readouterr().err


@pytest.fixture(scope="module")
def finished(tmp_path_factory):
    """A finished run of the experiment (h5md), made once."""
    folder = tmp_path_factory.mktemp("finished") / "run"
    assert main(["run", str(EXPERIMENT), "-o", str(folder), *SHORT]) == 0
    return folder


@pytest.fixture(scope="module")
def interrupted(tmp_path_factory):
    """A run whose binary dumps were never converted, recorded "interrupted" as a stopped runner does."""
    from pylmp_lattice.case import load_case
    from pylmp_lattice.run_folder import marker, write_folder
    from pylmp_lattice.runner import run_deck

    folder = write_folder(load_case(EXPERIMENT, ["run.duration=2"]), tmp_path_factory.mktemp("stopped") / "run")
    run_deck(folder)
    marker.record(folder, marker.INTERRUPTED, time_ms=2.0)
    assert (folder / layout.TRAJ_BIN).is_file()
    return folder


# ----------------------------------------------------------------------------- the primitives

def test_atomic_write_refuses_a_link_and_replaces_a_file(tmp_path, outside):
    before = snapshot(outside)
    for dangling in (False, True):
        link = plant(tmp_path, "a.json", outside, dangling)
        with pytest.raises(files.LinkError, match=r"a\.json: is a symbolic link"):
            files.atomic_write(link, "{}")
        assert link.is_symlink()
    assert snapshot(outside) == before
    target = tmp_path / "b.json"
    target.write_text("old")
    files.atomic_write(target, "new")
    assert target.read_text() == "new"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.json", "b.json", "outside"]  # no temporary left


def test_replacing_leaves_the_old_file_on_an_error_and_a_full_disk_is_named(tmp_path):
    target = tmp_path / "shock.png"
    target.write_bytes(b"old")
    with pytest.raises(files.DiskFull, match=r"no space left on the device for .*shock\.png"):
        with files.replacing(target) as tmp:
            tmp.write_bytes(b"half")
            raise OSError(errno.ENOSPC, "No space left on device")
    assert target.read_bytes() == b"old"
    assert [p.name for p in tmp_path.iterdir()] == ["shock.png"]
    # h5py reports a full disk as text in a plain OSError
    assert files.disk_full(OSError("Unable to create file (file write failed: errno = 28, error message = "
                                   "'No space left on device')"))
    # a sweep's worker sends both errors back to the coordinator pickled
    for err in (files.DiskFull("/a/b", "then"), files.LinkError("/a/b")):
        again = pickle.loads(pickle.dumps(err))
        assert type(again) is type(err) and str(again) == str(err)


def test_a_fixed_part_name_that_is_a_link_is_removed_not_followed(tmp_path, outside):
    before = snapshot(outside)
    part = plant(tmp_path, "traj.h5md.part", outside, dangling=False)
    with files.replacing(tmp_path / "traj.h5md", part=part) as tmp:
        tmp.write_text("frames")
    assert (tmp_path / "traj.h5md").read_text() == "frames" and not os.path.lexists(part)
    assert snapshot(outside) == before


# ----------------------------------------------------------------------------- run, deck

@pytest.mark.parametrize("dangling", [False, True], ids=["to a file", "dangling"])
def test_run_and_deck_refuse_a_link_at_every_run_file_name(tmp_path, outside, capsys, dangling):
    before = snapshot(outside)
    for name in layout.RUN_FILES:
        # `deck` writes through the same check as `run`: three names for it
        for command in ("run", "deck") if name in (layout.DECK, layout.CASE, layout.LOCK) else ("run",):
            folder = tmp_path / f"{command}-{name}"
            folder.mkdir()
            link = plant(folder, name, outside, dangling)
            rc, err = cli(capsys, command, EXPERIMENT, "-o", folder, *SHORT[:2])
            assert rc == 2, (command, name, err)
            assert f"{link}: is a symbolic link" in err and len(err.strip().splitlines()) == 1, err
            assert link.is_symlink() and [p.name for p in folder.iterdir()] == [name]  # nothing written
    assert snapshot(outside) == before



@pytest.mark.parametrize("name", [layout.LOG, layout.TRAJ_BIN, layout.FRONT_BIN])
def test_a_hand_run_refuses_a_link_where_lammps_writes(tmp_path, outside, capsys, monkeypatch, name):
    """`pylmp-lattice lmp -in in.lattice` in a deck folder with a dangling link at a file LAMMPS
    writes: refused with one line, exit 2, before LAMMPS starts (it wrote 10 kB through the link)."""
    deck = tmp_path / "deck"
    assert main(["deck", str(EXPERIMENT), "-o", str(deck), "--set", "run.duration=2"]) == 0
    before = snapshot(outside)
    plant(deck, name, outside, dangling=True)
    monkeypatch.chdir(deck)
    rc, err = cli(capsys, "lmp", "-in", layout.DECK)
    assert rc == 2 and err.count("\n") == 1 and f"{name}: is a symbolic link" in err
    assert snapshot(outside) == before

def test_overwrite_removes_links_and_never_follows_them(tmp_path, outside, finished, capsys):
    folder = tmp_path / "run"
    shutil.copytree(finished, folder)
    # every run file a link: those of the run to files outside (so the folder still reads as a
    # run), the others dangling
    for name in layout.RUN_FILES:
        if name == layout.LOCK:
            continue
        if (folder / name).is_file():
            shutil.move(folder / name, outside / name)
            (folder / name).symlink_to(outside / name)
        else:
            plant(folder, name, outside, dangling=True)
    before = snapshot(outside)
    rc, err = cli(capsys, "run", EXPERIMENT, "-o", folder, "--overwrite", *SHORT)
    assert rc == 0, err
    assert snapshot(outside) == before
    assert not [p.name for p in folder.iterdir() if p.is_symlink()]
    assert (folder / layout.SUMMARY).is_file() and (folder / layout.H5MD).is_file()
    # the lock is taken before anything else: a link there is refused, also with --overwrite
    link = plant(folder, layout.LOCK, outside, dangling=True)
    rc, err = cli(capsys, "run", EXPERIMENT, "-o", folder, "--overwrite", *SHORT)
    assert rc == 2 and f"{link}: is a symbolic link" in err
    assert snapshot(outside) == before


# ----------------------------------------------------------------------------- summarize, convert

@pytest.mark.parametrize("dangling", [False, True], ids=["to a file", "dangling"])
def test_summarize_refuses_a_link_at_every_run_file_name(tmp_path, outside, finished, capsys, dangling):
    before = snapshot(outside)
    for name in layout.RUN_FILES:
        folder = tmp_path / name
        shutil.copytree(finished, folder)
        link = plant(folder, name, outside, dangling)
        rc, err = cli(capsys, "summarize", folder)
        assert rc == 2, (name, err)
        assert f"{link}: is a symbolic link" in err and len(err.strip().splitlines()) == 1, err
        assert snapshot(outside) == before, name


@pytest.mark.parametrize("dangling", [False, True], ids=["to a file", "dangling"])
def test_converting_an_interrupted_run_refuses_a_link_at_every_run_file_name(tmp_path, outside, interrupted,
                                                                             dangling):
    from pylmp_lattice.run_folder import RunFolder

    before = snapshot(outside)
    for name in layout.RUN_FILES:
        folder = tmp_path / name
        shutil.copytree(interrupted, folder)
        plant(folder, name, outside, dangling)
        with pytest.raises(ConfigError, match=f"{name}: is a symbolic link"):
            RunFolder(folder).convert()
        assert snapshot(outside) == before, name
        h5md = folder / layout.H5MD
        assert not (h5md.is_file() and not h5md.is_symlink())  # nothing converted
        if name != layout.TRAJ_BIN:  # the dumps stay
            assert (folder / layout.TRAJ_BIN).is_file() and not (folder / layout.TRAJ_BIN).is_symlink()
    # without links it converts
    folder = tmp_path / "clean"
    shutil.copytree(interrupted, folder)
    assert RunFolder(folder).convert()
    assert (folder / layout.H5MD).is_file() and not (folder / layout.TRAJ_BIN).exists()


def test_export_and_study_outputs_refuse_a_link(tmp_path, outside, finished, capsys):
    from pylmp_lattice.studies.output import StudyResult, write_study

    before = snapshot(outside)
    for dangling in (False, True):
        link = plant(tmp_path, "t.extxyz", outside, dangling)
        rc, err = cli(capsys, "export", finished, "-o", link, "--overwrite")
        assert rc == 2 and f"{link}: is a symbolic link" in err
        study = tmp_path / "study"
        study.mkdir(exist_ok=True)
        link = plant(study, "s.json", outside, dangling)
        with pytest.raises(files.LinkError):
            write_study(StudyResult("s", {"a": 1.0}), study)
    assert snapshot(outside) == before


@pytest.mark.parametrize("where", ["fig2", "fig2/paper_experiment", "fig2/paper_experiment/log.lammps", "fig2.json",
                                   "fig2_forces.csv"])
def test_a_study_refuses_a_link_where_it_writes_before_it_runs(tmp_path, outside, capsys, monkeypatch, where):
    """A link planted in the study's folder at its runs' folder (DIR/NAME), inside it, or at one of
    its files: refused before the study runs anything (`studies.refuse_planted_links`), exit 2."""
    from pylmp_lattice import studies

    out = tmp_path / "out"
    (out / where).parent.mkdir(parents=True, exist_ok=True)
    (out / where).symlink_to(outside)
    ran = []
    monkeypatch.setattr(studies, "study_module", lambda name: ran.append(name))  # (a run would import it)
    before = snapshot(outside)
    for name in ("fig2", "all"):
        rc, err = cli(capsys, "study", name, "-o", out, "--quick")
        assert rc == 2 and f"{out / where}: is a symbolic link" in err and len(err.strip().splitlines()) == 1, err
    assert not ran and snapshot(outside) == before


@pytest.mark.parametrize("dangling", [False, True], ids=["to a folder", "dangling"])
def test_an_output_folder_that_is_a_link_is_refused(tmp_path, outside, capsys, dangling, no_forkserver):
    """-o naming a link: its writes would land wherever it points, so each command refuses it."""
    target = outside / ("new" if dangling else "runs")
    if not dangling:
        target.mkdir()
    link = tmp_path / "out"
    link.symlink_to(target)
    sweep_file = write_sweep(tmp_path)
    before = snapshot(outside)
    for args in (("run", EXPERIMENT, *SHORT), ("deck", EXPERIMENT), ("sweep", sweep_file, "--quiet"),
                 ("study", "fig1", "--quick")):
        rc, err = cli(capsys, *args, "-o", link)
        assert rc == 2 and "a symbolic link" in err and "output" in err, (args, err)
        assert len(err.strip().splitlines()) == 1, err
    assert snapshot(outside) == before and link.is_symlink()


def test_a_sweep_folder_lammps_cannot_name_is_refused_before_any_member(tmp_path, capsys, no_forkserver):
    """A sweep folder with a space (or another character LAMMPS splits or reads) under the embedded
    runner: refused up front, exit 2, nothing written, where every member used to fail on it."""
    folder = tmp_path / "s w"
    for engine in ("lammps", "cpu"):  # (engine cpu: each member alone, a point each, runs with LAMMPS)
        rc, err = cli(capsys, "sweep", write_sweep(tmp_path), "-o", folder, "--quiet", "--engine", engine)
        assert rc == 2 and "embedded runner needs a path" in err and 'runner = "lmp"' in err
        assert len(err.strip().splitlines()) == 1 and not folder.exists()


# ----------------------------------------------------------------------------- sweeps

def write_sweep(folder: Path, velocities=(1.0, 2.0), base: str | None = None) -> Path:
    path = folder / "sweep.toml"
    path.write_text(f'base = "{base or EXPERIMENT}"\n[set]\n"run.duration" = 2.0\n'
                    f'[grid]\n"impactor.velocity" = {list(velocities)}\n')
    return path


def run_in_threads(sweep_file: Path, out: Path, **kw):
    """The sweep with its members in a thread of this process (so that a monkeypatch applies)."""
    from pylmp_lattice.sweep import load_sweep, run_sweep

    with ThreadPoolExecutor(1) as pool:
        return run_sweep(load_sweep(sweep_file), out, executor=pool, slots=1, progress=False, **kw)


@pytest.fixture
def no_forkserver(monkeypatch):
    """`sweep` on the command line without its fork server (these sweeps are refused, or run
    in a thread)."""
    from pylmp_lattice.sweep import pool

    monkeypatch.setattr(pool, "start_forkserver", lambda engine=None, also=(): None)


@pytest.fixture(scope="module")
def swept(tmp_path_factory):
    """A finished sweep of two members."""
    folder = tmp_path_factory.mktemp("swept")
    table = run_in_threads(write_sweep(folder), folder / "sw")
    assert list(table["status"]) == ["done", "done"]
    return folder / "sw"


@pytest.mark.parametrize("dangling", [False, True], ids=["to a file", "dangling"])
def test_a_sweep_refuses_a_link_at_each_of_its_names(tmp_path, outside, capsys, dangling, no_forkserver):
    before = snapshot(outside)
    sweep_file = write_sweep(tmp_path)
    for name in SWEEP_NAMES:
        folder = tmp_path / f"sw-{name}"
        folder.mkdir()
        link = plant(folder, name, outside, dangling)
        rc, err = cli(capsys, "sweep", sweep_file, "-o", folder, "--quiet")
        assert rc == 2 and f"{link}: is a symbolic link" in err, (name, err)
    assert snapshot(outside) == before


def test_a_member_folder_that_is_a_link_is_run_again_in_its_own_folder(tmp_path, outside, swept):
    out = tmp_path / "sw"
    shutil.copytree(swept, out)
    member = next((out / store.MEMBERS).iterdir())
    shutil.move(member, outside / member.name)  # a done member's files, outside: not this sweep's
    member.symlink_to(outside / member.name)
    before = snapshot(outside)
    table = run_in_threads(write_sweep(tmp_path), out)
    assert list(table["status"]) == ["done", "done"]
    assert member.is_dir() and not member.is_symlink() and (member / layout.SUMMARY).is_file()
    assert snapshot(outside) == before


def test_run_refuses_a_sweeps_folder_and_its_members_and_batches(swept, capsys):
    member = next((swept / store.MEMBERS).iterdir())
    before = snapshot(swept)
    for folder in (swept, member, swept / store.BATCHES / "x", member / "sub"):
        for command in ("run", "deck"):
            rc, err = cli(capsys, command, EXPERIMENT, "-o", folder, "--overwrite", "--set", "impactor.velocity=3.0")
            assert rc == 2 and "a run there would be taken for the sweep's own" in err, (folder, err)
    assert snapshot(swept) == before


def test_resume_runs_again_a_member_whose_folder_holds_another_case(tmp_path, swept):
    """Issue 27 item 2: a run of another case put into a member's folder (through the API, which
    the command line refuses) must not pass for the member: resume runs it again."""
    from pylmp_lattice.case import case_id, load_case
    from pylmp_lattice.run_folder import RunFolder, run_case

    out = tmp_path / "sw"
    shutil.copytree(swept, out)
    row = run_in_threads(write_sweep(tmp_path), out).iloc[0]
    member = out / row["folder"]
    status = (member / store.STATUS).read_text()
    other = load_case(EXPERIMENT, ["run.duration=2", "impactor.velocity=3.0"])
    run_case(other, member, overwrite=True, figure=False)
    (member / store.STATUS).write_text(status)  # the member's record, as before
    assert RunFolder(member).summary["impactor_peak_velocity_m_per_s"] == 3.0
    table = run_in_threads(write_sweep(tmp_path), out)
    again = table.set_index("id").loc[row["id"]]
    assert again["status"] == "done" and again["impactor.velocity"] == 1.0
    assert again["impactor_peak_velocity_m_per_s"] == 1.0  # the member's own case, run again
    assert case_id(RunFolder(member).case) == row["id"]


def test_the_sweep_disk_check_refuses_with_the_numbers_also_with_yes(tmp_path, monkeypatch, capsys, no_forkserver):
    from pylmp_lattice import preflight
    from pylmp_lattice.sweep import disk, load_sweep

    sweep_file = write_sweep(tmp_path, velocities=[1.0, 1.5, 2.0, 2.5])
    each = disk.member_bytes(load_sweep(sweep_file), 1)
    # a member alone keeps its run folder: the force table (693 kB) is most of it
    assert 0.7e6 < each < 1.2e6
    monkeypatch.setattr(preflight, "free_disk", lambda folder: 3.5 * each)
    rc, err = cli(capsys, "sweep", sweep_file, "-o", tmp_path / "sw", "--yes", "--quiet")
    assert rc == 2, err
    assert f"(4 members to run, about {preflight._size(each)} each)" in err and "3" in err and "free" in err
    assert not (tmp_path / "sw").exists()  # refused before anything was written
    monkeypatch.setattr(preflight, "free_disk", lambda folder: 4.5 * each)  # fits
    assert len(run_in_threads(sweep_file, tmp_path / "sw")) == 4


def test_the_sweep_disk_estimate_samples_the_grid_s_last_point_too(tmp_path):
    """Fewer points than the samples: each one counts (two points used to give the first alone,
    so a huge last member passed the check and each worker then stopped the sweep on it)."""
    from pylmp_lattice.sweep import disk, load_sweep

    shutil.copy(EXPERIMENT, tmp_path / "base.toml")
    each = {}
    for order in ([21, 100_000_000], [100_000_000, 21], [21, 22, 100_000_000]):
        path = tmp_path / "sweep.toml"
        path.write_text(f'base = "base.toml"\n[grid]\n"chain.particles" = {order}\n')
        each[len(order), order[0]] = disk.member_bytes(load_sweep(path), 1)
    assert each[2, 21] == pytest.approx(each[2, 100_000_000], rel=1e-12) and each[2, 21] > 4e11  # bytes: half the huge one
    assert each[3, 21] == pytest.approx(each[2, 21] * 2 / 3, rel=0.01)  # the huge member is one of three


def test_a_member_larger_than_the_whole_disk_fails_and_does_not_stop_the_sweep(tmp_path, monkeypatch):
    """`member._no_room`: a member whose run does not fit the free space stops the sweep as a full
    disk (freeing space and resuming runs it), unless it is larger than the whole file system or
    than the memory: then it fails alone, with preflight's refusal as its error."""
    import dataclasses

    from pylmp_lattice import preflight
    from pylmp_lattice.case import load_case
    from pylmp_lattice.sweep import member

    case, total = load_case(EXPERIMENT), shutil.disk_usage(tmp_path).total
    est = preflight.estimate(case)
    monkeypatch.setattr(preflight, "free_disk", lambda folder: 1e6)
    monkeypatch.setattr(preflight, "available_memory", lambda: 1e9)
    for need, memory, stops in ((2e6, 1e8, True), (total + 1.0, 1e8, False), (5e5, 1e8, False), (2e6, 2e9, False)):
        sized = dataclasses.replace(est, files={"all": need}, memory_bytes=memory)
        monkeypatch.setattr(preflight, "estimate", lambda case, sized=sized: sized)
        for folder in (tmp_path, tmp_path / "members" / "0123456789abcdef"):  # (not made yet: its parent's disk)
            assert member._no_room(case, folder) is stops, (need, memory, folder)


def stopped_at_the_disk_check(monkeypatch) -> list:
    """The sweep's disk check made to record (members to run, what it says) and stop the command
    there (exit 2): the list it records into."""
    from pylmp_lattice.errors import UsageError
    from pylmp_lattice.sweep import disk

    checked, real = [], disk.check

    def check(sweep, root, todo, slots):
        checked.append((todo, real(sweep, root, todo, slots)))
        raise UsageError("-o", "stopped after the disk check")

    monkeypatch.setattr(disk, "check", check)
    return checked


def test_a_folder_holding_more_members_than_the_sweep_gives_no_negative_disk_need(tmp_path, monkeypatch, capsys,
                                                                                  no_forkserver):
    """The members to run are the sweep's count less the outcomes on disk, an upper bound that
    counts another sweep's members too (`--overwrite` keeps them): "about -121 MB on disk"."""
    from pylmp_lattice.sweep import load_sweep

    out = tmp_path / "sw"
    sweep_file = write_sweep(tmp_path, velocities=[1.0])
    for name in ("a", "b", "c"):  # three folders of another sweep's members, done (left by an --overwrite)
        (out / store.MEMBERS / name).mkdir(parents=True)
        store.write_status(out / store.MEMBERS / name, {"id": name, "status": "done"})
    (out / store.SWEEP_FILE).write_text(json.dumps({"identity": load_sweep(sweep_file).identity()}))  # this sweep's
    checked = stopped_at_the_disk_check(monkeypatch)
    rc, err = cli(capsys, "sweep", sweep_file, "-o", out, "--quiet")
    assert rc == 2 and "stopped after the disk check" in err
    assert checked == [(0, "about 0 B on disk")]


@pytest.mark.parametrize("retry", [False, True], ids=["failed kept", "--retry-failed"])
def test_a_resumed_sweep_counts_its_unfinished_members_on_disk(tmp_path, monkeypatch, capsys, retry, no_forkserver):
    """The disk estimate of a resumed sweep: members whose folder holds an interrupted or
    unrecorded run (or is a link) run again and need their disk, as do failed ones with
    --retry-failed; done ones (and failed ones kept) do not. It used to count every folder as
    done: "about 0 B on disk" for a sweep whose members were all interrupted."""
    from pylmp_lattice.preflight import _size
    from pylmp_lattice.sweep import disk, load_sweep

    sweep_file = write_sweep(tmp_path, velocities=[1.0, 1.5, 2.0, 2.5, 3.0, 3.5])
    out = tmp_path / "sw"
    members = out / store.MEMBERS
    states = {"done": "done", "failed": "failed", "interrupted": "interrupted", "running": "running", "none": None}
    for name, status in states.items():
        (members / name).mkdir(parents=True)
        if status:
            store.write_status(members / name, {"id": name, "status": status})
    (members / "link").symlink_to(members / "done", target_is_directory=True)
    (out / store.SWEEP_FILE).write_text(json.dumps({"identity": load_sweep(sweep_file).identity()}))  # this sweep's
    checked = stopped_at_the_disk_check(monkeypatch)
    rc, err = cli(capsys, "sweep", sweep_file, "-o", out, "--quiet", *(["--retry-failed"] if retry else []))
    assert rc == 2 and "stopped after the disk check" in err
    todo = 6 - 1 - (0 if retry else 1)  # of the six members, the done one (and the failed one) stand
    each = disk.member_bytes(load_sweep(sweep_file), 1)  # (a member alone: its run folder, most of a MB)
    assert checked == [(todo, f"about {_size(todo * each)} on disk")] and each > 0.5e6
    assert store.Outcomes(out).to_keep(retry) == 6 - todo


def test_another_sweep_s_members_count_as_none_of_this_one_s(tmp_path, monkeypatch, capsys, no_forkserver):
    """--overwrite of a folder that holds another sweep: its done members' folders stay on disk,
    but none is this sweep's, so every member of this one is to run (and to fit on the disk)."""
    out = tmp_path / "sw"
    for name in ("a", "b"):
        (out / store.MEMBERS / name).mkdir(parents=True)
        store.write_status(out / store.MEMBERS / name, {"id": name, "status": "done"})
    (out / store.SWEEP_FILE).write_text(json.dumps({"identity": "another sweep"}))
    checked = stopped_at_the_disk_check(monkeypatch)
    rc, err = cli(capsys, "sweep", write_sweep(tmp_path), "-o", out, "--overwrite", "--quiet")
    assert rc == 2 and "stopped after the disk check" in err and [todo for todo, _ in checked] == [2]


def test_a_resumed_sweep_estimates_only_the_members_left(tmp_path, swept, caplog):
    """A finished sweep run again says how many of its members are left to run, and its time
    estimate is theirs (none here: the start-up alone), not the whole sweep's again."""
    import logging

    out = tmp_path / "sw"
    shutil.copytree(swept, out)
    with caplog.at_level(logging.INFO, logger="pylmp_lattice"):
        table = run_in_threads(write_sweep(tmp_path), out)
    assert list(table["status"]) == ["done", "done"]
    said = next(r.getMessage() for r in caplog.records if " kept from before " in r.getMessage())
    assert said.startswith("sw: 2 members, 2 kept from before (about ") and "about 0 B on disk" in said, said


def test_a_full_disk_mid_sweep_stops_it_keeping_finished_members_and_the_table(tmp_path, monkeypatch, capsys,
                                                                             caplog, no_forkserver):
    """The disk fills for the third member's files (ENOSPC from the write primitive): the sweep
    stops as on Ctrl-C, with the two finished members and results.csv, and one line naming the
    file; the same command then finishes it."""
    from pylmp_lattice.sweep import execute

    sweep_file = write_sweep(tmp_path, velocities=[1.0, 1.5, 2.0, 2.5])
    out = tmp_path / "sw"
    create, members = files._create, []

    def full(path, part):
        folder = Path(path).parent
        if folder.parent.name == store.MEMBERS and folder not in members:
            members.append(folder)
        # the member's status.json fits, its run's files do not
        if len(members) > 2 and folder.parent.name == store.MEMBERS and Path(path).name != store.STATUS:
            raise OSError(errno.ENOSPC, "No space left on device")
        return create(path, part)

    monkeypatch.setattr(files, "_create", full)
    caplog.set_level("INFO", logger="pylmp_lattice")
    with pytest.raises(files.DiskFull) as caught:
        run_in_threads(sweep_file, out)
    assert "the first task sent" not in caplog.text  # no timeline of a sweep that stopped
    message = str(caught.value)
    assert f"no space left on the device for {members[2]}/" in message
    assert "stopped with 2 of 4 members done" in message and "run the same command to resume" in message
    import pandas as pd

    table = pd.read_csv(out / "results.csv")
    assert list(table["status"])[:2] == ["done", "done"] and (table["status"] == "done").sum() == 2
    assert sorted(p.name for p in (out / store.MEMBERS).iterdir() if (p / layout.SUMMARY).exists()) \
        == sorted(p.name for p in members[:2])
    # the command line: one line, exit 1
    monkeypatch.setattr(execute, "executor_pool", _thread_pool(execute.executor_pool))
    members.clear()
    shutil.rmtree(out)
    rc, err = cli(capsys, "sweep", sweep_file, "-o", out, "--quiet")
    errors = [line for line in err.splitlines() if line.startswith("pylmp-lattice: error:")]
    assert rc == 1 and len(errors) == 1 and errors[0].startswith("pylmp-lattice: error: no space left on the device "
                                                                 f"for {members[2]}/"), err
    # what it says is true: the stopped member's folder is gone (it used to say "the files are kept")
    warned = [r.getMessage() for r in caplog.records if "no space left" in r.getMessage()]
    assert warned and all(f"member {members[2].name}'s folder is removed; it runs again on resume" in w
                          for w in warned), warned
    assert not members[2].exists() and f"kept in {out} and its results.csv;" in errors[0], err
    # no room for results.csv either: the line does not claim one (it used to say "and its results.csv")
    members.clear()
    shutil.rmtree(out)
    table_full = full

    def full(path, part):
        if Path(path).name.startswith("results.") and len(members) > 2:
            raise OSError(errno.ENOSPC, "No space left on device")
        return table_full(path, part)

    monkeypatch.setattr(files, "_create", full)
    rc, err = cli(capsys, "sweep", sweep_file, "-o", out, "--quiet")
    errors = [line for line in err.splitlines() if line.startswith("pylmp-lattice: error:")]
    assert rc == 1 and not (out / "results.csv").exists() and len(errors) == 1, err
    assert f"kept in {out} (no room to write results.csv); free space and run the same command" in errors[0], err
    # space again: the same command finishes the sweep, keeping the finished members
    monkeypatch.setattr(files, "_create", create)
    kept = {p.name: (p / layout.SUMMARY).stat().st_mtime_ns for p in members[:2]}
    rc, err = cli(capsys, "sweep", sweep_file, "-o", out, "--quiet")
    assert rc == 0, err
    table = pd.read_csv(out / "results.csv")
    assert list(table["status"]) == ["done"] * 4
    assert {n: (out / store.MEMBERS / n / layout.SUMMARY).stat().st_mtime_ns for n in kept} == kept


class _DyingWorker(Executor):
    """An executor whose worker dies (or reports a full disk) in its task's first member, after
    writing the member's status.json "running", as a worker killed GRACE s after a stop, or
    one whose "interrupted" record did not fit on the disk, leaves it."""

    def __init__(self, error: BaseException):
        import subprocess

        gone = subprocess.Popen(["true"])
        gone.wait()
        self.pid, self.error = gone.pid, error  # a process of this machine that no longer runs

    def submit(self, fn, task):
        import socket

        from pylmp_lattice.sweep.member import _record

        m = task.each()[0]
        folder = store.member_folder(task.root, m.id)
        folder.mkdir(parents=True)
        record = _record(m) | {"pid": self.pid}
        record["provenance"]["host"] = socket.gethostname()
        store.write_status(folder, record)
        future = Future()
        future.set_exception(self.error)
        return future


@pytest.mark.parametrize("how", ["lost worker", "full disk"])
def test_no_member_stays_running_once_the_sweep_has_stopped_by_itself(tmp_path, monkeypatch, how):
    """Issue 27 item 6: a full disk mid-sweep once left a member's status.json "running" (its
    worker could not write "interrupted"). Once the sweep has stopped on its own (a lost worker,
    a full disk), a member whose worker is gone is "interrupted" on disk, or, with no room even
    for that record, has no folder: it runs again on resume either way."""
    from concurrent.futures.process import BrokenProcessPool

    from pylmp_lattice.sweep import load_sweep, run_sweep

    sweep_file = write_sweep(tmp_path, velocities=[1.0])
    out = tmp_path / "sw"
    if how == "lost worker":
        table = run_sweep(load_sweep(sweep_file), out, executor=_DyingWorker(BrokenProcessPool("killed")), slots=1,
                          progress=False)
    else:  # the disk is full: the worker's task says so, and no status.json fits any more
        create = files._create

        def full(path, part):
            if Path(path).name == store.STATUS and Path(path).exists():  # the worker's "running" fitted
                raise OSError(errno.ENOSPC, "No space left on device")
            return create(path, part)

        monkeypatch.setattr(files, "_create", full)
        with pytest.raises(files.DiskFull, match="stopped with 0 of 1 members done"):
            run_sweep(load_sweep(sweep_file), out, executor=_DyingWorker(files.DiskFull(out / "x")), slots=1,
                      progress=False)
        import pandas as pd

        table = pd.read_csv(out / "results.csv")
    assert list(table["status"]) == ["interrupted"]
    members = list((out / store.MEMBERS).iterdir())
    if how == "lost worker":
        assert [store.read_status(m)["status"] for m in members] == ["interrupted"]
    else:
        assert members == []  # no room for its record: its folder went
    if how == "full disk":  # space again: the same sweep resumes
        monkeypatch.undo()
        assert list(run_in_threads(sweep_file, out)["status"]) == ["done"]


def test_a_running_member_of_a_live_or_remote_worker_is_left_alone(tmp_path):
    """Only a worker known gone (a process of this machine that no longer runs) is settled: a
    thread of this process, or a worker on another machine, may still write its outcome."""
    import socket

    from pylmp_lattice.sweep.execute import _settle
    from pylmp_lattice.sweep.member import _record
    from pylmp_lattice.sweep.spec import load_sweep

    m = next(load_sweep(write_sweep(tmp_path, velocities=[1.0])).iter_members())
    folder = store.member_folder(tmp_path / "sw", m.id)
    folder.mkdir(parents=True)
    for pid, host in ((os.getpid(), socket.gethostname()), (_DyingWorker(None).pid, "another-host")):
        record = _record(m) | {"pid": pid}
        record["provenance"]["host"] = host
        store.write_status(folder, record)
        _settle(tmp_path / "sw", m)
        assert store.read_status(folder)["status"] == "running"


def _thread_pool(original):
    """executor_pool with a thread of this process as the worker, for the command line."""
    import contextlib

    @contextlib.contextmanager
    def pool(workers, scheduler, runner, executor, slots, *engine):
        with ThreadPoolExecutor(1) as threads, original(None, None, runner, threads, 1, *engine) as p:
            yield p

    return pool


# ----------------------------------------------------------------------------- the base case

def test_a_sweep_base_may_be_outside_its_folder(tmp_path, capsys, no_forkserver):
    """Issue 27 item 11: base = "../inputs/x.toml" or an absolute path is read (an input); the
    sweep writes only in -o."""
    scratch = tmp_path / "scratch"
    scratch.mkdir()
    shutil.copy(EXPERIMENT, tmp_path / "case.toml")
    for base in ("../case.toml", str(tmp_path / "case.toml")):
        table = run_in_threads(write_sweep(scratch, velocities=[1.0], base=base), scratch / "sw")
        assert list(table["status"]) == ["done"] and table["impactor.velocity"][0] == 1.0
    assert (tmp_path / "case.toml").read_bytes() == EXPERIMENT.read_bytes()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["case.toml", "scratch"]  # written in -o only
    # a missing one is named with its whole path
    sweep_file = write_sweep(scratch, velocities=[1.0], base="../" + "long-name/" * 8 + "case.toml")
    rc, err = cli(capsys, "sweep", sweep_file, "-o", scratch / "sw2", "--quiet")
    assert rc == 2 and f"base: file not found: {tmp_path}/{'long-name/' * 8}case.toml" in err, err


def test_a_member_folder_whose_run_was_interrupted_holds_no_outcome(tmp_path):
    """A member alone recorded "interrupted" (a stop, a lost worker: `execute._settle`) has no
    outcome, whatever its folder holds (here a summary.json): a resumed sweep runs it again
    (mutation: "interrupted" counted among the finished records, which kept the member and its
    row "interrupted" for good, survived the fast tests)."""
    folder = store.member_folder(tmp_path, "m")
    folder.mkdir(parents=True)
    store.write_status(folder, {"id": "m", "status": "interrupted", "error": None})
    (folder / layout.SUMMARY).write_text('{"status": "interrupted"}\n')
    assert store.outcome(tmp_path, "m") is None and store.Outcomes(tmp_path).get("m") is None
    assert store.Outcomes(tmp_path).to_keep() == 0


def test_a_member_folder_holding_another_member_s_failed_record_holds_no_outcome(tmp_path):
    """A member folder whose status.json is another member's (a folder copied or renamed by
    hand) is not this member's outcome, "failed" ones included (a "done" one is also refused by
    its case.toml's identity): the member runs again (mutation: the record's id unread survived)."""
    folder = store.member_folder(tmp_path, "a")
    folder.mkdir(parents=True)
    store.write_status(folder, {"id": "b", "status": "failed", "error": "ConfigError: b's own"})
    assert store.outcome(tmp_path, "a") is None and store.Outcomes(tmp_path).get("a") is None
    assert store.Outcomes(tmp_path).to_keep() == 0
    store.write_status(folder, {"id": "a", "status": "failed", "error": "ConfigError: a's own"})
    assert store.outcome(tmp_path, "a")["record"]["error"] == "ConfigError: a's own"


def test_a_conversion_that_does_not_verify_keeps_the_dumps_and_writes_no_h5md(tmp_path, interrupted, monkeypatch):
    """The H5MD file written with a frame fewer than the dump holds (as a writer that stopped
    early would): the conversion is refused, traj.bin stays byte for byte, and neither traj.h5md
    nor its partial file is left (mutation: the check of the frames and the last frame skipped,
    which deleted the dump, survived)."""
    import dataclasses

    from pylmp_lattice.errors import LatticeError
    from pylmp_lattice.formats import h5md
    from pylmp_lattice.run_folder import RunFolder

    folder = tmp_path / "run"
    shutil.copytree(interrupted, folder)
    dump = (folder / layout.TRAJ_BIN).read_bytes()
    real = h5md.write_file

    def short(path, header, sources, *args, **kwargs):
        cut = {group: dataclasses.replace(d, frames=d.frames - 1) for group, d in sources.items()}
        return real(path, header, cut, *args, **kwargs)

    monkeypatch.setattr(h5md, "write_file", short)
    with pytest.raises(LatticeError, match=r"the H5MD conversion of traj\.bin did not verify; kept it"):
        RunFolder(folder).convert()
    assert (folder / layout.TRAJ_BIN).read_bytes() == dump
    assert not (folder / layout.H5MD).exists() and not (folder / (layout.H5MD + ".part")).exists()
    monkeypatch.setattr(h5md, "write_file", real)
    assert RunFolder(folder).convert() and not (folder / layout.TRAJ_BIN).exists()  # whole: converted
