"""The heel-rise variant of the SciPy reference flat-foot walker (``heel_rise=True``).

SciPy only, no JAX: tests/reference/flatfoot with docs/model.md's "The heel-rise
walker" (phases 5-7, the stance foot on its toe; guards ``heel_rise`` and
``heel_drop``; section ``(psi, psi_2, psi_dot)``). Checked here: a step without
heel rise is the base walker's step; along steps with a heel rise (and one with a
heel drop) energy minus the actuators' work is constant in every phase, the
active constraints hold, heel rise changes no velocity and no energy, heel drop
loses energy and leaves the foot flat, and toe-strike's toe-1 impulse pushes;
ankle 1's acceleration on entering a twin has the sign docs/model.md derives.
Each test takes a few seconds.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.integrate import solve_ivp

from tests.reference import flatfoot as ff
from tests.reference.flatfoot import constraints as con
from tests.reference.flatfoot import kinematics as kin
from tests.reference.flatfoot.dynamics import energy, impact, vector_field
from tests.reference.flatfoot.forces import actuator_work, reset_work, stance_toe
from tests.reference.flatfoot.guards import G, guard_values
from tests.reference.flatfoot.newton import heel_rise_point
from tests.reference.flatfoot.params import (
    HEEL_PIVOT, HEEL_PIVOT_HEEL_UP, LOCKED_SWING, LOCKED_SWING_HEEL_UP, N_Q, PUSH_OFF, SHANK_RELEASE, SWING,
    SWING_HEEL_UP, TWIN, foot_arms,
)  # fmt: skip
from tests.reference.flatfoot.resets import ankle_1_lift, on_event
from tests.reference.flatfoot.step import section_to_state, solve_phase, state_to_section

#: The shoe walker's options over the paper's walker (docs/model.md, "The shoe gait") and its gait.
SHOE = dict(P=0.045, k_hip=0.12, ankle_push=0.09, heel_brake=0.01, hip_double_support=0.5, swing_dorsi=0.1,
            knee_gate=1, scuff_tol=0, mu=0.8)  # fmt: skip
SHOE_V = (0.324519973953, -0.373398980250)
#: A stiffer ankle relaxed at each toe-strike: the base walker's step from the shoe gait
#: ends ``foot_rolling`` onto the stance toe in heel pivot; the variant's heel rises there.
STIFF = dict(SHOE, ankle_reset=1.0, k=0.15)
#: A step whose heel rises in swing, drops at knee-strike and rises again (found by a random scan).
DROP = dict(SHOE, P=0.0748, ankle_reset=1.0, k=0.2139)
DROP_V = (0.26713, -0.26713, -0.44476)


def _audit(v, p):
    """Walk one variant step phase by phase; per phase ``(phase, name, y0, y_ev, tr, balance, residual)``
    with ``balance`` the spread of energy minus actuator work (M g L) on 12 points of a tighter
    (1e-12) integration and ``residual`` the largest active constraint at its end (L)."""
    y, phase, ctx = section_to_state(v, p, heel_rise=True)
    t, out = 0.0, []
    for _ in range(20):
        status, name, t_ev, y_ev, _ = solve_phase(t, y, p, phase, ctx)
        assert status is None
        sol = solve_ivp(lambda _, x: vector_field(x, p, phase, ctx), (t, t_ev), y, method="DOP853",
                        rtol=1e-12, atol=1e-12, t_eval=np.linspace(t, t_ev, 12))  # fmt: skip
        balance = np.ptp([energy(x, p, phase, ctx) - actuator_work(y[:N_Q], x[:N_Q], p, phase, ctx) for x in sol.y.T])
        rows = list(con.ACTIVE[phase])
        residual = np.max(np.abs(con.constraint_terms(sol.y[:N_Q, -1], sol.y[N_Q:, -1], p, ctx)[0][rows]))
        tr = on_event(name, t_ev, y_ev, p, phase, ctx)
        out.append((phase, name, ctx, y_ev, tr, balance, residual))
        assert tr.status is None, (name, tr.status)
        if tr.done:
            return out
        t, y, phase, ctx = t_ev, tr.y, tr.phase, tr.ctx
    raise AssertionError("no toe-strike in 20 phases")


def _check_energy_and_events(records, p):
    """The checks common to every variant step: energy balance and constraints in each
    phase, heel rise without a jump, heel drop inelastic onto a flat foot."""
    for phase, name, ctx, y_ev, tr, balance, residual in records:
        assert balance < 1e-8, (phase, balance)
        assert residual < 1e-9, (phase, residual)
        e_before = energy(y_ev, p, phase, ctx)
        if name == "heel_rise":
            assert tr.phase == TWIN[phase] and np.array_equal(tr.y, y_ev)  # no impact: nothing changes
            assert abs(energy(tr.y, p, tr.phase, tr.ctx) - e_before) < 1e-9
        if name == "heel_drop":
            assert energy(tr.y, p, tr.phase, tr.ctx) < e_before - 1e-6  # an inelastic impact loses energy
            xi, sigma, _ = con.constraint_terms(tr.y[:N_Q], tr.y[N_Q:], p, tr.ctx)
            rows = list(con.ACTIVE[tr.phase])  # ankle 1 pinned again: flat foot, at rest
            assert np.max(np.abs(xi[rows])) < 1e-9 and np.max(np.abs(sigma[rows] @ tr.y[N_Q:])) < 1e-12
            _, imp = impact(y_ev, p, ctx, rows)
            assert imp[con.ANKLE_1_Y] > 0.0  # the stance foot's impulse pushes


def test_flat_step_is_the_base_step():
    """From ``psi_2 = -psi`` with no heel rise in the step (the paper's walker), the
    variant's step is the base walker's: ``(psi', psi_dot')`` to 1e-9 and ``psi_2' = -psi'``."""
    v_base, info_base = ff.step_map(ff.PAPER_GUESS, ff.params())
    v, info = ff.step_map(heel_rise_point(ff.PAPER_GUESS), ff.params(), heel_rise=True)
    assert info["status"] == info_base["status"] == "ok"
    np.testing.assert_allclose(v[[0, 2]], v_base, rtol=0, atol=1e-9)
    assert abs(v[1] + v[0]) < 1e-9
    assert [e[0] for e in info["events"]] == [e[0] for e in info_base["events"]]
    np.testing.assert_allclose([e[1] for e in info["events"]], [e[1] for e in info_base["events"]], atol=1e-9)
    assert abs(info["work"] - info_base["work"]) < 1e-12 and abs(info["length"] - info_base["length"]) < 1e-9


def test_section_point_with_the_trailing_heel_up():
    """``(psi, psi_2, psi_dot)`` with ``psi_2 < -psi``: knees locked, ankle 1 at the origin,
    ankle 2 above the ground on its toe circle, the five push-off rows' velocities zero,
    and ``state_to_section`` reads the point back."""
    p = ff.params(**STIFF)
    v = np.array([0.2, -0.23, -0.25])
    y, phase, ctx = section_to_state(v, p, heel_rise=True)
    assert phase == PUSH_OFF and ctx["heel_rise"]
    np.testing.assert_allclose(state_to_section(y, p, heel_rise=True), v, rtol=0, atol=1e-15)
    xi, sigma, _ = con.constraint_terms(y[:N_Q], y[N_Q:], p, ctx)
    rows = [con.ANKLE_1_X, con.ANKLE_1_Y, con.KNEE_1, con.KNEE_2, con.TOE_2]
    assert np.max(np.abs(xi[rows])) < 1e-15 and np.max(np.abs(sigma[rows] @ y[N_Q:])) < 1e-15
    a2, _ = kin.ankle(y[:N_Q], p, 2)
    assert a2[1] > 0.005 and ctx["y_toe_2"] == 0.0 and ctx["x_toe_2"] > a2[0]


def test_heel_rise_step_with_a_stiff_ankle():
    """The shoe walker with ``ankle_reset = 1``, ``k = 0.15``: the base walker's step ends
    ``foot_rolling`` in heel pivot; the variant's heel rises at that instant (the same
    guard) and the step ends at toe-strike with the stance heel up (``psi_2' < -psi'``). Energy balance in every
    phase, no jump at heel rise, the toe-1 impulse pushes, and the raised spring's
    reset is taken from its ankle angle, so it winds nothing up."""
    p = ff.params(**STIFF)
    _, base = ff.step_map(SHOE_V, p)
    assert base["status"] == "foot_rolling" and base["events"][-1][0] == "heel_strike"
    records = _audit(heel_rise_point(SHOE_V), p)
    assert abs(records[-1][4].ctx["events"][-2][1] - base["time"]) < 1e-9  # heel_rise where the base rolls
    assert [r[0] for r in records] == [PUSH_OFF, SHANK_RELEASE, SWING, LOCKED_SWING, HEEL_PIVOT, HEEL_PIVOT_HEEL_UP]
    assert [r[1] for r in records][-2:] == ["heel_rise", "toe_strike"]
    _check_energy_and_events(records, p)
    phase, _, ctx, y_ev, tr, _, _ = records[-1]
    _, imp = impact(y_ev, p, ctx, con.TOE_STRIKE_ROWS)
    a1, _ = kin.ankle(y_ev[:N_Q], p, 1)
    toe_1 = con.anchors(p, ctx)["toe_1"]
    assert a1[1] > 1e-5 and imp[con.TOE_1] * (a1 - toe_1)[1] / math.dist(a1, toe_1) > 0.0
    # ``ankle_reset = 1``: the old stance spring, deflected on its toe, is relaxed at its
    # ankle angle (shank less the raised foot's angle) as the trailing toe's, so
    # resetting it winds nothing up (with the shank's angle alone it would be k/2 phi_1^2).
    w, _, _ = stance_toe(y_ev[:N_Q], p, ctx)
    assert abs(math.atan2(w[1], w[0])) > 1e-5
    assert abs(reset_work(y_ev[:N_Q], ctx, tr.y[:N_Q], tr.ctx, p, phase)) < 1e-15
    v_next, info = ff.step_map(heel_rise_point(SHOE_V), p, heel_rise=True)
    assert info["status"] == "ok" and v_next[1] + v_next[0] < -1e-4
    assert abs(info["reset_work"]) < 1e-12


def test_heel_drop_step():
    """A step whose heel rises in swing and drops at knee-strike (then rises again): every
    continuous phase, the twins' included, balances energy and actuator work; heel drop is
    an inelastic impact onto ankle 1's pin, its impulse pushing."""
    p = ff.params(**DROP)
    records = _audit(DROP_V, p)
    assert [r[0] for r in records] == [PUSH_OFF, SHANK_RELEASE, SWING, SWING_HEEL_UP, LOCKED_SWING_HEEL_UP,
                                       LOCKED_SWING, LOCKED_SWING_HEEL_UP, HEEL_PIVOT_HEEL_UP]  # fmt: skip
    names = ["heel_rise", "knee_strike", "heel_drop", "heel_rise", "heel_strike", "toe_strike"]
    assert [r[1] for r in records][2:] == names
    _check_energy_and_events(records, p)


