"""The Python API: `import pylmp_lattice as pl` and the README's example, run as written."""

from __future__ import annotations

import re
import shutil
from pathlib import Path

import pytest

import pylmp_lattice as pl

ROOT = Path(__file__).parent.parent


def readme_example() -> str:
    """The first python block of the README's "Python API" section."""
    text = (ROOT / "README.md").read_text()
    section = text.split("## Python API", 1)[1]
    return re.search(r"```python\n(.*?)```", section, re.S).group(1)


def test_the_package_lists_the_names_a_researcher_needs():
    names = set(dir(pl))
    assert {"load_case", "case_from_dict", "run", "RunFolder", "read_run", "measures", "plots", "to_atoms",
            "case_from_atoms", "estimate"} <= names
    with pytest.raises(AttributeError):
        pl.no_such_name


@pytest.mark.lammps
def test_readme_python_example_runs(tmp_path, monkeypatch):
    shutil.copytree(ROOT / "inputs", tmp_path / "inputs")
    monkeypatch.chdir(tmp_path)
    namespace = {}
    exec(compile(readme_example(), "README.md", "exec"), namespace)
    namespace = {}  # a second time, as a user runs a script again (it raised "already holds a run")
    exec(compile(readme_example(), "README.md", "exec"), namespace)
    # what the example claims: a finished run folder and measures of its front
    summary, run, front = namespace["summary"], namespace["run"], namespace["front"]
    assert (tmp_path / "runs/api_example/summary.json").exists() and (tmp_path / "api_example.png").exists()
    assert run.summary == summary and run.trajectory().t[-1] == pytest.approx(40.0)
    assert len(namespace["frames"]) == len(run.trajectory().t)
    # the half-sine drive's front, 12 mm gaps: between V0 = 1.6 m/s and the bound V0 + 2 * 2.81
    vp = summary["shock_velocity_plateau_m_per_s"]["mean"]
    assert 1.6 < vp < 7.2 and front.arrival[1] < front.arrival[5]


def test_a_path_that_is_no_path_is_named_not_a_pathlib_error(tmp_path, monkeypatch):
    """load_case(None) and run(case, None) failed in pathlib: "expected str, bytes or os.PathLike
    object, not NoneType"."""
    from pylmp_lattice.errors import UsageError

    monkeypatch.chdir(tmp_path)
    with pytest.raises(UsageError, match=r"^path: got None; expected a str or Path: the path of a case file \(TOML\)$"):
        pl.load_case(None)
    case = pl.case_from_dict({"chain": {"particles": 5, "mass": 1.0, "r0": 12.0, "far_end": "fixed"},
                              "force": {"law": "power"}, "impactor": {"profile": "constant", "velocity": 1.0},
                              "run": {"duration": 1.0, "dt": 0.01, "output_interval": 0.1}})
    for folder in (None, 5, case):
        with pytest.raises(UsageError, match=r"^folder: got .*; expected a str or Path: the path of the run's folder$"):
            pl.run(case, folder)
    assert sorted(p.name for p in tmp_path.iterdir()) == []


def test_nprocs_and_runner_of_the_wrong_kind_are_named(tmp_path, monkeypatch):
    """run(case, folder, nprocs="2") failed as "'>' not supported between instances of 'str' and
    'int'", runner=None as "'NoneType' object has no attribute 'check'", and numpy's np.int64(1)
    was refused as no integer."""
    from pylmp_lattice.errors import UsageError
    from pylmp_lattice.run_folder.execution import Lammps

    monkeypatch.chdir(tmp_path)
    case = pl.case_from_dict({"chain": {"particles": 5, "mass": 1.0, "r0": 12.0, "far_end": "fixed"},
                              "force": {"law": "power"}, "impactor": {"profile": "constant", "velocity": 1.0},
                              "run": {"duration": 1.0, "dt": 0.01, "output_interval": 0.1}})
    with pytest.raises(UsageError, match=r"^--np: got '2'; expected an integer >= 1 \(nprocs, the MPI ranks\)$"):
        pl.run(case, "x", nprocs="2")
    with pytest.raises(UsageError, match=r"^runner: got NoneType; choose one of embedded, lmp, or an Engine$"):
        pl.run(case, "x", runner=None)
    assert list(tmp_path.iterdir()) == []
    assert Lammps("lmp", __import__("numpy").int64(2)).nprocs == 2


def test_a_trajectory_s_repr_is_its_shape_not_its_values():
    """A Trajectory in a notebook printed its arrays (some 700 lines for two magnets of a run,
    trial3's note): its repr is its frames, magnets and time span."""
    import numpy as np

    from pylmp_lattice.trajectory import Trajectory

    zeros = np.zeros((401, 21))
    traj = Trajectory(np.linspace(0.0, 40.0, 401), np.arange(21.0), zeros, zeros, zeros)
    assert repr(traj) == "Trajectory(frames=401, magnets=21, t=0..40 ms)"
    assert repr(Trajectory(np.zeros(0), np.arange(3.0), *(np.zeros((0, 3)),) * 3)) == "Trajectory(frames=0, magnets=3)"


