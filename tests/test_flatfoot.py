"""The flat-foot walker against physics: conservation, contacts, impacts, the gait.

Every program is compiled once per module (module-scoped fixtures): the step map
with its forward-mode derivative along one direction (one program; the ground
drop an input, so the step-down test walks with it too) and the engine's
recorder; the batched step-down search is the one other flat-foot program here.
Parameters passed to them keep the defaults' dtypes (a weak-typed ``0.0`` in
place of a float64 array is another signature: one more compile of minutes).

The walker here is the paper's (``PAPER_PARAMS``: constant hip torque, floor
penetration tolerated), the one the SciPy reference and the published figures
describe; the shoe walker of the defaults and the other documented gaits are
held step by step against the same reference in tests/test_flatfoot_gaits.py.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxwalk import compiling, mechanics
from jaxwalk.models import get_model
from jaxwalk.models.flatfoot import clearance as cl
from jaxwalk.models.flatfoot import events as ev
from jaxwalk.models.flatfoot import forces as fo
from jaxwalk.models.flatfoot import geometry as geo
from jaxwalk.models.flatfoot import phases as ph
from jaxwalk.models.flatfoot.model import HIP_SPRING_PARAMS, PAPER_PARAMS, SHOE_PARAMS
from jaxwalk.simulate import AFTER_EVENT, BEFORE_EVENT, record_walk
from jaxwalk.status import Status
from jaxwalk.stepdown import StepDownOptions, h_max
from tests.flatfoot_program import LEVEL as _LEVEL, NO_TANGENT as _NO_TANGENT, STEP_PROGRAM, newton as _newton
from tests.flatfoot_program import energy_drifts, walk_phases, with_params as _with

MODEL = get_model("flatfoot")

_reactions = jax.jit(MODEL.reactions)
_energy = jax.jit(MODEL.energy)


@jax.jit
def _constraint_residuals(y, params, ctx):
    position = MODEL.constraints(y[:6], params, ctx)
    return position, jax.jacfwd(MODEL.constraints)(y[:6], params, ctx) @ y[6:]


@jax.jit
def _section_energy(v, params):
    y, phase, ctx = MODEL.section_to_state(v, params)
    return MODEL.energy(y, params, phase, ctx)


_EXTREMA = (ev.HEEL_EXTREMUM, ev.TOE_EXTREMUM)

#: The paper's seven phases (1-based) entered by each event of a nominal step.
PAPER_PHASE_OF_EVENT = {
    ev.KNEE_FLEX: 2,  # shank releasing starts when the knee leaves its stop
    ev.TOE_OFF: 3,
    ev.KNEE_STRIKE: 4,
    ev.HEEL_STRIKE: 5,  # the impact; heel pivot (6) follows at once
    ev.TOE_STRIKE: 7,
}


@pytest.fixture(scope="module")
def params():
    return _with(MODEL.default_params(), **PAPER_PARAMS)


@pytest.fixture(scope="module")
def step_program():
    """``(v, dv, params, drop) -> (v_next, StepResult, dv_next)`` (tests/flatfoot_program.py)."""
    return STEP_PROGRAM


@pytest.fixture(scope="module")
def dropped_step_fn(step_program):
    """``(v, params, drop) -> (v_next, StepResult)``."""
    return lambda v, p, drop: step_program(v, _NO_TANGENT, p, drop)[:2]


@pytest.fixture(scope="module")
def step_fn(step_program):
    """``(v, params) -> (v_next, StepResult)`` on level ground."""
    return lambda v, p: step_program(v, _NO_TANGENT, p, _LEVEL)[:2]


@pytest.fixture(scope="module")
def tangent_fn(step_program):
    """``(v, dv, params) -> (v_next, dv_next)``: one column of the Jacobian at a time."""

    def tangent(v, dv, p):
        v1, _, dv1 = step_program(v, dv, p, _LEVEL)
        return v1, dv1

    return tangent


@pytest.fixture(scope="module")
def fixed_point(params, step_fn, tangent_fn):
    """Newton from the stored nominal gait; returns ``(v, J)``."""
    return _newton(params, step_fn, tangent_fn)[:2]


@pytest.fixture(scope="module")
def walk(params, fixed_point):
    """One recorded step from the gait (the engine's recorder, run_step's own state machine)."""
    y0, phase0, ctx0 = MODEL.section_to_state(fixed_point[0], params)
    return record_walk(MODEL, params, y0, phase0, ctx0, n_steps=1, dt=0.05)


def _events(walk):
    """``(guard, before, after)`` for each event; ``before``/``after`` are ``(y, phase, ctx)``."""
    out = []
    for i in np.flatnonzero(walk.sample_kind == BEFORE_EVENT):
        state = lambda j: (jnp.asarray(walk.y[j]), int(walk.phase[j]), jnp.asarray(walk.ctx[j]))
        out.append((int(walk.event_guard[i]), state(i), state(i + 1)))
    return out


def _event_losses(walk, params):
    """``[(guard, loss, work)]`` for each event: the energy it dissipated (before less
    after, plus the actuator work done in the reset, ``walker.Transition.work``)
    and that work, from the recorder's cumulative work across the event."""
    works = np.diff(walk.work)[np.flatnonzero(walk.sample_kind == BEFORE_EVENT)]
    return [(guard, float(_energy(y0, params, p0, c0)) - float(_energy(y1, params, p1, c1)) + w, float(w))
            for (guard, (y0, p0, c0), (y1, p1, c1)), w in zip(_events(walk), works)]


