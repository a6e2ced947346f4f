"""units: the one place user units (mm, g, ms, N, m/s) become the engine's (LAMMPS `units si`).

Every factor is checked against a number worked out by hand from the paper's values, and the
user units against the rule that makes them one system (1 g mm/ms^2 = 1 N): to_engine and
from_engine are inverses of each other whatever the factors, so no round trip can see a wrong
factor. All values are exact decimal scalings, so the tolerances are a few ulp (rel 1e-15).
"""

from __future__ import annotations

import numpy as np
import pytest

from pylmp_lattice.units import TO_SI, acceleration, frequency, from_engine, period, to_engine, to_h5md

# The paper's magnet and law in user units, and the same numbers in SI, written out by hand.
PAPER_SI = [
    (12.0, "length", 0.012),  # r0: 12 mm = 0.012 m
    (1.084, "mass", 1.084e-3),  # m: 1.084 g = 1.084e-3 kg
    (0.01, "time", 1e-5),  # dt: 0.01 ms = 1e-5 s
    (3.92, "velocity", 3.92),  # the measured front speed, m/s either way
    (9.81, "acceleration", 9.81),  # g, m/s^2 either way
    (0.1026, "force", 0.1026),  # F(12 mm), N either way
    (2.5, "energy", 2.5e-3),  # 2.5 mJ = 2.5 N mm = 2.5e-3 J
    (3 * 413.8 / 3.917**4, "stiffness", 3 * 413.8 / 3.917**4 * 1e3),  # 3 K / b^4 N/mm = 5.281 N/mm -> N/m
]


@pytest.mark.parametrize("user, quantity, si", PAPER_SI, ids=[q for _, q, _ in PAPER_SI])
def test_each_quantity_converts_by_its_hand_worked_factor(user, quantity, si):
    assert to_engine(user, quantity) == pytest.approx(si, rel=1e-15)
    assert from_engine(si, quantity) == pytest.approx(user, rel=1e-15)
    array = to_engine(np.array([user, 2 * user]), quantity)  # arrays elementwise, the same factor
    np.testing.assert_allclose(array, [si, 2 * si], rtol=1e-15)


def test_user_units_form_one_system():
    """mm, g, ms: velocity = length/time, force = mass length/time^2, energy = force length,
    stiffness = force/length, each the product of the base factors; acceleration is reported
    in m/s^2 (not mm/ms^2 = 1e3 m/s^2): its factor is 1."""
    L, M, T = TO_SI["length"], TO_SI["mass"], TO_SI["time"]
    assert (L, M, T) == (1e-3, 1e-3, 1e-3)
    derived = {"velocity": L / T, "force": M * L / T**2, "energy": M * L**2 / T**2, "stiffness": M / T**2,
               "acceleration": 1.0}
    for quantity, factor in derived.items():
        assert TO_SI[quantity] == pytest.approx(factor, rel=1e-15), quantity


def test_newton_s_law_reads_the_same_in_both_unit_systems():
    """A paper magnet 12 mm from its neighbour: F = 413.8 / 15.917^3 = 0.10261 N on 1.084 g,
    a = F/m = 94.66 m/s^2 worked out in SI; in user units F/m is 0.09466 m/s per ms, which
    `acceleration` reports as the same 94.66 m/s^2."""
    force_n, mass_g = 413.8 / (12.0 + 3.917) ** 3, 1.084
    a_si = to_engine(force_n, "force") / to_engine(mass_g, "mass")
    assert a_si == pytest.approx(94.662, rel=1e-4)
    assert acceleration(force_n / mass_g) == pytest.approx(a_si, rel=1e-15)
    assert from_engine(a_si, "acceleration") == pytest.approx(a_si, rel=1e-15)


def test_periods_frequencies_and_rates():
    """The paper's f0 = 42.4 Hz has a period of 1000/42.4 = 23.585 ms; a period of 25 ms is
    40 Hz; 1 m/s gained per ms is 1000 m/s^2; and frequency and period invert each other."""
    assert period(42.4) == pytest.approx(23.58490566, rel=1e-9)
    assert frequency(25.0) == pytest.approx(40.0, rel=1e-15)
    assert acceleration(1.0) == pytest.approx(1000.0, rel=1e-15)
    f = np.array([10.0, 42.4, 1e3])
    np.testing.assert_allclose(frequency(period(f)), f, rtol=1e-15)
    np.testing.assert_allclose(period(f), [100.0, 1000 / 42.4, 1.0], rtol=1e-15)


def test_h5md_file_units():
    """The H5MD file takes SI positions in nm and times in ps: 0.012 m = 1.2e7 nm, 1e-5 s =
    1e7 ps; velocities, forces and energies stay SI."""
    assert to_h5md(0.012, "length") == pytest.approx(1.2e7, rel=1e-15)
    assert to_h5md(1e-5, "time") == pytest.approx(1e7, rel=1e-15)
    for quantity in ("velocity", "force", "energy"):
        assert to_h5md(3.92, quantity) == 3.92
