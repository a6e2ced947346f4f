"""Run output: H5MD trajectories, binary dumps, fine output, and the on-the-fly front record."""

from __future__ import annotations

import re
import warnings

import numpy as np
import pytest

from pylmp_lattice import measures
from pylmp_lattice.formats.bindump import open_dump
from pylmp_lattice.errors import ConfigError, RunError, UsageError
from pylmp_lattice.case_measures import read_front_record
from pylmp_lattice.run_folder import RunFolder, execute, run_case, simulate

from conftest import make_case

FRICTION = {"mu": 0.285, "p": 0.012}
lammps = pytest.mark.lammps


@pytest.mark.parametrize("section, message", [
    ({"format": "xyz"}, "output.format: got 'xyz'; choose one of h5md, text, none"),
    ({"fine": [0, 5]}, r"output.fine: got \[0, 5\]; expected magnet numbers in \[1, 30\]"),
    ({"fine": [5, 5]}, "expected distinct magnet numbers"),
    ({"fine": [5], "fine_interval": 0.015}, "output.fine_interval: got 0.015 ms; expected a whole multiple"),
    ({"compression": 1}, "output.compression: got 1; choose one of lzf, gzip, none"),
    ({"front": 1}, "output.front: got 1; expected true or false"),
])
def test_bad_output_settings_name_the_field(section, message):
    with pytest.raises(ConfigError, match=message):
        make_case(output=section)


PULSE = {"profile": "sine", "velocity": 2.0, "duration": 10.0}


@lammps
@pytest.mark.parametrize("sections, method", [
    ({}, "level"), ({"friction": FRICTION}, "level"), ({"impactor": PULSE}, "velocity_peak"),
    ({"impactor": PULSE, "friction": FRICTION}, "velocity_peak"),
], ids=["constant", "constant-friction", "pulse", "pulse-friction"])
def test_front_record_equals_the_array_measures_of_every_step(tmp_path, sections, method):
    """Sampled at every step, the engine's record and measures.front see the same numbers."""
    case = make_case(particles=40, duration=40.0, interval=0.01, **sections)
    traj = simulate(case, tmp_path)
    arrays = measures.front(traj.t, traj.v, traj.a, 2.0, case.chain.gaps(), method)
    record = read_front_record(case, tmp_path / "front.bin", method).front
    assert np.sum(np.isfinite(record.peaks.peak_velocity)) >= 8 and np.sum(np.isfinite(record.arrival)) >= 8
    for a, b in ((arrays.arrival, record.arrival), *zip(_peak_fields(arrays), _peak_fields(record))):
        np.testing.assert_array_equal(np.isnan(a), np.isnan(b))
        np.testing.assert_allclose(b, a, rtol=1e-9, atol=1e-12)


def _peak_fields(front):
    p = front.peaks
    return p.start_time, p.peak_time, p.peak_velocity, p.peak_acceleration


@lammps
def test_front_record_against_coarse_frames_within_the_interpolation_error(tmp_path):
    """From frames 0.1 ms and 0.5 ms apart, the array measures interpolate linearly between
    frames: their arrival times differ from the record's (every 0.01 ms step) by an error that
    grows as the square of the frame interval (measured 1.4e-3 ms and 0.035 ms)."""
    errors = {}
    for interval in (0.1, 0.5):
        case = make_case(particles=40, duration=40.0, interval=interval)
        traj = simulate(case, tmp_path / str(interval))
        arrays = measures.front(traj.t, traj.v, traj.a, 2.0, case.chain.gaps())
        record = read_front_record(case, tmp_path / str(interval) / "front.bin").front
        reached = np.isfinite(record.arrival)
        errors[interval] = np.max(np.abs(arrays.arrival[reached] - record.arrival[reached]))
        peak = np.isfinite(record.peaks.peak_velocity)
        assert np.max(np.abs(arrays.peaks.peak_time[peak] - record.peaks.peak_time[peak])) < 0.1 * interval
    assert errors[0.1] < 0.05 * 0.1
    assert 10 < errors[0.5] / errors[0.1] < 40  # (0.5 / 0.1)^2 = 25