# ----------------------------------------------------------------- the gait
def test_nominal_gait_is_a_stable_fixed_point(params, step_fn, fixed_point):
    v, jac = fixed_point
    v1, res = step_fn(v, params)
    assert int(res.status) == Status.OK
    np.testing.assert_allclose(np.asarray(v1), np.asarray(v), atol=1e-8)
    assert np.max(np.abs(np.linalg.eigvals(np.asarray(jac)))) < 1.0
    assert float(res.length) > 0.0 and float(res.time) > 0.0


def test_nominal_gait_visits_the_seven_phases_in_order(params, step_fn, fixed_point):
    _, res = step_fn(fixed_point[0], params)
    codes = ph.decode_history(np.asarray(res.ctx))
    assert codes == [ev.UNLOCK, ev.KNEE_FLEX, ev.TOE_OFF, ev.KNEE_STRIKE, ev.HEEL_STRIKE, ev.TOE_STRIKE]
    paper = [1] + [PAPER_PHASE_OF_EVENT[c] for c in codes if c in PAPER_PHASE_OF_EVENT]
    assert paper == [1, 2, 3, 4, 5, 7]  # 6 (heel pivot) lies between the heel- and toe-strike events
    times = [float(res.ctx[ph.C[name]]) for name in ("t_unlock", "t_knee_flex", "t_toe_off", "t_knee_strike", "t_heel_strike")]
    assert times == sorted(times) and times[-1] < float(res.time)


def test_recorded_step_matches_step_map(params, step_fn, fixed_point, walk):
    _, res = step_fn(fixed_point[0], params)
    assert walk.status == Status.OK and walk.steps_completed == 1
    # The knee leaves its stop at the unlock itself, so push-off gives way to shank release at once.
    # The swing foot's height extrema are events (they track min_clearance) that change no phase.
    phases = [p[0][1] for p in walk_phases(walk)]
    phases = [p for i, p in enumerate(phases) if i == 0 or p != phases[i - 1]]
    assert phases == [ph.PUSH_OFF, ph.SHANK_RELEASE, ph.SWING, ph.LOCKED_SWING, ph.HEEL_PIVOT, ph.PUSH_OFF]
    events = [e[0] for e in _events(walk) if e[0] not in _EXTREMA]
    assert events == [ev.UNLOCK, ev.TOE_OFF, ev.KNEE_STRIKE, ev.HEEL_STRIKE, ev.TOE_STRIKE]
    np.testing.assert_allclose(walk.y[-1], np.asarray(res.y), atol=1e-9)


