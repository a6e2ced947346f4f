"""Checks before a run: output size estimate against a real run, refusals, warnings."""

from __future__ import annotations

import logging
import os
import subprocess
import sys
import time
import tracemalloc
from pathlib import Path

import numpy as np
import pytest
import tomli_w

from pylmp_lattice import deck, preflight
from pylmp_lattice.case import Chain, case_from_dict, case_to_dict
from pylmp_lattice.errors import ConfigError, UsageError
from pylmp_lattice.run_folder import RunFolder, execute_batch, simulate
from pylmp_lattice.formats import layout
from pylmp_lattice.runner import run_embedded

from conftest import make_case


# Cases not among those benchmarks/calibrate_preflight.py fits the constants on.
HELD_OUT = {
    "text ramp": make_case(particles=120, duration=40.0, interval=0.2, output={"format": "text"},
                           impactor={"profile": "ramp", "velocity": 1.5, "ramp_time": 5.0}),
    "text thermal": make_case(particles=60, duration=20.0, output={"format": "text"},
                              chain={"thermal_velocity": 0.05, "seed": 4}),
    "h5md lzf fine": make_case(particles=1000, duration=20.0, interval=0.5, output={"fine": [3, 30]}),
    "h5md gzip r0 disorder": make_case(particles=300, duration=20.0, output={"compression": "gzip"},
                                       chain={"r0_disorder": 0.01, "seed": 5}),
    "h5md none": make_case(particles=150, duration=30.0, output={"compression": "none"}),
}


@pytest.mark.lammps
@pytest.mark.parametrize("label", HELD_OUT)
def test_every_file_estimate_within_25_percent_of_the_run(tmp_path, label):
    """Data file, force table, front record, text dump or H5MD file (each measured after the
    run), the binary dumps (measured from a bare LAMMPS run, before any conversion) and the
    peak of the folder (the binary dumps and the H5MD file together): within 25 %."""
    case = HELD_OUT[label]
    est = preflight.file_bytes(case)
    simulate(case, tmp_path / "full")
    measured = {p.name: p.stat().st_size for p in (tmp_path / "full").iterdir()}
    if case.output.format == "h5md":
        raw = RunFolder.create(case, tmp_path / "raw").path
        run_embedded(raw)
        measured |= {p.name: p.stat().st_size for p in raw.iterdir() if p.suffix == ".bin" and p.name != layout.FRONT_BIN}
    checked = [name for name in est if name in measured]
    assert {layout.DATA, layout.TABLE} <= set(checked) and len(checked) >= 4
    for name in checked:
        assert est[name] == pytest.approx(measured[name], rel=0.25), name
    peak = sum(measured[name] for name in checked)
    assert sum(est[name] for name in checked) == pytest.approx(peak, rel=0.25)
    assert preflight.output_bytes(make_case(output={"format": "none"})) < 1e6  # data, table, small files


def test_estimate_takes_a_case_file_path_and_refuses_other_arguments_in_one_line(tmp_path):
    """pl.estimate("case.toml") reads the case as load_case does (trial: "'str' object has no attribute 'chain'")."""
    import pylmp_lattice as pl

    case = make_case(particles=40, duration=30.0)
    path = tmp_path / "c.toml"
    path.write_bytes(tomli_w.dumps(case_to_dict(case)).encode())
    for given in (path, str(path)):
        got = pl.estimate(given)
        assert (got.frames, got.files) == (pl.estimate(case).frames, pl.estimate(case).files)
    with pytest.raises(UsageError, match=r"^case: got 3; expected a Case or the path of a case file \(TOML\)$"):
        pl.estimate(3)
    with pytest.raises(ConfigError, match=r"^case: file not found: .*nope.toml$"):
        pl.estimate(tmp_path / "nope.toml")


def test_binary_dump_size_is_exact_from_its_format():
    case = make_case(particles=40, duration=30.0)
    assert preflight.file_bytes(case)[layout.TRAJ_BIN] == 301 * (159 + 32 * 40)


def test_ten_to_the_eight_magnets_refused_in_under_2_s_and_300_MB(tmp_path):
    """Building the case and refusing it: no array of N values (tracemalloc counts numpy's)."""
    data = case_to_dict(make_case(particles=10, duration=10.0))
    data["chain"]["particles"] = 10**8
    tracemalloc.start()
    start = time.perf_counter()
    with pytest.raises(ConfigError, match=r"^run: too large for this machine: 101 frames"):
        preflight.check(case_from_dict(data), tmp_path)
    seconds = time.perf_counter() - start
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert seconds < 2.0 and peak < 300e6, (seconds, peak)


