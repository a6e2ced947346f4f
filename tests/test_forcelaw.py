"""Force laws: F = -dU/dr, stiffness = -dF/dr, and the power-law fit."""

from __future__ import annotations

import numpy as np
import pytest

from pylmp_lattice.errors import ConfigError
from pylmp_lattice.forcelaw import LinearSpring, PowerLaw, SampledLaw, fit_power_law

R = np.linspace(0.5, 40.0, 4001)  # mm


@pytest.mark.parametrize("law", [PowerLaw(), PowerLaw(K=100.0, b=2.0, q=4.5), LinearSpring(k=0.02, r_free=30.0)])
def test_force_is_minus_energy_gradient_and_stiffness_is_minus_force_gradient(law):
    h = 1e-5
    dudr = (law.energy(R + h) - law.energy(R - h)) / (2 * h)
    dfdr = (law.force(R + h) - law.force(R - h)) / (2 * h)
    np.testing.assert_allclose(-dudr, law.force(R), rtol=1e-7, atol=1e-12)
    np.testing.assert_allclose(-dfdr, law.stiffness(R), rtol=1e-6)


def test_paper_law_values():
    """F(12 mm) = 413.8 / 15.917^3 N; stiffness at contact 3 K / b^4 N/mm."""
    law = PowerLaw()
    assert law.force(12.0) == pytest.approx(0.102614, rel=1e-5)
    assert law.stiffness(0.0) == pytest.approx(3 * 413.8 / 3.917**4, rel=1e-12)


def test_sampled_law_reproduces_the_sampled_function():
    """A cubic spline through 601 samples (0.1 mm apart) of the paper's law: force within 1e-5,
    energy exactly its integral (F = -dU/dr to round-off)."""
    r = np.linspace(0.0, 60.0, 601)
    exact = PowerLaw()
    law = SampledLaw(tuple(r), tuple(exact.force(r)))
    x = np.linspace(0.0, 60.0, 3001)
    np.testing.assert_allclose(law.force(x), exact.force(x), rtol=1e-5)
    u_exact = exact.energy(x) - exact.energy(60.0)
    np.testing.assert_allclose(law.energy(x), u_exact, rtol=1e-5, atol=1e-9)
    assert law.domain() == (0.0, 60.0)


def test_fit_recovers_the_paper_law_from_exact_samples():
    r = np.linspace(1.0, 60.0, 50)
    fit = fit_power_law(r, PowerLaw().force(r), guess=PowerLaw(K=300.0, b=3.0, q=2.5))
    assert fit.law.K == pytest.approx(413.8, rel=1e-6)
    assert fit.law.b == pytest.approx(3.917, rel=1e-6)
    assert fit.law.q == pytest.approx(3.0, rel=1e-6)
    assert fit.rms_relative_error < 1e-8


def test_fit_reports_the_error_of_noisy_samples():
    """2% multiplicative noise: the fit's rms relative error is about 2%, the law close."""
    rng = np.random.default_rng(1)
    r = np.linspace(1.0, 60.0, 400)
    noisy = PowerLaw().force(r) * (1 + 0.02 * rng.standard_normal(r.size))
    fit = fit_power_law(r, noisy)
    assert 0.015 < fit.rms_relative_error < 0.025
    assert fit.law.force(12.0) == pytest.approx(PowerLaw().force(12.0), rel=0.01)


@pytest.mark.parametrize(
    "make, field",
    [
        (lambda: PowerLaw(K=-1.0), "force.K"),
        (lambda: PowerLaw(q=1.0), "force.q"),
        (lambda: LinearSpring(k=0.0, r_free=1.0), "force.k"),
        (lambda: SampledLaw((0.0, 1.0, 1.0, 2.0), (1.0, 1.0, 1.0, 1.0)), "force.r"),
        (lambda: fit_power_law([1.0, 2.0, 3.0, 4.0], [1.0, -1.0, 1.0, 1.0]), "force.F"),
    ],
)
def test_invalid_laws_name_the_field(make, field):
    with pytest.raises(ConfigError) as info:
        make()
    assert info.value.field == field
