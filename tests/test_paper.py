"""The paper's long lattice (Fig. 3): r0 = 12 mm, V_I = 2 m/s, no friction.

Paper: V0 = 1.62 m/s, shock velocity plateau V_P = 3.92 m/s, first peak velocity saturating
at 2 V_I, first peak velocity and acceleration growing with the particle number.
Definitions used (see `measures`): front arrival = first time v reaches V_I/2; V_P(n) =
r0 / (t_(n+1) - t_n); plateau = mean over the last quarter of the gaps the front crossed.
The plateau is insensitive to the arrival level (3.9131 m/s for V_I/10 ... 3 V_I/2).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from pylmp_lattice.case import load_case
from pylmp_lattice.run_folder import RunFolder, simulate
from pylmp_lattice.summary import summary_of

pytestmark = [pytest.mark.lammps, pytest.mark.slow]
CASE = Path(__file__).parent.parent / "inputs" / "paper_long_lattice.toml"


@pytest.fixture(scope="module")
def long_lattice(tmp_path_factory):
    case, folder = load_case(CASE), tmp_path_factory.mktemp("long")
    return case, simulate(case, folder), folder


def test_paper_long_lattice_numbers(long_lattice):
    case, _, folder = long_lattice
    s = summary_of(case, *RunFolder(folder).measures())
    assert 1.60 <= s["linear_wave_speed_V0_m_per_s"] <= 1.62
    # 0.5%: the paper gives 3 digits and our plateau still drifts by +0.06% across its window
    assert s["shock_velocity_plateau_m_per_s"]["mean"] == pytest.approx(3.92, rel=5e-3)
    assert abs(s["shock_velocity_plateau_m_per_s"]["relative_drift"]) < 2e-3
    # saturating at 2 V_I from below: 1.987 V_I over particles 146-194 after 600 ms
    assert 1.96 <= s["first_peak_velocity_over_V_I"] <= 2.0
    assert s["far_end_quiet"]
    assert s["particles_reached_by_front"] > 150


def test_first_peaks_grow_along_the_chain(long_lattice):
    """Strong-shock signature (Fig. 3c), opposite to the linear chain (Fig. S5c)."""
    case, _, folder = long_lattice
    peaks = RunFolder(folder).front().peaks  # the engine's record of every step
    reached = np.flatnonzero(np.isfinite(peaks.peak_velocity))
    n = reached[(reached >= 1) & (reached <= 150)]
    assert np.all(np.diff(peaks.peak_velocity[n]) > 0)
    assert np.all(np.diff(peaks.peak_acceleration[n[::10]]) > 0)
    # rise time shrinks as the front steepens
    assert peaks.rise_time[150] < peaks.rise_time[5] < peaks.rise_time[1]
