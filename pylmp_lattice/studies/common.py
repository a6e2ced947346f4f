"""What the studies share: the paper's chain as a case, its linear constants, small plot helpers."""

from __future__ import annotations

import numpy as np

from .. import measures
from ..case import Case, case_from_dict

# The paper's lattice (main text): m, r0 and the magnet law F = K/(r+b)^q.
MASS, R0 = 1.084, 12.0  # g, mm
PAPER_FORCE = {"law": "power", "K": 413.8, "b": 3.917, "q": 3.0}
MAGNET_LENGTH = 6.35  # mm, one magnet particle (two ring magnets), paper Sec. 1


def paper_case(name: str, impactor: dict, duration: float, far_end: str = "long", particles: int | None = None,
               dt: float = 0.01, output_interval: float = 0.1, **sections) -> Case:
    """The paper's chain (m = 1.084 g, r0 = 12 mm, the magnet law) with an impactor profile and
    run length (ms); `sections` add or replace case sections (force, friction, ...)."""
    data = {
        "name": name,
        "chain": {"mass": MASS, "r0": R0, "far_end": far_end} | ({"particles": particles} if particles else {}),
        "force": dict(PAPER_FORCE),
        "impactor": dict(impactor),
        "run": {"duration": duration, "dt": dt, "output_interval": output_interval},
    }
    data.update(sections)
    return case_from_dict(data)


def linear_constants(case: Case) -> tuple[float, float]:
    """(V0 in m/s, f0 in Hz) of the case's nearest-neighbour law at its initial spacing."""
    r0 = float(np.mean(case.chain.gaps()))
    k = float(case.force.stiffness(r0))
    m = float(np.mean(case.chain.masses()))
    return measures.linear_wave_speed(k, m, r0), measures.linear_frequency(k, m)


def particles_reached(arrival) -> int:
    """How many particles the front reached (arrival finite)."""
    return int(np.sum(np.isfinite(arrival)))


def pick(candidates, limit: int) -> list[int]:
    """The 0-based particle indices among `candidates` below `limit`."""
    return [n for n in candidates if n < limit]
