"""A chain trajectory as plain arrays in user units (see `units`)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Trajectory:
    """Particle histories of one run, particles in chain order (index 0 is the impactor).

    t  (n_frames,)     time, ms
    x0 (N,)            initial positions, mm
    u  (n_frames, N)   displacement from x0, mm
    v  (n_frames, N)   velocity, m/s
    a  (n_frames, N)   acceleration, m/s^2 (total force / mass, friction included)
    """

    t: np.ndarray
    x0: np.ndarray
    u: np.ndarray
    v: np.ndarray
    a: np.ndarray

    def __post_init__(self):
        n_frames, n = len(self.t), len(self.x0)
        for name in ("u", "v", "a"):
            shape = getattr(self, name).shape
            if shape != (n_frames, n):
                raise ValueError(f"Trajectory.{name}: got shape {shape}; expected {(n_frames, n)}")

    def __repr__(self) -> str:  # the arrays' shapes and times, not their values (a notebook printed them all)
        span = f", t={self.t[0]:g}..{self.t[-1]:g} ms" if len(self.t) else ""
        return f"Trajectory(frames={len(self.t)}, magnets={len(self.x0)}{span})"

    def gaps(self) -> np.ndarray:
        """Separations of consecutive columns x[:, k+1] - x[:, k], mm, shape (n_frames, columns - 1):
        the gaps r_n = x_{n+1} - x_n of a whole chain or of consecutive magnets; of a selection
        such as magnets [3, 7], the distance x_7 - x_3 spanning gaps 3 .. 6, not one gap."""
        return np.diff(self.x0 + self.u, axis=1)
