"""Decks run by hand (`lmp -in in.lattice`) that do not end as written: a LAMMPS ERROR after a
hand edit is "failed", a killed lmp "interrupted" (measured up to where it stopped), and either
may be summarized and overwritten; a live lmp's folder stays "running" and refused. A deck
edited by hand is said so in summary.json, and a summary written again keeps what is still true."""

from __future__ import annotations

import dataclasses
import json
import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import tomli_w

from pylmp_lattice import measures
from pylmp_lattice.case import case_to_dict
from pylmp_lattice.cli import main
from pylmp_lattice.formats import layout
from pylmp_lattice.run_folder import RunFolder, marker, run_case
from pylmp_lattice.run_folder.marker import _open_for_writing

from conftest import make_case

LMP = Path(sys.executable).parent / "lmp"
lammps = pytest.mark.lammps


def deck(tmp_path: Path, case, name: str = "d") -> Path:
    """`pylmp-lattice deck` of `case` into tmp_path/name; the folder."""
    toml = tmp_path / f"{name}.toml"
    toml.write_bytes(tomli_w.dumps(case_to_dict(case)).encode())
    assert main(["deck", str(toml), "-o", str(tmp_path / name)]) == 0
    return tmp_path / name


def edit(folder: Path, old: str, new: str) -> None:
    """Edit the deck by hand: one line starting with `old` becomes `new` (once)."""
    text = (folder / layout.DECK).read_text()
    lines = text.splitlines()
    hits = [i for i, line in enumerate(lines) if line.startswith(old)]
    assert len(hits) == 1, old
    lines[hits[0]] = new
    (folder / layout.DECK).write_text("\n".join(lines) + "\n")


def run_by_hand(folder: Path) -> int:
    return subprocess.run([str(LMP), "-in", layout.DECK, "-screen", "none"], cwd=folder).returncode


@lammps
def test_a_lammps_error_is_failed_summarized_and_may_be_overwritten(tmp_path, caplog):
    """An unknown fix added by hand: lmp stops with an ERROR (no end of log). The folder is
    "failed", summarize says why (exit 0, a warning naming the ERROR line; "stopped" holds it),
    and `deck --overwrite` replaces it."""
    folder = deck(tmp_path, make_case(particles=10, duration=1.0))
    timestep = next(line for line in (folder / layout.DECK).read_text().splitlines() if line.startswith("timestep"))
    edit(folder, "timestep", timestep + "\nfix bogus all nosuchfix")
    assert run_by_hand(folder) != 0
    assert RunFolder(folder).status == "failed"
    assert main(["summarize", str(folder), "--no-figure"]) == 0
    assert f"{folder}: the run failed: ERROR: Unrecognized fix style 'nosuchfix'" in caplog.text
    summary = json.loads((folder / layout.SUMMARY).read_text())
    assert summary["status"] == "failed" and summary["deck_edited"] is True
    assert summary["stopped"]["reason"] == "failed"
    assert summary["stopped"]["error"].startswith("ERROR: Unrecognized fix style 'nosuchfix'")
    assert "src/" not in summary["stopped"]["error"]  # the line as the runners report it (`dump.error_line`)
    assert main(["deck", str(tmp_path / "d.toml"), "-o", str(folder), "--overwrite"]) == 0
    assert "nosuchfix" not in (folder / layout.DECK).read_text() and RunFolder(folder).status == "written"
    assert not (folder / layout.SUMMARY).exists() and not (folder / layout.LOG).exists()


