"""This machine's overheads for the estimates (`overhead`): measured once from the commands'
wall times, cached per host, Python and version, and used by a run's and a sweep's estimate."""

from __future__ import annotations

import json

import pytest

from pylmp_lattice import overhead, preflight
from pylmp_lattice.overhead import Overheads, contention

from conftest import make_case


@pytest.fixture
def cache(tmp_path, monkeypatch):
    """A fresh cache folder, measuring allowed (conftest forbids it elsewhere), at the defaults'
    contention (the machine's load does not move the numbers asserted)."""
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    monkeypatch.delenv(overhead.MEASURING)
    monkeypatch.setattr(overhead, "contention", lambda: Overheads().contention)
    return tmp_path


def test_measured_once_from_the_commands_wall_times_then_read_from_the_cache(cache, monkeypatch):
    """run: 3.1 s; a sweep of 1 member: 3.5 s, of 16: 6.5 s -> 0.2 s a member, 3.3 s the sweep's own."""
    calls = []
    walls = {"run": 3.1, "sweep1.toml": 3.5, "sweep16.toml": 6.5}

    def wall(args, cwd, tries=2):
        calls.append(args)
        assert (cwd / "tiny.toml").is_file()  # the tiny case the commands run
        return walls[args[0] if args[0] == "run" else args[1]]

    monkeypatch.setattr(overhead, "_wall", wall)
    assert overhead.overheads() == Overheads()  # not measured unless asked
    found = overhead.overheads(measure=True)
    assert found == Overheads(run_s=3.1, sweep_s=3.3, member_s=0.2, measured=True)
    assert len(calls) == 3 and json.loads(overhead.cache_file().read_text()) == {
        "run_s": 3.1, "sweep_s": 3.3, "member_s": 0.2, "contention": Overheads().contention}
    assert overhead.cache_file().parent == cache / "pylmp_lattice"
    assert overhead.overheads(measure=True) == found and len(calls) == 3  # once per machine


def test_a_runs_estimate_is_its_engine_and_output_plus_the_machines_run_overhead(cache, monkeypatch):
    case = make_case(particles=21, duration=60.0)
    base = preflight.estimate(case).seconds - Overheads().run_s  # engine and output alone
    overhead.cache_file().parent.mkdir(parents=True)
    overhead.cache_file().write_text(json.dumps({"run_s": 2.5, "sweep_s": 3.0, "member_s": 0.1}))
    assert preflight.estimate(case).seconds == pytest.approx(2.5 + base, rel=1e-12)
    assert 0 < base < 0.1  # a small run is mostly its overhead: the engine's model alone was 24-55 % low


def test_cached_times_scale_with_the_contention_now(cache, monkeypatch):
    """Measured at load 11 on 2 cores (contention 5.5), read at load 7 (3.5): each time x 3.5/5.5;
    below a load of one per core, no scaling."""
    overhead.cache_file().parent.mkdir(parents=True)
    overhead.cache_file().write_text(json.dumps({"run_s": 4.6, "sweep_s": 4.4, "member_s": 0.11, "contention": 5.5}))
    monkeypatch.setattr(overhead.os, "getloadavg", lambda: (7.0, 0.0, 0.0))
    monkeypatch.setattr(overhead.os, "cpu_count", lambda: 2)
    monkeypatch.setattr(overhead, "contention", contention)  # the real one, not the fixture's stand-in
    assert overhead.contention() == pytest.approx(3.5, rel=1e-15)
    now = overhead.overheads()
    assert (now.run_s, now.sweep_s, now.member_s) == pytest.approx((4.6 * 3.5 / 5.5, 4.4 * 3.5 / 5.5, 0.07), rel=1e-12)
    monkeypatch.setattr(overhead.os, "getloadavg", lambda: (1.9, 0.0, 0.0))  # under a load per core of 1: never below 1
    assert overhead.overheads().run_s == pytest.approx(4.6 / 5.5, rel=1e-12)


@pytest.mark.slow
@pytest.mark.lammps
def test_the_real_measurement_runs_the_commands(cache):
    """The commands it times run (no stand-in): plausible numbers, cached. ~10 s: marked slow."""
    found = overhead._measure()
    assert found.measured and 0.3 < found.run_s < 60 and 0 < found.sweep_s < 60 and 0 <= found.member_s < 10