def test_jacobian_matches_central_differences(params, step_fn, tangent_fn, fixed_point):
    v = fixed_point[0]
    h = 1e-5
    for i in range(2):
        e = jnp.zeros(2).at[i].set(1.0)
        _, column = tangent_fn(v, e, params)
        plus, minus = step_fn(v + h * e, params)[0], step_fn(v - h * e, params)[0]
        np.testing.assert_allclose(np.asarray(column), np.asarray((plus - minus) / (2 * h)), rtol=1e-4, atol=1e-5)


@pytest.fixture(scope="module")
def scipy_gait():
    """The independent NumPy/SciPy walker's gait from the same stored guess (no JAX: seconds)."""
    from tests.reference import flatfoot as ref

    return ref.gait()


def test_scipy_reference_has_the_paper_walker_and_guess(params):
    from tests.reference import flatfoot as ref

    assert set(ref.PAPER) == set(params)
    for name, value in ref.PAPER.items():
        assert float(params[name]) == value, name
    np.testing.assert_array_equal(np.asarray(MODEL.initial_guess(params)), np.asarray(ref.PAPER_GUESS))


def test_defaults_are_the_shoe_walker():
    """The defaults differ from the paper's walker exactly in the walker options, which are the shoe gait's."""
    defaults = MODEL.default_params()
    assert set(PAPER_PARAMS) == set(SHOE_PARAMS) and set(PAPER_PARAMS) <= set(defaults)
    assert {k: float(defaults[k]) for k in SHOE_PARAMS} == SHOE_PARAMS


def test_gait_matches_the_independent_scipy_walker(params, step_fn, fixed_point, scipy_gait):
    """Issue 12's check: the same walker written again from docs/model.md in NumPy
    (hand-derived equations, SciPy's DOP853 at the same tolerances, Newton on a
    central-difference Jacobian) has the same gait: fixed point to 1e-7, step
    period to 1e-7, lambda_max to 1e-5 (measured: 1.6e-8, 2e-8 and 3.3e-6; at
    rtol = atol = 1e-12 jaxwalk's gait comes within 5e-10, 6e-10 and 1e-7)."""
    v, jac = fixed_point
    assert scipy_gait.status == "ok"
    np.testing.assert_allclose(scipy_gait.v, np.asarray(v), rtol=0.0, atol=1e-7)
    lam = float(np.max(np.abs(np.linalg.eigvals(np.asarray(jac)))))
    assert abs(scipy_gait.lambda_max - lam) < 1e-5, (scipy_gait.lambda_max, lam)
    _, res = step_fn(v, params)
    assert abs(scipy_gait.step_info["time"] - float(res.time)) < 1e-7


def test_step_matches_the_independent_scipy_walker(params, step_fn, fixed_point):
    """One step from jaxwalk's fixed point in both: the same events in the same order
    at the same times (to 1e-7), the same next section point (to 1e-8), step length
    and minimum swing clearance. Measured: 4e-9 apart in ``v_next`` (3e-8 in the
    heel-strike time: the heel lands at 0.05 leg lengths per time unit). The SciPy
    step is converged in its tolerance (it moves by 1e-10 from rtol 1e-10 to 1e-12)
    and jaxwalk's at rtol = atol = 1e-12 lands 2e-11 from it, so the gap is
    jaxwalk's integration error at its default 1e-10, not a difference of model."""
    from tests.reference import flatfoot as ref

    v = fixed_point[0]
    v1, res = step_fn(v, params)
    v1_ref, info = ref.step_map(np.asarray(v))
    assert info["status"] == "ok"
    np.testing.assert_allclose(v1_ref, np.asarray(v1), rtol=0.0, atol=1e-8)
    names = [ev.GUARD_NAMES[c] for c in ph.decode_history(np.asarray(res.ctx))]
    assert [name for name, _ in info["events"]] == names
    times = dict(info["events"])
    for name in ("unlock", "knee_flex", "toe_off", "knee_strike", "heel_strike"):
        assert abs(times[name] - float(res.ctx[ph.C["t_" + name]])) < 1e-7, name
    assert abs(info["time"] - float(res.time)) < 1e-7 and abs(info["length"] - float(res.length)) < 1e-7
    assert abs(info["min_clearance"] - float(cl.min_clearance(res.ctx))) < 1e-8
    assert info["n_events"] == int(res.n_events)