@lammps
def test_h5md_opens_in_mdanalysis_with_the_same_positions_and_velocities(tmp_path):
    mda = pytest.importorskip("MDAnalysis")
    case = make_case(particles=20, duration=20.0, interval=0.5)
    traj = simulate(case, tmp_path)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # no topology: MDAnalysis guesses and says so
        u = mda.Universe(str(tmp_path / "traj.h5md"))  # converted to Angstrom, ps
    assert len(u.trajectory) == len(traj.t) == 41 and len(u.atoms) == 20
    angstrom_per_mm, angstrom_per_ps_per_m_per_s, ps_per_ms = 1e7, 1e-2, 1e9
    for frame, ts in enumerate(u.trajectory):
        # MDAnalysis keeps float32: 6e-8 relative of positions up to 230 mm
        np.testing.assert_allclose(ts.positions[:, 0], (traj.x0 + traj.u[frame]) * angstrom_per_mm, rtol=1.2e-7)
        np.testing.assert_allclose(ts.velocities[:, 0], traj.v[frame] * angstrom_per_ps_per_m_per_s,
                                   rtol=1.2e-7, atol=1e-12)
        assert np.all(ts.positions[:, 1:] == 0) and ts.time == pytest.approx(traj.t[frame] * ps_per_ms)


@lammps
def test_text_and_h5md_outputs_hold_the_same_trajectory(tmp_path):
    h5 = simulate(make_case(particles=20, duration=20.0), tmp_path / "h5")
    text = simulate(make_case(particles=20, duration=20.0, output={"format": "text"}), tmp_path / "text")
    assert not (tmp_path / "h5" / "traj.bin").exists()  # converted, then removed
    np.testing.assert_allclose(h5.t, text.t, rtol=1e-12)
    # the text dump keeps 12 significant digits: of x (up to 0.25 m), 1e-10 mm
    np.testing.assert_allclose(h5.u, text.u, rtol=0, atol=1e-9)
    np.testing.assert_allclose(h5.v, text.v, rtol=1e-11, atol=1e-15)
    np.testing.assert_allclose(h5.a, text.a, rtol=1e-11, atol=1e-9)


@lammps
def test_fine_output_holds_chosen_magnets_every_step(tmp_path):
    case = make_case(particles=20, duration=10.0, interval=0.5, output={"fine": [7, 2], "fine_interval": 0.02})
    simulate(case, tmp_path)
    coarse, fine = RunFolder(tmp_path).trajectory(), RunFolder(tmp_path).trajectory("fine")
    assert fine.v.shape == (501, 2) and np.allclose(np.diff(fine.t), 0.02)
    common = np.flatnonzero(np.isin(np.round(fine.t, 9), np.round(coarse.t, 9)))
    np.testing.assert_array_equal(fine.v[common], coarse.v[:, [1, 6]])  # columns in magnet order
    np.testing.assert_array_equal(fine.a[common], coarse.a[:, [1, 6]])  # impactor's from its profile


def test_fine_group_of_a_run_without_output_fine_is_refused_in_one_line(tmp_path):
    """trajectory("fine") where output.fine was not set names the group and what the run holds
    (trial: h5py's KeyError "object 'trajectory_fine' doesn't exist"); so does h5md.read_group."""
    import h5py

    from pylmp_lattice.formats import h5md

    run = RunFolder.create(make_case(particles=10, duration=2.0), tmp_path / "r")
    for magnets in (None, [3]):
        with pytest.raises(UsageError, match=r"^group: got 'fine'; output.fine was not set for the run in .*/r: "
                                             r"it holds the group chain alone$"):
            run.trajectory("fine", magnets=magnets)
    with h5py.File(tmp_path / "traj.h5md", "w") as h5:
        h5.create_group("particles/trajectory")
    with pytest.raises(UsageError, match=r"^group: got 'fine'; .*traj.h5md holds chain$"):
        h5md.read_group(tmp_path / "traj.h5md", "fine")


