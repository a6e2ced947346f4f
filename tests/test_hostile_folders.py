"""Damaged run folders and sweep members (issue 27, items 5 and 6): a front record cut short, a
run stopped before its second frame, a member's summary that is not ours. Each is one line
naming the file and exit 2, or a member that is simply not done; never a traceback.
"""

from __future__ import annotations

import json
import os
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest

from pylmp_lattice.cli import main
from pylmp_lattice.formats.bindump import open_dump
from pylmp_lattice.sweep import load_results, load_sweep, run_sweep
from test_hostile_signals import hooked, state
from test_sweep import BASE

pytestmark = pytest.mark.lammps


def one_error(capsys) -> str:
    err = capsys.readouterr().err
    lines = [line for line in err.splitlines() if not line.startswith("pylmp-lattice: info")]
    assert "Traceback" not in err and lines[-1].startswith("pylmp-lattice: error: "), err
    return lines[-1]


@pytest.fixture
def finished(tmp_path, capsys):
    """A finished run of 20 magnets, 6 frames; its folder."""
    (tmp_path / "base.toml").write_text(BASE.format(particles=20, duration=5.0, output=1.0))
    assert main(["run", str(tmp_path / "base.toml"), "-o", str(tmp_path / "r"), "--quiet"]) == 0
    capsys.readouterr()
    return tmp_path / "r"


@pytest.mark.parametrize("keep", [0, 10, 100, 1000])
def test_summarize_of_a_front_record_cut_short_names_the_file(finished, capsys, keep):
    record = finished / "front.bin"
    record.write_bytes(record.read_bytes()[:keep])
    assert main(["summarize", str(finished)]) == 2
    line = one_error(capsys)
    assert line.startswith(f"pylmp-lattice: error: {record}: "), line


def test_summarize_of_a_trajectory_of_one_frame_names_the_folder(tmp_path, capsys, monkeypatch):
    """Without a front record the front comes from the trajectory, and one frame has none: a run
    whose binary dump holds one frame (stopped before its conversion, the record removed)."""
    (tmp_path / "base.toml").write_text(BASE.format(particles=20, duration=5.0, output=1.0))
    stopped = hooked(tmp_path, "pylmp_lattice.run_folder.execution:convert_claimed", ["run", "base.toml", "-o", "r"])
    assert stopped.returncode == 143 and state(tmp_path / "r") == "done", stopped.stderr
    dump = tmp_path / "r" / "traj.bin"
    dump.write_bytes(dump.read_bytes()[:open_dump(dump).frame_dtype.itemsize])
    (tmp_path / "r" / "front.bin").unlink()
    monkeypatch.chdir(tmp_path)
    assert main(["summarize", "r"]) == 2
    assert one_error(capsys).startswith("pylmp-lattice: error: r: holds 1 frame(s) of its trajectory")


def test_summarize_of_a_run_interrupted_before_its_second_step_names_the_record(tmp_path, capsys, monkeypatch):
    (tmp_path / "base.toml").write_text(BASE.format(particles=20, duration=5.0, output=1.0))
    stopped = hooked(tmp_path, "pylmp_lattice.runner:new_lammps", ["run", "base.toml", "-o", "r", "--quiet"])
    assert stopped.returncode == 143 and state(tmp_path / "r") == "interrupted", stopped.stderr
    monkeypatch.chdir(tmp_path)
    assert main(["summarize", "r"]) == 2
    assert one_error(capsys) == ("pylmp-lattice: error: r/front.bin: the record ends at t = 0 ms, "
                                 "before the run's first step (0.01 ms); nothing to measure")


SWEEP = 'base = "base.toml"\n[grid]\n"impactor.velocity" = [0.5, 0.6]\n'


def sweep_here(tmp_path):
    (tmp_path / "base.toml").write_text(BASE.format(particles=8, duration=5.0, output=1.0))
    (tmp_path / "sweep.toml").write_text(SWEEP)
    with ThreadPoolExecutor(1) as pool:
        return run_sweep(load_sweep(tmp_path / "sweep.toml"), tmp_path / "out", executor=pool, slots=1,
                         progress=False)


