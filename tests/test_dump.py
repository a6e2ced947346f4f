"""Dump and log readers: both dump readers against each other, against LAMMPS, and on
hand-written files with known numbers."""

from __future__ import annotations

from dataclasses import fields

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

from pylmp_lattice.formats.dump import DUMP_COLUMNS, READERS, read_dump, read_log, trajectory_from_dump
from pylmp_lattice.errors import DumpFormatError

N_ATOMS, SPACING, MASS = 10, 0.01, 0.002  # m, kg
DT, EVERY, STEPS = 1e-5, 5, 50  # s, steps, steps


def chain_deck(dump_path) -> str:
    """Magnets 1 cm apart on the x axis joined by harmonic bonds, the first kicked at 2 m/s."""
    atoms = "\n".join(f"create_atoms 1 single {i * SPACING + 0.001} 0 0" for i in range(N_ATOMS))
    bonds = "\n".join(f"create_bonds single/bond 1 {i} {i + 1}" for i in range(1, N_ATOMS))
    return f"""
units si
atom_style bond
boundary s f f
region box block 0 {N_ATOMS * SPACING} -0.01 0.01 -0.01 0.01
create_box 1 box bond/types 1 extra/bond/per/atom 2
mass 1 {MASS}
{atoms}
{bonds}
bond_style harmonic
bond_coeff 1 50.0 {SPACING}
group impactor id 1
velocity impactor set 2.0 0 0
fix nve all nve
timestep {DT}
thermo 10
dump traj all custom {EVERY} {dump_path} {DUMP_COLUMNS}
dump_modify traj sort id format float %.12g
run {STEPS}
"""


@pytest.fixture(scope="module")
def chain_run(tmp_path_factory):
    """A 10-magnet chain run in LAMMPS: the folder with traj.dump and log.lammps, and the atoms'
    id, mass, x, vx, fx at the last step as LAMMPS holds them (sorted by id)."""
    from pylmp_lattice.engine import new_lammps

    folder = tmp_path_factory.mktemp("chain")
    lmp = new_lammps(["-screen", "none", "-log", str(folder / "log.lammps")])
    try:
        lmp.commands_string(chain_deck(folder / "traj.dump"))
        ids = lmp.numpy.extract_atom("id").copy()
        order = np.argsort(ids)
        last = {
            "id": ids[order],
            "mass": lmp.numpy.extract_atom("mass")[lmp.numpy.extract_atom("type")[order]],
            "x": lmp.numpy.extract_atom("x")[order, 0].copy(),
            "v": lmp.numpy.extract_atom("v")[order, 0].copy(),
            "f": lmp.numpy.extract_atom("f")[order, 0].copy(),
        }
    finally:
        lmp.close()
    return folder, last


def write_dump(path, time, step, mass, x, v, f):
    """A dump in the `dump traj` layout from arrays (SI), as LAMMPS would write it with
    `dump_modify time yes` (older runs); time None: the standard layout, without ITEM: TIME."""
    with open(path, "w") as out:
        for k, (s, xs, vs, fs) in enumerate(zip(step, x, v, f)):
            if time is not None:
                out.write(f"ITEM: TIME\n{time[k]:.12g}\n")
            out.write(f"ITEM: TIMESTEP\n{s}\nITEM: NUMBER OF ATOMS\n{len(xs)}\n")
            out.write("ITEM: BOX BOUNDS ss ff ff\n0 1\n-0.01 0.01\n-0.01 0.01\n")
            out.write(f"ITEM: ATOMS {DUMP_COLUMNS}\n")
            for i, (m, xi, vi, fi) in enumerate(zip(mass, xs, vs, fs), start=1):
                out.write(f"{i} 1 {m:.12g} {xi:.12g} 0 0 {vi:.12g} 0 0 {fi:.12g} 0 0\n")


def assert_frames_equal(a, b):
    for field in fields(a):
        assert_array_equal(getattr(a, field.name), getattr(b, field.name), err_msg=field.name)


