"""Force laws: F = -dU/dr, stiffness = -dF/dr, and the power-law fit."""

from __future__ import annotations

import numpy as np
import pytest

from pylmp_lattice.deck import deck_text
from pylmp_lattice.errors import ConfigError
from pylmp_lattice.forcelaw import (FPUT, LennardJones, LinearSpring, Morse, PowerLaw, SampledLaw, Toda,
                                    fit_power_law)
from pylmp_lattice.run_folder import simulate

from conftest import OTHER_LAWS, make_case, make_law_case
from reference import integrate_chain

R = np.linspace(0.5, 40.0, 4001)  # mm

LAWS = [
    PowerLaw(), PowerLaw(K=100.0, b=2.0, q=4.5), LinearSpring(k=0.02, r_free=30.0),
    Toda(A=1.0, B=1.0, a=10.0), Toda(A=0.05, B=0.3, a=12.0),
    LennardJones(epsilon=0.2, sigma=10.0), Morse(D=0.3, alpha=0.4, r_e=12.0),
    FPUT(k=0.02, a=12.0, alpha=0.01, beta=0.002), FPUT(k=1.0, a=12.0, alpha=-0.25),
]


@pytest.mark.parametrize("law", LAWS, ids=lambda law: law.law)
def test_force_is_minus_energy_gradient_and_stiffness_is_minus_force_gradient(law):
    """Central differences (h = 1e-5 mm) against the analytic F and k; Lennard-Jones from
    0.8 sigma (where it is 1e4 times stiffer than at its minimum) upward."""
    h = 1e-5
    r = R[R >= 0.8 * law.sigma] if isinstance(law, LennardJones) else R
    dudr = (law.energy(r + h) - law.energy(r - h)) / (2 * h)
    dfdr = (law.force(r + h) - law.force(r - h)) / (2 * h)
    scale_f, scale_k = np.max(np.abs(law.force(r))), np.max(np.abs(law.stiffness(r)))
    np.testing.assert_allclose(-dudr, law.force(r), rtol=1e-7, atol=1e-9 * scale_f)
    np.testing.assert_allclose(-dfdr, law.stiffness(r), rtol=1e-6, atol=1e-8 * scale_k)


@pytest.mark.parametrize("law, r_zero, u_min", [
    (Toda(A=2.0, B=0.5, a=12.0), 12.0, 0.0),
    (LennardJones(epsilon=0.2, sigma=10.0), 2 ** (1 / 6) * 10.0, -0.2),
    (Morse(D=0.3, alpha=0.4, r_e=12.0), 12.0, -0.3),
    (FPUT(k=0.02, a=12.0, alpha=0.01, beta=0.002), 12.0, 0.0),
], ids=lambda x: getattr(x, "law", ""))
def test_zero_force_separation_and_well_depth(law, r_zero, u_min):
    """F = 0 where each law says, U there is the well's bottom, and F > 0 (repulsive) when
    compressed below it, F < 0 when stretched."""
    assert law.force(r_zero) == pytest.approx(0.0, abs=1e-12)
    assert law.energy(r_zero) == pytest.approx(u_min, abs=1e-14)
    assert law.stiffness(r_zero) > 0
    assert law.force(0.9 * r_zero) > 0 > law.force(1.1 * r_zero)


def test_toda_and_fput_reduce_to_the_linear_spring():
    """Toda near r = a is a spring of stiffness A B; FPUT with alpha = beta = 0 is the linear
    spring with r_free = a."""
    toda, r = Toda(A=1.0, B=1.0, a=12.0), np.linspace(11.999, 12.001, 5)
    np.testing.assert_allclose(toda.force(r), 12.0 - r, atol=1e-6)
    spring, fput = LinearSpring(k=0.3, r_free=12.0), FPUT(k=0.3, a=12.0)
    for name in ("force", "energy", "stiffness"):
        np.testing.assert_allclose(getattr(fput, name)(R), getattr(spring, name)(R), rtol=1e-15)


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