@pytest.mark.parametrize("summary", ["[1]", '{"particles": NaN}', "NaN", '"done"'])
def test_a_member_whose_summary_is_not_ours_is_not_done_and_runs_again(tmp_path, summary):
    """A resume used to fail on `[1]` (a list has no items) and keep `NaN` as done."""
    first = sweep_here(tmp_path)
    assert set(first["status"]) == {"done"}
    member = tmp_path / "out" / first["folder"][0]
    (member / "summary.json").write_text(summary)
    again = sweep_here(tmp_path)
    assert set(again["status"]) == {"done"}
    assert json.loads((member / "summary.json").read_text())["particles"] == 8  # run again, its summary whole
    for column in ("linear_wave_speed_V0_m_per_s", "particles_reached_by_front", "first_peak_velocity_over_V_I"):
        assert np.allclose(again[column].astype(float), first[column].astype(float), rtol=1e-12, equal_nan=True)
    assert list(load_results(tmp_path / "out")["status"]) == ["done", "done"]


def test_open_dump_of_the_front_record_counts_its_frame(finished):
    """The check above stands on this: a whole record is one frame."""
    assert open_dump(finished / "front.bin").frames == 1


def test_a_full_disk_leaves_run_json_recorded_and_no_temporary_file(tmp_path, monkeypatch):
    """As another process filling the disk mid-run does (ENOSPC on the new file): run.json is
    rewritten in place, never left "running", and no 0-byte run.json.tmp stays."""
    import errno
    from pathlib import Path

    from pylmp_lattice.run_folder import marker

    marker.record(tmp_path, marker.RUNNING)
    real = Path.write_bytes

    def full(self, data):
        if self.name.endswith(".tmp"):
            real(self, b"")  # the file is created, its data does not fit
            raise OSError(errno.ENOSPC, "No space left on device")
        return real(self, data)

    monkeypatch.setattr(Path, "write_bytes", full)
    marker.record(tmp_path, marker.INTERRUPTED, time_ms=12.5)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run.json"]
    assert marker.read(tmp_path)["state"] == "interrupted" and marker.read(tmp_path)["time_ms"] == 12.5


def test_a_running_record_names_its_writer_and_a_gone_writer_is_known(tmp_path):
    import os
    import socket
    import subprocess
    import sys

    from pylmp_lattice.run_folder import marker

    marker.record(tmp_path, marker.RUNNING)
    data = marker.read(tmp_path)
    assert data["pid"] == os.getpid() and data["host"] == socket.gethostname()
    assert not marker.writer_gone(data)  # this process runs
    child = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True, text=True)
    assert marker.writer_gone(data | {"pid": int(child.stdout)})  # ended
    assert not marker.writer_gone(data | {"pid": int(child.stdout), "host": "elsewhere"})  # /proc cannot tell
    assert not marker.writer_gone(data | {"pid": "1; rm -rf /"}) and not marker.writer_gone({"state": "done"})


@pytest.mark.parametrize("code, signum", [(-9, 9), (247, 9), (137, 9), (143, 15), (1, None), (255, None), (3, None)])
def test_a_killed_lmp_names_its_signal(code, signum):
    """The wheel's `lmp` is a Python wrapper that exits with its child's -9 as 247: it used to
    read "lmp exited with code 247"."""
    from pylmp_lattice.runner import _killed_by

    assert _killed_by(code) == signum


