"""The heel-rise walker (``flatfoot_heel_rise``) against the base walker and physics.

Where the stance heel never rises, the variant's step is the base walker's,
with the third section coordinate ``psi_2 = -psi`` carried along; where it
rises (the shoe walker with ``ankle_reset = 1`` and ``k = 0.2``, which the base
walker cannot walk: its stance foot rolls onto its toe in heel pivot), the
step conserves energy less actuator work in every phase, the heel rise
changes neither velocity nor energy, ankle 1 rises off the ground on its toe
circle, the toe pushes, and the step map's forward derivative matches central
differences. Programs: the variant's step with a forward tangent (one), its
recorder (one), and the base walker's shared step program
(tests/flatfoot_program.py).
"""

from __future__ import annotations

import functools
import os

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxwalk import compiling, event_log
from jaxwalk.models import get_model
from jaxwalk.models.flatfoot import events as ev
from jaxwalk.models.flatfoot import geometry as geo
from jaxwalk.models.flatfoot import heel_rise as hr
from jaxwalk.models.flatfoot.clearance import min_clearance
from jaxwalk.models.flatfoot import phases as ph
from jaxwalk.models.flatfoot.model import SHOE_PARAMS
from jaxwalk.simulate import BEFORE_EVENT, record_walk
from jaxwalk.status import Status
from jaxwalk.step import step_map
from tests.flatfoot_program import step_fn as base_step_fn
from tests.flatfoot_program import energy_drifts, walk_phases, with_params

MODEL = get_model("flatfoot_heel_rise")
BASE = get_model("flatfoot")
#: Where the variant's stance heel rises in heel pivot (the base walker ends
#: that step ``foot_rolling`` onto the stance toe; docs/model.md).
RISING = {"ankle_reset": 1.0, "k": 0.2}


@functools.partial(compiling.jit, model=MODEL)
def _step(v, dv, params):
    """``(v, dv, params) -> (v_next, StepResult, dv_next)`` of the variant on level ground."""
    (v1, res), (dv1, _) = jax.jvp(lambda v_: step_map(MODEL, v_, params), (v,), (dv,))
    return v1, res, dv1


_energy = jax.jit(MODEL.energy)
_reactions = jax.jit(MODEL.reactions)
_no_tangent = jnp.zeros(3, jnp.float64)


def _names(ctx):
    return [MODEL.guards[c] for c in ph.decode_history(np.asarray(ctx))]


@pytest.fixture(scope="module")
def rising():
    """``(params, v, walk)``: one recorded step of the shoe walker's guess with the stiff ankle."""
    params = with_params(MODEL.default_params(), **RISING)
    v = MODEL.initial_guess(params)
    y0, phase0, ctx0 = MODEL.section_to_state(v, params)
    return params, v, record_walk(MODEL, params, y0, phase0, ctx0, n_steps=1, dt=0.05)


def test_guard_codes_keep_the_base_walkers_and_fit_the_event_log():
    assert MODEL.guards[: ev.HEEL_EXTREMUM] == BASE.guards[: ev.HEEL_EXTREMUM]
    assert MODEL.guards[hr.HEEL_RISE] == "heel_rise" and MODEL.guards[hr.HEEL_DROP] == "heel_drop"
    assert max(hr.HEEL_RISE, hr.HEEL_DROP) < ph.HISTORY_BASE  # logged events must fit a base-16 digit
    assert [MODEL.guards[c] for c in ev.extremum_codes(MODEL)] == ["heel_extremum", "toe_extremum"]
    assert MODEL.phases[: len(BASE.phases)] == BASE.phases
    for twin in range(ph.SWING_HEEL_UP, ph.HEEL_PIVOT_HEEL_UP + 1):
        mask, flat = np.asarray(ph.PHASE_MASKS[twin]), np.asarray(ph.PHASE_MASKS[twin - ph.HEEL_UP_OFFSET])
        assert mask[ph.TOE_1] == 1 and mask[ph.ANKLE_1_X] == mask[ph.ANKLE_1_Y] == 0
        same = [r for r in range(ph.N_CONSTRAINTS) if r not in (ph.TOE_1, ph.ANKLE_1_X, ph.ANKLE_1_Y)]
        np.testing.assert_array_equal(mask[same], flat[same])


