"""The mean state behind a shock and its oscillation energy: pure functions of a run's arrays.

Behind a dispersive shock the chain does not settle: it oscillates about a mean state. The
jump conditions (exact.jump, exact.wake_energy) speak of the mean state; `wake_state` measures
it over a window of gaps and times, with the energy of the oscillation about it, the paper's
analogue of the temperature behind a molecular shock. User units: t in ms, v in m/s, gaps in
mm, mass in g, energies in mJ per particle.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np


@dataclass(frozen=True)
class WakeState:
    """Means over gaps [gap_start, gap_stop) and times [t_start, t_end] behind the front.

    mean_gap (mm), mean_force (N, the mean of F(r), not F(mean r)), mean_velocity (m/s, of
    the particles that follow the gaps); kinetic (mJ): m <(v - <v>)^2> / 2, the oscillation's
    kinetic energy per particle (in 1D, half of k_B T); potential (mJ): <U(r)> - U(<r>), its
    potential energy per particle beyond the mean state's.
    """

    gap_start: int
    gap_stop: int
    t_start: float
    t_end: float
    mean_gap: float
    mean_force: float
    mean_velocity: float
    kinetic: float
    potential: float

    @property
    def oscillation_energy(self) -> float:
        """Kinetic plus potential energy of the oscillation per particle, mJ."""
        return self.kinetic + self.potential

    def to_dict(self) -> dict:
        return asdict(self) | {"oscillation_energy": self.oscillation_energy}


def wake_state(t, v, gaps, law, mass: float, gap_window: tuple[int, int], t_window: tuple[float, float]) -> WakeState:
    """The mean state and oscillation energy in a window of a run.

    t (n_frames,) ms; v (n_frames, N) m/s; gaps (n_frames, N-1) mm, gap n between particles n
    and n+1; law: a forcelaw object; gap_window: [start, stop) gap indices; t_window: ms.
    The velocities are those of particles start+1 .. stop (the right end of each gap), never
    the driven particle 0.
    """
    t, v, gaps = np.asarray(t, float), np.asarray(v, float), np.asarray(gaps, float)
    lo, hi = gap_window
    if not (0 <= lo < hi <= gaps.shape[1]):
        raise ValueError(f"gap_window: got {gap_window}; expected 0 <= start < stop <= {gaps.shape[1]}")
    frames = (t >= t_window[0]) & (t <= t_window[1])
    if not np.any(frames):
        raise ValueError(f"t_window: got {t_window} ms; no frame in it (run spans {t[0]}..{t[-1]} ms)")
    r = gaps[frames, lo:hi]
    u = v[frames, lo + 1:hi + 1]
    mean_gap, mean_v = float(np.mean(r)), float(np.mean(u))
    return WakeState(
        gap_start=lo, gap_stop=hi, t_start=float(t[frames][0]), t_end=float(t[frames][-1]),
        mean_gap=mean_gap, mean_force=float(np.mean(law.force(r))), mean_velocity=mean_v,
        kinetic=0.5 * mass * float(np.mean((u - mean_v) ** 2)),
        potential=float(np.mean(law.energy(r)) - law.energy(mean_gap)),
    )
