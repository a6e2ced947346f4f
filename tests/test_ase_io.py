"""ASE: a run's frames to ase.Atoms and files ASE reads back; a case from an ase.Atoms chain."""

from __future__ import annotations

import numpy as np
import pytest
from ase import Atoms
from ase.io import read

from pylmp_lattice.ase_io import case_from_atoms, to_atoms, write_trajectory
from pylmp_lattice.case import case_from_dict
from pylmp_lattice.errors import ConfigError, UsageError
from pylmp_lattice.run_folder import simulate

from conftest import PAPER_FORCE, make_case

RUN = {"duration": 20.0, "dt": 0.01, "output_interval": 0.1}
IMPACTOR = {"profile": "constant", "velocity": 2.0}


@pytest.mark.lammps
@pytest.mark.parametrize("suffix", [".extxyz", ".traj"])
def test_run_exports_to_ase_and_back(tmp_path, suffix):
    case = make_case(particles=12, duration=20.0)
    traj = simulate(case, tmp_path / "run")
    path = write_trajectory(tmp_path / f"frames{suffix}", traj, case.chain.masses(), every=10)
    frames = read(path, index=":")
    assert len(frames) == len(traj.t[::10]) == 21
    for k, atoms in zip(range(0, len(traj.t), 10), frames):
        assert atoms.info["time_ms"] == pytest.approx(traj.t[k], abs=1e-12)
        # extxyz writes 8 decimals: 1e-8 mm, 1e-8 m/s
        np.testing.assert_allclose(atoms.positions[:, 0], traj.x0 + traj.u[k], rtol=0, atol=1e-8)
        np.testing.assert_allclose(atoms.get_velocities()[:, 0], traj.v[k], rtol=0, atol=1e-8)
        np.testing.assert_allclose(atoms.get_masses(), 1.084, rtol=0, atol=1e-12)
        assert np.all(atoms.positions[:, 1:] == 0) and np.all(atoms.get_velocities()[:, 1:] == 0)
    # user units are consistent: ASE's kinetic energy is sum m v^2 / 2 in mJ (g (m/s)^2 = mJ)
    last = frames[-1]
    assert last.get_kinetic_energy() == pytest.approx(0.5 * np.sum(1.084 * traj.v[-1] ** 2), rel=1e-7)
    # and back: the first frame rebuilds the same chain
    again = case_from_atoms(frames[0], force=PAPER_FORCE, impactor=IMPACTOR, run=RUN)
    np.testing.assert_allclose(again.chain.positions(), case.chain.positions(), atol=1e-8)
    np.testing.assert_allclose(again.chain.masses(), case.chain.masses(), atol=1e-12)


@pytest.mark.lammps
def test_chain_built_from_ase_atoms_runs_like_the_same_chain_from_toml(tmp_path):
    """A dimer chain (alternating 1.084 and 2.168 g, gaps 12 and 10 mm) from ase.Atoms gives
    exactly the trajectory of the same chain written as a TOML-shaped dict."""
    n = 14
    masses = np.where(np.arange(n) % 2 == 0, 1.084, 2.168)
    gaps = np.where(np.arange(n - 1) % 2 == 0, 12.0, 10.0)
    x = np.concatenate([[0.0], np.cumsum(gaps)])
    atoms = Atoms(["X"] * n, positions=np.column_stack([x, np.zeros(n), np.zeros(n)]), masses=masses)
    from_atoms = case_from_atoms(atoms, force=PAPER_FORCE, impactor=IMPACTOR, run=RUN, name="dimer")
    from_dict = case_from_dict({"name": "dimer", "force": PAPER_FORCE, "impactor": IMPACTOR, "run": RUN,
                                "chain": {"particles": n, "mass": list(masses), "r0": list(gaps)}})
    a = simulate(from_atoms, tmp_path / "atoms")
    b = simulate(from_dict, tmp_path / "dict")
    np.testing.assert_array_equal(a.x0, x)
    assert np.array_equal(a.u, b.u) and np.array_equal(a.v, b.v)
    assert np.max(a.v[:, 5]) > 1.0  # the pulse got through the chain