def test_without_a_heel_rise_the_step_is_the_base_walkers():
    """The shoe gait's guess at the defaults (the stance heel stays down):
    the same events, the same next point, and ``psi_2 = -psi`` after it."""
    params = MODEL.default_params()
    v = MODEL.initial_guess(params)
    assert float(v[1]) == -float(v[0])
    v1, res, _ = _step(v, _no_tangent, params)
    v1_base, res_base = base_step_fn(BASE.initial_guess(params), params)
    assert int(res.status) == int(res_base.status) == Status.OK
    assert "heel_rise" not in _names(res.ctx)
    assert _names(res.ctx) == [BASE.guards[c] for c in ph.decode_history(np.asarray(res_base.ctx))]
    np.testing.assert_allclose(np.asarray(v1)[[0, 2]], np.asarray(v1_base), rtol=0.0, atol=1e-12)
    # Both feet flat at toe-strike, to the event's location (measured 9.7e-11).
    assert abs(float(v1[1]) + float(v1[0])) < 1e-9
    assert abs(float(res.time) - float(res_base.time)) < 1e-12


def test_a_stiff_ankle_lifts_the_stance_heel_in_heel_pivot_and_the_step_completes(rising):
    params, v, walk = rising
    assert walk.status == Status.OK and walk.steps_completed == 1
    v1, res, _ = _step(v, _no_tangent, params)
    assert int(res.status) == Status.OK
    names = _names(res.ctx)
    assert names[-2:] == ["heel_rise", "toe_strike"], names
    phases = [states[0][1] for states in walk_phases(walk)]
    assert phases[-2] == ph.HEEL_PIVOT_HEEL_UP and phases[-3] == ph.HEEL_PIVOT
    # The new trailing foot leaves on its toe with its ankle above the ground.
    y_next, _, _ = MODEL.section_to_state(v1, params)
    assert float(geo.ankle(y_next[:6], params, 2)[1]) > 1e-4
    assert float(v1[1]) < -float(v1[0]) - 1e-3  # its chord turned further back than the stance leg's


def test_energy_less_actuator_work_is_constant_in_every_phase_and_the_heel_rise_is_smooth(rising):
    params, _, walk = rising
    drifts = energy_drifts(MODEL, params, walk)
    assert {name for name, _ in drifts} >= {"heel_pivot", "heel_pivot_heel_up"}
    assert max(abs(d) for _, d in drifts) < 1e-8, max(drifts, key=lambda nd: abs(nd[1]))
    (i,) = [i for i in np.flatnonzero(walk.sample_kind == BEFORE_EVENT) if MODEL.guards[walk.event_guard[i]] == "heel_rise"]
    before, after = (jnp.asarray(walk.y[j]) for j in (i, i + 1))
    np.testing.assert_allclose(np.asarray(after), np.asarray(before), rtol=0.0, atol=1e-15)  # no impact
    (phase_b, ctx_b), (phase_a, ctx_a) = ((int(walk.phase[j]), jnp.asarray(walk.ctx[j])) for j in (i, i + 1))
    e_before, e_after = float(_energy(before, params, phase_b, ctx_b)), float(_energy(after, params, phase_a, ctx_a))
    # The stance spring's potential is continuous at a flat foot. The walk's foot is
    # flat up to the pin's drift (ankle 1's height, held at the acceleration level:
    # 1.2e-12 at f188ef2 and 3.2e-12 at 1603160, before and after the closed-form
    # dynamics changed its rounding); the energy's jump is the spring's jump at
    # that height, and nothing else.
    height = float(geo.ankle(before[:6], params, 1)[1])
    assert abs(height) < 1e-11

    def spring_jump(lift):
        q = before[:6].at[geo.Y_H].add(lift)  # the whole walker moved normal to the slope
        return MODEL.spring_energy(q, params, phase_b, ctx_b) - MODEL.spring_energy(q, params, phase_a, ctx_a)

    assert abs(float(spring_jump(-height))) < 1e-15  # ankle 1 on the ground: no jump (3e-17 measured)
    predicted = float(jax.grad(spring_jump)(0.0)) * height
    assert abs((e_before - e_after) - predicted) < 1e-15  # measured 2e-17, for jumps of 7e-13 and 1.8e-12


