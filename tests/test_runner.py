"""Running decks: contact detection, failures that keep their files, lmp vs embedded."""

from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest
import tomli_w

from pylmp_lattice.case import case_to_dict, load_case
from pylmp_lattice import runner
from pylmp_lattice.formats.bindump import open_dump
from pylmp_lattice.errors import ContactError, RunError
from pylmp_lattice.runner import run_embedded, run_executable
from pylmp_lattice.run_folder import RunFolder, simulate

from conftest import make_case

pytestmark = pytest.mark.lammps
INPUTS = Path(__file__).parent.parent / "inputs"


def test_paper_chain_driven_into_its_fixed_end_stops_on_contact(tmp_path):
    """21 magnets, constant 2 m/s into the fixed end: two magnets meet before ~0.08-0.1 s."""
    case = make_case(particles=21, velocity=2.0, duration=200.0)
    with pytest.raises(ContactError) as info:
        simulate(case, tmp_path)
    err = info.value
    assert 60.0 < err.time_ms < 100.0
    assert err.pair[1] == err.pair[0] + 1 and 1 <= err.pair[0] < 21
    assert err.gap_mm <= 0 and str(tmp_path) in str(err)
    # what was written up to the stop stays readable: frames up to the contact time
    traj = RunFolder(tmp_path).trajectory()
    assert traj.t[-1] == pytest.approx(err.time_ms, abs=0.1 + 1e-9)
    assert len(traj.t) == round(traj.t[-1] / 0.1) + 1
    log_lines = (tmp_path / "log.lammps").read_text().splitlines()
    assert sum(line.startswith("CONTACT: magnets") for line in log_lines) == 1


def test_cli_reports_contact_in_one_line(tmp_path):
    case_file = tmp_path / "into_the_wall.toml"
    case_file.write_bytes(tomli_w.dumps(case_to_dict(make_case(particles=21, velocity=2.0, duration=200.0))).encode())
    done = subprocess.run(
        [sys.executable, "-m", "pylmp_lattice.cli", "run", str(case_file), "-o", str(tmp_path / "run"), "--quiet"],
        capture_output=True, text=True, cwd=tmp_path,
    )
    assert done.returncode == 1
    errors = [line for line in done.stderr.splitlines() if "error" in line]
    # the chain engine checks every step: the contact's exact step (see test_engine)
    assert len(errors) == 1 and "magnets 19 and 20 touched" in errors[0] and "t = 68.5600 ms" in errors[0]
    assert "Traceback" not in done.stderr and (tmp_path / "run" / "traj.h5md").exists()


def test_deck_runs_unchanged_with_lmp_and_matches_embedded(tmp_path):
    case = make_case(particles=30, velocity=2.0, duration=40.0)
    a = run_embedded(RunFolder.create(case, tmp_path / "embedded").path)
    b = run_executable(RunFolder.create(case, tmp_path / "lmp").path)
    fa, fb = open_dump(a / "traj.bin").read(), open_dump(b / "traj.bin").read()
    assert fa.data.shape == fb.data.shape == (401, 30, 4)
    assert np.array_equal(fa.data, fb.data) and np.array_equal(fa.time, fb.time)


def test_lammps_error_is_reported_with_its_error_line(tmp_path):
    # a short pulse: once the impactor stops, the chain runs away from it and gap 1-2 opens
    case = make_case(particles=10, velocity=2.0, duration=60.0, table={"r_max": 13.0},
                     impactor={"profile": "sine", "velocity": 2.0, "duration": 5.0})
    folder = RunFolder.create(case, tmp_path).path
    with pytest.raises(RunError, match=r"magnets \d+ and \d+ outside the table range") as info:
        run_embedded(folder)
    assert info.value.folder == folder.resolve()
    # the length LAMMPS names (m) is reported in mm, without LAMMPS's source location
    assert re.search(r"type 1 length 13\.\d+ mm \(files kept in ", str(info.value))
    # so are the table range and the time, in the case's mm and ms (not m and s beside mm)
    assert re.search(r"outside the table range \[0, 13\] mm at t = [\d.]+ ms ", str(info.value))
    assert "src/" not in str(info.value)