def test_fit_reports_the_largest_error_whatever_its_sign():
    """Exact samples of the paper's law but one, doubled (F twice the law's at r = 20 mm): the
    law fitted in log space runs below it, so its largest relative error there is negative,
    close to 1/2 - 1 = -0.5; max_relative_error is its size, as numpy finds it from the fit."""
    r = np.linspace(1.0, 60.0, 40)
    F = PowerLaw().force(r)
    F[np.argmin(np.abs(r - 20.0))] *= 2.0
    fit = fit_power_law(r, F)
    rel = fit.law.force(r) / F - 1
    assert rel[np.argmax(np.abs(rel))] < -0.4  # the outlier's error: the largest, and negative
    assert fit.max_relative_error == pytest.approx(float(np.max(np.abs(rel))), rel=1e-12)
    assert fit.rms_relative_error == pytest.approx(float(np.sqrt(np.mean(rel**2))), rel=1e-12)
    assert fit.max_relative_error > 0.4


@pytest.mark.parametrize(
    "make, field",
    [
        (lambda: PowerLaw(K=-1.0), "force.K"),
        (lambda: PowerLaw(q=1.0), "force.q"),
        (lambda: LinearSpring(k=0.0, r_free=1.0), "force.k"),
        (lambda: SampledLaw((0.0, 1.0, 1.0, 2.0), (1.0, 1.0, 1.0, 1.0)), "force.r"),
        (lambda: fit_power_law([1.0, 2.0, 3.0, 4.0], [1.0, -1.0, 1.0, 1.0]), "force.F"),
        (lambda: Toda(A=1.0, B=0.0, a=1.0), "force.B"),
        (lambda: LennardJones(epsilon=-1.0, sigma=1.0), "force.epsilon"),
        (lambda: Morse(D=1.0, alpha=1.0, r_e=0.0), "force.r_e"),
        (lambda: FPUT(k=1.0, a=1.0, beta=float("nan")), "force.beta"),
        (lambda: PowerLaw(K=float("inf")), "force.K"),  # inf > 0: refused as not finite
        (lambda: Toda(A=1.0, B=float("inf"), a=1.0), "force.B"),
        (lambda: SampledLaw((0.0, 1.0, 2.0), (3.0, 2.0, 1.0)), "force.r"),  # 3 samples: a not-a-knot cubic needs 4
        (lambda: fit_power_law([1.0, 2.0, 3.0, 4.0], [1.0, 0.0, 1.0, 1.0]), "force.F"),  # log F of 0
    ],
)
def test_invalid_laws_name_the_field(make, field):
    with pytest.raises(ConfigError) as info:
        make()
    assert info.value.field == field


@pytest.mark.lammps
@pytest.mark.parametrize("law", OTHER_LAWS)
def test_other_laws_run_like_an_independent_integrator(tmp_path, law):
    """20 unit masses driven at 0.5 m/s for 20 ms through each law's table, against scipy's
    DOP853 on the analytic law: the error is Verlet's alone (measured 1.1e-5 to 1.5e-4 m/s at
    dt = 0.01 ms, and 4.000 times less at half of it), so the table adds nothing visible."""
    errors = []
    for dt in (0.01, 0.005):
        case = make_law_case(law, particles=20, velocity=0.5, duration=20.0, run={"dt": dt})
        traj = simulate(case, tmp_path / str(dt))
        v_ref = integrate_chain(case.force.force, 1.0, OTHER_LAWS[law][1], 20, lambda t: 0.5 * t,
                                lambda t: np.full_like(t, 0.5), traj.t)
        assert np.max(np.abs(v_ref[:, 1:-1])) > 0.5  # the wave has crossed the chain
        errors.append(np.max(np.abs(traj.v - v_ref)))
    assert errors[0] < 5e-4 * 0.5
    assert 3.95 < errors[0] / errors[1] < 4.05


