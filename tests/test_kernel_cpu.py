"""The host engine (engines.cpu: the chain kernel on every core, on the road of every batch:
`run_folder.execute_batch` with `engines.road.KernelEngine`) against LAMMPS's batch of the same
members (deck.render_replicas, fix lattice/chain), for every law, drive, friction on and off,
thermal and disorder members and both far ends: final x and v within 1e-12 relative, the front
measures (read from the folder's front.bin, as a sweep reads them) within 1e-9, the friction work
within 1e-12 relative. The GPU engine (engines.gpu, the same kernel through NVRTC) against the
host engine, where CuPy finds a device (marked gpu). The layout the library exports against
the package's record columns."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from pylmp_lattice.case import Case
from pylmp_lattice.deck import render_replicas
from pylmp_lattice.engines.library import Unsupported, layout
from pylmp_lattice.engines.road import KernelEngine
from pylmp_lattice.case_measures import read_front_batch
from pylmp_lattice.measures import FirstPeaks
from pylmp_lattice.formats.layout import CHAIN_WORK, DECK, FRONT_BIN, FRONT_COLUMNS, FRONT_FIELDS, in_deck
from pylmp_lattice.run_folder import execute_batch
from pylmp_lattice.runner import run_embedded
from pylmp_lattice.units import from_engine

from conftest import OTHER_LAWS, make_case

pytestmark = pytest.mark.lammps
MEMBERS = 20
FRICTION = {"mu": 0.285, "p": 0.012}
FINAL = "final.txt"
_T = np.arange(0.0, 8.0 + 1e-9, 0.125)
DRIVES = {
    "constant": {"profile": "constant", "velocity": 2.0},
    "ramp": {"profile": "ramp", "velocity": 2.0, "ramp_time": 1.3},
    "sine": {"profile": "sine", "velocity": 2.0, "duration": 2.3},
    # u samples of a half-sine pulse (2 m/s for 2 ms), held after the data
    "measured": {"profile": "measured", "t": list(_T), "values": list(4.0 / np.pi * (1 - np.cos(np.pi * np.minimum(_T, 2.0) / 2.0))),
                 "column": "u", "after": "hold"},
    "rest": {"profile": "rest"},
}


def thermal(law: str = "power", chain: dict | None = None, **kw) -> list[Case]:
    """MEMBERS members of one point (21 magnets, 30 ms: the front reflects from the far end),
    each with its own thermal draw; law: "power" (the paper's) or one of OTHER_LAWS."""
    base = {"particles": 21, "duration": 30.0, "output": {"format": "none"}}
    if law != "power":
        force, r0, table = OTHER_LAWS[law]
        base |= {"force": force, "table": table, "velocity": 0.5}
        chain = {"mass": 1.0, "r0": r0} | (chain or {})
    return [make_case(**(base | kw), chain={"thermal_velocity": 0.02, "seed": s} | (chain or {})) for s in range(MEMBERS)]


def lammps(cases: list[Case], folder: Path, arrival_method: str = "level") -> dict:
    """The members as one LAMMPS batch (the sweep's batch deck) with their final x and v dumped."""
    folder.mkdir()
    for name, text in render_replicas(cases, front=True).items():
        (folder / name).write_text(text)
    deck = folder / DECK
    deck.write_text(deck.read_text() + f"write_dump all custom {in_deck(FINAL)} id x vx modify sort id format float %.17g\n")
    run_embedded(folder)
    n = cases[0].chain.particles
    rows = np.loadtxt(folder / FINAL, skiprows=9)
    return recorded(cases, folder, arrival_method, from_engine(rows[:, 1], "length").reshape(-1, n),
                    from_engine(rows[:, 2], "velocity").reshape(-1, n))


def kernel(cases: list[Case], folder: Path, arrival_method: str = "level", kind: str = "cpu") -> dict:
    """The members as one batch of the `kind` engine, on the sweep's road into `folder`."""
    engine = KernelEngine(kind, cases)
    execute_batch(cases, folder, engine)
    return recorded(cases, folder, arrival_method, *engine.final)


def recorded(cases: list[Case], folder: Path, arrival_method: str, x, v) -> dict:
    """What a batch left in its folder (front record, friction work) and its chains' final x, v."""
    out = {"x": x, "v": v}
    if (folder / FRONT_BIN).exists():
        out["record"] = read_front_batch(cases, folder / FRONT_BIN, arrival_method)
    if (folder / CHAIN_WORK).exists():
        out["work"] = from_engine(np.loadtxt(folder / CHAIN_WORK), "energy")
    return out


def assert_same(got: dict, ref: dict):
    for name in ("x", "v"):
        scale = np.max(np.abs(ref[name]))
        assert np.max(np.abs(got[name] - ref[name])) <= 1e-12 * scale, name
    assert ("work" in got) == ("work" in ref)
    if "work" in ref:
        np.testing.assert_allclose(got["work"], ref["work"], rtol=1e-12, atol=0)
        assert np.all(got["work"] > 0)
    assert ("record" in got) == ("record" in ref)
    if "record" not in ref:
        return
    got, want = got["record"], ref["record"]
    assert got.end_time == want.end_time
    pairs = [(got.max_speed, want.max_speed), (got.front.arrival, want.front.arrival),
             (got.front.propagation_velocity, want.front.propagation_velocity)]
    pairs += [(getattr(got.front.peaks, f.name), getattr(want.front.peaks, f.name)) for f in dataclasses.fields(FirstPeaks)]
    for a, b in pairs:
        np.testing.assert_allclose(a, b, rtol=1e-9, atol=0, equal_nan=True)
    assert np.isfinite(want.front.arrival[:, 1:]).any(axis=1).all()  # a front in every chain


@pytest.mark.parametrize("friction", [None, FRICTION], ids=["frictionless", "friction"])
@pytest.mark.parametrize("law", ["power", *OTHER_LAWS])
def test_every_law_with_and_without_friction(tmp_path, law, friction):
    cases = thermal(law, **({"friction": friction} if friction else {}))
    assert_same(kernel(cases, tmp_path / "cpu"), lammps(cases, tmp_path / "lammps"))


@pytest.mark.parametrize("drive", [d for d in DRIVES if d != "constant"])
def test_every_drive(tmp_path, drive):
    """(constant: the laws' test); pulses arrive by their velocity peaks (the record's pulse column)"""
    cases = thermal(impactor=DRIVES[drive], friction=FRICTION)
    method = "velocity_peak" if drive in ("sine", "measured") else "level"
    assert_same(kernel(cases, tmp_path / "cpu", method), lammps(cases, tmp_path / "lammps", method))


def test_mass_and_gap_disorder(tmp_path):
    """Disordered members (per-atom masses in LAMMPS), with friction."""
    cases = thermal(friction=FRICTION, chain={"thermal_velocity": None, "mass_disorder": 0.05, "r0_disorder": 0.05})
    assert len({c.chain.masses()[3] for c in cases}) == MEMBERS
    assert_same(kernel(cases, tmp_path / "cpu"), lammps(cases, tmp_path / "lammps"))


def test_long_far_end(tmp_path):
    cases = thermal(chain={"far_end": "long"}, particles=None, duration=10.0)
    assert cases[0].chain.particles > 21
    assert_same(kernel(cases, tmp_path / "cpu"), lammps(cases, tmp_path / "lammps"))


def test_members_it_cannot_run_are_refused_with_the_reason():
    cases = thermal()
    with pytest.raises(Unsupported, match="output.format"):
        KernelEngine("cpu", [dataclasses.replace(c, output=dataclasses.replace(c.output, format="text")) for c in cases])
    other = make_case(particles=22, output={"format": "none"})
    with pytest.raises(Unsupported, match="cannot share a batch"):
        KernelEngine("cpu", [cases[0], other])


def test_the_library_s_layout_is_the_record_s():
    """The columns, block and status names Python reads from the library (never restates)."""
    lay = layout()
    assert lay.nout == len(FRONT_FIELDS) == len(FRONT_COLUMNS.split()) - 1
    assert lay.ncol > lay.nout and lay.block >= 1
    assert lay.status == ("done", "contact", "out_of_range", "drive_ended")


def test_each_thread_s_share_of_a_call_fills_its_lanes(monkeypatch):
    """The chains of a call (`cpu.run_arrays`) are CHUNK_ATOM_STEPS a thread rounded up to the
    lanes a thread runs side by side: 20 chains of 1000 magnets, 3 a thread by CHUNK_ATOM_STEPS,
    on 2 threads in calls of 8, 8 and 4 (3 rounded up to 4 lanes, or 2 of 2), not of 6: fewer
    chains than lanes cost as much (the other lanes run copies), and a call whose lane batches
    were one per thread ran on one thread (the library's OpenMP loop took 2 at a grab: 64 chains
    of 1000 magnets took 0.87 s on 2 threads as on 1; now 0.43 s, cpu.run_arrays timed by hand,
    2026-11-27 22:08 UTC). The results are those of one call of all 20."""
    from pylmp_lattice.engines import cpu
    from pylmp_lattice.engines.arrays import prepare

    a = prepare([make_case(particles=1000, duration=4.0, output={"format": "none"},
                           chain={"thermal_velocity": 0.02, "seed": s}) for s in range(20)], "cpu")
    monkeypatch.setattr(cpu, "CHUNK_ATOM_STEPS", 3 * a.n * a.steps)
    lib, sizes = cpu.library(), []

    class Counted:
        def __getattr__(self, name):
            return getattr(lib, name)

        def pl_run_chains(self, count, *args):
            sizes.append(count)
            return lib.pl_run_chains(count, *args)

    monkeypatch.setattr(cpu, "library", Counted)
    got = cpu.run_arrays(a, 2)
    assert layout().lanes in (2, 4) and sizes == [8, 8, 4]
    monkeypatch.setattr(cpu, "CHUNK_ATOM_STEPS", 1e12)
    whole = cpu.run_arrays(a, 2)
    assert sizes[3:] == [20]
    for mine, one in zip(got, whole):
        assert np.array_equal(mine, one, equal_nan=True)


@pytest.mark.gpu
@pytest.mark.parametrize("members", ["power-friction", "table-law", "measured-drive"])
def test_the_gpu_engine_gives_the_host_engine_s_results(tmp_path, members):
    from pylmp_lattice.engines import gpu

    why = gpu.available()
    if why:
        pytest.skip(why)
    cases = {"power-friction": lambda: thermal(friction=FRICTION), "table-law": lambda: thermal("morse"),
             "measured-drive": lambda: thermal(impactor=DRIVES["measured"], friction=FRICTION)}[members]()
    method = "velocity_peak" if members == "measured-drive" else "level"
    assert_same(kernel(cases, tmp_path / "gpu", method, "gpu"), kernel(cases, tmp_path / "cpu", method))


def test_the_record_the_engine_holds_is_the_one_it_wrote(tmp_path):
    """`KernelEngine.record` (the sweep measures it, not reading front.bin back) is bit for bit
    what front.bin reads back as, and read_front_batch of it measures the same Front."""
    from pylmp_lattice.formats.front_record import read_front_rows

    cases = thermal(friction=FRICTION)
    engine = KernelEngine("cpu", cases)
    execute_batch(cases, tmp_path, engine)
    held, read = engine.record, read_front_rows(tmp_path / FRONT_BIN, MEMBERS, 21)
    assert held.end_time == read.end_time and list(held.columns) == [name for name, _ in FRONT_FIELDS]
    for name, column in read.columns.items():
        assert held.columns[name].shape == (MEMBERS, 21)
        assert held.columns[name].tobytes() == column.tobytes(), name
    assert np.isfinite(read.columns["arrival"][:, 1:]).any()  # fronts: the comparison is not of NaN alone
    got = read_front_batch(cases, tmp_path / "absent", "level", rows=engine.record)  # (the path is not read)
    want = read_front_batch(cases, tmp_path / FRONT_BIN, "level")
    assert got.front.arrival.tobytes() == want.front.arrival.tobytes()
    assert got.front.propagation_velocity.tobytes() == want.front.propagation_velocity.tobytes()
    for f in dataclasses.fields(FirstPeaks):
        assert getattr(got.front.peaks, f.name).tobytes() == getattr(want.front.peaks, f.name).tobytes()
    assert got.max_speed.tobytes() == want.max_speed.tobytes() and got.end_time == want.end_time