@pytest.mark.lammps
def test_readers_agree_exactly(chain_run):
    folder, _ = chain_run
    fast = read_dump(folder / "traj.dump", reader="fast", dt=DT)
    assert fast.n_frames == STEPS // EVERY + 1
    assert_frames_equal(fast, read_dump(folder / "traj.dump", reader="mdanalysis", dt=DT))


@pytest.mark.lammps
@pytest.mark.parametrize("reader", READERS)
def test_last_frame_matches_lammps(chain_run, reader):
    folder, last = chain_run
    frames = read_dump(folder / "traj.dump", reader=reader, dt=DT)
    assert_array_equal(frames.step, np.arange(0, STEPS + 1, EVERY))
    assert_allclose(frames.time, frames.step * DT, rtol=1e-12)
    assert_array_equal(frames.id, last["id"])
    assert_array_equal(frames.mass, last["mass"])
    for name in ("x", "v", "f"):
        # The dump prints 12 significant digits.
        scale = np.abs(last[name]).max()
        assert_allclose(getattr(frames, name)[-1], last[name], rtol=1e-11, atol=1e-11 * scale, err_msg=name)
    assert frames.v[0, 0] == 2.0 and frames.v[-1, 0] < 2.0  # the kick, then the bond pulling back


@pytest.mark.lammps
@pytest.mark.parametrize("reader", READERS)
@pytest.mark.parametrize("cut", ["mid_line", "after_step_item", "at_atoms_header"])
def test_truncated_last_frame_is_dropped(chain_run, tmp_path, reader, cut):
    folder, _ = chain_run
    text = (folder / "traj.dump").read_text()
    last_frame = text.rindex("ITEM: TIMESTEP")
    at = {
        "mid_line": text.rindex("\n", 0, len(text) - 1) + 5,
        "after_step_item": last_frame + len("ITEM: TIMESTEP\n"),
        "at_atoms_header": text.rindex("ITEM: ATOMS"),
    }[cut]
    (tmp_path / "traj.dump").write_text(text[:at])
    full = read_dump(folder / "traj.dump", reader=reader, dt=DT)
    cut_frames = read_dump(tmp_path / "traj.dump", reader=reader, dt=DT)
    assert cut_frames.n_frames == full.n_frames - 1
    assert_array_equal(cut_frames.x, full.x[:-1])
    assert_array_equal(cut_frames.f, full.f[:-1])


@pytest.mark.parametrize("reader", READERS)
@pytest.mark.parametrize("layout", ["standard", "with_time"])
def test_units_of_trajectory(tmp_path, reader, layout):
    # Two magnets of 2 g at 1 mm and 11 mm; after 0.1 ms (10 steps of 1e-5 s) the first has
    # moved 0.2 mm at 2 m/s under 0.5 N, i.e. 250 m/s^2.
    mass = np.array([0.002, 0.002])
    x = np.array([[0.001, 0.011], [0.0012, 0.011]])
    v = np.array([[2.0, 0.0], [2.0, 0.0]])
    f = np.array([[0.0, 0.0], [0.5, -0.5]])
    write_dump(tmp_path / "traj.dump", None if layout == "standard" else [0.0, 1e-4], [0, 10], mass, x, v, f)
    # a file with ITEM: TIME lines keeps its own times: the dt given is not used
    traj = trajectory_from_dump(read_dump(tmp_path / "traj.dump", reader=reader,
                                          dt=1e-5 if layout == "standard" else 7.0))
    assert_allclose(traj.t, [0.0, 0.1])
    assert_allclose(traj.x0, [1.0, 11.0])
    assert_allclose(traj.u, [[0.0, 0.0], [0.2, 0.0]], atol=1e-12)
    assert_allclose(traj.v, v)
    assert_allclose(traj.a, [[0.0, 0.0], [250.0, -250.0]])


def test_standard_layout_needs_the_time_step(tmp_path):
    write_dump(tmp_path / "traj.dump", None, [0], [0.002], [[0.001]], [[0.0]], [[0.0]])
    with pytest.raises(ValueError, match="dt: .*traj.dump has no ITEM: TIME lines"):
        read_dump(tmp_path / "traj.dump")


