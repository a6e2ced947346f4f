"""The phase portrait of one magnet: its velocity against the gap to the next magnet (paper
Fig. S9), r_n = x_{n+1} - x_n. Magnets are numbered from 1 (the impactor), as the paper
counts (`numbering`)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..serialize import jsonable
from ._common import check_history, require_integer


@dataclass(frozen=True)
class PhasePortrait:
    """magnet: n (1-based); time (ms), gap r_n (mm), velocity v_n (m/s), shape (n_frames,)."""

    magnet: int
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
        """The results as a dict of plain values (JSON), units in the keys."""
        return jsonable({"magnet": self.magnet, "time_ms": self.time, "gap_mm": self.gap,
                         "velocity_m_per_s": self.velocity})


def phase_portrait(t, x, v, magnet: int, first_magnet: int = 1) -> PhasePortrait:
    """Velocity of magnet number `magnet` against its gap to the next one; t (n_frames,) ms,
    x positions and v velocities (n_frames, K), mm and m/s, of magnets first_magnet ..
    first_magnet + K - 1 (default: the whole chain, column i magnet i + 1)."""
    t, v = check_history(t, v)
    x = np.asarray(x, dtype=float)
    if x.shape != v.shape:
        raise ValueError(f"x: got shape {x.shape}; expected {v.shape}, the shape of v")
    require_integer(magnet=magnet, first_magnet=first_magnet)
    last = first_magnet + v.shape[1] - 1
    if not first_magnet <= magnet < last:
        raise ValueError(f"magnet: got {magnet}; expected {first_magnet} <= magnet < {last} (it needs a next one)")
    i = magnet - first_magnet
    return PhasePortrait(magnet, t, x[:, i + 1] - x[:, i], v[:, i].copy())
