"""The dispersive-shock theory (pylmp_lattice.theory) against exact results, closed forms and
the simulations."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose

from pylmp_lattice import exact, theory
from pylmp_lattice.errors import ConfigError
from pylmp_lattice.forcelaw import FPUT, LennardJones, Morse, PowerLaw, SampledLaw, Toda

PAPER = PowerLaw()  # K = 413.8 N mm^3, b = 3.917 mm, q = 3
MASS, R0 = 1.084, 12.0  # g, mm


# ----------------------------------------------------------------------------- exact: the Toda lattice

@pytest.mark.parametrize("A, B, m", [(1.0, 1.0, 1.0), (2.5, 0.4, 3.0)])
def test_toda_lead_speed_and_critical_speed_are_exact(A, B, m):
    """Lead soliton cosh(kappa) = 1 + u, speed sinh(kappa)/kappa sites per time unit; wake
    exp(-r) = (1 + u/2)^2; V* = 2 sqrt(A/(m B)); in user units through exact.toda_scales."""
    a = 10.0
    law, scales = Toda(A, B, a), exact.toda_scales(A, B, m)
    for u in (0.05, 0.5, 1.0, 1.9, 3.0):
        p = theory.predict(law, m, a, u * scales.velocity)
        _, sites = exact.toda_lead_soliton(u)
        assert_allclose(p.lead_speed, a * sites / scales.time, rtol=1e-9)
        if u < 2:
            assert_allclose(B * (p.wake_gap - a), exact.toda_piston_wake(u), rtol=1e-9, atol=1e-12)
        assert p.wake_persists == (u > 2)
    assert_allclose(theory.critical_velocity(law, m, a), exact.toda_critical_piston_speed(A, B, m), rtol=1e-9)


def test_toda_trailing_edge_stops_at_the_critical_speed():
    """Eq. (2): s- = 2 c0 - c1 = 1 - u/2 sites per unit time for Toda; 0 from u = 2 on."""
    law = Toda(1.0, 1.0, 10.0)
    for u in (0.5, 1.0, 1.5, 1.99, 2.5):
        p = theory.predict(law, 1.0, 10.0, u)
        assert_allclose(p.trailing_speed, 10.0 * max(1 - u / 2, 0.0), rtol=1e-9, atol=1e-9)
    assert_allclose(theory.predict(law, 1.0, 10.0, 2.0 - 1e-9).trailing_wavenumber, np.pi, rtol=1e-6)


def test_toda_lead_decay_is_the_exact_soliton_s_and_the_trailing_wavenumber_its_group_velocity_s():
    """lead_decay k~+ is the lead soliton's tail exp(-k~+ n): the exact Toda soliton
    (exact.toda_soliton, cosh kappa = 1 + u) decays as exp(-2 kappa n) ahead of its centre, measured
    from its gaps 60 and 61 (1e-12). trailing_wavenumber k- is where the wake's linear waves,
    omega0 = 2 c(r1) sin(k/2), have group velocity trailing_speed / r0 (El's harmonic edge;
    trailing_speed is exact, 1 - u/2 sites per unit time, test above): by a central difference (1e-8)."""
    law = Toda(1.0, 1.0, 10.0)
    for u in (0.05, 0.5, 1.0, 1.9):
        p = theory.predict(law, 1.0, 10.0, u)
        kappa, _ = exact.toda_lead_soliton(u)
        _, _, r = exact.toda_soliton([60.0, 61.0], 0.0, float(kappa))
        assert_allclose(p.lead_decay, -np.log(r[0, 1] / r[0, 0]), rtol=1e-12)
        c1, k, h = np.exp(-(p.wake_gap - 10.0) / 2), p.trailing_wavenumber, 1e-6
        group = (2 * c1 * np.sin((k + h) / 2) - 2 * c1 * np.sin((k - h) / 2)) / (2 * h)
        assert_allclose(10.0 * group, p.trailing_speed, rtol=1e-8)


# ----------------------------------------------------------------------------- closed forms of the power law

@pytest.mark.parametrize("q", [2.0, 3.0, 5.0])
def test_power_law_weak_limit(q):
    """V_P -> V0 + (q+1) r0 V_I / (3 (r0 + b)) as V_I -> 0, with an O(V_I^2) remainder."""
    law = PowerLaw(q=q)
    v0 = theory.predict(law, MASS, R0, 1e-3).V0
    slope = (q + 1) * R0 / (3 * (R0 + law.b))
    excess = [(theory.predict(law, MASS, R0, v).lead_speed - v0) / v for v in (1e-4, 1e-3)]
    assert_allclose(excess, slope, rtol=2e-3)
    assert abs(excess[0] / slope - 1) < 0.2 * abs(excess[1] / slope - 1)  # the remainder is O(V_I)


@pytest.mark.parametrize("law, r0", [(LennardJones(1.0, 1.0), 2 ** (1 / 6)), (Morse(1.0, 3.0, 2.0), 2.0),
                                     (Toda(1.0, 1.0, 10.0), 10.0), (FPUT(1.0, 1.0, -0.5, 0.2), 1.0)])
def test_weak_limit_is_the_kdv_lead_soliton_for_any_law(law, r0):
    """V_P -> c0 + (4/3) s V_I, s the weak-shock coefficient of exact.weak_shock."""
    ws = exact.weak_shock(law, r0, 1.0)
    v = 1e-4 * ws.c0
    assert_allclose((theory.predict(law, 1.0, r0, v).lead_speed - ws.c0) / v, 4 * ws.s / 3, rtol=2e-3)


@pytest.mark.parametrize("q", [2.0, 2.5, 3.0, 4.0, 5.0])
def test_power_law_critical_speed_closed_form(q):
    """k(r*) = 4 k(r0): (r0 + b)/(r* + b) = 2^(2/(q+1)), and Eq. (4) integrates to
    V*/V0 = 2 (r0 + b) (2^((q-1)/(q+1)) - 1) / ((q - 1) r0)."""
    law = PowerLaw(q=q)
    v_star = theory.critical_velocity(law, MASS, R0)
    v0 = R0 * np.sqrt(float(law.stiffness(R0)) / MASS)
    expected = 2 * (R0 + law.b) * (2 ** ((q - 1) / (q + 1)) - 1) / ((q - 1) * R0)
    assert_allclose(v_star / v0, expected, rtol=1e-9)
    p = theory.predict(law, MASS, R0, v_star)
    assert_allclose(p.stiffness_ratio, 4.0, rtol=1e-8)
    assert_allclose(p.trailing_speed, 0.0, atol=1e-7)


def test_lennard_jones_against_an_independent_evaluation():
    """LJ, m = epsilon = sigma = 1 at r0 = 2^(1/6): V* = 0.8799035 (V*/V0 = 0.10370, section 4 of
    docs/literature.md) and at V_I = 0.5 r1 = 1.0705252, lead speed 11.572678, R-H speed 10.880067,
    from the referee's own script (analytic U'' = 4 (156 r^-14 - 42 r^-8), scipy quad/brentq,
    the El formulas re-derived): the package's spline-free path agrees to 1e-8."""
    law, r0 = LennardJones(1.0, 1.0), 2 ** (1 / 6)
    assert_allclose(theory.critical_velocity(law, 1.0, r0), 0.87990348, rtol=1e-8)
    p = theory.predict(law, 1.0, r0, 0.5)
    assert_allclose([p.wake_gap, p.lead_speed, p.rankine_hugoniot_speed], [1.07052517, 11.5726776, 10.8800668],
                    rtol=1e-8)


