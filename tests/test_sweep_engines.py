"""Sweeps with --engine cpu (the chain kernel on every core) and gpu against the default,
LAMMPS: the same results table, replica statistics, batch folders and resume; members the
kernel cannot run fall back to LAMMPS with a note; Ctrl-C stops the C engine within 2 s."""

from __future__ import annotations

import json
import logging
import math
import os
import signal
import subprocess
import sys
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from pylmp_lattice.cli import main
from pylmp_lattice.run_folder.marker import DONE
from pylmp_lattice.sweep import load_sweep, replica_stats, run_sweep
from pylmp_lattice.sweep.store import BATCH_FILE, Outcomes

ROOT = Path(__file__).resolve().parents[1]
EXPERIMENT = ROOT / "inputs" / "paper_experiment.toml"  # 21 magnets, friction on the rod, 4800 steps
ENSEMBLES = {
    "thermal with friction": '"chain.thermal_velocity" = 0.02\n',
    "mass disorder": '"chain.mass_disorder" = 0.02\n"chain.disorder" = "uniform"\n',
}


def write_sweep(folder: Path, replicas: int, extra: str, duration: float | None = None, keep: str = "measures") -> Path:
    path = folder / "sweep.toml"
    path.write_text(f'base = "{EXPERIMENT}"\nreplicas = {replicas}\nseed = 11\nkeep = "{keep}"\n[set]\n{extra}'
                    + (f'"run.duration" = {duration}\n' if duration else ""))
    return path


def sweep_in_process(path: Path, out: Path, engine: str) -> pd.DataFrame:
    with ThreadPoolExecutor(1) as pool:
        return run_sweep(load_sweep(path), out, executor=pool, slots=1, progress=False, engine=engine)


def assert_same_table(a: pd.DataFrame, b: pd.DataFrame, rtol: float = 1e-9) -> None:
    """Equal ids, statuses, folders' kind and every other column; numbers within rtol (measures)."""
    a, b = a.set_index("id").sort_index(), b.set_index("id").sort_index()
    assert list(a.columns) == list(b.columns) and list(a.index) == list(b.index)
    for column in a.columns.drop("wall_time_s"):
        if a[column].dtype.kind == "f":
            np.testing.assert_allclose(b[column], a[column], rtol=rtol, atol=0, equal_nan=True, err_msg=column)
        else:
            assert list(a[column]) == list(b[column]), column


@pytest.mark.lammps
@pytest.mark.parametrize("ensemble", ENSEMBLES)
def test_the_cpu_engine_gives_the_lammps_results_table(tmp_path, ensemble):
    """Six replicas of the 21-magnet experiment (friction on the rod), one batch each way: the
    table's measures within 1e-9 (the kernel is the fixes' physics: in fact bit for bit), the
    replica statistics alike, and the batch folders hold the same files but the log, the data
    and the levels file, which the kernel does not read: `write_folder` of the batch's cases
    writes the LAMMPS batch's deck, data and levels files again, byte for byte."""
    from pylmp_lattice.formats.layout import DATA, DECK, FRONT_LEVELS
    from pylmp_lattice.run_folder import RunFolder, write_folder

    path = write_sweep(tmp_path, 6, ENSEMBLES[ensemble])
    lammps = sweep_in_process(path, tmp_path / "lammps", "lammps")
    cpu = sweep_in_process(path, tmp_path / "cpu", "cpu")
    assert set(cpu["status"]) == {"done"} and cpu["shock_velocity_max_m_per_s.value"].nunique() == 6
    assert_same_table(lammps, cpu)
    assert "friction_dissipated_energy_mJ" in cpu and cpu["friction_dissipated_energy_mJ"].gt(0).all()
    pd.testing.assert_frame_equal(replica_stats(cpu), replica_stats(lammps), rtol=1e-9)
    disk = Outcomes(tmp_path / "cpu")
    records = [disk.get(i)["record"] for i in cpu["id"]]
    assert {r["engine"] for r in records} == {"cpu"} and len({r["batch"] for r in records}) == 1
    folder = tmp_path / "cpu" / records[0]["batch"]
    same = tmp_path / "lammps" / records[0]["batch"]
    assert sorted(p.name for p in folder.iterdir()) == sorted(p.name for p in same.iterdir()
                                                           if p.name not in (DATA, FRONT_LEVELS))
    assert (folder / "front.bin").read_bytes()[:200] != b"" and "cpu engine" in (folder / "log.lammps").read_text()
    again = write_folder(RunFolder(folder).cases, tmp_path / "again")  # as the log says
    assert "write_folder(RunFolder(THIS).cases, NEW)" in (folder / "log.lammps").read_text()
    assert (same / FRONT_LEVELS).exists() == ensemble.startswith("thermal")  # each chain its noise's levels
    for name in (DECK, DATA, FRONT_LEVELS):
        texts = [p.read_bytes() if p.exists() else None for p in (again / name, same / name)]
        assert texts[0] == texts[1] and (texts[0] is not None or name == FRONT_LEVELS), name
    states = [json.loads((f / "run.json").read_text())["state"] for f in (folder, same)]
    assert states == [DONE, DONE]