def test_a_disordered_chain_of_10_to_the_8_is_refused_before_its_draws(monkeypatch, tmp_path):
    """The refusal needs N alone: of 2 x 10^8 masses and gaps, only the preflight's sample of
    each series (SAMPLE) is drawn before it (counted where every draw is made)."""
    drawn = []
    series = Chain._series

    def counted(self, nominal, count, width, *args):
        for part in series(self, nominal, count, width, *args):
            drawn.append(len(part))
            yield part

    monkeypatch.setattr(Chain, "_series", counted)
    data = case_to_dict(make_case(particles=10, duration=10.0))
    data["chain"] |= {"particles": 10**8, "mass_disorder": 0.01, "r0_disorder": 0.01, "seed": 1}
    with pytest.raises(ConfigError, match=r"^run: too large for this machine: 101 frames"):
        preflight.check(case_from_dict(data), tmp_path)
    assert 0 < sum(drawn) <= 2 * preflight.SAMPLE, sum(drawn)


# A chain beyond CHUNK draws is checked at first use; CHUNK = 8 makes these 30-magnet chains so.
DEFERRED = [({"r0_disorder": 0.6, "seed": 2}, {}, "chain.r0_disorder", "a draw gave a value <= 0"),
            # dt under the nominal mass's limit (0.4534 ms), over the lightest drawn mass's (0.2018 ms)
            ({"mass_disorder": 0.3, "seed": 1}, {"dt": 0.25, "interval": 0.5}, "run.dt", "expected < 0.2018 ms")]


@pytest.mark.parametrize("chain, run, field, message", DEFERRED)
def test_deferred_draw_checks_refuse_before_anything_is_written(monkeypatch, tmp_path, capsys, chain, run, field,
                                                                message):
    """A case whose drawn masses or gaps do not fit is built, but never reaches a deck or a
    run: the preflight, the deck writer and the CLI refuse it (one line, exit 2), and a run
    folder it was to overwrite stays as it was."""
    from pylmp_lattice import case as case_module
    from pylmp_lattice.cli import main
    from pylmp_lattice.run_folder import execute

    monkeypatch.setattr(case_module.case, "CHUNK", 8)
    make = lambda: make_case(chain=chain, **run)  # noqa: E731
    case = make()  # built: the checks of its draws wait
    with pytest.raises(ConfigError) as info:
        preflight.check(case, tmp_path)
    assert info.value.field == field and message in str(info.value)
    with pytest.raises(ConfigError, match=field):
        execute(make(), tmp_path / "new")
    assert not (tmp_path / "new").exists()
    old = RunFolder.create(make_case(), tmp_path / "old").path
    before = {f.name: f.read_bytes() for f in old.iterdir()}
    with pytest.raises(ConfigError, match=field):
        RunFolder.create(make(), old, overwrite=True)
    assert {f.name: f.read_bytes() for f in old.iterdir()} == before
    case_file = tmp_path / "case.toml"
    case_file.write_text(tomli_w.dumps(case_to_dict(make())))
    for command in (["run", str(case_file), "-o", str(tmp_path / "cli")],
                    ["deck", str(case_file), "-o", str(old), "--overwrite"]):
        capsys.readouterr()
        assert main(command) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and err.startswith(f"pylmp-lattice: error: {field}: "), err
    assert not (tmp_path / "cli").exists()
    assert {f.name: f.read_bytes() for f in old.iterdir()} == before


def test_disordered_chain_is_validated_in_bounded_memory():
    """10^7 magnets with mass and gap disorder: the extremes are drawn in chunks, the same
    numbers as the full arrays (checked at 3e6, where the arrays still fit)."""
    data = case_to_dict(make_case(particles=10, duration=10.0))
    data["chain"] |= {"particles": 3 * 10**6, "mass_disorder": 0.05, "r0_disorder": 0.05, "seed": 7}
    tracemalloc.start()
    case = case_from_dict(data)
    case.check_draws()  # 6e6 draws: beyond CHUNK, checked on demand
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert peak < 100e6  # the two arrays would take 48 MB each, with their copies more
    masses, gaps = case.chain.masses(), case.chain.gaps()
    assert case.chain.mass_range == (masses.min(), masses.max())
    assert case.chain.gap_range == (gaps.min(), gaps.max())


