"""The front measures' levels of a case (m/s): its noise velocity sigma and the levels set
against it and V_I (`measures.levels`). One home for the deck, which passes them to fix
lattice/front, and for the readers of its record, which apply the same levels to arrays.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from . import measures
from .case import Case


def chain_noise(case: Case) -> float:
    """The case's noise velocity sigma, m/s: `measures.noise_velocity` of its initial state."""
    try:  # cached: a sweep's batch asks it per chain for the deck, the levels and the record
        return _chain_noise(case)
    except TypeError:  # a case built with arrays is not hashable: computed each time
        return _chain_noise.__wrapped__(case)


@lru_cache(maxsize=4096)
def _chain_noise(case: Case) -> float:
    chain = case.chain
    free = np.ones(chain.particles, bool)
    free[[0, *case.held()]] = False
    return measures.noise_velocity(chain.masses(), chain.velocities(), chain.gaps(), case.force.energy, free)


def front_levels(case: Case) -> measures.FrontLevels:
    """The front measures' levels for this case (m/s): the fix's arguments, and the array measures'."""
    return measures.front_levels(case.impactor.peak_velocity(), chain_noise(case))