def test_the_heel_always_rises_after_a_heel_rise():
    """docs/model.md's argument for no entry check: the twin is the flat phase with the
    pin's normal force ``N`` replaced by the toe's ``tau / a_t``, so ankle 1's acceleration
    there is ``-c (a_t N - tau)`` with one ``c > 0`` along the swing: zero at the heel rise
    the guard finds, positive once the guard is negative. (Forced where the guard is
    positive, the ankle would accelerate down: that is why the guard, not the
    acceleration, decides.)"""
    p = ff.params(**DROP)
    records = _audit(DROP_V, p)
    phase, name, ctx, y_rise, _, _, _ = records[2]
    assert phase == SWING and name == "heel_rise"
    y0 = records[1][4].y  # the swing's start
    sol = solve_ivp(lambda _, x: vector_field(x, p, phase, ctx), (0.0, 1.0), y0, method="DOP853", rtol=1e-10,
                    atol=1e-10, dense_output=True)  # fmt: skip
    guard = lambda y: guard_values(0.0, y, p, phase, ctx)[G["heel_rise"]]
    ratios = [ankle_1_lift(sol.sol(s), p, TWIN[phase], ctx) / guard(sol.sol(s)) for s in np.linspace(0.0, 0.9, 5)]
    assert max(ratios) < 0.0 and np.ptp(ratios) < 0.5 * abs(np.mean(ratios)), ratios
    assert abs(ankle_1_lift(y_rise, p, TWIN[phase], ctx)) < 1e-8
    early = sol.sol(0.5)
    assert guard(early) > 0.01 and ankle_1_lift(early, p, TWIN[phase], ctx) < 0.0
    assert on_event("heel_rise", 0.0, y_rise, p, phase, ctx).status is None