def test_missing_file(tmp_path):
    with pytest.raises(FileNotFoundError, match="nope.dump: dump file not found"):
        read_dump(tmp_path / "nope.dump")


def test_unexpected_columns(tmp_path):
    path = tmp_path / "traj.dump"
    path.write_text(
        "ITEM: TIME\n0\nITEM: TIMESTEP\n0\nITEM: NUMBER OF ATOMS\n1\nITEM: BOX BOUNDS ss ff ff\n"
        "0 1\n0 1\n0 1\nITEM: ATOMS id type x y z\n1 1 0.5 0 0\n"
    )
    with pytest.raises(DumpFormatError, match=f"traj.dump: got .*; expected 'ITEM: ATOMS {DUMP_COLUMNS}'"):
        read_dump(path)


def test_unknown_reader(tmp_path):
    with pytest.raises(ValueError, match="reader: got 'ase'; expected one of 'fast', 'mdanalysis'"):
        read_dump(tmp_path / "traj.dump", reader="ase")


@pytest.mark.lammps
def test_read_log_of_a_run(chain_run):
    folder, _ = chain_run
    log = read_log(folder / "log.lammps")
    assert log.errors == []
    (run,) = log.runs
    assert_array_equal(run["Step"], np.arange(0, STEPS + 1, 10))
    assert {"Temp", "TotEng"} <= set(run)


@pytest.mark.lammps
def test_read_log_ending_in_error(tmp_path):
    """A run stopped by an ERROR keeps its thermo rows up to the error (LogFile drops them)."""
    from pylmp_lattice.engine import new_lammps

    lmp = new_lammps(["-screen", "none", "-log", str(tmp_path / "log.lammps")])
    with pytest.raises(Exception, match="Bond atoms 1 2 missing"):
        # A bonded pair flies out of a fixed box: LAMMPS stops when the bond loses its atoms.
        lmp.commands_string(
            """
            units si
            atom_style bond
            boundary f f f
            region box block 0 0.1 -0.01 0.01 -0.01 0.01
            create_box 1 box bond/types 1 extra/bond/per/atom 2
            mass 1 0.002
            create_atoms 1 single 0.05 0 0
            create_atoms 1 single 0.06 0 0
            create_bonds single/bond 1 1 2
            bond_style harmonic
            bond_coeff 1 50.0 0.01
            fix nve all nve
            timestep 1e-5
            thermo 100
            run 100
            velocity all set 2.0 0 0
            run 10000
            """
        )
    lmp.close()
    log = read_log(tmp_path / "log.lammps")
    assert len(log.errors) == 1 and "Bond atoms 1 2 missing" in log.errors[0]
    first, failed = log.runs
    assert_array_equal(first["Step"], [0, 100])
    assert failed["Step"][0] == 100 and 2000 < failed["Step"][-1] < 10100
    assert np.all(np.isfinite(failed["TotEng"]))


@pytest.mark.lammps
def test_the_guides_mdanalysis_route_for_a_text_dump(tmp_path):
    """docs/guide.md's text-dump route, as written there: frame time step * dt (dt the time step
    in ps), the file's x through additional_columns, positions shifted by the box origin."""
    import MDAnalysis as mda

    from conftest import make_case

    from pylmp_lattice.run_folder import run_case

    case = make_case(particles=12, duration=5.0, dt=0.0125, interval=0.125, output={"format": "text"})
    run_case(case, tmp_path / "r", figure=False)
    u = mda.Universe(str(tmp_path / "r" / "traj.dump"), format="LAMMPSDUMP", dt=0.0125e9,
                     additional_columns=["x", "vx", "fx"])
    ts = u.trajectory[-1]
    assert ts.time == pytest.approx(5e9) and u.trajectory.dt == pytest.approx(0.0125e9)
    mine = read_dump(tmp_path / "r" / "traj.dump", dt=1.25e-5)
    assert_array_equal(ts.data["x"], mine.x[-1])
    assert not np.allclose(ts.positions[:, 0], ts.data["x"]) and np.ptp(ts.positions[:, 0] - ts.data["x"]) < 1e-6