def test_chain_from_atoms_must_be_in_chain_order():
    atoms = Atoms(["X"] * 3, positions=[[0, 0, 0], [24, 0, 0], [12, 0, 0]], masses=[1.0] * 3)
    with pytest.raises(ConfigError, match="atoms: .*increasing x"):
        case_from_atoms(atoms, force=PAPER_FORCE, impactor=IMPACTOR, run=RUN)


def test_to_atoms_keeps_every_kth_frame_with_its_time():
    from pylmp_lattice.trajectory import Trajectory

    t = np.arange(5.0)
    traj = Trajectory(t=t, x0=np.array([0.0, 12.0, 24.0]), u=np.zeros((5, 3)), v=np.ones((5, 3)), a=np.zeros((5, 3)))
    frames = to_atoms(traj, [1.0, 2.0, 3.0], every=2)
    assert [f.info["time_ms"] for f in frames] == [0.0, 2.0, 4.0]
    np.testing.assert_array_equal(frames[0].get_masses(), [1.0, 2.0, 3.0])


def test_mistaken_arguments_are_named_and_none_masses_are_not_nan(tmp_path):
    """to_atoms(traj, None) gave frames whose masses were all NaN; masses of the wrong length,
    write_trajectory's arguments in to_atoms's order and atoms=None failed inside numpy,
    pathlib or as an AttributeError."""
    from pylmp_lattice.trajectory import Trajectory

    traj = Trajectory(np.array([0.0, 0.1]), np.array([0.0, 12.0, 24.0]), np.zeros((2, 3)), np.zeros((2, 3)),
                      np.zeros((2, 3)))
    with pytest.raises(ValueError, match=r"^masses: got None; expected finite masses > 0 in g, one value or one "
                                         r"per magnet, shape \(3,\)"):
        to_atoms(traj, None)
    with pytest.raises(ValueError, match=r"^masses: got ndarray of shape \(2,\); expected"):
        to_atoms(traj, np.ones(2))
    with pytest.raises(ValueError, match=r"^every: got 0; expected an integer >= 1"):
        to_atoms(traj, 1.084, every=0)
    with pytest.raises(TypeError, match=r"^traj: got NoneType; expected a Trajectory"):
        to_atoms(None, 1.084)
    with pytest.raises(UsageError, match=r"^path: got Trajectory\(.*; expected a str or Path: the file to write, as in "
                       r"write_trajectory\(path, traj, masses\)$"):
        write_trajectory(traj, 1.084, tmp_path / "x.extxyz")
    with pytest.raises(TypeError, match=r"^atoms: got NoneType; expected an ase.Atoms"):
        case_from_atoms(None, force={}, impactor={}, run={})
    assert list(tmp_path.iterdir()) == []
    assert to_atoms(traj, 1.084)[1].get_masses().tolist() == [1.084] * 3


def test_write_trajectory_replaces_a_file_only_with_overwrite_and_never_writes_through_a_link(tmp_path):
    """write_trajectory replaced an existing file without a word, and wrote through a link
    planted at its path into the file the link named; now an existing file stays unless
    overwrite=True, a link is refused, and the frames go through a renamed temporary file."""
    from pylmp_lattice.formats.files import LinkError
    from pylmp_lattice.trajectory import Trajectory

    traj = Trajectory(np.array([0.0, 0.1]), np.array([0.0, 12.0, 24.0]), np.zeros((2, 3)), np.zeros((2, 3)),
                      np.zeros((2, 3)))
    mine = tmp_path / "mine.extxyz"
    mine.write_text("notes\n")
    with pytest.raises(UsageError) as err:
        write_trajectory(mine, traj, 1.084)
    assert str(err.value) == f"path: {mine} exists; pass --overwrite (overwrite=True) to replace it, or choose another file"
    assert mine.read_text() == "notes\n"
    assert write_trajectory(mine, traj, 1.084, overwrite=True) == mine
    assert len(read(mine, index=":")) == 2
    target = tmp_path / "target.txt"
    target.write_text("kept\n")
    (tmp_path / "link.extxyz").symlink_to(target)
    for overwrite in (False, True):
        with pytest.raises(LinkError, match=r"link\.extxyz: is a symbolic link \(to .*target\.txt\)"):
            write_trajectory(tmp_path / "link.extxyz", traj, 1.084, overwrite=overwrite)
    assert target.read_text() == "kept\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["link.extxyz", "mine.extxyz", "target.txt"]