# ----------------------------------------------------------------- physics
def test_energy_minus_actuator_work_is_constant_in_every_phase(params, walk):
    for name, drift in energy_drifts(MODEL, params, walk):
        assert abs(drift) < 1e-8, (name, drift)


def test_no_event_adds_energy(params, walk):
    # Level ground: neither the swap of labels nor the move of the frame changes the energy.
    assert float(params["gamma"]) == 0.0
    events = _event_losses(walk, params)
    losses = {MODEL.guards[guard]: loss for guard, loss, _ in events}
    assert max(abs(work) for _, _, work in events) < 1e-12  # the paper's springs: no reset work
    assert min(losses.values()) > -1e-10, losses
    # The unlock (and the knee leaving its stop) costs nothing; toe-off loses the
    # spring's energy; the three impacts dissipate.
    assert abs(losses["unlock"]) < 1e-12
    for impact in ("toe_off", "knee_strike", "toe_strike"):
        assert losses[impact] > 1e-5


def test_step_work_pays_for_the_losses_of_the_periodic_step(params, step_fn, fixed_point, walk):
    # On level ground the gait returns to the same state, so the hip's work over
    # one step (StepResult.work, from the joint angles at each phase's ends)
    # must equal what the events dissipate, and the recorder's integral of the
    # hip power over the recorded step.
    _, res = step_fn(fixed_point[0], params)
    work = float(res.work)
    losses = sum(loss for _, loss, _ in _event_losses(walk, params))
    assert work > 0.0
    assert abs(work - losses) < 1e-8 * max(1.0, work), (work, losses)
    assert abs(work - float(walk.work[-1])) < 1e-8, (work, float(walk.work[-1]))


def test_constraints_hold_along_the_step(params, walk):
    for states in walk_phases(walk):
        for y, phase, ctx in states:
            mask = np.asarray(ph.PHASE_MASKS[phase])
            position, velocity = _constraint_residuals(y, params, ctx)
            assert np.max(np.abs(np.asarray(position) * mask)) < 1e-8
            assert np.max(np.abs(np.asarray(velocity) * mask)) < 1e-8


def test_stance_normal_forces_are_compressive(params, walk):
    a_h, a_t = geo.foot_arms(params)
    for states in walk_phases(walk):
        for y, phase, ctx in states:
            stance, cop, toe, heel = _reactions(y, params, phase, ctx)
            assert float(stance[1]) > 0.0
            assert float(toe[1]) > -1e-9  # the trailing toe pushes until it lifts
            # The heel may pull by the model's rules (no bounce); in the nominal gait it does not.
            assert float(heel[1]) >= 0.0
            assert -float(a_h) < float(cop) < float(a_t)  # inside the flat stance foot


def test_limit_use_is_the_reactions_measured_against_their_limits(params, walk):
    """The recorded ``limit_use`` is each contact force measured against its
    limit, recomputed here from the reactions: the stance foot's and landing
    heel's ``|T| / (mu N)`` and the centre of pressure over the toe and heel arms.
    The nominal gait stays inside all of them."""
    a_h, a_t = (float(x) for x in geo.foot_arms(params))
    assert MODEL.limits == ("stance_friction", "heel_friction", "cop_toe", "cop_heel")
    assert walk.limit_use.shape == (len(walk.time), 4)
    for y, phase, ctx, use in zip(walk.y, walk.phase, walk.ctx, walk.limit_use):
        stance, cop, _, heel = (np.asarray(x) for x in _reactions(y, params, int(phase), ctx))
        mu = float(params["mu"])
        expected = [abs(stance[0]) / (mu * stance[1]), np.nan, cop / a_t, -cop / a_h]
        if phase == ph.HEEL_PIVOT:
            expected[1] = abs(heel[0]) / (mu * heel[1])
        np.testing.assert_allclose(use, expected, rtol=1e-9, atol=1e-15)
        assert np.nanmax(use) < 1.0
    assert np.isfinite(walk.limit_use[walk.phase == ph.HEEL_PIVOT, 1]).all()