def test_a_killed_lmp_run_says_killed_by_sigkill(tmp_path, capsys):
    import os
    import signal
    import subprocess
    import sys
    import time

    (tmp_path / "base.toml").write_text(BASE.format(particles=400, duration=2000.0, output=10.0))
    proc = subprocess.Popen([sys.executable, "-m", "pylmp_lattice.cli", "run", "base.toml", "-o", "r", "--quiet",
                             "--runner", "lmp"], cwd=tmp_path, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                            text=True)
    log = tmp_path / "r" / "log.lammps"
    while "Step" not in (log.read_text() if log.exists() else ""):
        assert proc.poll() is None, proc.stderr.read()
        time.sleep(0.05)
    engines = [int(p.parent.name) for p in __import__("pathlib").Path("/proc").glob("[0-9]*/exe")
               if _exe(p).endswith("/lammps/lmp") and _cwd(p.parent) == str((tmp_path / "r").resolve())]
    assert engines
    for pid in engines:
        os.kill(pid, signal.SIGKILL)
    err = proc.communicate(timeout=60)[1]
    assert proc.returncode == 1
    assert "lmp was killed by signal SIGKILL" in err.splitlines()[-1], err
    assert state(tmp_path / "r") == "failed"


def _exe(link) -> str:
    try:
        return os.readlink(link)
    except OSError:
        return ""


def _cwd(proc) -> str:
    try:
        return os.readlink(proc / "cwd")
    except OSError:
        return ""


def test_more_workers_than_cores_warns_once(tmp_path, caplog, monkeypatch):
    import os

    monkeypatch.setattr(os, "cpu_count", lambda: 1)
    (tmp_path / "base.toml").write_text(BASE.format(particles=8, duration=1.0, output=1.0))
    (tmp_path / "sweep.toml").write_text('base = "base.toml"\n[grid]\n"impactor.velocity" = [0.5]\n')
    run_sweep(load_sweep(tmp_path / "sweep.toml"), tmp_path / "out", workers=3, progress=False)
    warned = [r.getMessage() for r in caplog.records if "cores" in r.getMessage()]
    assert warned == ["--workers 3 is more than this machine's 1 cores: the members share them (each runs slower, "
                      "and each worker holds its own engine in memory)"]


NO_SPACE = "ERROR on proc 0: Error writing dump traj: No space left on device"


def test_a_disk_full_for_lammps_mid_run_names_the_dump_and_run_json_says_failed(tmp_path, capsys, monkeypatch):
    """LAMMPS stops on a full disk (its ERROR line names the dump ID): one line naming the file,
    exit 1, run.json "failed" with it; the conversion of what was written, refused for want of
    room, does not hide it (it gave a bare "no space ... topology.psf" before)."""
    from pylmp_lattice import runner
    from pylmp_lattice.errors import RunError
    from pylmp_lattice.run_folder import convert

    real = runner.run_deck

    def filled(path, *args, **kwargs):
        real(path, *args, **kwargs)  # dumps written; then the disk is full
        monkeypatch.setattr(convert, "free_bytes", lambda folder: 0)
        raise RunError(NO_SPACE, path)

    monkeypatch.setattr(runner, "run_deck", filled)
    (tmp_path / "base.toml").write_text(BASE.format(particles=20, duration=5.0, output=1.0))
    folder = tmp_path / "r"
    assert main(["run", str(tmp_path / "base.toml"), "-o", str(folder), "--quiet"]) == 1
    line = one_error(capsys)
    assert line == (f"pylmp-lattice: error: no space left on the device for {folder / 'traj.bin'}; LAMMPS stopped "
                    f"({NO_SPACE}); the files are kept"), line
    record = json.loads((folder / "run.json").read_text())
    assert record["state"] == "failed" and record["error"].startswith(f"{folder / 'traj.bin'}: no space left")
    assert (folder / "traj.bin").is_file() and not list(folder.glob("*.part"))