@pytest.mark.lammps
def test_members_the_kernel_cannot_run_fall_back_to_lammps_with_one_note(tmp_path, caplog, monkeypatch):
    """A batch the kernel refuses runs with LAMMPS (its record says so) and the log has one
    line for it, however many batches; so does a member that runs alone (trajectories kept)."""
    from pylmp_lattice.engines import road
    from pylmp_lattice.engines.library import Unsupported

    def refuse(cases, kind, draws=None):
        raise Unsupported("refused by this test")

    monkeypatch.setattr(road, "prepare", refuse)
    path = write_sweep(tmp_path, 4, ENSEMBLES["thermal with friction"], duration=10.0)
    with caplog.at_level(logging.WARNING, logger="pylmp_lattice"):
        table = sweep_in_process(path, tmp_path / "out", "cpu")
        alone = sweep_in_process(write_sweep(tmp_path, 2, ENSEMBLES["mass disorder"], duration=5.0, keep="all"),
                                 tmp_path / "alone", "cpu")
    assert set(table["status"]) == set(alone["status"]) == {"done"}
    disk = Outcomes(tmp_path / "out")
    assert {disk.get(i)["record"]["engine"] for i in table["id"]} == {"lammps"}
    notes = [r.getMessage() for r in caplog.records if "run with LAMMPS" in r.getMessage()]
    assert len([n for n in notes if "refused by this test" in n]) == 1, notes
    assert len([n for n in notes if "a batch cannot hold" in n]) == 1, notes


@pytest.mark.lammps
def test_a_grid_of_single_members_runs_on_the_kernel_as_lammps_runs_it(tmp_path, caplog):
    """A parameter grid with one member a point (and a task's odd member) runs on the kernel, in
    batches of one, with no note: each such member ran alone with LAMMPS, said as "cannot run"
    (trial: 60 velocities took 4.1 s and 43 MB, 3 replicas of each 1.8 s and 1.2 MB). The same
    table as LAMMPS's, every column within 1e-9 but the folder."""
    sweep = tmp_path / "grid.toml"
    sweep.write_text(f'base = "{EXPERIMENT}"\nkeep = "measures"\n[set]\n"run.duration" = 10.0\n'
                     '"chain.thermal_velocity" = 0.02\n[grid]\n"impactor.velocity" = [1.5, 2.0, 2.5]\n')
    with caplog.at_level(logging.WARNING, logger="pylmp_lattice"):
        table = sweep_in_process(sweep, tmp_path / "cpu", "cpu")
    assert not [r.getMessage() for r in caplog.records if "run with LAMMPS" in r.getMessage()]
    disk = Outcomes(tmp_path / "cpu")
    assert [disk.get(i)["record"]["engine"] for i in table["id"]] == ["cpu"] * 3
    assert not (tmp_path / "cpu" / "members").exists() or not any((tmp_path / "cpu" / "members").iterdir())
    assert list(table["folder"].str.split("/").str[0]) == ["batches"] * 3
    lammps = sweep_in_process(sweep, tmp_path / "lammps", "lammps")
    assert list(lammps["folder"].str.split("/").str[0]) == ["members"] * 3  # LAMMPS: each in its own run folder
    assert_same_table(lammps.drop(columns="folder"), table.drop(columns="folder"))


