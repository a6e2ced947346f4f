"""Checks before a run: output size estimate against a real run, refusals, warnings."""

from __future__ import annotations

import logging
import os

import pytest

from pylmp_lattice import preflight
from pylmp_lattice.errors import ConfigError
from pylmp_lattice.run_folder import simulate

from conftest import make_case


@pytest.mark.lammps
def test_output_estimate_matches_the_written_trajectory(tmp_path):
    """Text dump, every magnet moving (the calibration): within 5 %; most at rest: an upper
    bound. H5MD: the written file within the uncompressed 24 bytes per atom-frame of the estimate."""
    moving = make_case(particles=40, duration=30.0, output={"format": "text"})
    resting = make_case(particles=200, duration=30.0, output={"format": "text"})  # the front crosses ~10 gaps
    for case, low, high in ((moving, 0.95, 1.05), (resting, 1.0, 1.6)):
        est = preflight.estimate(case)
        simulate(case, tmp_path / str(case.chain.particles))
        written = (tmp_path / str(case.chain.particles) / "traj.dump").stat().st_size
        assert est.frames == 301
        assert low * written <= est.output_bytes <= high * written
    h5md = make_case(particles=40, duration=30.0)
    simulate(h5md, tmp_path / "h5md")
    assert preflight.output_bytes(h5md) == 56 * 40 * 301
    assert 0 < (tmp_path / "h5md" / "traj.h5md").stat().st_size < 24 * 40 * 301
    assert preflight.output_bytes(make_case(output={"format": "none"})) == 0


def test_run_larger_than_the_free_disk_is_refused_before_anything_is_written(tmp_path, monkeypatch):
    monkeypatch.setattr(preflight, "free_disk", lambda folder: 1e5)
    case = make_case(particles=40, duration=30.0)  # H5MD: 40 x 301 x 56 bytes = 674 kB
    with pytest.raises(ConfigError, match=r"^run: too large for this machine: 301 frames, output 674 kB.*100 kB free"):
        simulate(case, tmp_path / "run")
    assert not (tmp_path / "run").exists()


def test_run_longer_than_an_hour_needs_yes(tmp_path):
    # 10^5 magnets for 6e6 steps: 6e11 atom-steps at 1.3e-7 s each, about 21.7 h; output 61 frames
    case = make_case(particles=100_000, duration=60_000.0, interval=1000.0)
    with pytest.raises(ConfigError, match=r"estimated .*time 21\.\d+ h; pass --yes"):
        preflight.check(case, tmp_path)
    assert preflight.check(case, tmp_path, yes=True).seconds > 3600


def test_rank_count_is_checked(tmp_path, caplog):
    case = make_case(particles=12, duration=10.0)
    for bad in (0, -3):
        with pytest.raises(ConfigError, match="--np: got"):
            preflight.check(case, tmp_path, nprocs=bad)
    with caplog.at_level(logging.WARNING):
        preflight.check(case, tmp_path, nprocs=(os.cpu_count() or 1) + 1)
    assert "cores of this machine" in caplog.text


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