@pytest.mark.parametrize("damage, said", [
    ("text", "HDF5 cannot open it (Unable to synchronously open file (file signature not found)); expected an H5MD "
             "file as a run writes it (traj.h5md), whole"),
    ("cut", "HDF5 cannot open it (Unable to synchronously open file (truncated file: eof = 2000"),
    ("other", "Unable to synchronously open object (object 'particles' doesn't exist); expected a run's H5MD file: "
              "particles/trajectory with position, velocity, force, time and mass"),
])
def test_a_damaged_h5md_file_is_refused_in_one_line_naming_it(tmp_path, capsys, damage, said):
    """traj.h5md cut short, of text, or another program's HDF5 file: read_group says which file and
    what it expects (DumpFormatError), and `export` of its folder exits 2 with that line (trial:
    h5py's message naming no file, exit 1, and for the HDF5 file without the layout a KeyError's
    traceback)."""
    import h5py

    from pylmp_lattice.cli import main
    from pylmp_lattice.errors import DumpFormatError
    from pylmp_lattice.formats import h5md

    folder = tmp_path / "run"
    RunFolder.create(make_case(particles=5, duration=1.0), folder)
    target = folder / "traj.h5md"
    if damage == "text":
        target.write_text("not HDF5\n")
    else:
        with h5py.File(target, "w") as h5:
            h5.create_dataset("other/values", data=np.arange(1000.0))
        if damage == "cut":
            target.write_bytes(target.read_bytes()[:2000])
    with pytest.raises(DumpFormatError) as err:
        h5md.read_group(target)
    assert str(err.value).startswith(f"{target}: {said}")
    assert main(["export", str(folder), "-o", str(tmp_path / "frames.extxyz")]) == 2
    out = capsys.readouterr().err
    assert out.startswith(f"pylmp-lattice: error: {target}: {said}") and len(out.splitlines()) == 1, out
    assert not (tmp_path / "frames.extxyz").exists()


@pytest.mark.parametrize("content, said", [
    ("step", "Unable to synchronously open object (object 'value' doesn't exist)"),
    ("none", "observables/ holds none"),
])
def test_observables_of_an_h5md_file_of_another_layout_are_refused_in_one_line(tmp_path, content, said):
    """read_observables of an HDF5 file whose observables lack the run's layout (kinetic_energy
    with a step only; no observable at all): DumpFormatError naming the file, what is missing
    and what a run's file holds there, as read_group says it (trial: a KeyError traceback, and
    a StopIteration one for the empty group)."""
    import h5py

    from pylmp_lattice.errors import DumpFormatError
    from pylmp_lattice.formats import h5md

    target = tmp_path / "traj.h5md"
    with h5py.File(target, "w") as h5:
        h5.create_group("observables")
        if content == "step":
            h5.create_dataset("observables/kinetic_energy/step", data=np.arange(3))
    with pytest.raises(DumpFormatError) as err:
        h5md.read_observables(target)
    assert str(err.value) == (f"{target}: {said}; expected a run's H5MD file: observables/ with some of "
                              "kinetic_energy, potential_energy, total_energy, friction_work, min_gap, dt, each a "
                              "value and a time with their unit")


@lammps
def test_lammps_error_keeps_every_frame_written_before_it(tmp_path):
    # a short pulse: once the impactor stops, the chain runs away from it and gap 1-2 outgrows the table
    case = make_case(particles=10, duration=60.0, table={"r_max": 13.0},
                     impactor={"profile": "sine", "velocity": 2.0, "duration": 5.0})
    with pytest.raises(RunError, match=r"magnets \d+ and \d+ outside the table range"):  # chain engine
        execute(case, tmp_path)
    traj = RunFolder(tmp_path).trajectory()
    assert 5.0 < traj.t[-1] < 60.0 and np.allclose(np.diff(traj.t), 0.1)
    assert np.max(traj.gaps()[-1]) > 12.5  # a gap close to the table's end, 13 mm