@lammps
def test_a_killed_lmp_is_interrupted_and_measured_up_to_its_stop(tmp_path, capsys):
    """A 4000 ms deck of 2000 magnets run by hand: while lmp writes, the folder is "running",
    summarize and `deck --overwrite` are refused (nothing touched); once lmp's process group is
    killed (as Ctrl-C or a time limit does), it is "interrupted", summarize measures the frames
    written up to the stop, and `deck --overwrite` replaces it."""
    folder = deck(tmp_path, make_case(particles=2000, duration=4000.0, interval=1.0))
    frame = 2000 * 4 * 8  # bytes of a binary frame (4 doubles a magnet), at least
    lmp = subprocess.Popen([str(LMP), "-in", layout.DECK, "-screen", "none"], cwd=folder, start_new_session=True)
    try:
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline and lmp.poll() is None:
            dump = folder / layout.TRAJ_BIN
            if dump.exists() and dump.stat().st_size > 20 * frame:
                break
            time.sleep(0.02)
        assert RunFolder(folder).status == "running" and lmp.poll() is None, "lmp ended too soon for this test"
        capsys.readouterr()
        assert main(["summarize", str(folder)]) == 2
        assert main(["deck", str(tmp_path / "d.toml"), "-o", str(folder), "--overwrite"]) == 2
        assert "still being written" in capsys.readouterr().err
        assert not (folder / layout.SUMMARY).exists() and (folder / layout.TRAJ_BIN).exists()
        assert lmp.poll() is None, "lmp ended too soon for this test"
    finally:
        os.killpg(lmp.pid, signal.SIGKILL)  # the wrapper `lmp` and LAMMPS, its child
        lmp.wait(10)
    deadline = time.monotonic() + 10  # LAMMPS, the wrapper's child, lets go of its log as it dies
    while _open_for_writing(folder / layout.LOG) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert RunFolder(folder).status == "running"  # files changed within marker.QUIET: a writer we cannot see?
    age(folder, marker.QUIET + 1)
    assert RunFolder(folder).status == "interrupted"
    assert main(["summarize", str(folder), "--no-figure"]) == 0
    summary = json.loads((folder / layout.SUMMARY).read_text())
    traj = RunFolder(folder).trajectory()  # every frame written, from the dump: not converted before settled
    assert (folder / layout.TRAJ_BIN).exists() and not (folder / layout.H5MD).exists()
    stop = summary["stopped"]
    assert summary["status"] == "interrupted" and stop["reason"] == "interrupted"
    assert stop["time_ms"] == pytest.approx(traj.t[-1], rel=1e-14) and 20 <= stop["time_ms"] < 4000  # JSON: 15 digits
    np.testing.assert_allclose(np.diff(traj.t), 1.0, rtol=1e-9)  # frames 0, 1, ... ms up to the stop
    # the front measured in what was written: it reached magnets by then, none after the stop
    front = RunFolder(folder).front()
    reached = np.isfinite(front.arrival)
    assert summary["particles_reached_by_front"] == measures.particles_reached(front.arrival) >= 3
    assert np.nanmax(front.arrival) <= stop["time_ms"]
    assert main(["deck", str(tmp_path / "d.toml"), "-o", str(folder), "--overwrite"]) == 2  # not settled yet
    age(folder, marker.SETTLED + 1)
    assert main(["deck", str(tmp_path / "d.toml"), "-o", str(folder), "--overwrite"]) == 0
    assert RunFolder(folder).status == "written" and not (folder / layout.H5MD).exists()


def age(folder, seconds: float) -> None:
    """Set the run's log and dumps back `seconds` in time."""
    then = time.time() - seconds
    for name in (layout.LOG, *layout.BINARY_GROUPS.values()):
        if (folder / name).exists():
            os.utime(folder / name, (then, then))


def test_a_writer_proc_cannot_see_keeps_the_run_whole(tmp_path, monkeypatch):
    """LAMMPS of another user, or on another machine writing a shared folder, is not in /proc:
    a log without an end whose files changed within marker.QUIET is "running"; older, it is
    "interrupted" and may be summarized, but its dumps are neither converted nor overwritten
    until they stayed unchanged for marker.SETTLED (a frame may come only minutes apart)."""
    from pylmp_lattice.run_folder.convert import convert_dumps

    case = make_case(particles=10, duration=1.0)
    folder = deck(tmp_path, case)
    monkeypatch.setattr(marker, "_open_for_writing", lambda *paths: False)
    (folder / layout.LOG).write_text("LAMMPS (22 Jul 2025)\nStep Time\n0 0\n")
    (folder / layout.TRAJ_BIN).write_bytes(b"frames")
    assert RunFolder(folder).status == "running"
    age(folder, marker.QUIET + 1)
    assert RunFolder(folder).status == "interrupted" and not marker.settled(folder)  # by inference
    assert convert_dumps(folder, dataclasses.replace(case, output=dataclasses.replace(case.output, format="h5md"))) is False
    assert main(["deck", str(tmp_path / "d.toml"), "-o", str(folder), "--overwrite"]) == 2
    assert (folder / layout.TRAJ_BIN).read_bytes() == b"frames"
    age(folder, marker.SETTLED + 1)
    assert marker.settled(folder)
    assert main(["deck", str(tmp_path / "d.toml"), "-o", str(folder), "--overwrite"]) == 0