def test_on_its_toe_the_stance_foot_rises_holds_its_constraints_and_pushes(rising):
    params, _, walk = rising
    (heel_up,) = [s for s in walk_phases(walk) if s[0][1] == ph.HEEL_PIVOT_HEEL_UP]
    heights = [float(geo.ankle(y[:6], params, 1)[1]) for y, _, _ in heel_up]
    assert heights[0] == pytest.approx(0.0, abs=1e-11)  # the pin's drift (1.2e-12 measured)
    assert all(b > a for a, b in zip(heights, heights[1:])) and heights[-1] > 1e-4  # 5.6e-4 measured
    toe_1 = np.asarray(ph.anchors(params, heel_up[0][2])[0])
    a_t = float(geo.foot_arms(params)[1])
    for y, phase, ctx in heel_up:
        mask = np.asarray(ph.PHASE_MASKS[phase])
        assert np.max(np.abs(np.asarray(MODEL.constraints(y[:6], params, ctx)) * mask)) < 1e-8
        assert abs(float(jnp.linalg.norm(geo.ankle(y[:6], params, 1) - toe_1)) - a_t) < 1e-8
        stance, cop, _, heel = _reactions(y, params, phase, ctx)
        assert float(stance[1]) > 0.0 and float(cop) == pytest.approx(a_t)
        assert float(heel[1]) > 0.0


def _walked(v, params):
    """``v_next`` of a step from ``v`` that completes, heel rise and toe-strike included."""
    v1, res, _ = _step(v, _no_tangent, params)
    assert int(res.status) == Status.OK and _names(res.ctx)[-2:] == ["heel_rise", "toe_strike"]
    return v1


def test_the_step_maps_derivative_matches_central_differences_across_the_heel_rise(rising):
    """At a start with the trailing foot raised 6e-4 leg lengths on its toe, so that
    every difference stays inside the section (the guess itself, both feet flat,
    lies on its boundary ``y_ankle_2 = 0``, below which a step ends ``SCUFFING``)."""
    params, v, _ = rising
    h = 1e-4  # the step is accurate to ~1e-10: differences of 1e-6 would be noise at 1e-4
    eye = jnp.eye(3)
    v = v - 2e-3 * eye[1]  # the trailing leg tilted further back: its ankle off the ground
    for start in [*(v + h * eye), *(v - h * eye)]:
        y, _, ctx = MODEL.section_to_state(start, params)
        assert float(geo.ankle(y[:6], params, 2)[1] - ctx[ph.C["y_toe_2"]]) > 1e-4
    for i in range(3):
        _, res, column = _step(v, eye[i], params)
        assert int(res.status) == Status.OK and "heel_rise" in _names(res.ctx)
        difference = (_walked(v + h * eye[i], params) - _walked(v - h * eye[i], params)) / (2 * h)
        # Measured: at most 4.4e-6, on the psi column (entries 2.5-3.3; 1.4e-5 at h = 2e-4: truncation).
        np.testing.assert_allclose(np.asarray(column), np.asarray(difference), rtol=1e-5, atol=1e-6)


def test_on_the_sections_boundary_the_derivative_is_the_one_from_inside(rising):
    """At the guess (both feet flat: on the boundary, where every heel-down gait's
    multipliers are computed) the forward derivative along ``psi`` with ``psi_2 + psi``
    kept (the trailing foot stays flat) matches central differences, and along
    ``psi_2`` the one-sided second-order difference from inside (lowering ``psi_2``
    raises the trailing ankle); a step from just outside scuffs."""
    params, v, _ = rising
    h = 1e-4
    along_flat, raise_ = jnp.array([1.0, -1.0, 0.0]), jnp.array([0.0, 1.0, 0.0])
    _, res, column = _step(v, along_flat, params)
    assert int(res.status) == Status.OK
    difference = (_walked(v + h * along_flat, params) - _walked(v - h * along_flat, params)) / (2 * h)
    np.testing.assert_allclose(np.asarray(column), np.asarray(difference), rtol=1e-5, atol=1e-6)
    _, _, column = _step(v, raise_, params)
    inside = [_walked(v - j * h * raise_, params) for j in range(3)]
    one_sided = (3.0 * inside[0] - 4.0 * inside[1] + inside[2]) / (2 * h)
    # The column is small (0.012-0.029); the difference is 6.9e-7 at h = 1e-4 and 1.2e-6
    # at 2e-4 (the steps' noise and the truncation of the same order): 3x the measured.
    np.testing.assert_allclose(np.asarray(column), np.asarray(one_sided), rtol=1e-5, atol=2e-6)
    assert int(_step(v + h * raise_, _no_tangent, params)[1].status) == Status.SCUFFING