def test_a_switch_that_is_no_bool_is_named_not_taken_for_true(tmp_path, monkeypatch):
    """overwrite="no" counted as true: RunFolder.create replaced the run in its folder. Every
    switch of the public functions (overwrite, yes, echo, progress, figure, retry_failed) is
    True or False (a numpy bool too), else one line naming it, before anything is written."""
    import numpy as np

    from pylmp_lattice.errors import UsageError
    from pylmp_lattice.sweep import load_sweep, run_sweep
    from pylmp_lattice.trajectory import Trajectory

    monkeypatch.chdir(tmp_path)
    case = pl.case_from_dict({"chain": {"particles": 5, "mass": 1.0, "r0": 12.0, "far_end": "fixed"},
                              "force": {"law": "power"}, "impactor": {"profile": "constant", "velocity": 1.0},
                              "run": {"duration": 1.0, "dt": 0.01, "output_interval": 0.1}})
    pl.RunFolder.create(case, "r")
    written = {p.name: p.read_bytes() for p in (tmp_path / "r").iterdir()}
    with pytest.raises(UsageError) as err:
        pl.RunFolder.create(case, "r", overwrite="no")
    assert str(err.value) == "overwrite: got 'no'; expected True or False"
    assert {p.name: p.read_bytes() for p in (tmp_path / "r").iterdir()} == written
    for call, message in ((lambda: pl.run(case, "x", overwrite=1), "overwrite: got 1; expected True or False"),
                          (lambda: pl.run(case, "x", yes="yes"), "yes: got 'yes'; expected True or False"),
                          (lambda: pl.execute(case, "x", echo=None), "echo: got None; expected True or False"),
                          (lambda: pl.simulate(case, "x", progress="off"), "progress: got 'off'; expected True or False"),
                          (lambda: pl.run(case, "x", figure="no"), "figure: got 'no'; expected True or False")):
        with pytest.raises(UsageError) as err:
            call()
        assert str(err.value) == message
    traj = Trajectory(np.array([0.0, 0.1]), np.array([0.0, 12.0, 24.0]), *(np.zeros((2, 3)),) * 3)
    with pytest.raises(UsageError) as err:
        pl.write_trajectory("f.extxyz", traj, 1.0, overwrite="no")
    assert str(err.value) == "overwrite: got 'no'; expected True or False"
    (tmp_path / "base.toml").write_text(__import__("tomli_w").dumps(pl.case_to_dict(case)))
    (tmp_path / "sweep.toml").write_text('base = "base.toml"\n[grid]\n"impactor.velocity" = [0.5, 0.6]\n')
    with pytest.raises(UsageError) as err:
        run_sweep(load_sweep("sweep.toml"), "s", retry_failed="no")
    assert str(err.value) == "retry_failed: got 'no'; expected True or False"
    with pytest.raises(UsageError) as err:  # a bool or a ReplicaDrawing
        run_sweep(load_sweep("sweep.toml"), "s", stats="no")
    assert str(err.value) == "stats: got 'no'; expected True or False"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["base.toml", "r", "sweep.toml"]
    assert pl.RunFolder.create(case, "r", overwrite=np.True_).path.name == "r"  # replaced: a numpy bool is one


@pytest.mark.lammps
def test_every_switch_is_checked_before_its_work(tmp_path, monkeypatch):
    """Switches require_bool did not see: RunFolder.summarize(figure="no") (and summarize_folder)
    drew shock.png, run_study(quick="no") ran the small study, `echo` with an Engine as the
    runner was never looked at, and pl.estimate(measure="no") measured LAMMPS's start-up. Each
    is now one line naming it, before anything is read, run or written."""
    from pylmp_lattice import overhead
    from pylmp_lattice.errors import UsageError
    from pylmp_lattice.run_folder.folder import summarize_folder
    from pylmp_lattice.studies import run_study
    from pylmp_lattice.studies.literature import toda

    monkeypatch.chdir(tmp_path)
    case = pl.case_from_dict({"chain": {"particles": 5, "mass": 1.0, "r0": 12.0, "far_end": "fixed"},
                              "force": {"law": "power"}, "impactor": {"profile": "constant", "velocity": 1.0},
                              "run": {"duration": 1.0, "dt": 0.01, "output_interval": 0.1}})
    pl.run(case, "r", figure=False)
    before = {p.name: p.read_bytes() for p in (tmp_path / "r").iterdir()}
    ran = []

    class Engine:
        nprocs = 1

        def check(self, path):
            ran.append(path)

        def __call__(self, path, on_step=None):
            ran.append(path)

    monkeypatch.setattr(toda, "run", lambda out, quick: ran.append(quick))
    monkeypatch.setattr(overhead, "overheads", lambda measure: ran.append(measure))
    for call, message in ((lambda: pl.RunFolder("r").summarize(figure="no"), "figure: got 'no'; expected True or False"),
                          (lambda: summarize_folder("r", figure=0), "figure: got 0; expected True or False"),
                          (lambda: run_study("toda", "st", quick="no"), "quick: got 'no'; expected True or False"),
                          (lambda: pl.execute(case, "e", runner=Engine(), echo="no"), "echo: got 'no'; expected True or False"),
                          (lambda: pl.estimate(case, measure="no"), "measure: got 'no'; expected True or False")):
        with pytest.raises(UsageError) as err:
            call()
        assert str(err.value) == message
    assert ran == []
    assert {p.name: p.read_bytes() for p in (tmp_path / "r").iterdir()} == before  # no shock.png, no new summary
    assert sorted(p.name for p in tmp_path.iterdir()) == ["r"]
