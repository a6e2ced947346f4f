"""Shared test helpers: small cases built in Python, in user units (mm, g, ms, N, m/s)."""

from __future__ import annotations

import contextlib
import os
import subprocess
import time
import sys

import pytest

from pylmp_lattice.case import case_from_dict

# The estimates use the default overheads: no test (nor its subprocesses) measures this machine
# for 10-20 s or depends on the user's cache (tests/test_overhead.py measures with a stand-in).
os.environ["PYLMP_LATTICE_NO_MEASURE"] = "1"

PAPER_FORCE = {"law": "power", "K": 413.8, "b": 3.917, "q": 3.0}

SHM = "/dev/shm"


@pytest.fixture(autouse=True)
def _no_mpich_segment_of_a_killed_process(_mpich_segments_before):
    """A process that MPICH started and that was killed (the tests that kill runs, ranks and
    workers) leaves its 1 MB segment in /dev/shm, in memory until reboot (a full CI run left
    25-30): after each test, those that appeared since the session began, whose process is
    gone and that are over SEGMENT_AGE old are removed (at a later test's end).
    Processes that exit finalize MPI and leave none (`engine._finalize_mpi_at_exit`,
    tests/test_mpi_exit.py)."""
    yield
    for name in set(_mpich_segments()) - _mpich_segments_before:
        with contextlib.suppress(ValueError, IndexError):
            pid = int(name.split("_")[2], 16)  # mpich_shm_<pid in hex>_<n>
            # an mpiexec job's segment is named by a hash, not a pid: its ranks' until they have
            # all mapped it (one removed then, by another test session on the machine, hung a
            # CI run's 2-rank job), left by a job whose ranks were killed first
            if (not _alive(pid) if pid <= _PID_MAX else not _mapped(name)) and _older(name, SEGMENT_AGE):
                with contextlib.suppress(OSError):
                    os.unlink(os.path.join(SHM, name))


# A segment younger than this is left for a later test's end: another test session on the machine
# (tests/test_mpi_exit.py) may be about to look for the one its process left at exit (removed
# first by this clean-up, it failed that session's check)
SEGMENT_AGE = 60.0


def _older(name: str, seconds: float) -> bool:
    """Whether /dev/shm/`name` last changed over `seconds` ago (made, or written by its process)."""
    with contextlib.suppress(OSError):
        return time.time() - os.stat(os.path.join(SHM, name)).st_ctime > seconds
    return False


@pytest.fixture(scope="session")
def _mpich_segments_before() -> set[str]:
    return set(_mpich_segments())


def _pid_max() -> int:
    with contextlib.suppress(OSError, ValueError), open("/proc/sys/kernel/pid_max") as f:
        return int(f.read())
    return 4194304  # Linux's largest


_PID_MAX = _pid_max()


def _mpich_segments() -> list[str]:
    with contextlib.suppress(OSError):
        return [n for n in os.listdir(SHM) if n.startswith("mpich_shm_")]
    return []


def _mapped(name: str) -> bool:
    """Whether a process holds /dev/shm/`name` open or mapped (/proc: the processes this user may read)."""
    for proc in os.listdir("/proc"):
        if not proc.isdigit():
            continue
        with contextlib.suppress(OSError):
            with open(f"/proc/{proc}/maps") as f:
                if name in f.read():
                    return True
            if any(name in os.readlink(f"/proc/{proc}/fd/{fd}") for fd in os.listdir(f"/proc/{proc}/fd")):
                return True
    return False


def _alive(pid: int) -> bool:
    """Whether process `pid` runs (a zombie, killed and not yet waited for, does not)."""
    try:
        with open(f"/proc/{pid}/stat") as f:
            return f.read().rsplit(")", 1)[1].split()[0] != "Z"  # the state after "(comm)"
    except OSError:
        return False

# One chain per further law (m = 1 g; spacing r0 at the force's zero, except FPUT), with the
# table range each needs; every one takes the default dt = 0.01 ms (limits 0.08-0.09 ms).
OTHER_LAWS = {
    "toda": ({"law": "toda", "A": 1.0, "B": 1.0, "a": 10.0}, 10.0, {"r_min": 5.0}),
    "lj": ({"law": "lj", "epsilon": 1.0, "sigma": 10.0}, 2 ** (1 / 6) * 10.0, {"r_min": 8.0}),
    "morse": ({"law": "morse", "D": 1.0, "alpha": 0.5, "r_e": 10.0}, 10.0, {"r_min": 5.0}),
    "fput": ({"law": "fput", "k": 1.0, "a": 10.0, "alpha": 0.25, "beta": 0.1}, 10.0, {}),
}


