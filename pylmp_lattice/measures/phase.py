"""The phase portrait of one magnet: its velocity against the gap to the next magnet (paper
Fig. S9), r_n = x_{n+1} - x_n."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ._common import check_history


@dataclass(frozen=True)
class PhasePortrait:
    """particle: n (0-based); time (ms), gap r_n (mm), velocity v_n (m/s), shape (n_frames,)."""

    particle: int
    time: np.ndarray
    gap: np.ndarray
    velocity: np.ndarray

    def ranges(self, window: tuple[float, float]) -> dict:
        """Extent of the orbit in the time window (ms): min and max gap (mm) and velocity (m/s)."""
        keep = (self.time >= window[0]) & (self.time <= window[1])
        g, v = self.gap[keep], self.velocity[keep]
        return {"window_ms": list(window), "gap_min_mm": g.min(), "gap_max_mm": g.max(),
                "velocity_min_m_per_s": v.min(), "velocity_max_m_per_s": v.max()}

    def to_dict(self) -> dict:
        return {"particle": self.particle, "time_ms": self.time, "gap_mm": self.gap, "velocity_m_per_s": self.velocity}


def phase_portrait(t, x, v, particle: int) -> PhasePortrait:
    """Velocity of `particle` (0-based) against its gap to the next one; t (n_frames,) ms,
    x positions (n_frames, N) mm, v velocities (n_frames, N) m/s."""
    t, v = check_history(t, v)
    x = np.asarray(x, dtype=float)
    if x.shape != v.shape:
        raise ValueError(f"x: got shape {x.shape}; expected {v.shape}, the shape of v")
    if not 0 <= particle < v.shape[1] - 1:
        raise ValueError(f"particle: got {particle}; expected 0 <= particle < {v.shape[1] - 1} (it needs a next one)")
    return PhasePortrait(particle, t, x[:, particle + 1] - x[:, particle], v[:, particle].copy())