def test_without_proc_a_quiet_log_is_no_longer_written(tmp_path, monkeypatch):
    """Where /proc cannot tell who holds the log, a log without an end that changed in the last
    marker.QUIET seconds is "running", an older one "interrupted"."""
    folder = deck(tmp_path, make_case(particles=10, duration=1.0))
    monkeypatch.setattr(marker, "_open_for_writing", lambda *paths: None)
    log = folder / layout.LOG
    log.write_text("LAMMPS (22 Jul 2025)\nStep Time\n0 0\n")
    assert RunFolder(folder).status == "running"
    then = time.time() - marker.QUIET - 1
    os.utime(log, (then, then))
    assert RunFolder(folder).status == "interrupted"


@lammps
def test_an_edited_deck_is_said_in_the_summary(tmp_path, caplog):
    """`run 100` edited into `run 50` and run by hand: summary.json says "deck_edited": true and
    the steps the log ran against the case's, each with a warning; the deck as written says
    neither, also after the package's runner ran it (run.json keeps the deck's hash)."""
    case = make_case(particles=10, duration=1.0)  # 100 steps of 0.01 ms
    folder = deck(tmp_path, case)
    edit(folder, "run ", "run             50")
    assert run_by_hand(folder) == 0 and RunFolder(folder).status == "done"
    assert main(["summarize", str(folder), "--no-figure"]) == 0
    err = caplog.text
    caplog.clear()
    summary = json.loads((folder / layout.SUMMARY).read_text())
    assert summary["deck_edited"] is True and summary["run_steps"] == {"case": 100, "log": 50}
    assert f"{folder}: {layout.DECK} was edited after it was written" in err
    assert f"{folder}: the log ran 50 steps (0.5 ms), case.toml has 100 (1 ms)" in err
    plain = deck(tmp_path, case, "plain")
    assert run_by_hand(plain) == 0
    assert main(["summarize", str(plain), "--no-figure"]) == 0
    ran = run_case(case, tmp_path / "cli", figure=False)
    assert marker.read(tmp_path / "cli")[marker.DECK_HASH] == marker.read(plain)[marker.DECK_HASH]
    for summary in (json.loads((plain / layout.SUMMARY).read_text()), ran):
        assert "deck_edited" not in summary and "run_steps" not in summary
    assert "edited" not in caplog.text and "steps" not in caplog.text


@lammps
def test_summarize_again_keeps_the_wall_time_and_the_figure(tmp_path):
    """A finished run summarized again with --no-figure keeps its wall time and its figure entry
    (shock.png is still there and still of this run); once the log is newer (the deck run again
    by hand), neither is claimed."""
    folder = tmp_path / "r"
    first = run_case(make_case(particles=40, duration=30.0), folder)
    assert first["wall_time_s"] > 0 and first["files"]["figure"] == layout.FIGURE
    assert main(["summarize", str(folder), "--no-figure"]) == 0
    again = json.loads((folder / layout.SUMMARY).read_text())
    assert again["wall_time_s"] == first["wall_time_s"] and again["files"] == first["files"]
    later = time.time() + 5
    os.utime(folder / layout.LOG, (later, later))
    assert main(["summarize", str(folder), "--no-figure"]) == 0
    rerun = json.loads((folder / layout.SUMMARY).read_text())
    assert "wall_time_s" not in rerun and "figure" not in rerun["files"] and (folder / layout.FIGURE).exists()


MPIEXEC = Path(sys.executable).parent / "mpiexec"