def test_paper_law_wake_closed_form():
    """q = 3: V_I = sqrt(3 K/m) (1/(r1 + b) - 1/(r0 + b)); F(r1) and f = sqrt(k(r1)/m)/pi."""
    a = np.sqrt(3 * PAPER.K / MASS)
    for v in (0.1, 0.5, 1.0, 2.0):
        p = theory.predict(PAPER, MASS, R0, v)
        r1 = 1 / (v / a + 1 / (R0 + PAPER.b)) - PAPER.b
        assert_allclose(p.wake_gap, r1, rtol=1e-10)
        assert_allclose(p.piston_force, PAPER.K / (r1 + PAPER.b) ** 3, rtol=1e-10)
        assert_allclose(p.wake_frequency, 1e3 * np.sqrt(3 * PAPER.K / (r1 + PAPER.b) ** 4 / MASS) / np.pi, rtol=1e-10)
    assert_allclose(theory.critical_velocity(PAPER, MASS, R0), 0.880652, rtol=1e-6)


def test_rankine_hugoniot_values_are_the_jump_to_a_state_moving_at_V_I():
    p = theory.predict(PAPER, MASS, R0, 1.0)
    rh = exact.jump(PAPER, R0, MASS, p.rankine_hugoniot_gap)
    assert_allclose([rh.u_p, rh.D], [1.0, p.rankine_hugoniot_speed], rtol=1e-10)
    ws = exact.weak_shock(PAPER, R0, MASS)
    assert_allclose(p.weak_shock_speed, ws.c0 + ws.s, rtol=1e-12)
    assert p.lead_speed > p.rankine_hugoniot_speed  # the lead soliton outruns the jump


