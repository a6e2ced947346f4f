"""Shared test helpers: small cases built in Python, in user units (mm, g, ms, N, m/s)."""

from __future__ import annotations

import pytest

from pylmp_lattice.case import case_from_dict

PAPER_FORCE = {"law": "power", "K": 413.8, "b": 3.917, "q": 3.0}


def make_case(particles=30, velocity=2.0, duration=50.0, dt=0.01, interval=0.1, **sections):
    """A paper-like chain (m = 1.084 g, r0 = 12 mm, power law, fixed far end)."""
    data = {
        "name": "test",
        "chain": {"particles": particles, "mass": 1.084, "r0": 12.0, "far_end": "fixed"},
        "force": dict(PAPER_FORCE),
        "impactor": {"profile": "constant", "velocity": velocity},
        "run": {"duration": duration, "dt": dt, "output_interval": interval},
    }
    for name, values in sections.items():
        if name in ("impactor", "force"):  # a new profile or law replaces the default
            data[name] = dict(values)
        else:
            data.setdefault(name, {}).update(values)
    return case_from_dict(data)


@pytest.fixture
def case_factory():
    return make_case
