"""The chain engine (fix lattice/chain) against the stock path it replaces, on 1, 2 and 3 ranks."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from pylmp_lattice.formats.bindump import open_dump
from pylmp_lattice.case import case_from_dict, case_to_dict
from pylmp_lattice.deck import render_replicas
from pylmp_lattice.formats.layout import DATA
from pylmp_lattice.errors import ConfigError, ContactError
from pylmp_lattice.forcelaw import PowerLaw
from pylmp_lattice.impactor import SinePulse
from pylmp_lattice.formats.dump import read_dump, trajectory_from_dump
from pylmp_lattice.runner import run_deck, run_embedded
from pylmp_lattice.case_measures import read_front_record
from pylmp_lattice.run_folder import RunFolder, execute_batch, simulate, write_folder

from conftest import make_case

FRICTION = {"mu": 0.285, "p": 0.012}
# the measured profile: u samples of a 2 m/s, 10 ms half-sine pulse at 8 kHz, held after 20 ms
_T = np.arange(0.0, 20.0 + 1e-9, 0.125)
PROFILES = {
    "constant": {"profile": "constant", "velocity": 2.0},
    "ramp": {"profile": "ramp", "velocity": 2.0, "ramp_time": 7.3},
    "sine": {"profile": "sine", "velocity": 2.0, "duration": 7.3},
    "measured": {"profile": "measured", "t": list(_T), "values": list(SinePulse(2.0, 10.0).displacement_at(_T)),
                 "column": "u", "after": "hold"},
    "rest": {"profile": "rest"},
}


def with_run(case, **changes):
    return dataclasses.replace(case, run=dataclasses.replace(case.run, **changes))


def both_engines(case, folder):
    return {engine: simulate(with_run(case, engine=engine), folder / engine) for engine in ("chain", "stock")}


def _chain(profile: str, friction: bool):
    extra = {"friction": FRICTION} if friction else {}
    if profile == "rest":  # unequal gaps set the chain moving with the impactor at rest
        extra["chain"] = {"r0": [9.0 if k % 3 else 15.0 for k in range(20)]}
    return make_case(particles=21, duration=30.0, interval=0.5, impactor=PROFILES[profile], **extra)


@pytest.mark.lammps
@pytest.mark.parametrize("friction", [False, True], ids=["frictionless", "friction"])
@pytest.mark.parametrize("profile", sorted(PROFILES))
def test_chain_engine_matches_the_stock_path(tmp_path, profile, friction):
    """Same trajectories to 1e-9 m/s for every impactor profile, with and without friction
    (the bonds' table differs from the exact law by < 1e-6 relative; measured <= 8.1e-13 m/s)."""
    runs = both_engines(_chain(profile, friction), tmp_path)
    chain, stock = runs["chain"], runs["stock"]
    assert chain.v.shape == stock.v.shape == (61, 21)
    assert np.max(np.abs(chain.v)) > 0.1  # something moved
    assert np.max(np.abs(chain.v - stock.v)) < 1e-9
    assert np.max(np.abs(chain.u - stock.u)) < 1e-9  # mm
    # forces, friction included: 1e-6 relative of the largest acceleration
    assert np.max(np.abs(chain.a - stock.a)) < 1e-6 * np.max(np.abs(stock.a))
    if friction:
        stuck = stock.v[:, 1:-1] == 0.0
        assert np.any(stuck) and np.array_equal(chain.v[:, 1:-1] == 0.0, stuck)  # exact stick, same frames


@pytest.mark.lammps
def test_sampled_law_through_the_table_spline(tmp_path):
    """A law known only as samples: the chain fix interpolates the same table as bond_style
    table spline, so with friction both engines agree to round-off (1e-12 m/s)."""
    r = np.linspace(0.0, 40.0, 401)
    sampled = {"law": "sampled", "r": list(r), "F": list(PowerLaw().force(r))}
    case = make_case(particles=21, duration=30.0, interval=0.5, force=sampled, table={"r_max": 36.0},
                     friction=FRICTION)
    runs = both_engines(case, tmp_path)
    assert "law table ${dir}/force.table FORCE_LAW" in (tmp_path / "chain" / "in.lattice").read_text()
    assert np.max(np.abs(runs["chain"].v - runs["stock"].v)) < 1e-12


@pytest.mark.lammps
def test_contact_is_reported_at_the_step_of_a_step_by_step_guard(tmp_path):
    """21 magnets driven into the held end: the chain fix checks every gap at every step and
    names the same pair, time and gap as the stock guard run at every step (check_interval =
    dt); the stock default, every output interval, sees it up to 0.1 ms later."""
    case = make_case(particles=21, velocity=2.0, duration=200.0)
    errors = {}
    for name, run in {"chain": {}, "stock_every_step": {"engine": "stock", "check_interval": 0.01},
                      "stock_default": {"engine": "stock"}}.items():
        with pytest.raises(ContactError) as info:
            simulate(with_run(case, **run), tmp_path / name)
        errors[name] = info.value
    chain, stock = errors["chain"], errors["stock_every_step"]
    assert chain.pair == stock.pair == (19, 20)
    assert chain.time_ms == stock.time_ms == pytest.approx(68.56, abs=1e-9)
    assert chain.gap_mm == pytest.approx(stock.gap_mm, abs=1e-9) and chain.gap_mm <= 0
    assert errors["stock_default"].time_ms == pytest.approx(68.6, abs=1e-9)


@pytest.mark.slow  # MPI bit identity: several lmp runs under mpiexec
@pytest.mark.lammps
def test_one_two_and_three_ranks_give_bit_identical_trajectories_and_front_records(tmp_path):
    """700 magnets with friction and a pulse on 1, 2 and 3 MPI ranks (full doubles in the
    binary dumps): the chain fix owns the state on every rank (its log says so) and exchanges
    only the positions across the slab edges; x, v, f and the front record are identical bit
    for bit (each bond's force comes from the same two positions in the same order)."""
    case = make_case(particles=700, velocity=2.0, duration=50.0, interval=5.0, impactor=PROFILES["sine"],
                     friction=FRICTION)
    runs, fronts = {}, {}
    for n in (1, 2, 3):
        runs[n] = simulate(case, tmp_path / f"np{n}", runner="lmp", nprocs=n)
        log = (tmp_path / f"np{n}" / "log.lammps").read_text()
        assert f"owns the state (one pass per step, front record inside) on {n} rank" in log
        if n > 1:
            assert f"{n} by 1 by 1 MPI processor grid" in log
        # the record's values (the file's chunks differ: one per rank)
        fronts[n] = open_dump(tmp_path / f"np{n}" / "front.bin").read().data.view(np.uint64)
    assert np.max(np.abs(runs[1].v)) > 1.0
    assert np.sum(np.isfinite(read_front_record(case, tmp_path / "np1" / "front.bin").front.peaks.peak_velocity)) >= 5
    for n in (2, 3):
        for name in ("x0", "u", "v", "a"):
            assert np.array_equal(getattr(runs[1], name), getattr(runs[n], name)), (n, name)
        assert np.array_equal(fronts[n], fronts[1]), n


@pytest.mark.slow  # an lmp run under mpiexec
@pytest.mark.lammps
def test_two_ranks_reach_across_gaps_near_the_end_of_the_table(tmp_path):
    """Gaps of 12 mm with the table ending at 12.5 mm: every separation of the run is up to 96 %
    of the longest the deck allows, so each rank's ghosts must reach that far across its slab
    edge (comm_modify cutoff 1.05 r_max); on 2 ranks the run gives the bits of one rank's. A
    cutoff under 0.96 r_max stops it: 'atom 12 (neighbour of atom 11) is not on this rank'."""
    case = make_case(particles=21, velocity=2.0, duration=20.0, table={"r_max": 12.5})
    one = simulate(case, tmp_path / "np1")
    two = simulate(case, tmp_path / "np2", runner="lmp", nprocs=2)
    assert "2 by 1 by 1 MPI processor grid" in (tmp_path / "np2" / "log.lammps").read_text()
    assert np.max(one.gaps()) > 0.96 * 12.5 and np.max(np.abs(one.v)) > 2.0
    for name in ("u", "v", "a"):
        assert np.array_equal(getattr(one, name), getattr(two, name)), name


def test_engine_field_is_validated_and_round_trips():
    data = case_to_dict(make_case())
    assert data["run"]["engine"] == "chain"
    assert case_from_dict(data) == make_case()
    data["run"]["engine"] = "fast"
    with pytest.raises(ConfigError, match=r"run.engine: got 'fast'; choose one of chain, stock"):
        case_from_dict(data)


def _run_with_17_digits(folder, nprocs=1):
    """Run a written folder with its text dump at 17 digits (every double exactly), on `nprocs`
    ranks of `lmp` or (1) in-process."""
    deck = folder / "in.lattice"
    deck.write_text(deck.read_text().replace("format float %.12g", "format float %.17g"))
    run_deck(folder, "lmp" if nprocs > 1 else "embedded", nprocs=nprocs)
    return trajectory_from_dump(read_dump(folder / "traj.dump", dt=1e-5))  # make_case: dt = 0.01 ms


@pytest.mark.slow  # MPI bit identity: several lmp runs under mpiexec
@pytest.mark.lammps
def test_a_batch_on_several_ranks_is_split_by_whole_chains_bit_for_bit(tmp_path):
    """Five 21-magnet chains with friction on 1, 2 and 3 ranks: each rank owns whole chains
    (a 1 by P by 1 grid; the log says so), nothing crosses a rank, and the trajectories are
    those of one rank bit for bit."""
    cases = [make_case(particles=21, duration=30.0, interval=0.5, friction=FRICTION, chain={"mass": 1.0 + 0.05 * r},
                       output={"format": "text"}) for r in range(5)]
    runs = {n: _run_with_17_digits(write_folder(cases, tmp_path / f"np{n}"), n) for n in (1, 2, 3)}
    assert np.max(np.abs(runs[1].v)) > 1.0
    for n in (2, 3):
        log = (tmp_path / f"np{n}" / "log.lammps").read_text()
        assert f"1 by {n} by 1 MPI processor grid" in log
        assert f"owns the state (one pass per step) on {n} ranks, whole chains on each rank" in log
        for name in ("x0", "u", "v", "a"):
            assert np.array_equal(getattr(runs[1], name), getattr(runs[n], name)), (n, name)


@pytest.mark.lammps
def test_batched_replicas_equal_their_single_runs(tmp_path):
    """Four 21-magnet chains with different masses, with friction, in one LAMMPS instance:
    each replica's trajectory is bit for bit its own run's (same x values, y offsets only)."""
    cases = [make_case(particles=21, duration=30.0, interval=0.5, friction=FRICTION, chain={"mass": 1.0 + 0.05 * r},
                       output={"format": "text"}) for r in range(4)]
    _run_with_17_digits(write_folder(cases, tmp_path / "batched"))
    batched = RunFolder(tmp_path / "batched").replicas()
    assert "length 21" in (tmp_path / "batched" / "in.lattice").read_text()
    for r, case in enumerate(cases):
        single = _run_with_17_digits(RunFolder.create(case, tmp_path / f"single{r}").path)
        single.a[:, 0] = case.impactor.acceleration_at(single.t)
        assert np.max(np.abs(single.v)) > 1.0
        for name in ("x0", "u", "v", "a"):
            assert np.array_equal(getattr(batched[r], name), getattr(single, name)), (r, name)
    assert not np.array_equal(batched[0].v, batched[3].v)
    # the package's road: the same trajectories through execute_batch
    again = execute_batch(cases, tmp_path / "again").replicas()
    assert np.max(np.abs(again[2].v - batched[2].v)) < 1e-11


def _run_printing_work(folder, entries):
    """Run a written folder with `print` lines for f_chain entries after the run (17 digits)."""
    deck = folder / "in.lattice"
    prints = "".join(f'print "WORK {e} $(f_chain[{e}]:%.17g)"\n' for e in entries)
    deck.write_text(deck.read_text() + "\n" + prints)
    run_embedded(folder)
    log = (folder / "log.lammps").read_text()
    return {e: float(log.split(f"\nWORK {e} ")[1].split()[0]) for e in entries}


@pytest.mark.lammps
def test_batched_replicas_report_their_own_friction_work(tmp_path):
    """Each chain's friction work (fix lattice/chain's vector entry 3 + c) is its single run's
    (entry 1) bit for bit; entry 1 of the batch is their sum. `fix_modify chain write_work FILE`
    writes the same doubles, a line per chain."""
    cases = [make_case(particles=21, duration=30.0, interval=10.0, friction=FRICTION, chain={"mass": 1.0 + 0.05 * r})
             for r in range(3)]
    folder = write_folder(cases, tmp_path / "batched")
    deck = folder / "in.lattice"
    deck.write_text(deck.read_text() + "\nfix_modify chain write_work ${dir}/work.txt\n")
    batched = _run_printing_work(folder, [1, 3, 4, 5])
    single = [_run_printing_work(RunFolder.create(c, tmp_path / f"single{r}").path, [1, 3])[1] for r, c in enumerate(cases)]
    assert min(single) > 0 and len(set(single)) == 3
    assert [batched[3 + r] for r in range(3)] == single
    assert batched[1] == pytest.approx(sum(single), rel=1e-14)
    assert [float(line) for line in (folder / "work.txt").read_text().splitlines()] == single


@pytest.mark.lammps
def test_per_atom_masses_give_the_bits_of_per_type_masses(tmp_path):
    """The same masses per atom (fix property/atom rmass, as a mass-disordered chain may use)
    instead of per type: the chain fix, owning the state, gives the same x, v, f bit for bit."""
    case = make_case(particles=300, duration=30.0, interval=5.0, impactor=PROFILES["sine"], friction=FRICTION)
    runs = {}
    for name in ("type", "atom"):
        folder = RunFolder.create(case, tmp_path / name).path
        if name == "atom":
            mass = (folder / DATA).read_text().split("Masses")[1].split()[1]  # type 1's, as written
            deck = folder / "in.lattice"
            deck.write_text(deck.read_text().replace(
                "\ngroup           none empty",
                f"\nfix masses all property/atom rmass\nset group all mass {mass}\ngroup           none empty", 1))
        run_embedded(folder)
        assert "owns the state" in (folder / "log.lammps").read_text()
        runs[name] = RunFolder(folder).trajectory()
    assert "set group all mass" in (tmp_path / "atom" / "in.lattice").read_text()
    assert np.max(np.abs(runs["type"].v)) > 1.0
    for name in ("u", "v", "a"):
        assert np.array_equal(getattr(runs["type"], name), getattr(runs["atom"], name)), name


@pytest.mark.lammps
def test_batched_replicas_record_their_fronts_with_their_own_levels(tmp_path):
    """fix lattice/front with per-chain levels (length n levels FILE), as members whose noise
    sets their levels need: each chain's front record is its single run's with its levels, bit
    for bit (the chain fix samples it inside its pass)."""
    cases = [make_case(particles=21, duration=30.0, interval=10.0, friction=FRICTION, chain={"mass": 1.0 + 0.05 * r})
             for r in range(3)]
    levels = [f"{0.02 + 0.01 * r!r} {0.8 + 0.1 * r!r} 0.1 {0.1 + 0.05 * r!r} {0.01 * r!r}" for r in range(3)]
    records = {}
    for name, folder in [(r, RunFolder.create(c, tmp_path / f"single{r}").path) for r, c in enumerate(cases)] + \
            [("batched", write_folder(cases, tmp_path / "batched"))]:
        deck = folder / "in.lattice"
        lines = deck.read_text().splitlines()
        if name == "batched":  # its deck has no record: the single runs' lines, with the levels file
            (folder / "levels.txt").write_text("# start front drop pulse_drop pulse_floor\n" + "\n".join(levels) + "\n")
            single = (tmp_path / "single0" / "in.lattice").read_text().splitlines()
            k = next(i for i, line in enumerate(lines) if line.startswith("run "))
            lines[k:k + 1] = [next(line for line in single if " lattice/front " in line) +
                              " length 21 levels ${dir}/levels.txt", lines[k],
                              next(line for line in single if "front.bin" in line)]
        else:
            k = next(i for i, line in enumerate(lines) if " lattice/front " in line)
            start, front, drop, pulse_drop, floor = levels[name].split()
            lines[k] = (f"fix front all lattice/front start {start} front {front} drop {drop} pulse_drop {pulse_drop} "
                        f"pulse_floor {floor}")
        deck.write_text("\n".join(lines) + "\n")
        run_embedded(folder)
        assert "front record inside" in (folder / "log.lammps").read_text()
        records[name] = open_dump(folder / "front.bin").read().data[-1].view(np.uint64)
    for r in range(3):
        member = records["batched"][21 * r:21 * (r + 1), 1:]
        assert np.array_equal(member, records[r][:, 1:]), r
    assert not np.array_equal(records[0][:, 1:], records[1][:, 1:])


@pytest.mark.lammps
def test_replicas_at_rest_and_in_thermal_motion_share_a_batch(tmp_path):
    """Replicas may differ in anything under [chain], thermal motion too: a chain at rest beside
    a thermal one gets its zero velocities in the data file (a Velocities section has a line for
    every atom; without them LAMMPS stopped: 'Unexpected end of data file'), and each replica's
    trajectory is its own run's."""
    cases = [make_case(particles=21, duration=10.0, interval=0.5, chain={"thermal_velocity": t, "seed": 3})
             for t in (0.0, 0.02)]
    batched = execute_batch(cases, tmp_path / "batched").replicas()
    for r, case in enumerate(cases):
        np.testing.assert_allclose(batched[r].v[0, 1:-1], case.chain.velocities()[1:-1], rtol=0, atol=1e-12)  # m/s, the text dump's 12 digits
        single = simulate(case, tmp_path / f"single{r}")
        assert np.max(np.abs(batched[r].v - single.v)) < 1e-11
    assert not np.any(batched[0].v[0, 1:-1]) and np.any(batched[1].v[0, 1:-1])


@pytest.mark.lammps
@pytest.mark.parametrize("friction", [True, False], ids=["friction", "frictionless"])
def test_a_thermal_batch_s_front_record_is_the_general_path_s_bit_for_bit(tmp_path, friction):
    """The record inside the owned pass (per block: only active atoms, starters by a start gate,
    held ends only while they can change the record; rebuilt at every reneighbouring) against
    the record the front fix samples itself when another fix runs during the steps: three
    21-magnet chains with thermal motion of their own (so each has its own levels, a levels
    file), 60 ms (48 reneighbourings): front.bin byte for byte."""
    extra = {"friction": FRICTION} if friction else {}
    cases = [make_case(particles=21, duration=60.0, dt=0.0125, interval=0.5, impactor=PROFILES["sine"],
                       chain={"thermal_velocity": 0.02, "seed": s}, output={"format": "none"}, **extra)
             for s in (1, 2, 3)]
    fronts = {}
    for name, other in (("owned", ""), ("general", "fix             other all print 1000000000 ''\n")):
        folder = tmp_path / name
        folder.mkdir()
        for file, text in render_replicas(cases, front=True).items():
            (folder / file).write_text(text.replace("\nrun ", f"\n{other}run ", 1) if file == "in.lattice" else text)
        run_embedded(folder)
        log = (folder / "log.lammps").read_text()
        assert ("owns the state (one pass per step, front record inside)" in log) == (name == "owned")
        assert "levels" in (folder / "in.lattice").read_text()  # each chain its own levels
        fronts[name] = (folder / "front.bin").read_bytes()
    record = open_dump(tmp_path / "owned" / "front.bin").read()
    assert np.sum(np.isfinite(record.data[-1, :, 4])) >= 30  # first peaks found in half of the 63 magnets
    assert fronts["owned"] == fronts["general"]


def test_replicas_may_differ_only_in_their_chain():
    with pytest.raises(ConfigError, match="replica 1 differs from replica 0 outside"):
        render_replicas([make_case(), make_case(velocity=1.0)])
    with pytest.raises(ConfigError, match="batched replicas need the chain engine"):
        render_replicas([make_case(run={"engine": "stock"})])


@pytest.mark.lammps
@pytest.mark.parametrize("other_fix", ["viscous 0.0", "print 1000000000 ''"], ids=["post_force", "end_of_step"])
def test_owned_state_gives_the_bits_of_the_general_path(tmp_path, other_fix):
    """On one rank with only the front record beside it, the chain fix keeps x, v, f in its own
    arrays and samples the record in its pass; another fix during the steps (a zero viscous
    force after it, or one that only prints) makes it work in LAMMPS's arrays and the record
    sample itself. 700 magnets (blocks of 129), friction, a pulse: the same x, v, f and
    front record, bit for bit."""
    case = make_case(particles=700, duration=150.0, interval=5.0, impactor=PROFILES["sine"], friction=FRICTION)
    runs = {}
    for name, extra in (("owned", None), ("general", other_fix)):
        folder = RunFolder.create(case, tmp_path / name).path
        if extra:
            deck = folder / "in.lattice"
            deck.write_text(deck.read_text().replace("\nrun ", f"\nfix             other all {extra}\nrun ", 1))
        run_embedded(folder)
        log = (folder / "log.lammps").read_text()
        assert ("owns the state (one pass per step, front record inside)" in log) == (name == "owned")
        runs[name] = (RunFolder(folder).trajectory(), (folder / "front.bin").read_bytes())
    (owned, owned_front), (general, general_front) = runs["owned"], runs["general"]
    assert np.max(np.abs(owned.v)) > 1.0
    for name in ("u", "v", "a"):
        assert np.array_equal(getattr(owned, name), getattr(general, name)), name
    record = read_front_record(case, tmp_path / "owned" / "front.bin")
    assert np.sum(np.isfinite(record.front.peaks.peak_velocity)) >= 20
    assert owned_front == general_front
