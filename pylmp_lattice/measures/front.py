"""The per-particle front measures of a run, computed once for the summary and the figure."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .arrival import arrival_times
from .peaks import FirstPeaks, first_peaks
from .propagation import propagation_velocity


@dataclass(frozen=True)
class Front:
    """arrival (N,) ms by `arrival_method`; propagation_velocity (N-1,) m/s over each gap; peaks."""

    arrival: np.ndarray
    propagation_velocity: np.ndarray
    peaks: FirstPeaks
    arrival_method: str = "level"


def front(t, v, a, drive_velocity: float, spacing, arrival_method: str = "level") -> Front:
    """Arrival times (by `arrival_method`, see `arrival`), propagation velocity and first peaks."""
    arrival = arrival_times(t, v, drive_velocity, method=arrival_method, a=a)
    return Front(arrival, propagation_velocity(arrival, spacing), first_peaks(t, v, a, drive_velocity), arrival_method)