@pytest.mark.parametrize("how", ["checked", "reserved"])
def test_a_disk_full_for_the_h5md_file_keeps_the_dumps_and_names_the_file(tmp_path, capsys, monkeypatch, how):
    """A finished run whose H5MD file does not fit: one line naming traj.h5md, exit 1, the binary
    dumps kept, no part file or held lock, run.json "done"; with room again, summarize converts.
    checked: the free space is below the dumps' size; reserved: it shrank after the check (another
    process), so the reservation fails. HDF5 that ran out of room mid-file crashed the process
    (a segmentation fault, seen on a 45 MB tmpfs), which the reservation prevents."""
    import errno

    from pylmp_lattice.formats import h5md
    from pylmp_lattice.run_folder import convert, marker

    real = convert.convert_claimed
    if how == "checked":
        def full(claimed):
            monkeypatch.setattr(convert, "free_bytes", lambda folder: 1000)
            return real(claimed)
    else:
        def no_room(fd, size):
            raise OSError(errno.ENOSPC, "No space left on device")

        def full(claimed):
            monkeypatch.setattr(h5md, "_reserve", no_room)
            return real(claimed)
    monkeypatch.setattr("pylmp_lattice.run_folder.execution.convert_claimed", full)
    (tmp_path / "base.toml").write_text(BASE.format(particles=20, duration=5.0, output=1.0))
    folder = tmp_path / "r"
    assert main(["run", str(tmp_path / "base.toml"), "-o", str(folder), "--quiet"]) == 1
    line = one_error(capsys)
    assert line.startswith(f"pylmp-lattice: error: no space left on the device for {folder / 'traj.h5md'}"), line
    if how == "checked":
        assert "needs up to 1.0" in line and "MB, 0.001 MB free; they are kept" in line, line
    assert {"traj.bin", "front.bin"} <= {p.name for p in folder.iterdir()}
    assert not (folder / "traj.h5md").exists() and not list(folder.glob("*.part")) and not list(folder.glob(".*tmp"))
    assert marker.read(folder)["state"] == "done" and not marker.locked(folder)
    monkeypatch.undo()
    assert main(["summarize", str(folder)]) == 0
    assert (folder / "traj.h5md").is_file() and not (folder / "traj.bin").exists()


@pytest.fixture
def dumped(tmp_path):
    """A run of 20 magnets, 6 frames, whose binary dumps are not converted yet; its folder and case."""
    from pylmp_lattice.case import load_case
    from pylmp_lattice.run_folder import write_folder
    from pylmp_lattice.runner import run_deck

    (tmp_path / "base.toml").write_text(BASE.format(particles=20, duration=5.0, output=1.0))
    case = load_case(tmp_path / "base.toml")
    folder = write_folder(case, tmp_path / "r")
    run_deck(folder)
    return folder, case


def test_the_h5md_reservation_holds_the_whole_file(dumped):
    """The bytes reserved before HDF5 writes cover the file it writes: a small run's file is
    mostly HDF5's own (it reserved the dumps' 3 kB for a 100 kB file, and HDF5 ran out of room
    past them on a disk filled mid-sweep)."""
    from pylmp_lattice.run_folder import convert

    folder, case = dumped
    sources = {"chain": open_dump(folder / "traj.bin")}
    need = convert._check_room(folder, sources)
    assert convert._convert(folder, case)
    assert (folder / "traj.h5md").stat().st_size <= need


@pytest.mark.parametrize("cap", [1e9, 1e3])
def test_without_a_reservation_a_file_over_the_cap_is_written_directly_not_held_twice_in_memory(dumped, monkeypatch,
                                                                                             caplog, cap):
    """Where nothing can be reserved, HDF5 writes an image in memory that Python then copies out:
    the file twice in RAM. Up to h5md.IMAGE_BYTES that is how it writes (HDF5's core driver, no
    warning); a file that may be larger (the reservation it asked for: here the dumps' 3 kB and
    H5MD_OVERHEAD, over a cap of 1 kB) is written by HDF5 into the file itself, with one warning
    naming the file, its size and the cap. Either way the file verifies and the dumps go."""
    from pylmp_lattice.formats import h5md
    from pylmp_lattice.run_folder import convert

    folder, case = dumped
    drivers = []
    write = h5md._write_h5md
    monkeypatch.setattr(h5md, "_reserve", lambda fd, size: False)  # a file system without fallocate
    monkeypatch.setattr(h5md, "IMAGE_BYTES", cap)
    monkeypatch.setattr(h5md, "_write_h5md", lambda h5, *args: (drivers.append(h5.driver), write(h5, *args))[1])
    need = convert._check_room(folder, {"chain": open_dump(folder / "traj.bin")})
    with caplog.at_level("WARNING", logger="pylmp_lattice.formats.h5md"):
        assert convert._convert(folder, case)
    assert drivers == (["core"] if cap == 1e9 else ["fileobj"])
    warned = [r.getMessage() for r in caplog.records if r.name == "pylmp_lattice.formats.h5md"]
    if cap == 1e9:
        assert warned == []
    else:
        assert len(warned) == 1 and f"traj.h5md: up to {need / 1e6:.3g} MB, over the" \
            in warned[0] and "over the 0.001 MB cap for writing through memory" in warned[0], warned
    assert h5md.frame_count(folder / "traj.h5md", "chain")[0] == 6 and not (folder / "traj.bin").exists()


