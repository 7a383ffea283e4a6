"""Issue 14: the documented gaits of the flat-foot walker that walk with no floor
penetration (docs/model.md, "The hip-spring gait", "The push-off gait", "The
swing-hip gait" and "The shoe gait", the gait of the defaults), each found by
Newton from its stored guess,
and each step held against the SciPy reference walker (tests/reference/flatfoot),
which has the hip spring, the push-off, heel-brake and swing torques and the
hip's share in double support written again by hand."""

from __future__ import annotations

import functools

import numpy as np
import pytest

from jaxwalk.models.flatfoot import clearance as cl
from jaxwalk.models.flatfoot import events as ev
from jaxwalk.models.flatfoot import phases as ph
from jaxwalk.models.flatfoot.model import HIP_SPRING_PARAMS, PUSH_OFF_PARAMS, SHOE_PARAMS, SWING_HIP_PARAMS
from jaxwalk.status import Status
from tests.flatfoot_program import MODEL, newton, step_fn, tangent_fn, with_params

#: Each documented gait's parameters and its lambda_max as docs/model.md gives it.
DOCUMENTED_GAITS = {
    "hip_spring": (HIP_SPRING_PARAMS, 0.694),
    "push_off": (PUSH_OFF_PARAMS, 0.813),
    "swing_hip": (SWING_HIP_PARAMS, 0.750),
    "shoe": (SHOE_PARAMS, 0.554),
}


@functools.cache
def _gait(name):
    """``(params, v, J, residual, documented lambda_max)`` of a documented gait, Newton from its stored guess."""
    changes, lambda_max = DOCUMENTED_GAITS[name]
    p = with_params(MODEL.default_params(), **changes)
    return (p, *newton(p, step_fn, tangent_fn), lambda_max)


@pytest.fixture(scope="module", params=list(DOCUMENTED_GAITS))
def documented(request):
    return _gait(request.param)


def test_documented_gaits_are_stable_with_no_floor_penetration_tolerated(documented):
    """Issue 14: stable period-1 gaits with ``scuff_tol = 0``, the swing foot's
    tracked lowest point above the ground, the seven phases in the paper's order."""
    p, v, jac, residual, documented_lambda_max = documented
    assert float(p["scuff_tol"]) == 0.0 and residual < 1e-9
    lambda_max = float(np.max(np.abs(np.linalg.eigvals(np.asarray(jac)))))
    assert lambda_max < 1.0 and abs(lambda_max - documented_lambda_max) < 1e-3
    _, res = step_fn(v, p)
    assert int(res.status) == Status.OK and float(cl.min_clearance(res.ctx)) > 0.0
    names = [ev.GUARD_NAMES[c] for c in ph.decode_history(np.asarray(res.ctx))]
    assert names == ["unlock", "knee_flex", "toe_off", "knee_strike", "heel_strike", "toe_strike"]




def test_push_off_gait_walks_at_a_human_froude_number():
    """Issue 14, item 3: from its documented guess Newton finds the push-off gait,
    its Froude number (speed^2 / (g L)) in the human range 0.1-0.25 and its double
    support (push-off and heel pivot) a human-like fraction of the step."""
    p, v, _, residual, _ = _gait("push_off")
    _, res = step_fn(v, p)
    assert residual < 1e-9 and int(res.status) == Status.OK
    froude = (float(res.length) / float(res.time)) ** 2  # g = L = 1
    assert 0.1 <= froude <= 0.25, froude
    ctx, period = np.asarray(res.ctx), float(res.time)
    double_support = (ctx[ph.C["t_toe_off"]] + period - ctx[ph.C["t_heel_strike"]]) / period
    assert 0.15 < double_support < 0.4, double_support


def test_documented_step_matches_the_independent_scipy_walker(documented):
    """The hip spring and the push-off torque written again in the SciPy reference
    (forces, the toe's ground reaction and the actuators' work by hand): the same
    step from each documented gait (measured 1e-9 apart in ``v_next`` from the
    hip-spring gait, 1.1e-9 in the heel-strike time), the same events in the same
    order, the same actuator work."""
    from tests.reference import flatfoot as ref

    p, v, _, _, _ = documented
    v1, res = step_fn(v, p)
    v1_ref, info = ref.step_map(np.asarray(v), {k: float(x) for k, x in p.items()})
    assert info["status"] == "ok"
    np.testing.assert_allclose(v1_ref, np.asarray(v1), rtol=0.0, atol=1e-8)
    assert abs(info["time"] - float(res.time)) < 1e-7
    assert abs(info["work"] - float(res.work)) < 1e-8
    assert abs(info["min_clearance"] - float(cl.min_clearance(res.ctx))) < 1e-8
    names = [ev.GUARD_NAMES[c] for c in ph.decode_history(np.asarray(res.ctx))]
    assert [name for name, _ in info["events"]] == names
    times = dict(info["events"])
    for name in ("toe_off", "knee_strike", "heel_strike"):
        assert abs(times[name] - float(res.ctx[ph.C["t_" + name]])) < 1e-7, name