@pytest.mark.lammps
@pytest.mark.parametrize("q", [2.5, 4.0])
def test_power_laws_of_other_exponents_run_like_an_independent_integrator(tmp_path, q):
    """F = K/(r + b)^q with q = 2.5 (pow) and 4 (multiplications), K chosen for the paper's F at
    12 mm, through the engine's analytic law (K converted N mm^q -> N m^q): 20 magnets of 1.084 g
    driven at 1 m/s for 60 ms against scipy's DOP853 on the same law in user units, within
    1e-3 V_I (Verlet's error at dt = 0.01 ms, measured 1.2e-5 and 2.8e-5 m/s). A K converted as
    for q = 3 would be 1e-3^(q - 3) times the law's: 32 and 1e-3 times."""
    K = float(PowerLaw().force(12.0)) * (12.0 + 3.917) ** q
    case = make_case(particles=20, velocity=1.0, duration=60.0, force={"law": "power", "K": K, "b": 3.917, "q": q})
    traj = simulate(case, tmp_path)
    v_ref = integrate_chain(PowerLaw(K=K, b=3.917, q=q).force, 1.084, 12.0, 20, lambda t: 1.0 * t,
                            lambda t: np.full_like(t, 1.0), traj.t)
    assert np.max(np.abs(v_ref[:, 1:-1])) > 1.0  # the wave has crossed the chain
    assert np.max(np.abs(traj.v - v_ref)) < 1e-3 * 1.0


def _linear_chain_exact(t, n, k, m, V):
    """Velocities (m/s) and displacements (mm) of an n-magnet chain of linear springs k (N/mm),
    masses m (g), magnet 1 driven at V (m/s) from rest, magnet n held: the drive's static share
    u_i = V t (1 - i/(n-1)) plus the normal modes of the free magnets (sin(j pi i/(n-1)),
    omega_j^2 = (k/m) lambda_j) that start them at rest; user units, so k/m is in 1/ms^2."""
    i = np.arange(1, n - 1)
    share = 1 - i / (n - 1)
    L = 2 * np.eye(n - 2) - np.eye(n - 2, k=1) - np.eye(n - 2, k=-1)
    lam, phi = np.linalg.eigh(L)
    omega = np.sqrt(k / m * lam)
    b = phi.T @ (-V * share)  # w'(0) = -V (1 - i/(n-1)) in modal coordinates
    v = V * share + (np.cos(np.outer(t, omega)) * b) @ phi.T
    u = V * np.outer(t, share) + (np.sin(np.outer(t, omega)) * b / omega) @ phi.T
    return v, u


@pytest.mark.lammps
@pytest.mark.parametrize("engine", ["chain", "stock"])
def test_a_chain_of_linear_springs_runs_like_its_normal_modes(tmp_path, engine):
    """12 magnets of 1.084 g on springs F = k (r_free - r), k = 0.1 N/mm, r_free = 30 mm (the
    chain engine's analytic law, k converted N/mm -> N/m and r_free mm -> m; the stock engine's
    table), driven at 0.5 m/s for 40 ms (the wave, 3.6 m/s, crosses the chain and comes back):
    every free magnet's velocity and displacement against the exact solution of the linear
    equations, within 1e-3 V_I and 1e-3 mm (Verlet's error at dt = 0.01 ms, omega_max dt = 0.012:
    measured 1.2e-6 m/s and 4.2e-6 mm). A k off by 1e3 is far outside. (r_free does not enter:
    a linear chain's motion depends on differences of F alone; with friction it does, below.)"""
    k, r_free, m, n, V = 0.1, 30.0, 1.084, 12, 0.5
    case = make_case(particles=n, velocity=V, duration=40.0, force={"law": "linear", "k": k, "r_free": r_free},
                     run={"engine": engine})
    traj = simulate(case, tmp_path)
    v, u = _linear_chain_exact(traj.t, n, k, m, V)
    assert np.max(np.abs(v[:, -1])) > 0.2 * V  # the wave has reached the far end
    assert np.max(np.abs(traj.v[:, 1:-1] - v)) < 1e-3 * V
    assert np.max(np.abs(traj.u[:, 1:-1] - u)) < 1e-3


