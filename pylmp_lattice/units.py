"""Units: the user's (the paper's) units and the engine's, converted here and nowhere else.

User units are mm, g, ms, with forces in N and velocities in m/s. They form a consistent
system (1 g mm/ms^2 = 1 N, 1 mm/ms = 1 m/s), so energies are in mJ = N mm. Accelerations are
reported in m/s^2. LAMMPS runs with `units si` (m, kg, s, N, J).
"""

from __future__ import annotations

import operator

import numpy as np

# Size of one user unit in SI (engine) units, per quantity.
TO_SI = {
    "length": 1e-3,  # mm -> m
    "mass": 1e-3,  # g -> kg
    "time": 1e-3,  # ms -> s
    "velocity": 1.0,  # m/s
    "acceleration": 1.0,  # m/s^2
    "force": 1.0,  # N
    "energy": 1e-3,  # mJ = N mm -> J
    "stiffness": 1e3,  # N/mm -> N/m
}


def to_engine(value, quantity: str):
    """User units -> LAMMPS `units si`."""
    return _elementwise(np.multiply, value, TO_SI[quantity])


def from_engine(value, quantity: str):
    """LAMMPS `units si` -> user units."""
    return _elementwise(np.divide, value, TO_SI[quantity])


# Frequencies are reported in Hz (the paper's f0), while user times are in ms: a period in ms
# is 1e3 / f, and a rate per ms (a velocity's change per ms, a magnet count per ms) is 1e3 per s.
PER_MS_IN_HZ = 1.0 / TO_SI["time"]  # 1/ms -> Hz


def period(frequency):
    """A frequency in Hz -> its period in ms."""
    return _elementwise(np.divide, PER_MS_IN_HZ, frequency)


def frequency(period_ms):
    """A period in ms -> its frequency in Hz (also: a rate per ms -> per s)."""
    return _elementwise(np.divide, PER_MS_IN_HZ, period_ms)


def acceleration(rate):
    """A velocity's rate of change in m/s per ms -> m/s^2."""
    return _elementwise(np.multiply, rate, PER_MS_IN_HZ)


_OPERATORS = {np.multiply: operator.mul, np.divide: operator.truediv}


def _elementwise(ufunc, a, b):
    """ufunc(a, b), np.multiply or np.divide, of a value and a unit's factor: an array for a list
    or an array; for a scalar value the plain operator, so that a Python float stays one (the
    ufunc would return a numpy scalar)."""
    return _OPERATORS[ufunc](a, b) if np.isscalar(a) and np.isscalar(b) else ufunc(a, b)


# The H5MD trajectory file (see `h5md`) keeps the engine's SI units, but lengths in nm and times
# in ps: MDAnalysis's H5MD reader knows no m or mm, and takes the frame interval (observable dt)
# in ps without converting it. Name and size in SI of each unit.
H5MD_UNITS = {"length": ("nm", 1e-9), "time": ("ps", 1e-12), "velocity": ("m s-1", 1.0),
              "force": ("N", 1.0), "mass": ("kg", 1.0), "acceleration": ("m s-2", 1.0), "energy": ("J", 1.0)}


def to_h5md(value, quantity: str):
    """LAMMPS `units si` -> the H5MD file's units (the array itself where they are the same)."""
    return value if H5MD_UNITS[quantity][1] == 1.0 else np.divide(value, H5MD_UNITS[quantity][1])
