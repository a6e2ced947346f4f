"""A sweep's pool at its end: a local pool's workers are told to exit before the table is written
(they exit while it is written: 16 GPU workers took 1.0 s to, one after another), an executor the
caller gave is left as it was, and a GPU sweep's workers make their CUDA context as they start."""

from __future__ import annotations

import dataclasses
import os
import sys
import threading
import types
from concurrent.futures import ThreadPoolExecutor

import pytest

from pylmp_lattice.engines import gpu
from pylmp_lattice.sweep import load_sweep, pool, run_sweep, table

from test_sweep import SIX, write_sweep


@pytest.mark.lammps
def test_a_local_pool_is_released_before_the_last_table_write(tmp_path, monkeypatch):
    said = []
    release, write = pool.Pool.release, table.Table.write
    monkeypatch.setattr(pool.Pool, "release", lambda self: (said.append("release"), release(self))[1])
    monkeypatch.setattr(table.Table, "write", lambda self, *a, **k: (said.append("write"), write(self, *a, **k))[1])
    result = run_sweep(load_sweep(write_sweep(tmp_path, SIX)), tmp_path / "out", workers=2, progress=False)
    assert set(result["status"]) == {"done"} and len(result) == 6
    assert said == ["release", "write"]


@pytest.mark.lammps
def test_an_executor_the_caller_gave_is_left_running(tmp_path):
    with ThreadPoolExecutor(1) as given:
        result = run_sweep(load_sweep(write_sweep(tmp_path, SIX)), tmp_path / "out", executor=given, slots=1,
                           progress=False)
        assert set(result["status"]) == {"done"}
        assert given.submit(pow, 2, 10).result(timeout=10) == 1024  # not shut down


def test_a_gpu_pool_s_workers_make_their_cuda_context_as_they_start():
    with pool.executor_pool(1, None, "embedded", None, None, "gpu", "WARM") as p:
        assert p.executor._initargs[-2:] == (True, "WARM")  # noqa: SLF001 - what each worker's initializer gets
    with pool.executor_pool(1, None, "embedded", None, None, "cpu", "WARM") as p:
        assert p.executor._initargs[-2:] == (False, None)  # noqa: SLF001


WORKER_INIT = """import multiprocessing, sys, threading
from pylmp_lattice.engines import gpu
from pylmp_lattice.sweep import pool
got = []
gpu.warm_up = lambda warm: got.append((warm, threading.current_thread().name))
alive, stop = multiprocessing.Pipe(duplex=False), multiprocessing.Pipe(duplex=False)
pool._pool_worker_init(alive[0], stop[0], sys.argv[1] == "gpu", "WARM")
for t in threading.enumerate():
    if t.name == "pylmp-lattice-cuda-context":
        t.join(10)
print(got)
"""


@pytest.mark.parametrize("engine", ["gpu", "cpu"])
def test_a_gpu_pool_worker_warms_up_in_a_thread_of_its_own_as_it_starts(engine):
    """The pool worker's initializer (in a process of its own: it sets signal handlers) starts
    `engines.gpu.warm_up(warm)` in a thread for a GPU sweep, and nothing otherwise."""
    import subprocess
    from pathlib import Path

    root = Path(__file__).resolve().parents[1]
    done = subprocess.run([sys.executable, "-c", WORKER_INIT, engine], capture_output=True, text=True, timeout=60,
                          env={**os.environ, "PYTHONPATH": str(root)})
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == ("[('WARM', 'pylmp-lattice-cuda-context')]" if engine == "gpu" else "[]")


def test_a_gpu_sweep_s_workers_run_its_first_member_for_one_step_in_its_batches_module(tmp_path):
    from pylmp_lattice.engines.arrays import prepare
    from pylmp_lattice.sweep.execute import _gpu_warm

    from test_sweep import THERMAL

    for text in (THERMAL.format(replicas=5), THERMAL.format(replicas=5) + '"chain.mass_disorder" = 0.01\n'):
        sweep = dataclasses.replace(load_sweep(write_sweep(tmp_path, text)), engine="gpu")
        a = prepare([m.case for m in sweep.members()], "gpu")  # the batch of all of them
        warm = _gpu_warm(sweep)
        assert (warm.chains, warm.steps, a.steps) == (1, 1, 1000)
        module = gpu.compile_options(warm.n, gpu.batch_case(warm), one_mass=gpu.one_mass(warm))
        assert module == gpu.compile_options(a.n, gpu.batch_case(a), one_mass=gpu.one_mass(a))
        assert ("-DPL_ONE_MASS=1" in module) == ("mass_disorder" not in text)
        assert _gpu_warm(dataclasses.replace(sweep, engine="cpu")) is None


def test_the_warm_up_makes_the_context_runs_the_batch_and_leaves_errors_to_the_launch(monkeypatch):
    made, ran = [], []
    fake = types.ModuleType("cupy")
    fake.zeros = lambda n: made.append((n, threading.current_thread().name))
    monkeypatch.setitem(sys.modules, "cupy", fake)
    monkeypatch.setattr(gpu, "Launched", lambda batch: types.SimpleNamespace(result=lambda: ran.append(batch)))
    gpu.warm_up()
    assert made == [(1, threading.current_thread().name)] and ran == []
    gpu.warm_up("BATCH")
    assert ran == ["BATCH"]

    def no_device(n):
        raise RuntimeError("cudaErrorNoDevice")

    fake.zeros = no_device
    assert gpu.warm_up("BATCH") is None and ran == ["BATCH"]  # no exception: the task's launch reports it