def test_contact_impulses_are_compressive(params, walk):
    masks = {
        ev.KNEE_STRIKE: ph.PHASE_MASKS[ph.LOCKED_SWING],
        ev.HEEL_STRIKE: ph.PHASE_MASKS[ph.HEEL_PIVOT],
        ev.TOE_STRIKE: ph.TOE_STRIKE_MASK,
    }
    seen = []
    for guard, (y, _, ctx), (_, _, ctx_after) in _events(walk):
        if guard not in masks:
            continue
        # Heel-strike's anchor (the heel's contact point) is in the context after it.
        ctx = ctx_after if guard == ev.HEEL_STRIKE else ctx
        _, impulses = MODEL.apply_impact(y, params, ctx, masks[guard])
        normal = np.asarray(ev.normal_impulses(y[:6], impulses, params, ctx))
        assert np.all(normal > -1e-10), (MODEL.guards[guard], normal)
        seen.append(guard)
    assert seen == [ev.KNEE_STRIKE, ev.HEEL_STRIKE, ev.TOE_STRIKE]


def test_section_round_trip_and_consistency(params, fixed_point):
    v = fixed_point[0]
    y, phase, ctx = MODEL.section_to_state(v, params)
    assert int(phase) == ph.PUSH_OFF
    np.testing.assert_allclose(np.asarray(MODEL.state_to_section(y, params, ctx)), np.asarray(v), atol=1e-14)
    # Both feet flat on the ground: both ankles at height 0.
    assert abs(float(geo.ankle(y[:6], params, 1)[1])) < 1e-14
    assert abs(float(geo.ankle(y[:6], params, 2)[1])) < 1e-14


# ----------------------------------------------------------------- no free lunch
def test_no_gait_on_level_ground_without_hip_torque(params, step_fn):
    """With P = 0 and gamma = 0 nothing puts energy in: every step loses some, so no gait."""
    passive = dict(params, P=jnp.zeros_like(params["P"]))
    for psi in (0.15, 0.25, 0.35):
        for psi_dot in (-0.2, -0.4, -0.6):
            v = jnp.array([psi, psi_dot])
            energy = float(_section_energy(v, passive))
            for _ in range(20):
                v, res = step_fn(v, passive)
                if int(res.status) != Status.OK:
                    break
                after = float(_section_energy(v, passive))
                assert after < energy - 1e-6
                energy = after
            assert int(res.status) != Status.OK


# ----------------------------------------------------------------- step-down
def test_h_max_is_the_first_failed_drop_of_single_trials(params, fixed_point, dropped_step_fn):
    # The batched search (what sweeps run: jaxwalk.stepdown.h_max, one while
    # loop over drops around one over steps) against the definition, one drop
    # at a time and one step at a time through the step map: from the gait, a
    # step onto ground h lower, then n_steps steps on the new level. h_max = k dh
    # where drops dh .. k dh all survive and (k + 1) dh fails, with the failing
    # step's status. A drop of 0 keeps walking on the cycle.
    options = StepDownOptions(dh=0.002, count=10, n_steps=6)
    v_star = jnp.asarray(fixed_point[0])
    batched = compiling.jit(jax.vmap(lambda v_: h_max(MODEL, params, v_, options)), MODEL)(v_star[None])

    def trial(h):
        """``(survived, status of the first failed step or OK, steps completed)``."""
        v = v_star
        for k in range(options.n_steps + 1):
            drop = jnp.asarray(h if k == 0 else 0.0, jnp.float64)  # float64 like _LEVEL: one signature
            v, res = dropped_step_fn(v, params, drop)
            if int(res.status) != Status.OK:
                return False, int(res.status), k
        return True, int(Status.OK), options.n_steps + 1

    assert trial(0.0) == (True, Status.OK, options.n_steps + 1)
    outcomes = []
    for k in range(1, options.count + 1):
        outcomes.append(trial(k * options.dh))
        if not outcomes[-1][0]:
            break
    survived = [s for s, _, _ in outcomes]
    k_max = survived.index(False) if False in survived else options.count
    assert float(batched.h_max[0]) == pytest.approx(k_max * options.dh, abs=1e-15)
    if k_max < options.count:
        status = outcomes[k_max][1]
        assert status != Status.OK
        assert int(batched.first_failure[0]) == status
        assert float(batched.failed_at[0]) == pytest.approx((k_max + 1) * options.dh, abs=1e-15)
    else:
        assert int(batched.first_failure[0]) == Status.OK and np.isnan(float(batched.failed_at[0]))