@pytest.mark.lammps
@pytest.mark.parametrize("engine", ["chain", "stock"])
def test_a_chain_of_linear_springs_with_friction_runs_like_the_stick_slip_integrator(tmp_path, engine):
    """The chain above with Coulomb friction, mu = 0.285, p = 0.012: the springs' preload
    F = k (r_free - r0) = 1.8 N makes the normal load p (F_(n-1) + F_n) four times m g, so the
    friction limit depends on r_free itself (the analytic law's r_free, converted mm -> m), not
    only on differences of F. Against tests/reference.py's stick-slip DOP853 (rtol 1e-12) on
    the same equations with the law written here: within 1e-3 V_I, as the paper's chain
    (tests/test_friction.py; measured 1.6e-6 m/s); and the friction work, 1.3706 mJ, within
    1e-5 (measured 1e-7)."""
    from pylmp_lattice.formats.dump import read_log

    from reference import integrate_chain_friction

    k, r_free, m, n, V = 0.1, 30.0, 1.084, 12, 0.5
    case = make_case(particles=n, velocity=V, duration=40.0, force={"law": "linear", "k": k, "r_free": r_free},
                     friction={"mu": 0.285, "p": 0.012}, run={"engine": engine})
    traj = simulate(case, tmp_path)
    ref = integrate_chain_friction(lambda r: k * (r_free - r), m, 12.0, n, lambda t: V * t,
                                   lambda t: np.full_like(np.asarray(t, float), V), traj.t, mu=0.285, p=0.012)
    assert np.any(ref.v[:, 1:-1] == 0.0) and np.max(np.abs(ref.v[:, -2])) > 0.1 * V  # sticks; the wave crosses
    assert np.max(np.abs(traj.v - ref.v)) < 1e-3 * V
    dissipated = read_log(tmp_path / "log.lammps").runs[-1]["f_friction"][-1] * 1e3  # J -> mJ
    assert dissipated == pytest.approx(ref.w_friction[-1], rel=1e-5)


def test_friction_reads_the_table_for_the_other_laws():
    """The friction fix (stock engine) and the chain fix have analytic power and linear laws
    only; the others go through the table."""
    for law in OTHER_LAWS:
        text = deck_text(make_law_case(law, friction={"mu": 0.1, "p": 0.0}, run={"engine": "stock"}))
        assert "lattice/friction 0.1 0.0 9.81 law bond 1" in text
        assert "law table ${dir}/force.table FORCE_LAW" in deck_text(make_law_case(law))


@pytest.mark.parametrize("law", LAWS + [PowerLaw(K=1e-3, b=0.1, q=1.5), PowerLaw(K=5e4, b=10.0, q=12.0),
                                        Toda(A=3.0, B=40.0, a=12.0)], ids=lambda law: law.law)
def test_a_law_that_softens_is_stiffest_where_a_range_starts(law):
    """`Law.softens` (the stability limit then reads k_max at the table's start instead of 20001
    samples a range, and under gap disorder each replica has a range of its own): its stiffness
    never grows with r, and the largest of the samples of any range is its first, to the bit."""
    from pylmp_lattice.case.case import _max_stiffness, _sampled_max_stiffness

    rng = np.random.default_rng(7)
    lo0 = law.domain()[0] + 0.5
    if law.softens:
        assert np.all(np.diff(law.stiffness(np.linspace(lo0, lo0 + 60.0, 100001))) <= 0)
    for lo, width in zip(rng.uniform(lo0, lo0 + 40.0, 50), rng.uniform(1e-6, 40.0, 50)):
        assert _max_stiffness(law, lo, lo + width) == _sampled_max_stiffness(law, lo, lo + width)
    assert [type(law).__name__ for law in LAWS if law.softens] == ["PowerLaw", "PowerLaw", "LinearSpring", "Toda", "Toda"]