def test_type_pairs_are_counted_where_masses_are_per_type():
    """LAMMPS keeps 16 bytes per pair of atom types: a chain of 12 distinct masses has 12 types;
    mass disorder gives masses per magnet under one type, as a uniform chain has."""
    plain = preflight.estimate(make_case(particles=4000, duration=10.0))
    disordered = preflight.estimate(make_case(particles=4000, duration=10.0, chain={"mass_disorder": 0.01, "seed": 1}))
    assert disordered.memory_bytes == plain.memory_bytes
    twelve = make_case(particles=12, duration=10.0, chain={"mass": [1.0 + 0.01 * k for k in range(12)]})
    one = make_case(particles=12, duration=10.0)
    assert preflight.estimate(twelve).memory_bytes - preflight.estimate(one).memory_bytes == 16 * (13**2 - 2**2)


MEMORY_RUN = """
import resource, sys
sys.path.insert(0, {tests!r})
from conftest import make_case
from pylmp_lattice.run_folder import execute
chain = {{"mass_disorder": 0.02, "seed": 1}} if sys.argv[1] == "disorder" else {{}}
execute(make_case(particles=int(sys.argv[2]), duration=0.1, output={{"format": "none"}}, chain=chain), sys.argv[3])
print(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024)
"""


@pytest.mark.lammps
def test_mass_disorder_memory_is_linear_in_n(tmp_path):
    """A run's peak memory (RSS of a fresh process, 0.1 ms): 4000 and 8000 magnets with mass
    disorder cost what a uniform chain of 8000 does, within 10 MB (per-type masses took
    +238 MB at 4000 and would take +950 MB at 8000)."""
    code = MEMORY_RUN.format(tests=str(Path(__file__).parent))
    # the three processes at once (each measures its own peak): the test takes one's time, not three
    runs = {(kind, n): subprocess.Popen([sys.executable, "-c", code, kind, str(n), str(tmp_path / f"{kind}{n}")],
                                        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
            for kind, n in (("uniform", 8000), ("disorder", 4000), ("disorder", 8000))}
    rss = {}
    for key, proc in runs.items():
        out, err = proc.communicate(timeout=300)
        assert proc.returncode == 0, err
        rss[key] = int(out.split()[-1])
    assert rss["disorder", 8000] - rss["uniform", 8000] < 10e6, rss
    assert rss["disorder", 8000] - rss["disorder", 4000] < 10e6, rss


@pytest.mark.lammps
@pytest.mark.parametrize("engine", ["chain", "stock"])
def test_masses_per_magnet_give_the_run_of_masses_per_type(tmp_path, engine):
    """The same disordered chain (with friction on the chain engine) written with one atom type
    per mass and with masses per magnet: the text dumps agree in every column but the type."""
    case = make_case(particles=30, duration=5.0, output={"format": "text", "front": False}, run={"engine": engine},
                     chain={"mass_disorder": 0.02, "seed": 3}, friction={"mu": 0.285} if engine == "chain" else {})
    dumps = []
    for per_atom in (True, False):
        folder = RunFolder.create(case, tmp_path / str(per_atom)).path
        (folder / layout.DECK).write_text(deck.deck_text(case, per_atom=per_atom))
        (folder / layout.DATA).write_text(deck.data_text(case, per_atom))
        run_embedded(folder)
        lines = (folder / layout.DUMP).read_text().splitlines()
        dumps.append([line.split()[:1] + line.split()[2:] if len(line.split()) == 12 else line for line in lines])
    assert "MagnetMasses" in (tmp_path / "True" / layout.DATA).read_text()
    assert dumps[0] == dumps[1]


def test_run_larger_than_the_free_disk_is_refused_before_anything_is_written(tmp_path, monkeypatch):
    monkeypatch.setattr(preflight.checks, "free_disk", lambda folder: 1e5)  # where check looks it up
    case = make_case(particles=40, duration=30.0)  # force table 0.68 MB, binary dump 0.43 MB, H5MD, ...
    with pytest.raises(ConfigError, match=r"^run: too large for this machine: 301 frames, output 1.4\d MB.*100 kB free"):
        simulate(case, tmp_path / "run")
    assert not (tmp_path / "run").exists()


def test_run_longer_than_an_hour_needs_yes(tmp_path, monkeypatch):
    # 10^5 magnets for 6e7 steps at contention 1: 6e7 (1.3e-6 + 10^5 x 4.7e-9) s, about 7.86 h;
    # output 61 frames
    from pylmp_lattice import overhead

    monkeypatch.setattr(overhead, "contention", lambda: 1.0)
    case = make_case(particles=100_000, duration=600_000.0, interval=10_000.0)
    with pytest.raises(ConfigError, match=r"estimated .*time 7.86 h; pass --yes"):
        preflight.check(case, tmp_path)
    assert preflight.check(case, tmp_path, yes=True).seconds > 3600


def test_rank_count_is_checked(tmp_path, caplog):
    case = make_case(particles=12, duration=10.0)
    for bad in (0, -3):
        with pytest.raises(ConfigError, match="--np: got"):
            preflight.check(case, tmp_path, nprocs=bad)
    with caplog.at_level(logging.WARNING):
        preflight.check(case, tmp_path, nprocs=(os.cpu_count() or 1) + 1)
    assert "cores this run may use" in caplog.text  # ranks.rank_warnings


def test_coarse_but_stable_dt_warns_with_the_expected_error(caplog):
    """Linear springs k = 1 N/mm, m = 1 g: 1/f0 = pi ms, stable below dt = 1 ms. dt = 0.2 ms is
    stable but above pi/50 = 0.0628 ms; Verlet's phase error at f0: (2 dt)^2 / 24 = 0.67 %."""
    spring = {"law": "linear", "k": 1.0, "r_free": 24.0}
    coarse = make_case(particles=12, duration=10.0, dt=0.2, interval=0.2, chain={"mass": 1.0}, force=spring)
    with caplog.at_level(logging.WARNING):
        text = preflight.coarse_dt_warning(coarse)
    assert text in caplog.text
    assert "1/f0 = 3.142 ms" in text and "0.67 %" in text and "dt <= 0.0628 ms" in text
    fine = make_case(particles=12, duration=10.0, dt=0.05, interval=0.1, chain={"mass": 1.0}, force=spring)
    assert preflight.coarse_dt_warning(fine) is None


@pytest.mark.lammps
def test_batched_replicas_with_masses_per_magnet_equal_their_single_runs(tmp_path):
    """Three mass-disordered chains (seeds 1-3) in one LAMMPS instance: the data files' masses
    per magnet are stacked with the atoms, and each replica's trajectory is its own run's."""
    cases = [make_case(particles=21, duration=10.0, interval=0.5, output={"format": "text"},
                       chain={"mass_disorder": 0.05, "seed": seed}) for seed in (1, 2, 3)]
    batched = execute_batch(cases, tmp_path / "batched").replicas()
    stacked = (tmp_path / "batched" / layout.DATA).read_text().split("MagnetMasses\n\n")[1].splitlines()
    assert [int(line.split()[0]) for line in stacked] == list(range(1, 64))
    for r, case in enumerate(cases):
        single = simulate(case, tmp_path / f"single{r}")
        assert np.max(np.abs(batched[r].v - single.v)) < 1e-11 and np.max(np.abs(single.v)) > 0.5
    assert not np.array_equal(batched[0].v, batched[2].v)


def test_the_long_lattice_refuses_a_chain_the_unit_warning_calls_a_mistake_unless_yes(tmp_path, monkeypatch):
    """issue 27 item 10: r0 in metres on the long lattice built 201 336 magnets and wrote 35 MB
    before the contact error; now the guard refuses it, naming the field, unless --yes. (On a
    disk with under its 5.3 GB free, the refusal for its size came first: CI's disk once had
    3.6 GB; here the disk has a petabyte.)"""
    from pylmp_lattice.case import load_case
    from pylmp_lattice.preflight import checks

    monkeypatch.setattr(checks, "free_disk", lambda folder: 1e15)

    inputs = Path(__file__).parent.parent / "inputs"
    case = load_case(inputs / "paper_long_lattice.toml", ["chain.r0=0.012"])
    assert case.chain.particles > 100_000
    with pytest.raises(ConfigError, match=r"^chain\.r0: got 0\.012 mm; .* that is 12 mm; with chain\.far_end = "
                                          r"\"long\" that builds \d+ magnets .*pass --yes"):
        preflight.check(case, tmp_path / "r")
    try:
        preflight.check(case, tmp_path / "r", yes=True)
    except ConfigError as err:  # a machine too small for it may still refuse it, for its size
        assert err.field == "run" and "too large for this machine" in str(err)
    ok = load_case(inputs / "paper_long_lattice.toml")
    preflight.check(ok, tmp_path / "r")  # the case as it is passes
