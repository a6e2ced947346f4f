"""The levels of the front measures, set against the drive and against the chain's noise.

One rule, used by the array measures and, through the deck, by the engine's record (fix
lattice/front): every level is the larger of a fraction of the drive velocity V_I and a
multiple of the chain's noise velocity sigma (`noise_velocity`):

    start of motion      max(START_FRACTION V_I, NOISE_LEVEL sigma)
    front (arrival)      max(FRONT_FRACTION V_I, NOISE_LEVEL sigma)
    first-peak fall      max(PROMINENCE V_I,     NOISE_FALL sigma)
    pulse-maximum fall   max(PULSE_DROP |v_max|, NOISE_FALL sigma)

Without noise (sigma = 0) these are the fractions of V_I alone, so a noise-free run measures
exactly as before. Why 5 and 3 sigma: a thermal chain's velocities are Gaussian with RMS at most
sigma, so a magnet exceeds 5 sigma with probability 3e-7 per independent sample (at t = 0, the
worst moment; later the energy is shared with the springs and the RMS falls towards
sigma/sqrt(2)); a fall of 3 sigma on the shock's rise, which climbs V_I within a few steps of the
linear period, is as unlikely from the noise.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

# Levels as fractions of V_I: the start of motion, the front, the fall that confirms a first
# peak; and the relative fall that confirms a pulse's maximum.
START_FRACTION = 0.01
FRONT_FRACTION = 0.5
PROMINENCE = 0.05
PULSE_DROP = 0.1
# Levels as multiples of the noise velocity sigma: levels crossed, and falls that confirm.
NOISE_LEVEL = 5.0
NOISE_FALL = 3.0


@dataclass(frozen=True)
class FrontLevels:
    """Velocity levels of the front measures, m/s (see the module docstring).

    start: start of motion; front: arrival for a sustained drive, and where the first-peak
    search begins; drop: the fall that confirms a first peak; pulse_drop: the relative fall (of
    the maximum) that confirms a pulse's maximum, at least pulse_floor (m/s). Floats for one
    noise velocity; arrays of its shape for an array of them (one per magnet, or per chain)."""

    start: float | np.ndarray
    front: float | np.ndarray
    drop: float | np.ndarray
    pulse_drop: float
    pulse_floor: float | np.ndarray


def level(fraction: float, drive_velocity: float, noise=0.0, multiple: float = NOISE_LEVEL):
    """The larger of fraction * V_I and multiple * sigma, m/s (an array for an array of sigma)."""
    out = np.maximum(fraction * drive_velocity, multiple * np.asarray(noise, dtype=float))
    return float(out) if out.ndim == 0 else out


def front_levels(drive_velocity: float, noise=0.0, start_fraction: float = START_FRACTION,
                 front_fraction: float = FRONT_FRACTION, prominence: float = PROMINENCE,
                 pulse_drop: float = PULSE_DROP) -> FrontLevels:
    """The levels for drive velocity V_I (m/s) and noise velocity sigma (m/s; or an array of
    them, e.g. one per column of a history: each column's levels)."""
    sigma = np.asarray(noise, dtype=float)
    if not np.all(np.isfinite(sigma) & (sigma >= 0)):
        raise ValueError(f"noise: got {noise}; expected a velocity >= 0 (m/s)")
    floor = NOISE_FALL * sigma
    return FrontLevels(
        start=level(start_fraction, drive_velocity, sigma),
        front=level(front_fraction, drive_velocity, sigma),
        drop=level(prominence, drive_velocity, sigma, NOISE_FALL),
        pulse_drop=pulse_drop,
        pulse_floor=float(floor) if floor.ndim == 0 else floor,
    )


def noise_velocity(masses, velocities, gaps, energy, free):
    """The chain's noise velocity sigma, m/s: the RMS velocity its free magnets would have,
    undriven, if all the energy of its initial state above the uniform chain at rest were kinetic:

        sigma^2 = (sum m v^2 + 2 [sum U(r_n) - (N-1) U(mean r)]) / sum m,   sums over free magnets
                                                                             (energy: all gaps)

    the thermal kinetic energy plus the potential energy of the gap disorder (for a convex U the
    bracket is >= 0, zero for equal gaps). Energy is conserved undriven (friction only takes
    some), so no free magnet's RMS velocity before the front exceeds sigma; mass disorder alone
    gives sigma = 0. Units: masses g, velocities m/s, gaps mm, energy(r) in mJ (N mm), so that
    m v^2 and U are both mJ.

    masses, velocities (N,); gaps (N-1,); energy: U(r) of the nearest-neighbour law, vectorised;
    free (N,) bool: the magnets that move freely (not the impactor, not the held end).
    For R chains at once (a batch), masses and velocities (R, N) and gaps (R, N-1) give sigma of
    each, shape (R,): one chain is a batch of one, and each row's sums are those of the row alone
    (numpy reduces each row of a C-contiguous array along its last axis as it reduces a 1-D array)."""
    single = np.ndim(masses) == 1
    masses, velocities, gaps = (np.atleast_2d(np.asarray(x, dtype=float, order="C")) for x in (masses, velocities, gaps))
    free = np.asarray(free, dtype=bool)
    # C order, so that each row is reduced as a 1-D array is (boolean indexing gives F order)
    m, v = (np.ascontiguousarray(x[:, free]) for x in (masses, velocities))
    # masses relative to the largest, so that sums of huge masses cannot overflow
    scale = np.max(m, axis=1, keepdims=True) if m.shape[1] else np.ones((len(m), 1))
    relative = m / scale
    kinetic = np.sum(relative * v**2, axis=1)
    # exactly 0 for equal gaps (the sum would leave rounding errors)
    mean = np.mean(gaps, axis=1, keepdims=True)
    disorder = np.where(np.ptp(gaps, axis=1) > 0, np.sum(energy(gaps), axis=1) - gaps.shape[1] * energy(mean)[:, 0], 0.0)
    sigma = np.sqrt(np.maximum(kinetic + 2.0 * np.maximum(disorder, 0.0) / scale[:, 0], 0.0) / np.sum(relative, axis=1))
    return float(sigma[0]) if single else sigma