#: The stance spring alone relaxed at toe-strike (``trailing_reset = 0``), a
#: stiffer ankle: the gait rises on the stance toe before the other foot is flat
#: (docs/model.md, "The heel-rise walker"); its fixed point to 5 digits, from
#: continuation in ``k`` from the shoe gait.
STANCE_RESET = {"ankle_reset": 1.0, "trailing_reset": 0.0, "k": 0.1}
STANCE_RESET_GUESS = (0.3, -0.30008, -0.32271)
#: The same with less push-off and hip torque: the stiffest stable gait at a
#: shoe's friction (sweeps/flatfoot_heel_rise_push_k.toml; its line's gait is
#: lost at k 0.2621 where the landing foot leaves its friction cone).
PUSH_K = {**STANCE_RESET, "k": 0.26, "ankle_push": 0.06, "P": 0.035}
PUSH_K_GUESS = (0.22104, -0.24624, -0.24743)


#: Newton's stopping test here. At these gaits the step map is noisy at a few
#: 1e-10 (the adaptive steps' and events' discrete choices: moving ``v`` by 1e-12
#: moves ``v_next - v`` by up to 3e-10, measured at PUSH_K at f188ef2 and
#: 1603160), so a test at 1e-10 would stop, or not, by chance; the sweeps stop
#: at 1e-8. The same stop serves STANCE_RESET, which had also passed at 1e-10.
NEWTON_TOL = 1e-9


def _fixed_point(params, guess):
    """Newton on the step's forward tangent (this module's one step program) from
    ``guess``: ``(v, StepResult, jacobian)``, asserted converged to :data:`NEWTON_TOL`."""
    v, eye = jnp.asarray(guess), jnp.eye(3)
    for _ in range(6):
        v1, res, _ = _step(v, _no_tangent, params)
        residual = v1 - v
        if float(jnp.max(jnp.abs(residual))) < NEWTON_TOL:
            break
        jac = jnp.stack([_step(v, eye[i], params)[2] for i in range(3)], axis=1)
        v = v - jnp.linalg.solve(jac - eye, residual)
    assert int(res.status) == Status.OK and float(jnp.max(jnp.abs(residual))) < NEWTON_TOL
    return v, res, jnp.stack([_step(v, eye[i], params)[2] for i in range(3)], axis=1)


@pytest.mark.parametrize(
    "changes, guess, raised, lam_search",
    [(STANCE_RESET, STANCE_RESET_GUESS, 0.0, 0.48145766), (PUSH_K, PUSH_K_GUESS, 5e-3, 0.68004128)],
    ids=["k_0.1", "k_0.26_less_push"],
)
def test_with_only_the_stance_spring_reset_a_stable_gait_ends_its_step_heel_up(changes, guess, raised, lam_search):
    """Newton (on the step's forward tangent) from the documented guess: a fixed
    point whose step ends heel up with the new trailing ankle above ``raised``
    leg lengths, stable, with the sweeps' searches' ``lambda_max`` (``lam_search``)."""
    params = with_params(MODEL.default_params(), **changes)
    v, res, jac = _fixed_point(params, guess)
    lam = float(np.max(np.abs(np.linalg.eigvals(np.asarray(jac)))))
    # The sweeps' searches (Newton to 1e-8; lam_search to 8 decimals) and this one
    # differ by 2.4e-9 and 2.7e-8 (measured at 1603160).
    assert abs(lam - lam_search) < 1e-6, lam
    assert _names(res.ctx)[-2:] == ["heel_rise", "toe_strike"]
    # The sequence code a sweep writes (event_sequence) says the same.
    assert event_log.decode(int(event_log.sequence_code(MODEL, res.ctx)), MODEL.guards) == tuple(_names(res.ctx))
    # Heel up at toe-strike: the new trailing ankle starts above the ground.
    y0, _, _ = MODEL.section_to_state(v, params)
    assert float(geo.ankle(y0[:6], params, 2)[1]) > raised  # measured 2.2e-5 (near grazing) and 5.8e-3