# ----------------------------------------------------------------- stated assumptions, checked
@jax.jit
def _stance_knee_torque(y, params, phase, ctx):
    """The ``KNEE_1`` multiplier: the stance knee's torque, positive while a stop would push."""
    return MODEL.dynamics(y, params, phase, ctx)[1][ph.KNEE_1]


@jax.jit
def _lowest_point(y, params, ctx):
    """Height of the swing foot's lower end (heel or toe) above the ground below it."""
    return jnp.min(cl.heights(y[:6], y[6:], params, ctx, ev._ground_under)[0])


def test_a_guard_that_just_fired_hides_no_other_crossing(params, step_fn):
    """Regression (stepbase.guard_offsets): at l_f = 0.13 a locked-swing phase starts
    with the heel-extremum guard at -6e-17 (its event just ended the last phase) and
    the toe's extremum 0.01 later. Watched as the smallest guard, the heel's
    rounding error hid the toe's crossing; the toe guard then stayed negative, no
    other guard could fire, and the walker fell through the floor until the phase's
    time limit (``timeout``, 180 points of a 21 x 46 (l_f, r) map). It is a normal
    step: the seven phases and both feet's extrema, 11 events."""
    p = dict(params, l_f=jnp.asarray(0.13, jnp.float64))  # not weak-typed: the same program
    v = jnp.array([0.18786143861484147, -0.2143837788574308])  # the gait at l_f = 0.14
    _, res = step_fn(v, p)
    assert int(res.status) == Status.OK
    assert int(res.n_events) == 11 and 3.0 < float(res.time) < 4.0


def test_the_stance_knee_is_a_latch_and_buckles_on_its_stop_alone(params, step_fn, fixed_point, walk):
    # The stance knee's constraint pulls (holds the knee against flexing) all step:
    # a latch, stated as stance_latch = 1. On its extension stop alone it buckles.
    for states in walk_phases(walk)[:-1]:
        for y, phase, ctx in states:
            assert float(_stance_knee_torque(y, params, phase, ctx)) < 0.0
    _, res = step_fn(fixed_point[0], _with(params, stance_latch=0.0))
    assert int(res.status) == Status.KNEE_BUCKLED


def test_min_clearance_is_the_lowest_swing_minimum_of_the_recorded_step(params, step_fn, fixed_point, walk):
    # The tracked minimum (events at the heel's and toe's height extrema) against
    # the recorder's samples of the swing foot's lowest point: never above them,
    # and within the sampling error of a 0.05 grid (events sampled exactly).
    _, res = step_fn(fixed_point[0], params)
    tracked = float(cl.min_clearance(res.ctx))
    sampled = []
    for states in walk_phases(walk):
        for y, phase, ctx in states:
            if phase in (ph.SWING, ph.LOCKED_SWING):
                sampled.append(float(_lowest_point(y, params, ctx)))
    assert tracked <= min(sampled) + 1e-12
    assert min(sampled) - tracked < 2e-3
    # The nominal gait (scuff_tol = 0.03) dips below the ground: the reason for issue 14.
    assert -float(params["scuff_tol"]) < tracked < 0.0