@pytest.mark.parametrize("changes", [{"ankle_rest": 0.1, "k": 0.05}, {"ankle_reset": 1.0, "k": 0.1},
                                     {"ankle_reset": 1.0, "ankle_rest": 0.3, "k": 0.05}],
                         ids=["ankle_rest", "ankle_reset", "reset_work"])
def test_ankle_rest_angles_step_matches_the_independent_scipy_walker(changes):
    """The ankle springs' rest angles written again in the SciPy reference: the
    same step from the shoe gait, at a stiffer ankle, with the standing feet's
    springs relaxed 0.1 rad plantarflexed (``ankle_rest``), at the shank
    angles of the step's toe-strike (``ankle_reset``), or 0.3 rad from them, which
    winds the landing spring up at toe-strike: the same work, that included
    (the other two wind nothing up)."""
    p, v, _, _, _ = _gait("shoe")
    p = with_params(p, **changes)
    v1, res, info = _step_against_the_reference(v, p)
    wound = "ankle_rest" in changes and "ankle_reset" in changes  # the landing spring turned past slack
    assert info["reset_work"] > 1e-4 if wound else info["reset_work"] == 0.0, info["reset_work"]
    # The rest angles the step hands on (swap_legs) are those the next step's
    # section point gives (section_to_state): the same walk whether or not it
    # passes through the section.
    _, _, ctx_next = MODEL.section_to_state(v1, p)
    for name in ("shank_1_strike", "shank_2_strike"):
        assert abs(float(res.ctx[ph.C[name]]) - float(ctx_next[ph.C[name]])) < 1e-9, name


def test_swing_torque_step_matches_the_independent_scipy_walker():
    """The swing torque written again in the SciPy reference (the hip torque in
    phase swing, and its work): the same step from the shoe gait with and
    without ``swing_torque`` 0.02, the same events, and the same step work,
    which with the torque is larger (it pushes the swing thigh forward)."""
    p, v, _, _, _ = _gait("shoe")
    works = [float(_step_against_the_reference(v, with_params(p, swing_torque=value))[1].work) for value in (0.0, 0.02)]
    assert works[1] - works[0] > 1e-3, works


def _step_against_the_reference(v, p):
    """``(v_next, result, reference info)`` of one step from ``v``, both walkers
    completing it with the same next point (1e-8), time, work and events."""
    from tests.reference import flatfoot as ref

    v1, res = step_fn(v, p)
    assert int(res.status) == Status.OK
    v1_ref, info = ref.step_map(np.asarray(v), {k: float(x) for k, x in p.items()})
    assert info["status"] == "ok"
    np.testing.assert_allclose(v1_ref, np.asarray(v1), rtol=0.0, atol=1e-8)
    assert abs(info["time"] - float(res.time)) < 1e-7 and abs(info["work"] - float(res.work)) < 1e-8
    names = [ev.GUARD_NAMES[c] for c in ph.decode_history(np.asarray(res.ctx))]
    assert [name for name, _ in info["events"]] == names
    return v1, res, info


def test_the_stance_foot_rolls_at_the_same_instant_in_the_independent_scipy_walker():
    """The flat stance foot's centre-of-pressure limit (``foot_roll``) written again
    in the SciPy reference (moment balance of the massless foot about its ankle,
    with the spring's rest angle): from the shoe gait with a stiff ankle whose
    springs start 0.2 rad from relaxed, the stance foot's centre of pressure
    reaches its toe in heel pivot, in both walkers, at the same time."""
    from tests.reference import flatfoot as ref

    p, v, _, _, _ = _gait("shoe")
    p = with_params(p, ankle_reset=1.0, ankle_rest=0.2, k=0.1)
    _, res = step_fn(v, p)
    _, info = ref.step_map(np.asarray(v), {k: float(x) for k, x in p.items()})
    assert int(res.status) == Status.FOOT_ROLLING and info["status"] == "foot_rolling"
    assert int(res.phase) == ph.HEEL_PIVOT == info["phase"]
    assert abs(info["time"] - float(res.time)) < 1e-7, (info["time"], float(res.time))


