"""Shock measures on particle histories: pure functions of arrays, no I/O and no LAMMPS.

Conventions (user units, see `units`): time t in ms, particle velocity v in m/s (= mm/ms),
acceleration a in m/s^2, lengths in mm, mass in g, stiffness in N/mm, frequency in Hz.
A history has shape (n_frames, N): magnets in chain order, column 0 magnet 1, the impactor.
Results objects number magnets and gaps from 1 as the paper does (gap n between magnets n and
n+1), with inclusive ranges named `first_gap`, `last_gap`, ... (`numbering`). The
shock runs towards increasing index and drives particles with positive velocities; the drive
(impactor) velocity V_I > 0 sets the scale of every threshold, given as a fraction of V_I, and
in a noisy chain each is also at least a multiple of its noise velocity (`levels`).
A measure that does not exist for a particle (the front never reached it, no confirmed peak)
is NaN, not an exception; arrays of the wrong shape raise ValueError. Results objects are
dataclasses that `serialize.dumps` writes as strict JSON (NaN as null).

One module per concept: `levels` (every threshold, against V_I and the chain's noise),
`linear` (V0, f0, the slowest linear speed), `arrival` (front arrival), `propagation` (V_P and
its plateau), `peaks` (first peaks, rise time), `oscillation` (extrema, frequency, steady
oscillation), `critical` (V*), `transition` (transition zone), `phase` (phase portrait), and
`front` (the run's per-particle measures at once), `pulse` (a pulse's speed, the piston
problem's lead pulse and period two), `wake` (the mean state behind a shock). Typical use on a
`Trajectory` `tr`:

    t_front = arrival_times(tr.t, tr.v, vi)
    vp = propagation_velocity(t_front, np.diff(tr.x0))
    speed = trailing_plateau(vp)             # speed.mean over gaps speed.first..speed.last, speed.converged()
    peaks = first_peaks(tr.t, tr.v, tr.a, vi)
    steady = steady_oscillation(tr.t, tr.v[:, 50], vi, window=(400.0, 500.0))
"""

from typing import TYPE_CHECKING

from ..lazy import lazy_names
from .arrival import ARRIVAL_METHODS, arrival_times, default_arrival_method, particles_reached
from .front import Front, front, stack_fronts
from .levels import (
    FRONT_FRACTION, NOISE_FALL, NOISE_LEVEL, PROMINENCE, PULSE_DROP, START_FRACTION, FrontLevels, front_levels,
    noise_velocity,
)
from .linear import linear_frequency, linear_wave_speed, slowest_linear_speed
from .peaks import FirstPeaks, first_peaks
from .propagation import (
    FrontFit,
    Plateau,
    Plateaus,
    centred_propagation_velocity,
    fit_front_speeds,
    fit_propagation_velocity,
    propagation_velocity,
    trailing_plateau,
    trailing_plateaus,
)

# Loaded on first use (PEP 562): a run's and a sweep's measures (above) need none of these, and
# a sweep's command and its workers' fork server import this package before their first member.
# The same imports for type checkers and the API reference (griffe reads them; nothing runs them).
if TYPE_CHECKING:
    from .critical import KNEE_METHODS, CriticalVelocity, critical_velocities, critical_velocity
    from .friction_fit import FrictionFit, RigMotion, fit_friction, rig_motion
    from .oscillation import Oscillations, SteadyOscillation, oscillations, steady_oscillation
    from .phase import PhasePortrait, phase_portrait
    from .pulse import centroid_speed, lead_pulse, staggered_amplitude
    from .transition import TransitionZone, steady_onset_times, transition_zone
    from .wake import WakeState, wake_state
_LAZY = {
    "critical": ["KNEE_METHODS", "CriticalVelocity", "critical_velocities", "critical_velocity"],
    "friction_fit": ["FrictionFit", "RigMotion", "fit_friction", "rig_motion"],  # Fig. S4 calibration
    "oscillation": ["Oscillations", "SteadyOscillation", "oscillations", "steady_oscillation"],
    "phase": ["PhasePortrait", "phase_portrait"],
    "pulse": ["centroid_speed", "lead_pulse", "staggered_amplitude"],
    "transition": ["TransitionZone", "steady_onset_times", "transition_zone"],
    "wake": ["WakeState", "wake_state"],
}
__getattr__, __dir__ = lazy_names(__name__, {name: module for module, names in _LAZY.items() for name in names})

__all__ = [
    "FRONT_FRACTION", "NOISE_FALL", "NOISE_LEVEL", "PROMINENCE", "PULSE_DROP", "START_FRACTION",
    "ARRIVAL_METHODS", "KNEE_METHODS", "CriticalVelocity", "FirstPeaks", "Front", "FrontFit", "FrontLevels",
    "Oscillations",
    "PhasePortrait", "Plateau", "Plateaus", "SteadyOscillation", "TransitionZone", "arrival_times", "centred_propagation_velocity",
    "critical_velocities", "critical_velocity", "default_arrival_method", "first_peaks", "fit_front_speeds", "fit_propagation_velocity",
    "front", "front_levels", "particles_reached", "stack_fronts", "linear_frequency", "linear_wave_speed", "noise_velocity", "oscillations",
    "phase_portrait", "propagation_velocity", "slowest_linear_speed", "steady_oscillation", "steady_onset_times",
    "trailing_plateau", "trailing_plateaus", "transition_zone",
    "WakeState", "centroid_speed", "lead_pulse", "staggered_amplitude", "wake_state",
    "FrictionFit", "RigMotion", "fit_friction", "rig_motion",
]