# ----------------------------------------------------------------- each new option
#: Each option at a value where one step from the nominal v* completes (the audits
#: then cover every phase); its measured effects are in docs/model.md.
OPTION_CASES = {
    "knee_gate": {"knee_gate": 1.0},
    "inertia": {"rho_t": 0.1, "rho_s": 0.1},
    "swing_dorsi": {"swing_dorsi": 0.03},
    "hip_spring": {"k_hip": 0.002},
    "ankle_push": {"ankle_push": 1e-4},
    # (0.8 already scuffs from the nominal gait: the swing starts slower)
    "hip_double_support": {"k_hip": 0.002, "hip_double_support": 0.9},
    "heel_brake": {"heel_brake": 1e-4},
    "swing_torque": {"swing_torque": 1e-4},
    "ankle_rest": {"ankle_rest": 0.003},
    "ankle_reset": {"ankle_reset": 0.05},
    "trailing_reset": {"ankle_reset": 0.05, "trailing_reset": 0.0},
}


@pytest.fixture(scope="module", params=list(OPTION_CASES))
def option_walk(request, params, fixed_point):
    """``(params, walk)``: one recorded step from v* with one option switched on."""
    p = _with(params, **OPTION_CASES[request.param])
    y0, phase0, ctx0 = MODEL.section_to_state(fixed_point[0], p)
    return p, record_walk(MODEL, p, y0, phase0, ctx0, n_steps=1, dt=0.05)


def test_each_option_keeps_energy_balance_and_no_event_adds_energy(option_walk):
    p, walk = option_walk
    assert walk.status == Status.OK and walk.steps_completed == 1
    for name, drift in energy_drifts(MODEL, p, walk):
        assert abs(drift) < 1e-8, (name, drift)
    for guard, loss, _ in _event_losses(walk, p):
        assert loss > -1e-10, MODEL.guards[guard]


def test_an_ankle_spring_wound_up_at_toe_strike_is_actuator_work(step_fn):
    """``ankle_reset = 1``, ``ankle_rest = 0.3``: at toe-strike the landing foot's
    spring, stretched 0.289 rad from its landing angle (shank 0.189 plus
    ``swing_dorsi``), becomes the stance spring turned 0.3 rad the other way, its
    relaxed angle moving past the still foot: the stretch is let go (lost) and the
    spring wound from slack, ``k/2 0.3^2`` of actuator work in the step's work
    (``forces.reset_work``); the old stance spring only lets energy go. Once that
    work is counted every event dissipates."""
    p = _with(MODEL.default_params(), ankle_reset=1.0, ankle_rest=0.3, k=0.05)
    y0, phase0, ctx0 = MODEL.section_to_state(MODEL.initial_guess(p), p)
    walk = record_walk(MODEL, p, y0, phase0, ctx0, n_steps=1, dt=0.05)
    assert walk.status == Status.OK and walk.steps_completed == 1
    (_, _, work), = [e for e in _event_losses(walk, p) if MODEL.guards[e[0]] == "toe_strike"]
    after = walk.y[np.flatnonzero(walk.sample_kind == AFTER_EVENT)[-1]]
    k, rest = float(p["k"]), float(p["ankle_rest"])
    landing = (after[geo.SHANK_1] + float(p["swing_dorsi"]), -rest)  # deflections before, after (both feet flat)
    old_stance = (after[geo.SHANK_2] - rest - float(ctx0[ph.C["shank_1_strike"]]), -rest)
    assert landing[0] > 0.0 > landing[1] and old_stance[0] < old_stance[1] < 0.0
    assert abs(work - 0.5 * k * rest**2) < 1e-12, work
    assert all(loss > -1e-10 for _, loss, _ in _event_losses(walk, p))
    # The engine's step work: each phase's actuator work (exact, from potentials) and the reset's.
    phases = sum(float(fo.actuator_work(states[0][0][:6], states[-1][0][:6], p, states[0][1], states[0][2]))
                 for states in walk_phases(walk)[:-1])
    _, res = step_fn(MODEL.initial_guess(p), p)
    assert abs(float(res.work) - (phases + work)) < 1e-9, (float(res.work), phases, work)


