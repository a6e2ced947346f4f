"""Fig. 3 (a-e): the long lattice without friction, constant V_I = 2 m/s.

The panels and measures are those of `studies.long_lattice` (a-e, and (f, ours) the width of
the disordered transition zone against time). Numbers: V0, the V_P plateau and whether it has
converged, where the first peak reaches the paper's 3.87 m/s, the saturated first peak / V_I,
the steady oscillation (f/f0, eta, amplitude) of particles behind the front, and the
transition zone's growth. Full: 600 ms (the front reaches particle ~200); quick: 200 ms.
"""

from __future__ import annotations

from pathlib import Path

from ...run_folder import simulate
from ..long_lattice import analyse
from ..output import StudyResult
from ..scaffold import paper_case

NAME = "fig3"
VI = 2.0  # m/s
PAPER = {"V0_m_per_s": 1.62, "V_P_m_per_s": 3.92, "first_peak_m_per_s": 3.87, "saturated_first_peak_over_V_I": 2.0}


def run(out: Path, quick: bool = False) -> StudyResult:
    """Run this study into `out` (`quick`: its small version) and return its results; what it
    runs and measures is the module's docstring."""
    duration = 200.0 if quick else 600.0
    case = paper_case("fig3_long_lattice", {"profile": "constant", "velocity": VI}, duration)
    traj = simulate(case, out / NAME / case.name, overwrite=True)
    result = analyse(NAME, f"Fig. 3: long lattice, constant $V_I$ = {VI:g} m/s, no friction, {duration:g} ms", traj,
                     case, VI, duration, quick)
    result.numbers["paper"] = PAPER
    return result