def test_base_toe_1_impulse_is_zero_on_a_flat_foot():
    """The toe-1 impulse check (both walkers): in the base walker's toe-strike foot 1 is flat,
    so that impulse is along the ground and its normal part vanishes (the check cannot fire)."""
    p = ff.params()
    y, phase, ctx = section_to_state(ff.PAPER_GUESS, p)
    t = 0.0
    while True:
        _, name, t_ev, y_ev, _ = solve_phase(t, y, p, phase, ctx)
        if name == "toe_strike":
            break
        tr = on_event(name, t_ev, y_ev, p, phase, ctx)
        t, y, phase, ctx = t_ev, tr.y, tr.phase, tr.ctx
    _, imp = impact(y_ev, p, ctx, con.TOE_STRIKE_ROWS)
    a1, _ = kin.ankle(y_ev[:N_Q], p, 1)
    normal = imp[con.TOE_1] * (a1 - con.anchors(p, ctx)["toe_1"])[1] / foot_arms(p)[1]
    assert abs(imp[con.TOE_1]) > 1e-4 and abs(normal) < 1e-9 * np.max(np.abs(imp))


def test_section_jacobian_stays_inside_the_section_and_is_exact_for_a_cubic_map():
    """The reference's Newton on the variant differences inside its section
    (``newton.section_jacobian``). On a cubic stand-in map that fails outside the
    section (``psi_2 + psi > 0``, as a step from there scuffs), at a point on the
    boundary: no difference steps out, the plain differences are off by O(h^2), and
    the Richardson step of ``fixed_point`` (the same formulas at h and 2h) is exact,
    as it must be where the fourth derivatives vanish."""
    from tests.reference.fixed_points import _extrapolated
    from tests.reference.flatfoot.newton import section_jacobian

    a = np.array([[0.3, -0.2, 0.5], [0.1, 0.4, -0.3], [-0.6, 0.2, 0.7]])
    c = np.array([2.0, -1.5, 3.0])

    def step(v):
        if v[0] + v[1] > 1e-12:
            return np.full(3, np.nan), {"status": "scuffing"}
        return a @ v + c * v**3 + 0.5 * np.roll(v, 1) ** 3, {"status": "ok"}

    v = np.array([0.3, -0.3, -0.37])
    exact = a + np.diag(3.0 * c * v**2) + np.roll(np.diag(1.5 * v**2), 1, axis=0)
    h = 1e-2
    plain, bad = section_jacobian(step, v, h)
    assert bad is None and 1e-6 < np.max(np.abs(plain - exact)) < 1e-3
    extrapolated, bad = _extrapolated(section_jacobian, step, v, h, (), True)
    assert bad is None and np.max(np.abs(extrapolated - exact)) < 1e-12