def test_killed_lmp_is_reported_as_killed(tmp_path, monkeypatch):
    """SIGKILL from outside (e.g. the OOM killer) to lmp's process group (the `lmp` wrapper and
    the engine it starts): one message naming the signal, files kept."""
    started = []

    class Recorded(subprocess.Popen):
        def __init__(self, *args, **kwargs):
            super().__init__(*args, **kwargs)
            started.append(self)

    def killer():
        while not started or not (tmp_path / "traj.bin").exists():
            time.sleep(0.05)
        os.killpg(started[0].pid, signal.SIGKILL)

    monkeypatch.setattr(runner.subprocess, "Popen", Recorded)
    folder = RunFolder.create(load_case(INPUTS / "paper_long_lattice.toml"), tmp_path).path
    threading.Thread(target=killer, daemon=True).start()
    with pytest.raises(RunError, match=r"^lmp was killed by signal SIGKILL \(files kept in ") as info:
        run_executable(folder)
    assert info.value.exit_code == -signal.SIGKILL


def test_sigint_stops_lmp_also_when_the_caller_ignored_it(tmp_path):
    """A command started with SIGINT ignored (`cmd &` in a shell script without job control)
    still stops on SIGINT, as the embedded runner does: lmp must not inherit the ignored
    disposition, else the forwarded signal is lost and the run goes on to its end."""
    case = load_case(INPUTS / "paper_long_lattice.toml", ["run.duration=3000", "output.format=none"])
    folder = RunFolder.create(case, tmp_path).path

    def interrupt():
        while not (tmp_path / "log.lammps").exists() or "Step" not in (tmp_path / "log.lammps").read_text():
            time.sleep(0.05)
        os.kill(os.getpid(), signal.SIGINT)

    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        threading.Thread(target=interrupt, daemon=True).start()
        with pytest.raises(runner.Interrupted) as info:
            run_executable(folder)
    finally:
        signal.signal(signal.SIGINT, previous)
    # 3000 ms take about 2 s here; stopped at the signal, it ends in the first few hundred ms
    assert info.value.time_ms is not None and info.value.time_ms < 1500.0


@pytest.mark.slow  # MPI bit identity: several lmp runs under mpiexec
def test_two_mpi_ranks_give_the_same_trajectory_with_friction(tmp_path):
    """The package's deck (friction on) on 1 and 2 ranks: identical dumps and front records
    (paper experiment); two ranks write two chunks per binary frame."""
    case = load_case(INPUTS / "paper_experiment.toml")
    one, two = (run_executable(RunFolder.create(case, tmp_path / f"np{n}").path, nprocs=n) for n in (1, 2))
    assert "2 by 1 by 1 MPI processor grid" in (tmp_path / "np2" / "log.lammps").read_text()
    for name in ("traj.bin", "front.bin"):
        a, b = open_dump(one / name), open_dump(two / name)
        assert b.frame_dtype is None or name == "front.bin"  # several chunks: walked frame by frame
        assert np.array_equal(a.read().data, b.read().data, equal_nan=True)


def test_motion_stays_on_the_x_axis(tmp_path):
    """y, z, vy, vz, fy, fz are exactly zero in every frame of a strong-shock run."""
    simulate(make_case(particles=30, velocity=2.0, duration=60.0, output={"format": "text"}), tmp_path)
    rows = [line.split() for line in (tmp_path / "traj.dump").read_text().splitlines()
            if len(line.split()) == 12]
    columns = np.array(rows, dtype=float)  # id type mass x y z vx vy vz fx fy fz
    assert len(columns) == 601 * 30
    assert np.all(columns[:, [4, 5, 7, 8, 10, 11]] == 0.0)


@pytest.mark.lammps
def test_runs_in_threads_take_turns_and_each_gets_its_own_run(tmp_path):
    """Four embedded runs started together in threads (LAMMPS with MPI cannot hold two
    instances side by side in a process: it crashed or failed with 'Unrecognized fix style'):
    they take turns on engine.ONE_INSTANCE, all finish, and each equals its run alone."""
    cases = [make_case(particles=21, velocity=v, duration=40.0, interval=0.5) for v in (1.0, 1.5, 2.0, 2.5)]
    results, errors = {}, []

    def one(k):
        try:
            results[k] = simulate(cases[k], tmp_path / f"thread{k}")
        except Exception as err:  # noqa: BLE001 (reported below)
            errors.append(err)

    threads = [threading.Thread(target=one, args=(k,)) for k in range(len(cases))]
    for t in threads:
        t.start()
    for t in threads:
        t.join(120)
    assert not errors and len(results) == len(cases)
    for k, case in enumerate(cases):
        alone = simulate(case, tmp_path / f"alone{k}")
        assert np.array_equal(results[k].v, alone.v) and np.max(np.abs(alone.v)) > 0.5