@lammps
def test_truncated_binary_dump_keeps_its_complete_frames(tmp_path):
    from pylmp_lattice.run_folder import RunFolder
    from pylmp_lattice.runner import run_embedded

    folder = run_embedded(RunFolder.create(make_case(particles=10, duration=5.0), tmp_path).path)
    path = folder / "traj.bin"
    whole = open_dump(path).read()
    path.write_bytes(path.read_bytes()[:-100])
    cut = open_dump(path)
    assert cut.frames == len(whole.step) - 1
    np.testing.assert_array_equal(cut.read().data, whole.data[:-1])
    path.write_bytes(path.read_bytes()[:100])  # cut inside the first frame: nothing to convert
    assert open_dump(path).frames == 0 and open_dump(path).read().data.size == 0
    assert not RunFolder(folder).convert() and path.exists()


@lammps
def test_run_without_trajectory_still_has_its_front_measures(tmp_path):
    """output.format = "none": the summary comes from the engine's record alone."""
    with_h5 = run_case(make_case(particles=40, duration=30.0), tmp_path / "h5", figure=False)
    bare = run_case(make_case(particles=40, duration=30.0, output={"format": "none"}), tmp_path / "none")
    assert sorted(p.name for p in (tmp_path / "none").iterdir() if p.suffix in (".h5", ".bin", ".dump")) == ["front.bin"]
    assert "trajectory" not in bare["files"] and (tmp_path / "none" / "shock.png").exists()
    for key in ("shock_velocity_plateau_m_per_s", "first_peak_velocity_plateau_m_per_s"):
        assert bare[key] == with_h5[key]


@pytest.mark.parametrize("atoms", [1, 5, 6, 7, 20])
def test_a_frame_written_with_its_ids_beside_the_data_equals_the_whole_frame(tmp_path, monkeypatch, atoms):
    """write_frame(ids=True), as the kernel engines write front.bin: the same bytes as the frame
    made whole (ids column first), across its blocks of rows (3 here), and read back."""
    from pylmp_lattice.formats import bindump, layout

    monkeypatch.setattr(bindump, "_ROWS", 3)
    data = np.random.default_rng(atoms).normal(size=(atoms, len(layout.FRONT_COLUMNS.split()) - 1))
    whole = np.hstack([np.arange(1, atoms + 1, dtype=float)[:, None], data])
    bindump.write_frame(tmp_path / "whole.bin", 7, 0.25, layout.FRONT_COLUMNS, whole)
    bindump.write_frame(tmp_path / "ids.bin", 7, 0.25, layout.FRONT_COLUMNS, data, ids=True)
    assert (tmp_path / "ids.bin").read_bytes() == (tmp_path / "whole.bin").read_bytes()
    frame = open_dump(tmp_path / "ids.bin").read()
    np.testing.assert_array_equal(frame.data[0], whole)


def _chunked_frame(step: int, time: float, values: np.ndarray, chunks: int) -> bytes:
    """One frame of a binary dump (columns "id x vx fx") as LAMMPS writes it on `chunks` ranks:
    the atoms' rows in `chunks` consecutive chunks (see `bindump`)."""
    names = b"id x vx fx"
    head = (np.array([-10], "<i8").tobytes() + b"DUMPCUSTOM" + np.array([1, 2], "<i4").tobytes()
            + np.array([step, len(values)], "<i8").tobytes() + np.zeros(7, "<i4").tobytes()
            + np.zeros(6, "<f8").tobytes() + np.array([4, 2], "<i4").tobytes() + b"si" + b"\x01"
            + np.array([time], "<f8").tobytes() + np.array([len(names)], "<i4").tobytes() + names
            + np.array([chunks], "<i4").tobytes())
    parts = np.array_split(np.ascontiguousarray(values, "<f8"), chunks)
    return head + b"".join(np.array([part.size], "<i4").tobytes() + part.tobytes() for part in parts)