@pytest.mark.lammps
def test_the_fallback_note_is_said_once_by_the_command_however_many_workers(tmp_path):
    """Members that run alone under engine cpu (trajectories kept), on 2 local workers: the
    command says so once, with its prefix, where each worker used to print it itself, bare."""
    sweep = tmp_path / "all.toml"
    sweep.write_text(f'base = "{EXPERIMENT}"\nkeep = "all"\n[set]\n"run.duration" = 2.0\n'
                     '[grid]\n"impactor.velocity" = [1.0, 2.0, 3.0, 4.0]\n')
    done = subprocess.run([sys.executable, "-m", "pylmp_lattice", "sweep", str(sweep), "-o", str(tmp_path / "out"),
                           "--engine", "cpu", "--workers", "2", "--quiet"], capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    notes = [line for line in done.stderr.splitlines() if "cannot run some members" in line]
    assert notes == ["pylmp-lattice: warning: engine cpu cannot run some members (a member a batch cannot hold "
                     "(trajectories kept, no front record, or a setup of LAMMPS's own engine)): they run with LAMMPS"], \
        done.stderr


def test_a_host_build_of_another_abi_is_noted_once_and_the_members_run_with_lammps(tmp_path, caplog, monkeypatch):
    """A latticeengine.so left from an older install (another ABI): every batch runs with LAMMPS,
    and the log says why once, not a refusal hidden in each batch's run.json."""
    from pylmp_lattice.engines import library
    from pylmp_lattice.engines.library import Unsupported

    def old(*_a):
        raise Unsupported("latticeengine.so has ABI 3; this package needs 4: reinstall it")

    monkeypatch.setattr(library, "_LOADED", [])
    monkeypatch.setattr(library, "_load", old)
    with caplog.at_level(logging.WARNING, logger="pylmp_lattice"):
        table = sweep_in_process(write_sweep(tmp_path, 4, ENSEMBLES["thermal with friction"], duration=5.0),
                                 tmp_path / "out", "cpu")
    assert set(table["status"]) == {"done"}
    assert {Outcomes(tmp_path / "out").get(i)["record"]["engine"] for i in table["id"]} == {"lammps"}
    notes = [r.getMessage() for r in caplog.records if "run with LAMMPS" in r.getMessage()]
    assert notes == ["engine cpu cannot run some members (latticeengine.so has ABI 3; this package needs 4: reinstall "
                     "it): they run with LAMMPS"]


@pytest.mark.lammps
def test_a_cpu_sweep_resumes_only_what_is_missing(tmp_path):
    """A batch whose members.json is gone runs again (only it), and the table is as before;
    a sweep run with LAMMPS resumes with the cpu engine (the engine is not the sweep's identity)."""
    path = write_sweep(tmp_path, 4, ENSEMBLES["thermal with friction"], duration=10.0)
    out = tmp_path / "out"
    first = sweep_in_process(path, out, "lammps")
    batches = sorted((out / "batches").glob(f"*/{BATCH_FILE}"))
    assert len(batches) == 1
    stamp = batches[0].stat().st_mtime_ns
    again = sweep_in_process(path, out, "cpu")
    assert batches[0].stat().st_mtime_ns == stamp  # kept, not run again
    batches[0].unlink()
    third = sweep_in_process(path, out, "cpu")
    assert Outcomes(out).get(third["id"][0])["record"]["engine"] == "cpu"
    assert_same_table(first, again) and assert_same_table(first, third)


def test_a_sweep_that_overwrites_another_batches_its_members_as_in_a_new_folder(tmp_path, caplog):
    """--overwrite leaves the other sweep's 4 outcomes on disk; they were counted as this sweep's
    done members, so its tasks were of one member each: all 4 ran alone (members/, about 0.7 MB
    each, 120x the disk estimate at 200 members), and when resumed the estimate said "4 kept
    from before" with none kept. Now they run as one batch, as in a new folder, also resumed."""
    out = tmp_path / "out"
    with ThreadPoolExecutor(1) as pool:
        run_sweep(load_sweep(write_sweep(tmp_path, 4, ENSEMBLES["thermal with friction"], duration=5.0)), out,
                  executor=pool, slots=1, progress=False, engine="cpu")
        other = tmp_path / "other.toml"
        other.write_text(write_sweep(tmp_path, 4, ENSEMBLES["thermal with friction"], duration=5.0).read_text()
                         .replace("seed = 11", "seed = 12"))
        for resumed in (False, True):
            if resumed:  # its batch stopped before it was recorded: run again, nothing kept
                (out / table["folder"][0] / BATCH_FILE).unlink()
            with caplog.at_level(logging.INFO, logger="pylmp_lattice"):
                caplog.clear()
                table = run_sweep(load_sweep(other), out, executor=pool, slots=1, progress=False, engine="cpu",
                                  overwrite=True)
            assert list(table["status"]) == [DONE] * 4
            assert table["folder"].nunique() == 1 and table["folder"][0].startswith("batches/")
            assert not any((out / "members").iterdir())
            assert "out: 4 members (" in caplog.text


def test_a_kernel_engine_s_disk_estimate_is_within_25_percent_of_what_its_sweep_writes(tmp_path):
    """A batch of the cpu or gpu engine writes no data file and no force table (the chains go to
    the kernel as arrays), which the disk check counted: 4.76 GB for 10^6 members of the
    experiment that wrote about 2.8 GB. 2000 members with engine cpu: the estimate (what
    `run_sweep` checks) against the bytes the sweep left, within 25 %, as a run's (test_preflight);
    LAMMPS's batches keep their data file (about 1.4 kB a member more)."""
    import dataclasses

    from pylmp_lattice.formats.layout import DATA
    from pylmp_lattice.preflight import file_bytes
    from pylmp_lattice.sweep.disk import member_bytes

    path = write_sweep(tmp_path, 2000, ENSEMBLES["thermal with friction"], duration=5.0)
    sweep = dataclasses.replace(load_sweep(path), engine="cpu")
    sweep_in_process(path, tmp_path / "out", "cpu")
    written = sum(f.stat().st_size for f in (tmp_path / "out").rglob("*") if f.is_file())
    assert member_bytes(sweep, 1) * 2000 == pytest.approx(written, rel=0.25)
    data = file_bytes(next(sweep.iter_members()).case)[DATA]
    assert member_bytes(dataclasses.replace(sweep, engine="lammps"), 1) > member_bytes(sweep, 1) + data


def test_engine_gpu_without_cupy_or_a_device_is_one_line_exit_2(tmp_path, capsys):
    from pylmp_lattice.engines.gpu import available

    if available() is None:
        pytest.skip("this machine has a GPU the engine can use")
    path = write_sweep(tmp_path, 2, ENSEMBLES["mass disorder"])
    assert main(["sweep", str(path), "-o", str(tmp_path / "out"), "--engine", "gpu", "--quiet"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "engine" in err and "gpu" in err
    assert not (tmp_path / "out" / "members").exists()


def test_an_unknown_engine_in_a_sweep_file_names_the_field(tmp_path, capsys):
    path = write_sweep(tmp_path, 2, ENSEMBLES["mass disorder"])
    path.write_text(path.read_text().replace("keep =", 'engine = "tpu"\nkeep ='))
    assert main(["sweep", str(path), "-o", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "engine" in err and "'tpu'" in err and "cpu" in err


@pytest.mark.lammps
@pytest.mark.slow  # 3 s
def test_ctrl_c_stops_a_cpu_sweep_within_2_s(tmp_path):
    """SIGINT to the command's process group while the kernel runs (in C, in chunks): exit 130
    within 2 s, members "done" or "interrupted" (resume: test_a_cpu_sweep_resumes_only_what_is_missing)."""
    # about 4 s on any number of cores (4800 steps each; its 2 workers share the cores; 5000
    # members on 2 cores ended within the 1.5 s below)
    path = write_sweep(tmp_path, 10000 * (os.cpu_count() or 2), ENSEMBLES["mass disorder"])
    out = tmp_path / "out"
    cmd = [sys.executable, "-m", "pylmp_lattice.cli", "sweep", str(path), "-o", str(out), "--engine", "cpu",
           "--workers", "2", "--quiet"]
    proc = subprocess.Popen(cmd, start_new_session=True, stderr=subprocess.PIPE, text=True, cwd=tmp_path)
    deadline = time.monotonic() + 60
    while not any((out / "batches").glob("*/run.json")) and time.monotonic() < deadline:
        time.sleep(0.05)
    time.sleep(1.5)  # the kernel is running, and the coordinator has loaded pandas for the table
    assert proc.poll() is None, proc.stderr.read()
    os.killpg(proc.pid, signal.SIGINT)
    sent = time.monotonic()
    _, err = proc.communicate(timeout=30)
    took = time.monotonic() - sent
    assert proc.returncode == 130 and took < 2.0, (proc.returncode, took, err)
    table = pd.read_csv(out / "results.csv")
    assert set(table["status"]) <= {"done", "interrupted"} and (table["status"] == "interrupted").any()


@pytest.mark.gpu
def test_the_gpu_engine_gives_the_cpu_engine_s_results_table(tmp_path):
    """Where CuPy finds a device: the same sweep with --engine gpu and --engine cpu, within 1e-12
    (one kernel; the GPU may contract a*b+c into an FMA)."""
    from pylmp_lattice.engines.gpu import available

    why = available()
    if why:
        pytest.skip(why)
    path = write_sweep(tmp_path, 6, ENSEMBLES["thermal with friction"])
    assert_same_table(sweep_in_process(path, tmp_path / "cpu", "cpu"), sweep_in_process(path, tmp_path / "gpu", "gpu"),
                      rtol=1e-12)


def test_gpu_tasks_hold_enough_chains_to_fill_a_device(tmp_path):
    """With engine = "gpu" a task is not bounded by a LAMMPS instance's limits (at most 992
    members of the experiment) but by GPU_MAX_ATOMS and GPU_TASK_CHAINS (about a wave of the
    device): 10^6 members on 16 workers, 32 tasks of 31250."""
    from pylmp_lattice.sweep.execute import GPU_MAX_ATOMS, _Blocks

    first = next(load_sweep(write_sweep(tmp_path, 2, ENSEMBLES["mass disorder"])).iter_members())
    sizes = {engine: _Blocks(10**6, 16, 1, 10**6, engine=engine).next_size(first) for engine in ("lammps", "gpu")}
    assert sizes["lammps"] <= 992 and sizes["gpu"] == 31250 and 31250 * 21 <= GPU_MAX_ATOMS


@pytest.mark.lammps
@pytest.mark.parametrize("engine", ["cpu", "lammps"])
def test_no_friction_work_is_minus_zero(tmp_path, engine):
    """With mu = 0 a chain's friction work is a sum of the kicks' rounding errors, which rounds
    to -0.0 in some chains (2 of these 8, both engines: a trial saw "-0.0" in results.csv): the
    table's friction_dissipated_energy_mJ is 0.0, never -0.0."""
    sweep = tmp_path / "mu0.toml"
    sweep.write_text(f'base = "{EXPERIMENT}"\nkeep = "measures"\nreplicas = 2\nseed = 5\n[set]\n"friction.mu" = 0.0\n'
                     '"chain.thermal_velocity" = 0.02\n"run.duration" = 10.0\n[grid]\n'
                     '"impactor.velocity" = [1.0, 1.5, 2.0, 2.5]\n')
    work = sweep_in_process(sweep, tmp_path / "out", engine)["friction_dissipated_energy_mJ"]
    assert len(work) == 8 and all(w == 0.0 and math.copysign(1.0, w) == 1.0 for w in work), list(work)