def by_hand_on_ranks(folder: Path, ranks: int) -> subprocess.Popen:
    """`mpiexec -n RANKS pylmp-lattice lmp -in in.lattice` in the folder, in a session of its own
    (as a terminal's job: Ctrl-C reaches mpiexec and every rank)."""
    return subprocess.Popen([str(MPIEXEC), "-n", str(ranks), sys.executable, "-m", "pylmp_lattice", "lmp", "-in",
                             layout.DECK, "-screen", "none"], cwd=folder, start_new_session=True,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def ended(job: subprocess.Popen, seconds: float) -> tuple[str, str]:
    """The job's output once it ended; its ranks killed and the test failed if it had not within
    `seconds` (a rank waiting for another for ever)."""
    try:
        return job.communicate(timeout=seconds)
    except subprocess.TimeoutExpired:
        os.killpg(job.pid, signal.SIGKILL)
        job.communicate()
        pytest.fail(f"mpiexec had not ended {seconds} s on")


@lammps
def test_a_hand_run_on_two_mpi_ranks_is_the_run_on_one(tmp_path):
    """`mpiexec -n 2 pylmp-lattice lmp -in in.lattice`: each rank is a hand run of the folder,
    rank 0 alone keeps its record (the other found the folder claimed, said so and left rank 0
    waiting for it for ever). The folder ends "done", and its front record is bit for bit that of
    the same case run on one rank (fix lattice/chain is bit-identical on any number of ranks)."""
    case = make_case(particles=400, duration=150.0, interval=5.0)
    folder = deck(tmp_path, case, "two")
    with by_hand_on_ranks(folder, 2) as job:
        out, err = ended(job, 120)
    assert job.returncode == 0, err
    assert RunFolder(folder).status == "done" and "on 2 procs" in (folder / layout.LOG).read_text()
    one = deck(tmp_path, case, "one")
    assert main(["lmp", "-in", str(one / layout.DECK), "-screen", "none"]) == 0
    assert "on 1 procs" in (one / layout.LOG).read_text()
    two_front, one_front = RunFolder(folder).front(), RunFolder(one).front()
    assert np.isfinite(two_front.arrival).sum() >= 10
    np.testing.assert_array_equal(two_front.arrival, one_front.arrival)
    np.testing.assert_array_equal(two_front.peaks.peak_velocity, one_front.peaks.peak_velocity)


@lammps
def test_ctrl_c_stops_every_mpi_rank_of_a_hand_run_at_one_step(tmp_path):
    """Ctrl-C to `mpiexec -n 2 pylmp-lattice lmp -in in.lattice` (SIGINT to the job's process
    group) while it runs: every rank stops at the same step (fix lattice/chain takes the stop in
    its gap check's reduction; LAMMPS's force_timeout, which each rank called as its signal came,
    left the other rank waiting in an exchange for ever). The job ends within seconds with 130,
    its folder "interrupted" at the step of the log's one stop line, the front record written."""
    folder = deck(tmp_path, make_case(particles=3000, duration=1e5, interval=10.0))
    with by_hand_on_ranks(folder, 2) as job:
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline and job.poll() is None:  # two thermo rows: the loop runs
            if len(re.findall(r"^\s+\d+\s+[-+.\deE]+\s", (folder / layout.LOG).read_text() if (folder / layout.LOG).exists()
                              else "", re.MULTILINE)) >= 2:
                break
            time.sleep(0.05)
        assert job.poll() is None, "the run ended too soon for this test"
        os.killpg(job.pid, signal.SIGINT)
        out, err = ended(job, 30)
    assert job.returncode == 128 + signal.SIGINT, err
    log = (folder / layout.LOG).read_text()
    stops = re.findall(r"^Fix lattice/chain: stopped on request \(a signal\) after step (\d+)$", log, re.MULTILINE)
    assert len(stops) == 1 and "on 2 procs" in log
    run = json.loads((folder / layout.MARKER).read_text())
    step = int(stops[0])
    assert run["state"] == "interrupted" and run["time_ms"] == pytest.approx(step * 0.01, rel=1e-12)
    front = RunFolder(folder).front()
    assert np.isfinite(front.arrival).sum() >= 2 and np.nanmax(front.arrival) <= run["time_ms"]
    assert err.count("interrupted at t =") == 1  # rank 0 says it


def test_other_commands_under_an_mpi_launcher_are_refused_before_they_write(tmp_path, monkeypatch, capsys):
    """`mpiexec -n 2 pylmp-lattice run ...` made two processes each run the whole case and race for
    its folder: one was refused it, the other waited in MPI_Init for it for ever (SIGTERM could not
    stop it) and left the folder "running". Each rank of a command other than `lmp` (whose ranks
    run one hand run, above) now stops at once, exit 2, one line naming the commands that do run
    on 2 ranks; nothing is written."""
    case = make_case(particles=5, duration=1.0)
    deck(tmp_path, case)
    capsys.readouterr()
    monkeypatch.setenv("PMI_RANK", "0")  # what MPICH's mpiexec (Hydra) tells each rank
    monkeypatch.setenv("PMI_SIZE", "2")
    assert main(["run", str(tmp_path / "d.toml"), "-o", str(tmp_path / "r")]) == 2
    assert main(["deck", str(tmp_path / "d.toml"), "-o", str(tmp_path / "e")]) == 2
    assert not (tmp_path / "r").exists() and not (tmp_path / "e").exists()
    lines = capsys.readouterr().err.splitlines()
    assert len(lines) == 2 and all(line.startswith("pylmp-lattice: error: mpiexec: got 2 ranks;") for line in lines)
    assert all("--runner lmp --np 2" in line and "mpiexec -n 2 pylmp-lattice lmp -in in.lattice" in line for line in lines)


@lammps
def test_a_deck_run_with_its_log_elsewhere_names_no_log_in_its_summary(tmp_path, caplog):
    """`lmp -in D/in.lattice -var dir D` from another folder logs there: D read as "written" (a
    deck never run) and its summary said so; its "files" named a log all the same. Now D is
    "running" while its dumps are fresh, then "unlogged", and the summary says that status, names
    the files D holds (the trajectory and figure, no log) and the warning what to do. Its end is
    not known: the summary had no "stopped" entry and the figure no note, as if it had finished
    (a killed one too); they say its last frame, as an interrupted run's do."""
    folder = deck(tmp_path, make_case(particles=8, duration=2.0))
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    assert subprocess.run([str(LMP), "-in", str(folder / layout.DECK), "-var", "dir", str(folder), "-screen", "none"],
                          cwd=elsewhere).returncode == 0
    assert (elsewhere / layout.LOG).is_file() and not (folder / layout.LOG).exists()
    assert RunFolder(folder).status == "running"  # its dumps changed within marker.QUIET: a writer we cannot see?
    age(folder, marker.SETTLED + 1)
    assert RunFolder(folder).status == "unlogged"
    assert main(["summarize", str(folder)]) == 0
    summary = json.loads((folder / layout.SUMMARY).read_text())
    assert summary["status"] == "unlogged" and summary["stopped"] == {"reason": "unlogged", "time_ms": 2.0}
    assert RunFolder(folder).figure()._suptitle.get_text() == (
        "test: $V_I$ = 2 m/s, N = 8; stopped at 2 of 2 ms (unlogged)")
    assert summary["files"] == {"folder": str(folder), "trajectory": layout.H5MD, "figure": layout.FIGURE}
    assert (f"{folder}: no log.lammps (LAMMPS writes it where it runs: `lmp -in` from another folder without -log "
            f"left it there): the run's end and its friction work are not known; move that log.lammps into {folder} "
            "and summarize again") in caplog.text


def test_outputs_without_a_log_are_a_run_not_a_deck_never_run(tmp_path, monkeypatch):
    """A deck's dumps with no log.lammps beside them and run.json "written" (run by hand from
    another folder, its log there): "written" said the deck never ran, and its dumps could be
    converted while a LAMMPS /proc cannot see still wrote them. Now it is "running" while they
    change, "unlogged" after marker.QUIET, and settled only after marker.SETTLED, as a hand run
    "interrupted" by inference; a text dump counts as a binary one does."""
    folder = deck(tmp_path, make_case(particles=10, duration=1.0))
    monkeypatch.setattr(marker, "_open_for_writing", lambda *paths: False)
    assert RunFolder(folder).status == "written"
    for dump in (layout.TRAJ_BIN, layout.DUMP):
        (folder / dump).write_bytes(b"frames")
        assert RunFolder(folder).status == "running"
        then = time.time() - marker.QUIET - 1
        os.utime(folder / dump, (then, then))
        assert RunFolder(folder).status == "unlogged" and not marker.settled(folder)
        then = time.time() - marker.SETTLED - 1
        os.utime(folder / dump, (then, then))
        assert marker.settled(folder)
        (folder / dump).unlink()


def test_a_dump_held_open_by_a_lammps_run_from_elsewhere_is_still_being_written(tmp_path, capsys):
    """`lmp -in D/in.lattice` from another folder without -log holds D's traj.bin open, its
    frames more than marker.QUIET apart: /proc was asked only about D/log.lammps, which is not
    there, so D read "unlogged" while LAMMPS wrote it (summarize measured partial data), the
    refusal of --overwrite said "a LAMMPS this machine cannot see", and `pylmp-lattice lmp -in
    D/in.lattice` ran over its dumps. Now a dump held open for writing is "running": summarize,
    --overwrite and a hand run are refused as for a folder still written, nothing touched; once
    no process holds it, it is "unlogged", and the hand run waits for marker.SETTLED as
    --overwrite does, saying how long."""
    folder = deck(tmp_path, make_case(particles=10, duration=1.0))
    capsys.readouterr()
    with open(folder / layout.TRAJ_BIN, "ab") as writer:  # the LAMMPS (here this process) that writes it
        writer.write(b"frames")
        writer.flush()
        then = time.time() - marker.QUIET - 1  # its last frame written before marker.QUIET
        os.utime(folder / layout.TRAJ_BIN, (then, then))
        assert RunFolder(folder).status == "running"
        assert main(["summarize", str(folder)]) == 2
        assert main(["deck", str(tmp_path / "d.toml"), "-o", str(folder), "--overwrite"]) == 2
        assert main(["lmp", "-in", str(folder / layout.DECK)]) == 2
        assert capsys.readouterr().err.splitlines() == [
            f"pylmp-lattice: error: {folder}: still being written by LAMMPS; summarize it when the run ends",
            f"pylmp-lattice: error: output: {folder} holds a run that is still being written; wait for it or stop it",
            f"pylmp-lattice: error: -in: {folder} holds a run that is still being written; wait for it or stop it"]
    assert (folder / layout.TRAJ_BIN).read_bytes() == b"frames" and marker.read(folder)["state"] == "written"
    assert not (folder / layout.SUMMARY).exists() and not (folder / layout.LOG).exists()
    then = time.time() - marker.QUIET - 1.5
    os.utime(folder / layout.TRAJ_BIN, (then, then))
    assert RunFolder(folder).status == "unlogged"
    assert main(["lmp", "-in", str(folder / layout.DECK)]) == 2
    assert main(["deck", str(tmp_path / "d.toml"), "-o", str(folder), "--overwrite"]) == 2
    why = (f"{folder} holds a run whose {layout.TRAJ_BIN} changed 31 s ago, with no writer seen; a LAMMPS this "
           f"machine cannot see (another user's, or another machine's on a shared folder) may still write it until "
           f"it stays unchanged for 600 s: wait 569 s, ")
    assert capsys.readouterr().err.splitlines() == [
        f"pylmp-lattice: error: -in: {why}or remove its log and dumps yourself if no LAMMPS writes them",
        f"pylmp-lattice: error: output: {why}or remove the folder yourself"]
    assert (folder / layout.TRAJ_BIN).read_bytes() == b"frames" and marker.read(folder)["state"] == "written"


def test_proc_is_asked_about_the_files_there_only(tmp_path, monkeypatch):
    """With no log.lammps, `status` scanned all of /proc for it (8 ms, against 0.08 ms), a file
    that cannot be open. Now /proc is asked once, about the log if there is one, else the
    outputs the folder holds; a folder with neither is not looked for."""
    folder = deck(tmp_path, make_case(particles=10, duration=1.0))
    asked = []
    monkeypatch.setattr(marker, "_open_for_writing", lambda *paths: asked.append(paths) and False)
    then = time.time() - marker.QUIET - 1
    assert RunFolder(folder).status == "written" and marker.quiet_wait(folder) is None and asked == []
    for name in (layout.DUMP, layout.FRONT_BIN):
        (folder / name).write_bytes(b"out")
        os.utime(folder / name, (then, then))
    assert RunFolder(folder).status == "unlogged"
    assert asked == [(folder / layout.FRONT_BIN, folder / layout.DUMP)]
    (folder / layout.LOG).write_text("LAMMPS (22 Jul 2025)\nStep Time\n0 0\n")
    os.utime(folder / layout.LOG, (then, then))
    asked.clear()
    assert RunFolder(folder).status == "interrupted" and asked == [(folder / layout.LOG,)]


def test_a_hand_run_s_records_keep_the_deck_s_hash_so_an_edit_is_still_said(tmp_path):
    """`pylmp-lattice lmp` records the run "running", then how it ended, without the deck's hash:
    each record keeps the one the writer recorded, so a deck edited before the hand run is
    still said ("deck_edited") after it (mutation: `record` forgetting the earlier hash survived)."""
    folder = deck(tmp_path, make_case(particles=10, duration=1.0))
    written = marker.read(folder)[marker.DECK_HASH]
    edit(folder, "run ", "run             50")
    with marker.hand_run(folder):  # (LAMMPS not run: its end is "interrupted")
        assert marker.read(folder)["state"] == "running"
    assert marker.read(folder)["state"] == "interrupted" and marker.read(folder)[marker.DECK_HASH] == written
    assert RunFolder(folder).deck_changes() == {"deck_edited": True}


def test_an_interrupted_run_s_summary_says_the_time_its_runner_recorded(tmp_path):
    """A run recorded "interrupted" at time_ms by its runner (LAMMPS's soft stop): summary.json's
    "stopped" says that time, not the last frame's (here none was written). Mutation: the
    recorded time ignored survived."""
    folder = deck(tmp_path, make_case(particles=10, duration=1.0))
    marker.record(folder, marker.INTERRUPTED, time_ms=0.37)
    summary = RunFolder(folder).summarize(figure=False)
    assert summary["status"] == "interrupted"
    assert summary["stopped"] == {"reason": "interrupted", "time_ms": 0.37}


@lammps
def test_a_link_planted_in_a_folder_run_on_mpi_ranks_ends_the_job(tmp_path):
    """A link at log.lammps, hand run on 2 ranks: rank 0 refused it, and rank 1, which neither
    claims nor records, went on into MPI and waited there for ever for rank 0 (killed after 10
    minutes, unstoppable by SIGTERM). Rank 0 now ends the job (MPI_Abort): it ends at once with
    2 and rank 0's one line, nothing written through the link."""
    folder = deck(tmp_path, make_case(particles=40, duration=20.0))
    outside = tmp_path / "outside.log"
    (folder / layout.LOG).symlink_to(outside)
    with by_hand_on_ranks(folder, 2) as job:
        out, err = ended(job, 60)
    assert job.returncode == 2 and "log.lammps: is a symbolic link" in err, err
    assert not outside.exists() and marker.read(folder)["state"] == "written"


@lammps
def test_a_folder_held_by_another_run_ends_an_mpi_hand_run_at_once(tmp_path):
    """Rank 0 refuses a folder another run holds (its lock held here), and rank 1 waited in MPI
    for it until killed (Ctrl-C too was lost: its handler waited behind the instance being made).
    Rank 0 now ends the job: exit 2 within seconds, its one line said, the folder untouched."""
    folder = deck(tmp_path, make_case(particles=40, duration=20.0))
    with marker.claimed(folder), by_hand_on_ranks(folder, 2) as job:
        out, err = ended(job, 30)
    assert job.returncode == 2 and "still being written" in err, err
    assert marker.read(folder)["state"] == "written" and not (folder / layout.LOG).exists()


@lammps
def test_a_rank_waiting_in_mpi_stops_at_ctrl_c(tmp_path):
    """A rank of several whose instance is still being made (MPI waiting for a rank that has not
    come: here rank 1 of a job whose rank 0 sleeps before it starts) ends by the signal at once:
    its handler waited behind the instance, and Ctrl-C was lost."""
    folder = deck(tmp_path, make_case(particles=40, duration=20.0))
    job = subprocess.Popen([str(MPIEXEC), "-n", "2", sys.executable, "-c",
                            "import os, sys, time\n"
                            "if os.environ.get('PMI_RANK') == '0': time.sleep(60)\n"
                            "from pylmp_lattice.cli import main\n"
                            "sys.exit(main(['lmp', '-in', 'in.lattice', '-screen', 'none']))"],
                           cwd=folder, start_new_session=True, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    with job:
        time.sleep(3)  # rank 1 in MPI's start, waiting for rank 0
        assert job.poll() is None, "the job ended before Ctrl-C: nothing waited"
        os.killpg(job.pid, signal.SIGINT)
        out, err = ended(job, 20)
    assert job.returncode != 0