#: The shoe walker's options over the paper's walker (the reference's parameters start from the paper's).
_SHOE = {name: float(value) for name, value in SHOE_PARAMS.items()}


@pytest.mark.parametrize(
    "changes, start",
    [
        # The stance heel rises in heel pivot (the base walker rolls onto its toe there).
        ({"ankle_reset": 1.0, "k": 0.15}, (0.324519973953, -0.324519973953, -0.373398980250)),
        # The step that starts with the trailing foot raised: the next step of the one above.
        ({"ankle_reset": 1.0, "k": 0.15}, (0.18709204, -0.18734030, -0.22846435)),
        # Heel rise in swing, heel drop at knee-strike (an impact), heel rise again in locked swing.
        ({"P": 0.0748, "ankle_reset": 1.0, "k": 0.2139}, (0.26713, -0.26713, -0.44476)),
        # The same with a swing torque, which acts in swing_heel_up too.
        ({"P": 0.0748, "ankle_reset": 1.0, "k": 0.2139, "swing_torque": 0.002}, (0.26713, -0.26713, -0.44476)),
        # Only the stance spring relaxed at toe-strike: the heel-up gait of the test above.
        (STANCE_RESET, STANCE_RESET_GUESS),
        # Less push-off and hip torque: the stiffest locally stable gait at a shoe's friction.
        (PUSH_K, PUSH_K_GUESS),
    ],
    ids=["heel_pivot", "raised_start", "drop", "drop_swing_torque", "stance_reset", "push_k_0.26"],
)
def test_the_step_matches_the_independent_scipy_walker(changes, start):
    """The SciPy reference written again from docs/model.md (tests/reference/flatfoot,
    ``heel_rise=True``): the same events in the same order, the next point to 1e-8
    (measured 8e-10 and 7e-10 where the heel rises in heel pivot and drops), the step's
    time, its actuators' work (the springs' reset work included) and its minimum swing
    clearance to 1e-8."""
    from tests.reference import flatfoot as ref

    p_ref = ref.params(**{**_SHOE, **changes})
    params = with_params(MODEL.default_params(), **p_ref)
    v1, res, _ = _step(jnp.asarray(start), _no_tangent, params)
    v1_ref, info = ref.step_map(np.asarray(start), p_ref, heel_rise=True)
    assert int(res.status) == Status.OK and info["status"] == "ok"
    assert _names(res.ctx) == [name for name, _ in info["events"]]
    assert "heel_rise" in _names(res.ctx)
    np.testing.assert_allclose(np.asarray(v1), v1_ref, rtol=0.0, atol=1e-8)
    assert abs(float(res.time) - info["time"]) < 1e-8 and abs(float(res.work) - info["work"]) < 1e-8
    clearance = float(min_clearance(res.ctx))
    assert np.isnan(clearance) == np.isnan(info["min_clearance"])
    assert np.isnan(clearance) or abs(clearance - info["min_clearance"]) < 1e-8