def _chunked_dump(frames: int = 3, atoms: int = 5) -> tuple[bytes, np.ndarray]:
    rng = np.random.default_rng(7)
    data = np.concatenate([np.broadcast_to(np.arange(1.0, atoms + 1)[None, :, None], (frames, atoms, 1)),
                           rng.normal(size=(frames, atoms, 3))], axis=2)
    return b"".join(_chunked_frame(10 * k, 0.5 * k, data[k], 2) for k in range(frames)), data


def test_a_dump_written_by_several_ranks_reads_back_every_frame(tmp_path):
    """Frames of two chunks each (two ranks), walked one by one: all 3 come back bit for bit,
    whole or from a frame on (mutation: the walk dropping its last block, here every frame,
    survived: only slow MPI tests wrote such dumps)."""
    from pylmp_lattice.formats.bindump import write_frame

    raw, data = _chunked_dump()
    write_frame(tmp_path / "one.bin", 10, 0.5, "id x vx fx", data[1])  # the layout, as one rank writes it
    assert (tmp_path / "one.bin").read_bytes() == _chunked_frame(10, 0.5, data[1], 1)
    (tmp_path / "traj.bin").write_bytes(raw)
    dump = open_dump(tmp_path / "traj.bin")
    assert (dump.frames, dump.atoms, dump.columns, dump.frame_dtype) == (3, 5, ("id", "x", "vx", "fx"), None)
    frames = dump.read()
    assert frames.step.tolist() == [0, 10, 20] and frames.time.tolist() == [0.0, 0.5, 1.0]
    assert frames.data.tobytes() == data.tobytes()
    assert dump.read(1).data.tobytes() == data[1:].tobytes()


def test_a_dump_written_by_several_ranks_drops_a_last_frame_cut_in_its_data(tmp_path):
    """A multi-rank dump whose last frame is cut inside its last chunk's values (a stopped run):
    2 whole frames counted and read, bit for bit (mutation: a chunk's short values not noticed
    while counting, the cut frame counted whole, survived)."""
    from pylmp_lattice.formats.bindump import complete_bytes

    raw, data = _chunked_dump()
    (tmp_path / "traj.bin").write_bytes(raw[:-20])
    dump = open_dump(tmp_path / "traj.bin")
    assert dump.frames == 2
    assert dump.read().data.tobytes() == data[:2].tobytes()
    # what binary2txt is given of it: the two whole frames' bytes
    assert complete_bytes(tmp_path / "traj.bin") == len(raw) - len(_chunked_frame(20, 1.0, data[2], 2))
    (tmp_path / "whole.bin").write_bytes(raw)
    assert complete_bytes(tmp_path / "whole.bin") == len(raw)


def test_complete_bytes_takes_the_whole_file_where_frames_end_in_bytes_of_no_frame(tmp_path, caplog):
    """Two whole frames, then 128 zero bytes (a tail a crash left zeroed): no frame header there
    (0 columns), so binary2txt is given the whole file, as it was before, with a warning naming
    the frame and byte (not a cut at the last whole frame: the walk did not end inside one)."""
    from pylmp_lattice.formats.bindump import complete_bytes

    raw, _ = _chunked_dump(frames=2)
    (tmp_path / "traj.bin").write_bytes(raw + bytes(128))
    assert complete_bytes(tmp_path / "traj.bin") == len(raw) + 128
    assert caplog.messages == [f"{tmp_path / 'traj.bin'}: frame 2 at byte {len(raw)} not parsed here (0 columns; "
                               "expected >= 1): the whole file is converted, a last frame cut short not left out"]


