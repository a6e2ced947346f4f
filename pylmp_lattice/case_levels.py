"""The front measures' levels of a case (m/s): its noise velocity sigma and the levels set
against it and V_I (`measures.levels`). One home for the deck, which passes them to fix
lattice/front, and for the readers of its record, which apply the same levels to arrays.
"""

from __future__ import annotations

import numpy as np

from . import measures
from .case import Case, Chain


def chain_noise(case: Case) -> float:
    """The case's noise velocity sigma, m/s: `measures.noise_velocity` of its initial state."""
    return float(chain_noises([case])[0])


def chain_noises(cases) -> np.ndarray:
    """The noise velocity of each of R cases, m/s, shape (R,): the cases of a batch (equal N,
    held ends and force law; `deck.render_replicas` checks), computed together with the bits of
    each alone (`chain_noise` is a batch of one)."""
    first = cases[0]
    free = np.ones(first.chain.particles, bool)
    free[[0, *first.held()]] = False
    masses, velocities, gaps = (np.stack([draw(case.chain) for case in cases])
                                for draw in (Chain.masses, Chain.velocities, Chain.gaps))
    return measures.noise_velocity(masses, velocities, gaps, first.force.energy, free)


def front_levels(case: Case) -> measures.FrontLevels:
    """The front measures' levels for this case (m/s): the fix's arguments, and the array measures'."""
    return measures.front_levels(case.impactor.peak_velocity(), chain_noise(case))


def chain_front_levels(cases) -> measures.FrontLevels:
    """The front levels of each of R cases of one drive, m/s: arrays of shape (R,), entry r the
    levels of `front_levels(cases[r])`."""
    return measures.front_levels(cases[0].impactor.peak_velocity(), chain_noises(cases))
