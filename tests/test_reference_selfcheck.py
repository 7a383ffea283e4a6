"""Self-checks of the NumPy/SciPy reference walkers (tests/reference/scipy_walkers.py).

These test the reference against physics and the literature, not against the
JAX engine: Garcia's published fixed point, the period-doubling slope, energy
conservation in single support, angular-momentum conservation at heel-strike
(with kinematics written again here, from point-mass positions), and the
compass walker's simplest-walker limit.  The flat-foot reference
(tests/reference/flatfoot/) is checked against its own point-mass sums and
against energy conservation along its nominal step.  Each test runs in well
under 20 s.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from tests.reference import scipy_walkers as ref

GAMMA = 0.009


@pytest.fixture(scope="module")
def simplest_fp():
    fp = ref.simplest_fixed_point(GAMMA)
    assert fp.status == "ok"
    return fp


@pytest.fixture(scope="module")
def compass_fp():
    fp = ref.compass_fixed_point()
    assert fp.status == "ok"
    return fp


# ----------------------------------------------------------------- independent kinematics


def _n(q):
    return np.array([math.sin(q), -math.cos(q)])


def _points(x, p, foot=(0.0, 0.0)):
    """Hip, stance-leg mass, swing-leg mass positions (slope frame), stance foot at ``foot``."""
    a1, a2 = x[0], x[1]
    l = p["a"] + p["b"]
    foot = np.asarray(foot, dtype=float)
    hip = foot - l * _n(a1)
    return hip, foot - p["a"] * _n(a1), hip + p["b"] * _n(a2)


def _velocities(x, p, foot=(0.0, 0.0), eps=1e-6):
    """Point velocities by central differences of the positions along (q, q_dot)."""
    q, qd = np.asarray(x[:2]), np.asarray(x[2:])
    plus = _points(np.r_[q + eps * qd, qd], p, foot)
    minus = _points(np.r_[q - eps * qd, qd], p, foot)
    return [(rp - rm) / (2 * eps) for rp, rm in zip(plus, minus)]


def _masses(p):
    return p["m_h"], p["m"], p["m"]


def _cross(u, w):
    return u[0] * w[1] - u[1] * w[0]


def _energy(x, p):
    grav = p["g"] * np.array([math.sin(p["gamma"]), -math.cos(p["gamma"])])
    kin = sum(0.5 * m * v @ v for m, v in zip(_masses(p), _velocities(x, p)))
    pot = sum(-m * grav @ r for m, r in zip(_masses(p), _points(x, p)))
    return kin + pot


# ----------------------------------------------------------------- simplest walker


def test_garcia_fixed_point(simplest_fp):
    th, thd = ref.GARCIA_FIXED_POINT_0009
    v = simplest_fp.v
    assert abs(v[0] - th) < 1e-9
    assert abs(v[1] - thd) < 1e-9
    assert abs(v[2] - math.cos(2 * th) * thd) < 1e-9  # alpha_2_dot = cos(2 theta) theta_dot
    eig = simplest_fp.eigenvalues
    # stable: a complex pair inside the unit circle; the third multiplier is 0
    # (the image of the 3-D map lies on alpha_2_dot = cos(2 alpha_1) alpha_1_dot).
    assert simplest_fp.lambda_max < 0.6
    assert abs(eig[0].real + 0.1900998410) < 1e-8 and abs(abs(eig[0].imag) - 0.5575987762) < 1e-8
    assert abs(eig[2]) < 1e-9


def test_garcia_section_agrees(simplest_fp):
    fp2 = ref.fixed_point(ref.simplest_step_garcia, ref.GARCIA_FIXED_POINT_0009, args=(GAMMA,))
    assert fp2.status == "ok"
    np.testing.assert_allclose(fp2.v, simplest_fp.v[:2], atol=1e-11)
    np.testing.assert_allclose(np.sort_complex(fp2.eigenvalues), np.sort_complex(simplest_fp.eigenvalues[:2]),
                               atol=1e-8)


def test_step_map_converged_in_tolerance(simplest_fp, compass_fp):
    for step, v in ((lambda v, r: ref.simplest_step(v, GAMMA, rtol=r), simplest_fp.v),
                    (lambda v, r: ref.compass_step(v, rtol=r), compass_fp.v)):
        a, ia = step(v, 1e-12)
        b, ib = step(v, 1e-13)
        assert ia["status"] == ib["status"] == "ok"
        assert np.max(np.abs(a - b)) < 1e-11
        assert np.max(np.abs(a - v)) < 1e-11


def test_simplest_loses_stability_near_0_0151():
    """Garcia et al.: the period-one gait period-doubles near gamma = 0.0151."""
    before = ref.simplest_fixed_point(0.0150)
    after = ref.simplest_fixed_point(0.0152)
    assert before.status == after.status == "ok"
    assert before.lambda_max < 1.0 < after.lambda_max
    assert after.eigenvalues[0].real < -1.0 and abs(after.eigenvalues[0].imag) < 1e-9


def test_simplest_impact_is_garcias():
    th, thd = -0.21, -0.37
    x_minus = np.array([th, -th, thd, 0.15])  # phi- = 2 theta-
    a1, a2, w1, w2 = ref.simplest_impact(x_minus)
    c = math.cos(2 * th)
    assert a1 == pytest.approx(-th, abs=1e-15)          # theta+ = -theta-
    assert a1 - a2 == pytest.approx(-2 * th, abs=1e-15)  # phi+ = -2 theta- = 2 theta+
    assert w1 == pytest.approx(c * thd, abs=1e-15)       # theta_dot+ = cos(2 theta) theta_dot-
    assert w1 - w2 == pytest.approx(c * (1 - c) * thd, abs=1e-15)  # phi_dot+


def test_simplest_hip_energy_conserved(simplest_fp):
    x0 = ref.v_to_state(simplest_fp.v)
    sol = solve_ivp(ref.simplest_rhs, (0, 3.8), x0, args=(GAMMA,), method="DOP853", rtol=1e-12,
                    atol=1e-13, dense_output=True)
    e = [ref.simplest_energy(sol.sol(t), GAMMA) for t in np.linspace(0, 3.8, 50)]
    assert np.ptp(e) < 1e-11


def test_compass_limit_is_simplest(simplest_fp):
    """Compass walker with m_h = 1, foot masses beta at the feet, g = l = 1 -> simplest walker (O(beta))."""
    beta = 1e-7
    p = dict(gamma=GAMMA, m=beta, m_h=1.0, a=0.0, b=1.0, g=1.0)
    fp = ref.compass_fixed_point(p, v0=simplest_fp.v)
    assert fp.status == "ok"
    np.testing.assert_allclose(fp.v, simplest_fp.v, atol=10 * beta)
    np.testing.assert_allclose(fp.eigenvalues[:2], simplest_fp.eigenvalues[:2], atol=100 * beta)


# ----------------------------------------------------------------- compass walker


def test_compass_gait(compass_fp):
    v = compass_fp.v
    np.testing.assert_allclose(v, [0.271028680499, -1.092383589884, -0.377373948907], atol=1e-10)
    assert compass_fp.lambda_max == pytest.approx(0.579952332, abs=1e-8)
    assert compass_fp.lambda_max < 1.0
    _, info = ref.compass_step(v)
    assert info["status"] == "ok"
    assert info["step_time"] == pytest.approx(0.734346391159, abs=1e-9)
    p = ref.compass_params()
    # symmetric heel-strike: step length = 2 l sin(alpha_1*)
    assert info["step_length"] == pytest.approx(2 * (p["a"] + p["b"]) * math.sin(v[0]), abs=1e-10)


@pytest.mark.parametrize("x0", [None, (0.35, -0.2, -1.6, 2.5), (0.1, 0.4, 0.3, -4.0)])
def test_compass_energy_conserved_in_swing(compass_fp, x0):
    p = ref.compass_params()
    x0 = ref.v_to_state(compass_fp.v) if x0 is None else np.array(x0)
    sol = solve_ivp(ref.compass_rhs, (0, 0.7), x0, args=(p,), method="DOP853", rtol=1e-12, atol=1e-13,
                    dense_output=True)
    e = np.array([_energy(sol.sol(t), p) for t in np.linspace(0, 0.7, 40)])
    e_ref = np.array([ref.compass_energy(sol.sol(t), p) for t in np.linspace(0, 0.7, 40)])
    scale = p["m_h"] * p["g"] * (p["a"] + p["b"])
    assert np.ptp(e) / scale < 1e-9
    # the module's closed-form energy agrees with the point-mass energy (up to a constant: none here)
    np.testing.assert_allclose(e_ref, e, atol=1e-8 * scale)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_compass_impact_conserves_angular_momentum(seed):
    rng = np.random.default_rng(seed)
    p = ref.compass_params({"m": rng.uniform(1, 8), "m_h": rng.uniform(2, 20), "a": rng.uniform(0.1, 0.7),
                            "b": rng.uniform(0.2, 0.7)})
    a1 = -rng.uniform(0.1, 0.4)
    a2 = rng.uniform(0.05, 0.45)  # asymmetric on purpose (step-down touchdowns)
    x_minus = np.array([a1, a2, -rng.uniform(0.5, 2.0), rng.uniform(-2.0, 2.0)])
    x_plus = ref.compass_impact(x_minus, p)
    l = p["a"] + p["b"]
    assert x_plus[0] == x_minus[1] and x_plus[1] == x_minus[0]

    # before: old stance foot at the origin; new contact point = old swing foot
    hip, r_old_stance, r_old_swing = _points(x_minus, p)
    contact = hip + l * _n(a2)
    v_hip, v_old_stance, v_old_swing = _velocities(x_minus, p)
    # after: stance foot at the contact point; the same points in space
    hip_p, r_new_stance, r_new_swing = _points(x_plus, p, foot=contact)
    np.testing.assert_allclose(hip_p, hip, atol=1e-14)
    np.testing.assert_allclose(r_new_stance, r_old_swing, atol=1e-14)
    np.testing.assert_allclose(r_new_swing, r_old_stance, atol=1e-14)
    vp_hip, vp_new_stance, vp_new_swing = _velocities(x_plus, p, foot=contact)

    m_h, m = p["m_h"], p["m"]
    h_before = (m_h * _cross(hip - contact, v_hip) + m * _cross(r_old_stance - contact, v_old_stance)
                + m * _cross(r_old_swing - contact, v_old_swing))
    h_after = (m_h * _cross(hip - contact, vp_hip) + m * _cross(r_new_stance - contact, vp_new_stance)
               + m * _cross(r_new_swing - contact, vp_new_swing))
    assert h_after == pytest.approx(h_before, rel=1e-9, abs=1e-9)
    # trailing leg (old stance = new swing) about the hip, absolute velocities
    t_before = m * _cross(r_old_stance - hip, v_old_stance)
    t_after = m * _cross(r_new_swing - hip, vp_new_swing)
    assert t_after == pytest.approx(t_before, rel=1e-9, abs=1e-9)
    # a plastic impact loses kinetic energy (the configuration does not change)
    kin_before = sum(0.5 * mm * v @ v for mm, v in zip(_masses(p), (v_hip, v_old_stance, v_old_swing)))
    kin_after = sum(0.5 * mm * v @ v for mm, v in zip(_masses(p), (vp_hip, vp_new_stance, vp_new_swing)))
    assert kin_after < kin_before


# ----------------------------------------------------------------- failures and step-down


def test_failure_statuses():
    assert ref.simplest_step([0.2, 0.05, 0.0], GAMMA)[1]["status"] == "stalled"   # rotating backwards
    assert ref.simplest_step([0.2, -0.05, -0.05], GAMMA)[1]["status"] == "stalled"  # cannot vault
    assert ref.simplest_step([1.1, -0.5, -0.5], GAMMA)[1]["status"] == "fell"     # hip below l/2
    v, info = ref.compass_step([np.nan, -1.0, -0.3])
    assert info["status"] == "nonfinite" and np.all(np.isnan(v))


def test_step_down_simplest(simplest_fp):
    ok, info = ref.step_down_trial(0.0, GAMMA, n_steps=3, v_star=simplest_fp.v)
    assert ok and np.max(np.abs(info["v_final"] - simplest_fp.v)) < 1e-10
    hm, details = ref.h_max({"gamma": GAMMA}, dh=0.0005, K=6, n_steps=10, v_star=simplest_fp.v,
                            return_details=True)
    # At h = 0.001 the swing leg still trails the stance leg at mid-stance of the
    # first step after the drop (alpha_2 = -0.024 there): a scuff, which the foot
    # height alone (a dip shorter than a solver step) would have let through.
    assert hm == pytest.approx(0.0005)
    h, ok, info = details[-1]
    assert h == pytest.approx(0.001) and not ok and info["status"] == "scuffing" and info["failed_step"] == 1


def test_step_down_compass_small_drop(compass_fp):
    ok, info = ref.step_down_trial(0.005, model="compass", n_steps=10, v_star=compass_fp.v)
    assert ok
    # the gait is recovered (lambda_max ~ 0.58 per step)
    assert np.max(np.abs(info["v_final"] - compass_fp.v)) < 1e-3


def test_scuffing_rule_garcia(simplest_fp):
    """After a 1.5e-3 drop the swing foot reaches the ground at the stance foot after
    mid-stance: a failure by the engine's rule, ignored by Garcia's (scuffing="ignore")."""
    p = {"gamma": GAMMA}
    x, info = ref.simplest_step_full(ref.v_to_state(simplest_fp.v), GAMMA, drop=0.0015 * math.cos(GAMMA))
    assert info["status"] == "ok"
    _, strict = ref.simplest_step_full(x, GAMMA)
    assert strict["status"] == "scuffing"
    _, garcia = ref.simplest_step_full(x, GAMMA, scuffing="ignore")
    assert garcia["status"] == "ok" and garcia["scuffed_after_midstance"]
    a1, a2, w1, w2 = garcia["x_minus"]
    assert a1 + a2 == pytest.approx(0.0, abs=1e-12)
    # The strike is the foot coming down ahead (Garcia's phi = 2 theta), not its rise back
    # out of the ground just after the legs pass (step length 0.045, foot rising).
    assert -math.sin(a1) * w1 + math.sin(a2) * w2 < 0 and garcia["step_length"] > 0.4
    assert ref.step_down_trial(0.0015, p, v_star=simplest_fp.v, scuffing="ignore")[0]


# ----------------------------------------------------------------- the flat-foot reference
def test_flatfoot_reference_mass_matrix_closed_form_is_the_point_sum():
    """The vector field's closed-form double-pendulum mass matrix and forces equal
    the plain sum over point masses, ``sum m J^T J`` and ``sum J^T m (g - Jdot qd)``,
    with inertias and a slope switched on."""
    from tests.reference.flatfoot import kinematics as kin
    from tests.reference.flatfoot import params

    p = params(rho_t=0.3, rho_s=0.25, gamma=0.05, c_t=0.4, m_f=0.02)
    rng = np.random.default_rng(7)
    for _ in range(5):
        q, qd = rng.normal(size=6), rng.normal(size=6)
        mass, force = kin.mass_matrix_and_forces(q, qd, p)
        summed = sum(m * (kin.leg_point(q, leg, a, b)[1].T @ (kin.gravity(p) - kin.leg_point_convective(q, qd, leg, a, b)))
                     for m, leg, a, b in kin.point_masses(p))  # fmt: skip
        np.testing.assert_allclose(mass, kin.mass_matrix(q, p), atol=1e-14)
        np.testing.assert_allclose(force, summed, atol=1e-13)


@pytest.mark.parametrize("option", [{}, {"ankle_push": 1e-4}, {"k_hip": 0.002, "hip_double_support": 0.9}, {"heel_brake": 1e-4},
                                    {"swing_torque": 1e-4}, {"ankle_rest": 0.003}, {"ankle_reset": 0.05}],
                         ids=["nominal", "ankle_push", "hip_double_support", "heel_brake", "swing_torque", "ankle_rest",
                              "ankle_reset"])
def test_flatfoot_reference_conserves_energy_minus_actuator_work_in_every_phase(option):
    """Along the step from the nominal gait, energy (kinetic, gravity, springs)
    minus the actuators' work is constant within each phase, and the active
    constraints keep holding: the hand-derived forces are those of the potentials
    (docs/model.md, "Forces"), the push-off, heel-brake and swing torques', the hip's
    double-support share and the ankle's rest angles (constant, or set at toe-strike) included."""
    from tests.reference import flatfoot as ff
    from tests.reference.flatfoot.constraints import ACTIVE, constraint_terms
    from tests.reference.flatfoot.dynamics import energy, vector_field
    from tests.reference.flatfoot.forces import actuator_work
    from tests.reference.flatfoot.resets import on_event
    from tests.reference.flatfoot.step import solve_phase

    p = ff.params(**option)
    y, phase, ctx = ff.section_to_state(ff.PAPER_GUESS, p)
    t, visited = 0.0, []
    while True:
        status, name, t_ev, y_ev, _ = solve_phase(t, y, p, phase, ctx)
        assert status is None
        sol = solve_ivp(lambda _, x: vector_field(x, p, phase, ctx), (t, t_ev), y, method="DOP853",
                        rtol=1e-12, atol=1e-12, t_eval=np.linspace(t, t_ev, 12))  # fmt: skip
        balance = [energy(x, p, phase, ctx) - actuator_work(y[:6], x[:6], p, phase, ctx) for x in sol.y.T]
        assert np.ptp(balance) < 1e-10, (phase, np.ptp(balance))
        rows = list(ACTIVE[phase])
        assert np.max(np.abs(constraint_terms(sol.y[:6, -1], sol.y[6:, -1], p, ctx)[0][rows])) < 1e-10
        visited.append(phase)
        tr = on_event(name, t_ev, y_ev, p, phase, ctx)
        assert tr.status is None
        if tr.done:
            break
        t, y, phase, ctx = t_ev, tr.y, tr.phase, tr.ctx
    assert visited == [0, 1, 2, 3, 4]