@pytest.mark.parametrize("args, field, got, low", [
    ((5,), "start", "5", 0), ((-1,), "start", "-1", 0), ((1.5,), "start", "1.5", 0),
    ((2, 1), "stop", "1", 2), ((0, 4), "stop", "4", 0), ((0, -1), "stop", "-1", 0),
])
def test_a_frame_index_out_of_range_is_named_with_the_range(tmp_path, args, field, got, low):
    """BinaryDump.read(start, stop) of a 3-frame dump: an index outside 0 .. 3 (or a stop before
    the start) is a UsageError naming it and the range (trial: a start past the end or a stop
    below it read 0 frames silently, a negative start failed in numpy as "[Errno 22] Invalid
    argument"); the range's ends read as Python's slices do."""
    raw, data = _chunked_dump()
    for name, content in (("chunks.bin", raw), ("one.bin", None)):
        if content is None:  # one chunk a frame: read as records
            from pylmp_lattice.formats.bindump import write_frame

            parts = []
            for k in range(3):
                write_frame(tmp_path / name, 10 * k, 0.5 * k, "id x vx fx", data[k])
                parts.append((tmp_path / name).read_bytes())
            content = b"".join(parts)
        (tmp_path / name).write_bytes(content)
        dump = open_dump(tmp_path / name)
        with pytest.raises(UsageError, match=rf"^{field}: got {re.escape(got)}; expected an integer frame index in "
                                             rf"{low} \.\. 3 \({name} holds 3 frames\)$"):
            dump.read(*args)
        assert dump.read(3).step.tolist() == [] and dump.read(1, 3).step.tolist() == [10, 20]
        assert dump.read(2).data.tobytes() == data[2:].tobytes()


def test_a_dump_whose_later_frame_has_another_layout_is_refused(tmp_path):
    """A later frame of another atom count (a dump appended to by another run) is a
    DumpFormatError naming it, never its bytes read as values: where the frames are counted one
    by one (here the package's own frames, each with its unit style), when the file is opened;
    where they are counted from the file's size (frames alike: LAMMPS's, the unit style in none),
    as each is read (mutation: the records' layout check skipped survived)."""
    from pylmp_lattice.errors import DumpFormatError
    from pylmp_lattice.formats.bindump import _frame_dtype, _Frame, write_frame

    for k, atoms in enumerate((4, 8)):
        data = np.column_stack([np.arange(1.0, atoms + 1), np.full((atoms, 3), 0.25 * k)])
        write_frame(tmp_path / f"{k}.bin", k, 0.5 * k, "id x vx fx", data)
    (tmp_path / "traj.bin").write_bytes((tmp_path / "0.bin").read_bytes() + (tmp_path / "1.bin").read_bytes())
    with pytest.raises(DumpFormatError, match=r"traj\.bin: frame 1 holds 8 atoms of id x vx fx; frame 0 4 of"):
        open_dump(tmp_path / "traj.bin")
    names = b"id x vx fx"
    rec = np.zeros(3, _frame_dtype(_Frame(tuple(names.decode().split()), 4, 0, 0.0, 1, 0, len(names), None)))
    rec["magic_len"], rec["magic"], rec["endian"], rec["revision"], rec["ncol"] = -10, b"DUMPCUSTOM", 1, 2, 4
    rec["atoms"], rec["time_flag"], rec["names_len"], rec["names"], rec["chunks"], rec["n"] = 4, 1, len(names), names, 1, 16
    rec["step"], rec["time"] = [0, 1, 2], [0.0, 0.5, 1.0]
    rec["data"][:, :, 0] = np.arange(1.0, 5.0)
    rec["atoms"][2] = 2  # (its size as if of 4)
    rec.tofile(tmp_path / "alike.bin")
    dump = open_dump(tmp_path / "alike.bin")
    assert dump.frames == 3 and dump.atoms == 4 and dump.frame_dtype is not None
    assert list(dump.read(0, 2).step) == [0, 1]
    with pytest.raises(DumpFormatError, match=r"alike\.bin: frame 2 differs in layout from frame 0"):
        dump.read()