def test_weak_shock_speed_is_the_weak_shock_line_at_every_V_I():
    """weak_shock_speed = c0 + s V_I with the power law's closed forms c0 = r0 sqrt(3 K / ((r0 + b)^4 m))
    and s = (q + 1) r0 / (4 (r0 + b)) (weak_shock's central difference: 1e-9), at V_I away from 1
    m/s; the Rankine-Hugoniot speed leaves that line by O(V_I^2): (D - c0)/V_I -> s (measured
    7.8e-5 off at 1e-3 m/s, 7.8e-4 at 1e-2)."""
    c0 = R0 * np.sqrt(3 * PAPER.K / (R0 + PAPER.b) ** 4 / MASS)
    s = 4 * R0 / (4 * (R0 + PAPER.b))
    for v in (1e-3, 1e-2, 0.3, 2.0):
        p = theory.predict(PAPER, MASS, R0, v)
        assert_allclose(p.weak_shock_speed, c0 + s * v, rtol=1e-8)
    for v, tol in ((1e-3, 2e-4), (1e-2, 2e-3)):
        assert_allclose((theory.predict(PAPER, MASS, R0, v).rankine_hugoniot_speed - c0) / v, s, rtol=tol)


def test_sampled_law_goes_through_its_spline():
    r = np.linspace(4.0, 14.0, 400)
    sampled = SampledLaw(tuple(r), tuple(PAPER.force(r)))
    a, b = theory.predict(sampled, MASS, R0, 1.0), theory.predict(PAPER, MASS, R0, 1.0)
    assert_allclose([a.lead_speed, a.wake_gap, a.wake_frequency], [b.lead_speed, b.wake_gap, b.wake_frequency],
                    rtol=1e-6)


def test_where_the_theory_does_not_apply():
    with pytest.raises(ValueError, match="V_I: got 0"):
        theory.predict(PAPER, MASS, R0, 0.0)
    with pytest.raises(ValueError, match="before contact"):
        theory.predict(PAPER, MASS, R0, 7.0)  # int_0^r0 c dr = 6.51 m/s
    softening = FPUT(1.0, 1.0, alpha=0.5)  # stiffness falls under compression: no compressive shock
    with pytest.raises(ValueError, match="c\\(r\\) must grow under compression"):
        theory.predict(softening, 1.0, 1.0, 0.1)
    assert theory.critical_velocity(softening, 1.0, 1.0) == np.inf
    assert theory.critical_velocity(FPUT(1.0, 1.0, -0.5, 0.2), 1.0, 1.0) == np.inf  # k(0) = 2.6 k(r0) at contact


def test_prediction_says_when_V_I_is_outside_the_theory_s_domain():
    """in_domain: V_I <= V* (0.880652 m/s for the paper's chain, rho = c(r1)/c(r0) = 2 there);
    above, the numbers are still given, flagged, with the trailing edge clipped at the piston."""
    v_star = theory.critical_velocity(PAPER, MASS, R0)
    inside, edge, outside = (theory.predict(PAPER, MASS, R0, v) for v in (0.5 * v_star, v_star, 2.0 * v_star))
    assert inside.in_domain and edge.in_domain and not outside.in_domain
    assert edge.stiffness_ratio == pytest.approx(4.0, rel=1e-9)  # k(r1) = 4 k(r0) at V*: the edge
    assert outside.stiffness_ratio > 4 and outside.trailing_speed == 0.0
    assert outside.to_dict()["in_domain"] is False


# ----------------------------------------------------------------------------- the A - C/n fit

