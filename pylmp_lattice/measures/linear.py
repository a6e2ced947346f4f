"""The linear chain's constants: wave speed V0 and oscillation frequency f0."""

from __future__ import annotations

import numpy as np

from ._common import HZ_PER_INV_MS, require_positive


def linear_wave_speed(stiffness: float, mass: float, spacing: float) -> float:
    """Speed of small-amplitude waves, V0 = r0 sqrt(k/m), in m/s.

    stiffness: k = -dF/dr at r = r0, N/mm; mass: m, g; spacing: r0, mm.
    In user units N/mm per g is 1/ms^2 (= 1e6 1/s^2), so r0 sqrt(k/m) is in mm/ms = m/s.
    """
    require_positive(stiffness=stiffness, mass=mass, spacing=spacing)
    return spacing * np.sqrt(stiffness / mass)


def linear_frequency(stiffness: float, mass: float) -> float:
    """Linear oscillation frequency f0 = (1/pi) sqrt(k/m), in Hz.

    The top of the harmonic chain's band, omega_max = 2 sqrt(k/m), as a frequency; units as
    in `linear_wave_speed` (sqrt(k/m) in 1/ms, converted to Hz).
    """
    require_positive(stiffness=stiffness, mass=mass)
    return np.sqrt(stiffness / mass) / np.pi * HZ_PER_INV_MS


def slowest_linear_speed(stiffness, masses, gaps):
    """The slowest local linear wave speed of a chain, m/s: min over gaps n of
    r_n sqrt(k_n / max(m_n, m_(n+1))), k_n = -dF/dr at r_n (N/mm), masses (N,) g, gaps (N-1,)
    mm. For a uniform chain it is V0; no front of a compressive wave is slower (a gap
    measured slower was crossed by something else, e.g. noise, and is flagged).
    For R chains, stiffness and gaps (R, N-1) and masses (R, N): one speed per chain, (R,)."""
    stiffness, masses, gaps = (np.asarray(x, dtype=float) for x in (stiffness, masses, gaps))
    require_positive(smallest_stiffness=stiffness.min(), smallest_mass=masses.min(), smallest_gap=gaps.min())
    speed = np.min(gaps * np.sqrt(stiffness / np.maximum(masses[..., :-1], masses[..., 1:])), axis=-1)
    return float(speed) if speed.ndim == 0 else speed
