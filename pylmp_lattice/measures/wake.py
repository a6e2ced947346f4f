"""The mean state behind a shock and its oscillation energy: pure functions of a run's arrays.

Behind a dispersive shock the chain does not settle: it oscillates about a mean state. The
jump conditions (exact.jump, exact.wake_energy) speak of the mean state; `wake_state` measures
it over a window of gaps and times, with the energy of the oscillation about it, the paper's
analogue of the temperature behind a molecular shock. User units: t in ms, v in m/s, gaps in
mm, mass in g, energies in mJ per particle. Gaps are numbered as the paper counts
(`numbering`): gap n lies between magnets n and n+1, magnet 1 the impactor.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from ..numbering import entries
from ..serialize import jsonable


@dataclass(frozen=True)
class WakeState:
    """Means over gaps first_gap .. last_gap (1-based, inclusive) and times [t_start, t_end]
    behind the front.

    mean_gap (mm), mean_force (N, the mean of F(r), not F(mean r)), mean_velocity (m/s, of
    the particles that follow the gaps); kinetic (mJ): m <(v - <v>)^2> / 2, the oscillation's
    kinetic energy per particle (in 1D, half of k_B T); potential (mJ): <U(r)> - U(<r>), its
    potential energy per particle beyond the mean state's.
    """

    first_gap: int
    last_gap: int
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
        """The results as a dict of plain values (JSON), units in the keys."""
        return jsonable(asdict(self) | {"oscillation_energy": self.oscillation_energy})


def wake_state(t, v, gaps, law, mass: float, gap_range: tuple[int, int], t_window: tuple[float, float]) -> WakeState:
    """The mean state and oscillation energy in a window of a run.

    t (n_frames,) ms; v (n_frames, N) m/s, column i magnet i + 1; gaps (n_frames, N-1) mm,
    column i gap i + 1 (between magnets i + 1 and i + 2); law: a forcelaw object; gap_range:
    (first_gap, last_gap), 1-based and inclusive; t_window: ms. The velocities are those of
    magnets first_gap + 1 .. last_gap + 1 (the right end of each gap), never the impactor.
    """
    t, v, gaps = np.asarray(t, float), np.asarray(v, float), np.asarray(gaps, float)
    first, last = gap_range
    if not (1 <= first <= last <= gaps.shape[1]):
        raise ValueError(f"gap_range: got {gap_range}; expected 1 <= first_gap <= last_gap <= {gaps.shape[1]}")
    frames = (t >= t_window[0]) & (t <= t_window[1])
    if not np.any(frames):
        raise ValueError(f"t_window: got {t_window} ms; no frame in it (run spans {t[0]}..{t[-1]} ms)")
    r = gaps[frames, entries(first, last)]
    u = v[frames, entries(first + 1, last + 1)]
    mean_gap, mean_v = float(np.mean(r)), float(np.mean(u))
    return WakeState(
        first_gap=first, last_gap=last, t_start=float(t[frames][0]), t_end=float(t[frames][-1]),
        mean_gap=mean_gap, mean_force=float(np.mean(law.force(r))), mean_velocity=mean_v,
        kinetic=0.5 * mass * float(np.mean((u - mean_v) ** 2)),
        potential=float(np.mean(law.energy(r)) - law.energy(mean_gap)),
    )