def test_first_peak_limit_recovers_a_known_limit_with_its_uncertainty():
    rng = np.random.default_rng(3)
    n = np.arange(20, 200)
    errors = []
    for _ in range(200):
        fit = theory.first_peak_limit(n, 2.0 - 1.5 / n + rng.normal(0, 1e-3, n.size))
        errors.append((fit.A - 2.0) / fit.A_error)
    errors = np.array(errors)
    assert abs(np.mean(errors)) < 0.3 and 0.8 < np.std(errors) < 1.2  # the standard error is honest
    fit = theory.first_peak_limit(np.append(n, 300), np.append(2.0 - 1.5 / n, np.nan))
    assert_allclose([fit.A, fit.C], [2.0, 1.5], rtol=1e-9)
    assert fit.points == n.size
    with pytest.raises(ValueError, match="at least 3"):
        theory.first_peak_limit([1, 2], [1.0, 1.5])


# ----------------------------------------------------------------------------- against the simulations

@pytest.fixture(scope="module")
def paper_runs(tmp_path_factory):
    """The paper's long lattice at V_I = 0.5, 0.75, 1.0 m/s for 30 linear periods (706 ms),
    measured by the dsw study's `measure`."""
    from pylmp_lattice.studies.literature import dsw
    from pylmp_lattice.studies.scaffold import sweep_runs

    base, t0 = dsw.chain_base("magnet q=3", 30.0)
    runs = sweep_runs(base, tmp_path_factory.mktemp("dsw"), grid={"impactor.velocity": [0.5, 0.75, 1.0]})
    assert all(r.done for r in runs)
    return {r.member.params["impactor.velocity"]: dsw.measure(r, t0, theory.predict(PAPER, MASS, R0,
                                                                                   r.member.params["impactor.velocity"]))
            for r in runs}


@pytest.mark.lammps
def test_lead_speed_and_wake_frequency_against_the_paper_chain(paper_runs):
    """V_P within 1 % (its limit n -> oo, A - C/n) and f of magnet 10 within 0.5 %, V_I <= 1 m/s."""
    for vi, m in paper_runs.items():
        assert abs(m["V_P_limit_vs_lead"]) < 0.01, (vi, m["V_P_limit_vs_lead"])
        assert abs(m["f_vs_theory"]) < 0.005, (vi, m["f_vs_theory"])
        assert abs(m["mean_force_vs_theory"]) < 0.01, (vi, m["mean_force_vs_theory"])


@pytest.mark.lammps
def test_critical_velocity_lies_between_decaying_and_persisting_wakes(paper_runs):
    """eta(T)/eta(T/2) at magnet 10: below DECAYS the wake decays, above PERSISTS it persists."""
    from pylmp_lattice.studies.literature.dsw import DECAYS, PERSISTS

    decaying = [vi for vi, m in paper_runs.items() if m["eta_ratio"] < DECAYS]
    persisting = [vi for vi, m in paper_runs.items() if m["eta_ratio"] > PERSISTS]
    assert decaying and persisting, {vi: m["eta_ratio"] for vi, m in paper_runs.items()}
    assert max(decaying) < theory.critical_velocity(PAPER, MASS, R0) < min(persisting)


def test_a_mistyped_argument_is_named_not_a_numpy_error():
    law = PowerLaw(K=413.8, b=3.917, q=3.0)
    with pytest.raises(TypeError, match=r"^mass: got '1.084' \(str\); expected a number$"):
        theory.predict(law, "1.084", 12.0, 2.0)
    with pytest.raises(TypeError, match=r"^V_I: got None \(NoneType\); expected a number$"):
        theory.predict(law, 1.084, 12.0, None)
    with pytest.raises(TypeError, match=r"^law: got dict; expected a force law"):
        theory.critical_velocity({"law": "power", "K": 413.8}, 1.084, 12.0)
    with pytest.raises(ConfigError, match=r"^force.K: got '413.8' \(str\); expected a number$"):
        PowerLaw(K="413.8")
    with pytest.raises(ConfigError, match=r"^force.q: got None \(NoneType\); expected a number$"):
        PowerLaw(q=None)
    assert theory.critical_velocity(law, np.float64(1.084), np.int64(12)) == theory.critical_velocity(law, 1.084, 12.0)