def make_law_case(law: str, particles=20, velocity=0.5, duration=10.0, **sections):
    """A chain of unit masses with one of OTHER_LAWS, driven at `velocity` (m/s)."""
    force, r0, table = OTHER_LAWS[law]
    return make_case(particles=particles, velocity=velocity, duration=duration, force=force,
                     chain={"mass": 1.0, "r0": r0}, table=table, **sections)


def make_case(particles=30, velocity=2.0, duration=50.0, dt=0.01, interval=0.1, **sections):
    """A paper-like chain (m = 1.084 g, r0 = 12 mm, power law, fixed far end)."""
    data = {
        "name": "test",
        "chain": {"particles": particles, "mass": 1.084, "r0": 12.0, "far_end": "fixed"},
        "force": dict(PAPER_FORCE),
        "impactor": {"profile": "constant", "velocity": velocity},
        "run": {"duration": duration, "dt": dt, "output_interval": interval},
    }
    for name, values in sections.items():
        if name in ("impactor", "force"):  # a new profile or law replaces the default
            data[name] = dict(values)
        else:
            data.setdefault(name, {}).update(values)
    return case_from_dict(data)


@pytest.fixture
def case_factory():
    return make_case


@pytest.fixture(scope="session")
def quick_studies(tmp_path_factory):
    """Run a study's quick version once per test session (tests/test_studies.py checks its
    numbers, tests/test_figures.py its figure); returns its StudyResult."""
    from pylmp_lattice.studies import run_study

    out = tmp_path_factory.mktemp("studies")
    done = {}

    def get(name):
        if name not in done:
            done[name] = run_study(name, out, quick=True)
        return done[name]

    get.out = out
    return get


@pytest.fixture(scope="session")
def all_study(tmp_path_factory):
    """Study `all` over fig2 alone (quick), run once per test session: returns (its folder, its
    StudyResult, the lines it logged). tests/test_studies.py checks its files and progress lines
    and fig2's numbers in the same folder, tests/test_figures.py its figure."""
    import logging

    import pylmp_lattice.studies as studies

    out, lines = tmp_path_factory.mktemp("all"), []
    keep = logging.Handler(logging.INFO)
    keep.emit = lambda record: lines.append(record.getMessage())
    logger = logging.getLogger("pylmp_lattice.studies")
    level = logger.level
    logger.setLevel(logging.INFO)
    logger.addHandler(keep)
    try:
        with pytest.MonkeyPatch.context() as patch:
            patch.setattr(studies, "STUDIES", {"fig2": studies.STUDIES["fig2"], "all": studies.STUDIES["all"]})
            result = studies.run_study("all", out, quick=True)
    finally:
        logger.removeHandler(keep)
        logger.setLevel(level)
    return out, result, lines


# Set on CI (.ci/run): SLURM that cannot start fails the slurm tests instead of skipping them.
REQUIRE_SLURM = "PYLMP_LATTICE_REQUIRE_SLURM"


@pytest.fixture(scope="session")
def slurm():
    """A one-node SLURM on localhost for this test session (tests/slurm_cluster.py); skipped,
    saying why, where it cannot start, unless PYLMP_LATTICE_REQUIRE_SLURM=1."""
    import os

    from slurm_cluster import LocalSlurm, SlurmUnavailable

    try:
        cluster = LocalSlurm.started()
    except SlurmUnavailable as err:
        if os.environ.get(REQUIRE_SLURM) == "1":
            pytest.fail(f"SLURM did not start ({REQUIRE_SLURM}=1): {err}")
        pytest.skip(f"SLURM did not start: {err}")
    try:
        yield cluster
    finally:
        cluster.stop()


@contextlib.contextmanager
def held_elsewhere(path):
    """The lock of `path` (file_lock.exclusive) held by another process while the block runs
    (a lock is its process's: inside the holder it is simply held on); that process lets go,
    and removes the file, when the block ends."""
    holder = subprocess.Popen(
        [sys.executable, "-c", "import sys\nfrom pylmp_lattice.file_lock import exclusive\n"
         f"with exclusive({str(path)!r}):\n    print('held', flush=True)\n    sys.stdin.read()\n"],
        stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    try:
        assert holder.stdout.readline().strip() == "held"
        yield holder
    finally:
        holder.stdin.close()
        holder.wait(10)


def frame_of_dicts(rows: dict):
    """The sweep's table as pandas makes it of rows as dicts (by member index): keys in the order
    the rows first name them, swept fields before status, measures after wall_time_s."""
    import pandas as pd

    from pylmp_lattice.sweep.table import FIXED

    params, measures = {}, {}
    for row in (rows[i] for i in sorted(rows)):
        keys = list(row)
        params |= dict.fromkeys(keys[1:keys.index("status")])
        measures |= dict.fromkeys(keys[keys.index("wall_time_s") + 1:])
    return pd.DataFrame([rows[i] for i in sorted(rows)], columns=["id", *params, *FIXED[1:], *measures])