def test_a_raised_trailing_heel_coming_down_is_watched_in_push_off():
    """``scuff`` in push-off (the variant only): while the raised trailing foot lowers
    its heel, its height to flat (ankle 2 above its toe); 1 while it rises. The same
    state in the SciPy reference gives the same value."""
    from tests.reference import flatfoot as ref
    from tests.reference.flatfoot.guards import G, guard_values

    params = with_params(MODEL.default_params(), ankle_reset=1.0, k=0.15)
    start = jnp.asarray([0.18709204, -0.18734030, -0.22846435])  # the stiff step's end: trailing foot raised
    y, phase, ctx = MODEL.section_to_state(start, params)
    assert int(phase) == ph.PUSH_OFF
    height = float(geo.ankle(y[:6], params, 2)[1] - ctx[ph.C["y_toe_2"]])
    assert height > 1e-5
    scuff = MODEL.guards.index("scuff")
    lowering = jnp.concatenate([y[:6], -y[6:]])  # the same motion reversed: the ankle comes down
    rate = lambda y_: jax.jvp(lambda q: geo.ankle(q, params, 2)[1], (y_[:6],), (y_[6:],))[1]
    assert float(rate(y)) > 0.0 > float(rate(lowering))
    assert float(MODEL.guard_values(jnp.zeros(()), y, params, phase, ctx)[scuff]) == 1.0
    assert float(MODEL.guard_values(jnp.zeros(()), lowering, params, phase, ctx)[scuff]) == pytest.approx(height, abs=1e-15)
    p_ref = ref.params(**{name: float(value) for name, value in params.items()})
    y_ref, phase_ref, ctx_ref = ref.section_to_state(np.asarray(start), p_ref, heel_rise=True)
    lowering_ref = np.concatenate([y_ref[:6], -y_ref[6:]])
    assert guard_values(0.0, lowering_ref, p_ref, phase_ref, ctx_ref)[G["scuff"]] == pytest.approx(height, abs=1e-12)
    assert guard_values(0.0, y_ref, p_ref, phase_ref, ctx_ref)[G["scuff"]] == 1.0


def test_a_start_with_the_trailing_heel_below_the_ground_scuffs_at_once():
    """The section's formulas continue below ``y_ankle_2 = 0`` (so Newton can reach
    the heel-down gaits on that boundary), but a step from there would start with
    the trailing heel in the floor: ``scuff`` is active below the toe whichever way
    the ankle moves, beyond ``SUNK_TOL`` (room for the flat foot's drift), and the
    step ends ``SCUFFING`` at its start, in both implementations. The same point
    with the foot flat (``psi_2 = -psi``) walks, and so does one half ``SUNK_TOL``
    down; one twice ``SUNK_TOL`` down does not."""
    from tests.reference import flatfoot as ref
    from tests.reference.flatfoot import guards as ref_guards

    assert hr.SUNK_TOL == ref_guards.SUNK_TOL
    params = MODEL.default_params()
    p_ref = ref.params(**{name: float(value) for name, value in params.items()})
    sunk = jnp.asarray([0.3245, 0.0, -0.3734])  # ankle 2 about 0.05 leg lengths below the ground
    flat = sunk.at[1].set(-sunk[0])
    depth = lambda v: -float(geo.ankle(MODEL.section_to_state(v, params)[0][:6], params, 2)[1])
    assert depth(sunk) > 0.01 and abs(depth(flat)) < 1e-15
    # psi_2 up by d sinks ankle 2 by about its rate times d: starts half and twice SUNK_TOL down.
    rate = depth(flat.at[1].add(1e-4)) / 1e-4
    near, beyond = flat.at[1].add(0.5 * hr.SUNK_TOL / rate), flat.at[1].add(2.0 * hr.SUNK_TOL / rate)
    assert 0.4 < depth(near) / hr.SUNK_TOL < 0.6 and 1.9 < depth(beyond) / hr.SUNK_TOL < 2.1
    for start, status in ((sunk, "scuffing"), (beyond, "scuffing"), (flat, "ok"), (near, "ok")):
        _, res, _ = _step(start, _no_tangent, params)
        _, info = ref.step_map(np.asarray(start), p_ref, heel_rise=True)
        assert Status(int(res.status)).name.lower() == status and info["status"] == status
        if status == "scuffing":
            assert float(res.time) == 0.0 and info["time"] == 0.0