FAILED_THEN_GOOD = """
import builtins, errno, io, sys
from pathlib import Path
from pylmp_lattice import load_case
from pylmp_lattice.formats import files, h5md
from pylmp_lattice.run_folder import convert

folder = Path(sys.argv[1])
case = load_case(folder / "case.toml")


class Full(io.FileIO):
    room = 30_000  # of a 100 kB file: the disk fills mid-file

    def write(self, data):
        Full.room -= len(memoryview(data))
        if Full.room < 0:
            raise OSError(errno.ENOSPC, "No space left on device")
        return super().write(data)


reserve = h5md._reserve
h5md.open = lambda path, mode="r": io.BufferedRandom(Full(path, "w+")) if str(path).endswith(".part") else open(path, mode)
h5md._reserve = lambda fd, size: False  # a file system without fallocate
try:
    convert._convert(folder, case)
except files.DiskFull as err:
    print("failed:", err)
h5md._reserve = reserve
del h5md.open  # room again: the same process converts, closes HDF5's files, exits
assert not (folder / "traj.h5md").exists() and (folder / "traj.bin").is_file()
convert._convert(folder, case)
print("frames:", h5md.frame_count(folder / "traj.h5md", "chain")[0])
"""


def test_a_failed_h5md_write_is_one_error_and_leaves_hdf5_whole(dumped):
    """Where nothing could be reserved (a file system without fallocate), a write that fails
    mid-file is DiskFull naming traj.h5md, and the process goes on: HDF5 writing into a failing
    Python file printed a traceback per h5py object and kept the half-closed file in its state,
    which crashed a later close (the suite segfaulted two tests later, or at exit). A child
    process: a crash there fails this test, not the suite."""
    import subprocess
    import sys

    folder, _ = dumped
    done = subprocess.run([sys.executable, "-c", FAILED_THEN_GOOD, str(folder)], capture_output=True, text=True,
                          timeout=120)
    assert done.returncode == 0, done.stderr[-3000:]
    assert "failed:" in done.stdout and "traj.h5md" in done.stdout, done.stdout
    assert "frames: 6" in done.stdout, done.stdout  # 5 ms of 1 ms frames and the first
    assert "Traceback" not in done.stderr and "Exception ignored" not in done.stderr, done.stderr


def test_the_reservation_allocates_the_blocks_and_the_file_keeps_its_length(tmp_path):
    """What the H5MD writer stands on: fallocate(KEEP_SIZE) holds the bytes on the disk, the
    length stays 0 for HDF5 to write from, and the blocks beyond it go once released."""
    from pylmp_lattice.formats import h5md

    path = tmp_path / "f"
    with open(path, "w+b") as f:
        h5md._reserve(f.fileno(), 4_000_000)
        if os.fstat(f.fileno()).st_blocks == 0:
            pytest.skip("this file system does not reserve (fallocate unsupported)")
        assert os.fstat(f.fileno()).st_size == 0 and os.fstat(f.fileno()).st_blocks * 512 >= 4_000_000
        with h5md._released(f):
            f.write(b"x" * 1000)
    assert path.stat().st_size == 1000 and path.stat().st_blocks * 512 < 100_000