@jax.jit
def _mass_and_sigma(y, params, ctx):
    mass = mechanics.mass_matrix(lambda q_: MODEL.points(q_, params), MODEL.masses(params), y[:6])
    return mass, jax.jacfwd(MODEL.constraints)(y[:6], params, ctx)


def test_each_option_impacts_conserve_momentum_along_the_constraints(option_walk):
    # An inelastic impact keeps the generalized momentum along every velocity the
    # constraints after it allow: N^T M (qd+ - qd-) = 0, N spanning their null space.
    p, walk = option_walk
    masks = {
        ev.KNEE_STRIKE: ph.PHASE_MASKS[ph.LOCKED_SWING],
        ev.HEEL_STRIKE: ph.PHASE_MASKS[ph.HEEL_PIVOT],
        ev.TOE_STRIKE: ph.TOE_STRIKE_MASK,
    }
    unswap = np.array([0, 1, 4, 5, 2, 3])  # the swap's permutation is its own inverse
    seen = set()
    for guard, (y, _, ctx), (y_after, _, ctx_after) in _events(walk):
        if guard not in masks:
            continue
        qd_plus = np.asarray(y_after[6:])[unswap] if guard == ev.TOE_STRIKE else np.asarray(y_after[6:])
        mass, sigma = _mass_and_sigma(y, p, ctx_after if guard == ev.HEEL_STRIKE else ctx)
        active = np.asarray(sigma)[np.asarray(masks[guard]) > 0]
        null = np.linalg.svd(active)[2][np.linalg.matrix_rank(active):].T
        change = np.asarray(mass) @ (qd_plus - np.asarray(y[6:]))
        assert np.max(np.abs(null.T @ change)) < 1e-9, MODEL.guards[guard]
        assert np.max(np.abs(active @ qd_plus)) < 1e-9
        seen.add(guard)
    assert seen == set(masks)


@pytest.mark.parametrize("case", list(OPTION_CASES))
def test_each_option_jacobian_matches_central_differences(params, step_fn, tangent_fn, fixed_point, case):
    p = _with(params, **OPTION_CASES[case])
    v, h = fixed_point[0], 1e-5
    assert int(step_fn(v, p)[1].status) == Status.OK
    for i in range(2):
        e = jnp.zeros(2).at[i].set(1.0)
        _, column = tangent_fn(v, e, p)
        plus, minus = step_fn(v + h * e, p)[0], step_fn(v - h * e, p)[0]
        np.testing.assert_allclose(np.asarray(column), np.asarray((plus - minus) / (2 * h)), rtol=1e-4, atol=1e-5)


# ----------------------------------------------------------------- the hip-spring gait (issue 14; tests/test_flatfoot_gaits.py)
@pytest.fixture(scope="module")
def hip_spring(params, step_fn, tangent_fn):
    p = _with(params, **HIP_SPRING_PARAMS)
    return (p, *_newton(p, step_fn, tangent_fn))


def test_hip_spring_swing_foot_stays_above_the_ground_at_every_sample(hip_spring):
    """Every recorded in-air sample of the hip-spring gait's swing foot is at or
    above the ground, and the knee is still flexed (its latch open) when the swing
    ankle passes the stance ankle."""
    p, v, _, _ = hip_spring
    y0, phase0, ctx0 = MODEL.section_to_state(v, p)
    walk = record_walk(MODEL, p, y0, phase0, ctx0, n_steps=1, dt=0.02)
    passed = False
    for y, phase, ctx in (s for states in walk_phases(walk) for s in states):
        if phase in (ph.SWING, ph.LOCKED_SWING):
            assert float(_lowest_point(y, p, ctx)) >= -1e-12
            q = np.asarray(y[:6])
            if not passed and geo.ankle(q, p, 2)[0] >= geo.ankle(q, p, 1)[0]:
                passed = True
                assert phase == ph.SWING and geo.flexion(q, 2) > 1.0  # rad; knee_lock is 0.2
    assert passed