def _friction_demand(v, p):
    """``(stance, heel, heel_start, cot_landing)``: the largest ``|T| / N`` of the stance
    foot over one step and of the landing heel in heel pivot, sampled on the SciPy
    reference walker's step from ``v`` (12 samples per phase, each phase's ends
    included); the heel's ``|T| / N`` at the start of heel pivot, and the cotangent
    of the foot's angle to the ground there."""
    from scipy.integrate import solve_ivp

    from tests.reference import flatfoot as ref
    from tests.reference.flatfoot.dynamics import accelerations, vector_field
    from tests.reference.flatfoot.forces import _pivot, reactions
    from tests.reference.flatfoot.params import HEEL_PIVOT
    from tests.reference.flatfoot.resets import on_event
    from tests.reference.flatfoot.step import solve_phase

    p = {k: float(x) for k, x in p.items()}
    y, phase, ctx = ref.section_to_state(np.asarray(v), p)
    t, stance, heel, start = 0.0, 0.0, 0.0, None
    while True:
        status, name, t_ev, y_ev, _ = solve_phase(t, y, p, phase, ctx)
        assert status is None
        sol = solve_ivp(lambda _, x: vector_field(x, p, phase, ctx), (t, t_ev), y, method="DOP853",
                        rtol=1e-10, atol=1e-10, t_eval=np.linspace(t, t_ev, 12))  # fmt: skip
        for x in sol.y.T:
            f_stance, _, f_heel = reactions(x[:6], accelerations(x, p, phase, ctx)[1], p, phase, ctx)
            stance = max(stance, abs(f_stance[0]) / f_stance[1])
            if phase == HEEL_PIVOT:
                heel = max(heel, abs(f_heel[0]) / f_heel[1])
                if start is None:
                    w = _pivot(x[:6], p, ctx, phase)[0]  # heel to ankle, along the foot
                    start = (abs(f_heel[0]) / f_heel[1], abs(w[0] / w[1]))
        tr = on_event(name, t_ev, y_ev, p, phase, ctx)
        assert tr.status is None
        if tr.done:
            return stance, heel, *start
        t, y, phase, ctx = t_ev, tr.y, tr.phase, tr.ctx


def test_swing_hip_gait_keeps_stance_foot_and_landing_heel_in_a_shoe_friction_cone():
    """docs/model.md, "The swing-hip gait": with half the hip's torque and spring in
    double support the stance foot's |T|/N falls from 1.11 (push-off gait) to 0.28,
    and with the heel brake the landing heel's from about 2.8 (the cotangent of
    its landing angle: without a torque at the ankle its force lies along the
    foot) to 0.24, both inside a shoe's friction cone (mu about 0.8)."""
    push_off = _friction_demand(_gait("push_off")[1], _gait("push_off")[0])
    p, v = _gait("swing_hip")[:2]
    stance, heel, _, _ = _friction_demand(v, p)
    _, heel_without_brake, at_landing, cot_landing = _friction_demand(v, with_params(p, heel_brake=0.0))
    assert push_off[0] > 1.0, push_off
    assert stance < 0.35 and heel < 0.35, (stance, heel)
    assert heel_without_brake > 2.0, heel_without_brake
    # Without a torque at the ankle the massless foot is a two-force member at
    # landing: its ground force lies along it, heel to ankle.
    assert at_landing == pytest.approx(cot_landing, rel=1e-8)


def test_shoe_gait_walks_with_a_shoe_friction_at_a_human_step_and_froude_number():
    """docs/model.md, "The shoe gait": with mu = 0.8 checked at every contact (the
    stance foot, the landing heel, the impacts; the toe leaves at its cone's edge)
    a stable gait with a human Froude number (0.1-0.25) and a step near a human's
    (0.65 L); at mu = 0.7 the same walker still walks."""
    p, v, _, residual, _ = _gait("shoe")
    assert float(p["mu"]) == 0.8 and float(p["scuff_tol"]) == 0.0
    _, res = step_fn(v, p)
    assert residual < 1e-9 and int(res.status) == Status.OK
    froude, step = (float(res.length) / float(res.time)) ** 2, float(res.length)
    assert 0.1 <= froude <= 0.25 and step > 0.6, (froude, step)
    _, res = step_fn(v, with_params(p, mu=0.7))
    assert int(res.status) == Status.OK