def test_newton_keeps_its_iterates_with_the_trailing_ankle_on_or_above_the_ground():
    """``into_section`` moves a point with ankle 2 more than ``SUNK_TOL`` below
    the ground onto the ground (both feet flat, ``psi_2 = -psi``; the legs
    together where ``psi_2 > 0``), and leaves the others as they are: above
    it, and within ``SUNK_TOL`` below (a flat foot's drift, which the step
    accepts as flat)."""
    params = MODEL.default_params()
    height = lambda v: float(geo.ankle(MODEL.section_to_state(v, params)[0][:6], params, 2)[1])
    for sunk, edge in (([0.3245, 0.0, -0.3734], -0.3245), ([0.3245, 0.1, -0.3734], 0.3245)):
        moved = MODEL.into_section(jnp.asarray(sunk), params)
        np.testing.assert_array_equal(np.asarray(moved), [0.3245, edge, -0.3734])
        assert height(jnp.asarray(sunk)) < -0.01 and abs(height(moved)) < 1e-15
    flat = jnp.asarray([0.3245, -0.3245, -0.3734])
    rate = -(height(flat.at[1].add(1e-4)) - height(flat)) / 1e-4  # depth per unit of psi_2 towards the stance leg
    drift, beyond = flat.at[1].add(0.5 * hr.SUNK_TOL / rate), flat.at[1].add(2.0 * hr.SUNK_TOL / rate)
    assert -hr.SUNK_TOL < height(drift) < 0.0 and height(beyond) < -hr.SUNK_TOL
    assert abs(float(MODEL.into_section(beyond, params)[1]) - -0.3245) < 1e-15
    for kept in ([0.22104, -0.24624, -0.24743], flat, drift):  # heel up; flat; flat to the drift
        v = jnp.asarray(kept)
        np.testing.assert_array_equal(np.asarray(MODEL.into_section(v, params)), np.asarray(v))


class _NoEdge(type(MODEL)):
    """The heel-rise walker as it was before Newton kept its iterates in the section."""

    name = "flatfoot_heel_rise_no_edge"

    def into_section(self, v, params):
        return v


@pytest.mark.skipif(not os.environ.get("JAXWALK_SLOW_CHECKS"), reason=(
    "compiles the heel-rise walker's gait search twice (a few minutes); the projection itself is "
    "tested above and in test_newton_in_section.py; set JAXWALK_SLOW_CHECKS=1"))
def test_the_search_reaches_a_heel_down_gait_through_the_edge_of_the_section():
    """At ``mu`` 1e6, ``ankle_rest`` 0.2, ``k`` 0.03 of the stance-reset walker,
    Newton from the model's guess crosses the section's edge on its way to a
    heel-down gait (``lambda_max`` 1.9118 in the stance-reset sweep): with its
    iterates kept in the section it converges there; without, its step from
    the sunk iterate ends ``scuffing``."""
    from jaxwalk.gait import find_gait

    params = with_params(MODEL.default_params(), **{**STANCE_RESET, "mu": 1e6, "ankle_rest": 0.2, "k": 0.03})
    found = {}
    for model in (MODEL, _NoEdge()):
        search = compiling.jit(lambda p, v, m=model: find_gait(m, p, v), model)
        found[model.name] = search(params, MODEL.initial_guess(params))
    gait, lost = found[MODEL.name], found["flatfoot_heel_rise_no_edge"]
    assert Status(int(gait.status)) == Status.OK and abs(float(gait.lambda_max) - 1.911808) < 1e-5
    assert abs(float(gait.v[1]) + float(gait.v[0])) < 1e-9  # heel down, on the edge (to the drift)
    assert Status(int(lost.status)) == Status.SCUFFING


#: Where the stance heel starts to rise before toe-strike on the push_k line
#: ``ankle_push`` 0.07, ``P`` 0.035: the border collision the sweep's bifurcation
#: table locates (to 1e-6 in ``k``), and the gait there (6 digits).
ONSET = {**PUSH_K, "ankle_push": 0.07, "P": 0.035, "k": 0.1051910}
ONSET_GUESS = (0.246997, -0.246997, -0.298038)


@pytest.mark.parametrize("dk, rises", [(-3e-6, False), (3e-6, True)], ids=["below", "above"])
def test_the_located_onset_of_heel_rise_separates_the_two_event_orders(dk, rises):
    """Just below the located collision the gait's step keeps the stance heel down
    to toe-strike; just above it the heel rises first (3e-6 away: the location's
    1e-6 and the 6 digits). Solved by this module's own Newton, not the locator's."""
    params = with_params(MODEL.default_params(), **{**ONSET, "k": ONSET["k"] + dk})
    _, res, _ = _fixed_point(params, ONSET_GUESS)
    assert _names(res.ctx)[-3:] == (["heel_strike", "heel_rise", "toe_strike"] if rises else
                                    ["knee_strike", "heel_strike", "toe_strike"])
