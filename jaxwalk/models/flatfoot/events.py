"""Guards and resets of the flat-foot walker.

Guards are positive while a phase goes on (the engine's convention); a guard that
does not apply in a phase returns 1.0, and every gate opens only where the gated
value is already positive, so that opening a gate is never itself a crossing.

The swing knee has an extension stop at flexion ``knee_lock`` and a latch
(``ctx["knee_2"]``: latched, released, relatched). Transitions:

* ``unlock`` (``delay - t``; the step starts at ``t = 0`` just after toe-strike):
  the latch releases. The knee stays on its stop while the stop pushes.
* ``knee_flex`` (the stop's torque falls to zero): the knee starts to flex;
  push_off -> shank_release, locked_swing -> swing.
* ``toe_off`` (leg 2's toe normal force falls to zero): push_off -> locked_swing,
  shank_release -> swing. The massless foot snaps to its relaxed angle and the
  spring's stored energy is lost.
* ``knee_strike`` (leg 2's flexion falls to ``knee_lock`` while extending):
  inelastic impact onto the knee lock, the latch closes; swing -> locked_swing,
  shank_release -> push_off.
* ``heel_strike`` (leg 2's heel reaches the ground ahead of foot 1): inelastic
  impact onto the heel circle; locked_swing -> heel_pivot. Unless the latch has
  closed again: ``SHANK_RELEASING``.
* ``toe_strike`` (leg 2's ankle reaches the ground: the foot is flat): inelastic
  impact onto ankle 2 pinned with leg 1 on its toe; legs swap, the frame moves
  to the new stance ankle, both shank angles are recorded (the springs' rest
  angles of ``ankle_reset``), and the step ends.

* ``slip`` / ``knee_buckle`` (a ground force leaves its friction cone; a knee
  on its stop alone, ``stance_latch = 0``, would have to pull): ``SLIPPING``,
  ``KNEE_BUCKLED``.
* ``foot_roll`` (the flat stance foot's centre of pressure reaches its heel or
  toe: a rigid flat foot can hold no larger ankle torque without tipping, and
  the base walker's phase sequence has no heel rise before toe-strike):
  ``FOOT_ROLLING``. In the heel-rise walker only over the heel, or the toe in
  push-off and shank release.
* ``heel_extremum`` / ``toe_extremum``: bookkeeping of the swing foot's minimum
  clearance (:mod:`clearance`); no phase change.
* The heel-rise walker only (``model.heel_rise``): ``heel_rise`` and ``heel_drop``
  (:mod:`heel_rise`), the stance foot tipping onto its toe and back. Its
  heel-up phases behave as their flat twins (:data:`phases.FLAT_PHASE`) in
  everything that concerns leg 2.

With ``knee_gate = 1`` knee-strike closes the latch only once the swing ankle
has passed the stance ankle; before that the knee rests on its stop unlatched,
and the latch closes as the ankle passes (a ``knee_strike`` with no impulse).

After every transition the new phase is checked on entry: a toe that would pull
on the ground leaves at once, a released knee whose stop would pull flexes at
once (both logged as events), and a failure guard already non-positive sets its
status. (The engine also ends a phase at its start, without integrating it,
where a guard is negative there (``jaxwalk.step.event_at_start``); resolving
these here names the transition and keeps the event log complete.)
"""

from __future__ import annotations

import jax
import jax.numpy as jnp

from jaxwalk.models.flatfoot import clearance, forces, heel_rise
from jaxwalk.models.flatfoot import geometry as geo
from jaxwalk.models.flatfoot import phases as ph
from jaxwalk.status import Status
from jaxwalk.walker import Transition

(UNLOCK, KNEE_FLEX, TOE_OFF, KNEE_STRIKE, HEEL_STRIKE, TOE_STRIKE,
 FALL, LEG_RANGE, STALL, RUNNING, SCUFF, SLIP, BUCKLE, FOOT_ROLL, HEEL_EXTREMUM, TOE_EXTREMUM) = range(16)  # fmt: skip
GUARD_NAMES = (
    "unlock",
    "knee_flex",
    "toe_off",
    "knee_strike",
    "heel_strike",
    "toe_strike",
    "fall",
    "leg_range",
    "stall",
    "running",
    "scuff",
    "slip",
    "knee_buckle",
    "foot_roll",
    "heel_extremum",
    "toe_extremum",
)
#: The heel-rise walker's guards: two more before the extrema (:mod:`heel_rise`).
HEEL_RISE_GUARD_NAMES = GUARD_NAMES[:HEEL_EXTREMUM] + heel_rise.NAMES + GUARD_NAMES[HEEL_EXTREMUM:]
#: Status of each failure guard, in order of precedence.
FAILURES = {
    FALL: Status.FELL,
    LEG_RANGE: Status.FELL,
    STALL: Status.STALLED,
    RUNNING: Status.RUNNING,
    SCUFF: Status.SCUFFING,
    SLIP: Status.SLIPPING,
    BUCKLE: Status.KNEE_BUCKLED,
    FOOT_ROLL: Status.FOOT_ROLLING,
}

#: Hip height (normal to the slope, leg lengths) below which the walker has fallen.
FALL_HEIGHT = 0.5
#: Largest |segment angle| (rad) from the slope normal before we call it a fall.
SEGMENT_LIMIT = 1.5
#: Largest swing-knee flexion (rad).
FLEXION_LIMIT = 2.5
#: Below this (units M sqrt(g L)) an impact is no impact: numerical zero.
IMPULSE_FLOOR = 1e-12

_CHECKED_IMPULSES = jnp.array([0, 1, 3, 4])
_STOP_PHASES = jnp.array([True, False, False, True, False, False, True, False])  # knee 2 locked, may release


def extremum_codes(model):
    """Guard codes of the swing foot's heel and toe extremum guards (after
    :mod:`heel_rise`'s two in the heel-rise walker)."""
    shift = len(heel_rise.NAMES) if model.heel_rise else 0
    return HEEL_EXTREMUM + shift, TOE_EXTREMUM + shift


def _ground_under(x, ctx, params):
    """Ground height below ``x``: the previous level behind foot 1, 0 under it, the next level ahead."""
    a_h, a_t = geo.foot_arms(params)
    x_a1 = ctx[ph.C["x_ankle_1"]]
    return jnp.where(
        x > x_a1 + a_t,
        ctx[ph.C["ground_next"]],
        jnp.where(x < x_a1 - a_h, ctx[ph.C["y_toe_2"]], 0.0),
    )


def _cone(force, params):
    """``mu N - |T|`` of a contact force ``(T, N)``: positive inside the friction cone."""
    return params["mu"] * force[1] - jnp.abs(force[0])


def guard_values(model, t, y, params, phase, ctx):
    """``(n_guards,)`` guard values in the order of ``model.guards`` (:data:`GUARD_NAMES`,
    or :data:`HEEL_RISE_GUARD_NAMES` in the heel-rise walker)."""
    q, qd = model.split(y)
    flat = ph.FLAT_PHASE[phase]
    _, lam = model.dynamics(y, params, phase, ctx)
    stance, _, toe, heel = forces.contact_reactions(q, lam, params, phase, ctx, model.heel_rise)
    gn, knee_state = ctx[ph.C["ground_next"]], ctx[ph.C["knee_2"]]
    a_h, a_t = geo.foot_arms(params)
    one = jnp.ones_like(t)

    on_stop = _STOP_PHASES[phase]
    unlock = jnp.where(on_stop & (knee_state == ph.LATCHED), params["delay"] - t, one)
    # The knee row's multiplier is a torque opening the knee: positive while the stop pushes.
    knee_flex = jnp.where(on_stop & (knee_state == ph.RELEASED), lam[ph.KNEE_2], one)
    # The toe leaves when its force reaches the edge of the friction cone (at the
    # latest when it stops pushing): a toe that would slide is unloaded and lifts.
    toe_off = jnp.where(ph.ON_TOE[phase], _cone(toe, params), one)
    flex, flex_rate = geo.flexion(q, 2), geo.flexion(qd, 2)
    knee = jnp.where(ph.KNEE_2_FREE[phase] & (flex_rate < 0.0), flex - params["knee_lock"], one)
    # The paper's mid-stance gate: a knee resting on its stop, unlatched, latches
    # when its ankle passes the stance ankle.
    gated = (params["knee_gate"] > 0.5) & (flat == ph.LOCKED_SWING) & (knee_state == ph.RELEASED)
    knee = jnp.where(gated, ctx[ph.C["x_ankle_1"]] - geo.ankle(q, params, 2)[0], knee)

    in_air = clearance.in_air(phase)
    heel_pt, toe_pt = geo.free_foot(q, params, 2)
    # Open once the heel is past foot 1's toe, where a heel in the air is above ground.
    past = heel_pt[0] > ctx[ph.C["x_ankle_1"]] + a_t
    heel_strike = jnp.where(in_air & past, heel_pt[1] - gn, one)
    toe_strike = jnp.where(flat == ph.HEEL_PIVOT, geo.ankle(q, params, 2)[1] - gn, one)

    fall = q[geo.Y_H] - FALL_HEIGHT
    leg_range = jnp.minimum(SEGMENT_LIMIT - jnp.max(jnp.abs(q[2:])), FLEXION_LIMIT - flex)
    stall = qd[geo.X_H]
    # The stance foot must push. The heel of foot 2 may pull in heel pivot: the
    # paper's impacts are "fully inelastic, no slip and no bounce" (assumption 4).
    running = stance[1]
    clearance_ = jnp.minimum(
        heel_pt[1] - _ground_under(heel_pt[0], ctx, params), toe_pt[1] - _ground_under(toe_pt[0], ctx, params)
    )
    scuff = jnp.where(in_air, clearance_ + params["scuff_tol"], one)
    if model.heel_rise:
        scuff = jnp.minimum(scuff, heel_rise.trailing_heel_landing(q, qd, params, phase, ctx))
    slip = jnp.minimum(_cone(stance, params), jnp.where(ph.ON_HEEL[phase], _cone(heel, params), one))
    # A knee on its extension stop (no latch) holds only while the stop pushes:
    # the stance knee always, the landing knee in heel pivot.
    no_latch = params["stance_latch"] < 0.5
    loaded_2 = jnp.where(flat == ph.HEEL_PIVOT, lam[ph.KNEE_2], one)
    buckle = jnp.where(no_latch, jnp.minimum(lam[ph.KNEE_1], loaded_2), one)
    # The flat stance foot holds its ankle spring's torque by where its normal
    # force acts; it stays flat only while that centre of pressure lies between
    # heel and toe, -a_h N <= tau <= a_t N (moment form: no division by N, whose
    # sign the `running` guard checks).
    tau = forces.stance_ankle_torque(q, params, ctx)
    toe_margin, heel_margin = a_t * stance[1] - tau, tau + a_h * stance[1]
    if model.heel_rise:
        foot_roll, *rise_drop = heel_rise.guards(q, qd, params, phase, toe_margin, heel_margin)
    else:
        foot_roll, rise_drop = jnp.minimum(toe_margin, heel_margin), []
    extrema = clearance.guards(q, qd, params, phase, ctx, _ground_under)
    return jnp.concatenate(
        [
            jnp.stack([unlock, knee_flex, toe_off, knee, heel_strike, toe_strike, fall, leg_range, stall, running]),
            jnp.stack([scuff, slip, buckle, foot_roll, *rise_drop]),
            extrema,
        ]
    )


def _log(ctx, guard, t, time_entry=None):
    ctx = ph.log_event(ctx, guard)
    return ctx if time_entry is None else ctx.at[ph.C[time_entry]].set(t)


def settle(model, t, y, params, phase, ctx):
    """Resolve contacts and the knee stop on entering ``phase``: ``(phase, ctx, guards)``.

    A toe that would pull on the ground leaves it (``toe_off``); a released knee
    whose stop would pull starts to flex (``knee_flex``). ``guards`` are the guard
    values in the phase finally chosen. At most two changes can happen, so three
    passes of one loop body (compiled once) reach the final phase and its guards.
    """

    def one_pass(_, carry):
        phase, ctx, _ = carry
        g = guard_values(model, t, y, params, phase, ctx)
        lifts = ph.ON_TOE[phase] & (g[TOE_OFF] < 0.0)
        flexes = ~lifts & (g[KNEE_FLEX] < 0.0)
        from_push_off = phase == ph.PUSH_OFF
        swing = jnp.where(ph.HEEL_UP[phase], ph.SWING_HEEL_UP, ph.SWING)
        new_phase = jnp.select(
            [lifts, flexes],
            [jnp.where(from_push_off, ph.LOCKED_SWING, ph.SWING), jnp.where(from_push_off, ph.SHANK_RELEASE, swing)],
            phase,
        ).astype(jnp.int32)
        new_ctx = jnp.select(
            [lifts, flexes], [_log(ctx, TOE_OFF, t, "t_toe_off"), _log(ctx, KNEE_FLEX, t, "t_knee_flex")], ctx
        )
        return new_phase, new_ctx, g

    g0 = jnp.ones(len(model.guards), y.dtype)
    return jax.lax.fori_loop(0, 3, one_pass, (jnp.asarray(phase, jnp.int32), ctx, g0))


def entry_failure(guards, phase):
    """Status of the first failure guard that is already non-positive on entering ``phase``
    (:data:`FAILURES` order), else ``SCUFFING`` for a heel pivot entered with the ankle
    not above the ground, else ``IN_PROGRESS``."""
    status = jnp.int8(Status.IN_PROGRESS)
    for guard, code in reversed(list(FAILURES.items())):  # the first listed wins
        status = jnp.where(guards[guard] <= 0.0, jnp.int8(code), status)
    # A heel pivot that starts with the ankle on or below the ground: the foot landed flat or toe
    # first. After the failure guards (a fall that lands the foot flat is a fall), as the SciPy walker.
    bad_landing = (ph.FLAT_PHASE[phase] == ph.HEEL_PIVOT) & (guards[TOE_STRIKE] <= 0.0)
    return jnp.where(bad_landing & (status == Status.IN_PROGRESS), jnp.int8(Status.SCUFFING), status)


def normal_impulses(q, impulses, params, ctx):
    """Normal components of the contact impulses ``(5,)``: foot 1, toe 2, heel 2, ankle 2, toe 1."""
    toe_1, toe_2, heel_2, _ = ph.anchors(params, ctx)
    ankle_1, ankle_2 = geo.ankle(q, params, 1), geo.ankle(q, params, 2)
    radial_y = lambda a, c: (a - c)[1] / jnp.linalg.norm(a - c)
    return jnp.stack(
        [
            impulses[ph.ANKLE_1_Y],
            impulses[ph.TOE_2] * radial_y(ankle_2, toe_2),
            impulses[ph.HEEL_2] * radial_y(ankle_2, heel_2),
            impulses[ph.ANKLE_2_Y],
            impulses[ph.TOE_1] * radial_y(ankle_1, toe_1),
        ]
    )


def impulse_failures(q, impulses, params, ctx):
    """``(pulls, slides)`` of an impact's contact impulses, scaled to the impact.

    Foot 1 flat, toe 2, the landing ankle 2 and toe 1 must push; foot 1 and the
    landing ankle must stay inside the friction cone. The heel of foot 2 is held without
    bounce (the paper's assumption 4), and its impulse, carried by the massless
    foot, lies along the foot, so its cone is checked on the force that follows
    (the ``slip`` guard). Toe 1's impulse has a normal part only with its heel
    up (a flat foot's lies along the ground), so its push check matters in the
    heel-rise walker alone; its friction is not checked in either walker (its
    tangential part is ``cot(phi)`` times its normal part, unbounded for a flat
    foot: the trailing foot is assumed not to slip at toe-strike, and in the
    heel-rise walker neither is a raised stance toe at knee- or heel-strike;
    docs/model.md, "The heel-rise walker").
    A knee without a latch (``stance_latch = 0``) must not be pulled by its stop
    (``buckles``: as the ``knee_buckle`` guard for the force, ``KNEE_BUCKLED``).
    Returns ``(pulls, slides, buckles)``, booleans.
    """
    normal = normal_impulses(q, impulses, params, ctx)
    scale = params["impulse_tol"] * jnp.max(jnp.abs(normal)) + IMPULSE_FLOOR
    pulls = jnp.min(normal[_CHECKED_IMPULSES]) < -scale
    knees = jnp.minimum(impulses[ph.KNEE_1], impulses[ph.KNEE_2])
    buckles = (params["stance_latch"] < 0.5) & (knees < -scale)
    cone = lambda tx, ny: params["mu"] * ny - jnp.abs(tx)
    slides = jnp.minimum(
        cone(impulses[ph.ANKLE_1_X], impulses[ph.ANKLE_1_Y]), cone(impulses[ph.ANKLE_2_X], impulses[ph.ANKLE_2_Y])
    ) < -scale
    return pulls, slides, buckles


def _latch_after_strike(q, params, phase, ctx):
    """The swing knee's latch after knee-strike: closed, unless the paper's gate
    (``knee_gate``) holds it open until the swing ankle passes the stance ankle.

    A knee-strike in locked_swing is the gate opening itself (the ankle passing,
    to root-finding accuracy): it always closes the latch, or the gate's guard,
    still at zero, would fire again and again.
    """
    passed = (geo.ankle(q, params, 2)[0] > ctx[ph.C["x_ankle_1"]]) | (ph.FLAT_PHASE[phase] == ph.LOCKED_SWING)
    return jnp.where((params["knee_gate"] < 0.5) | passed, ph.RELATCHED, ph.RELEASED)


def trailing_heel_sinks(y, params, ctx):
    """True if the trailing foot, flat on its toe circle, would turn heel-down (into the ground)."""
    q, qd = y[:6], y[6:]
    _, toe_2, _, _ = ph.anchors(params, ctx)
    angle = lambda q_: geo.toe_pivot_angle(geo.ankle(q_, params, 2), toe_2)
    return jax.jvp(angle, (q,), (qd,))[1] > 0.0


def swap_legs(y, params, ctx):
    """After toe-strike: leg 2 becomes stance, origin at its ankle. ``(y, ctx, shift)``."""
    q, qd = y[:6], y[6:]
    _, a_t = geo.foot_arms(params)
    landing = geo.ankle(q, params, 2)
    shift, drop = landing[0], landing[1]
    perm = jnp.array([0, 1, 4, 5, 2, 3])
    q_new = q[perm].at[0].add(-shift).at[1].add(-drop)
    ctx_new = (
        ctx.at[ph.C["x_ankle_1"]].set(0.0)
        .at[ph.C["x_toe_2"]].set(ctx[ph.C["x_ankle_1"]] + a_t - shift)
        .at[ph.C["y_toe_2"]].set(-drop)
        .at[ph.C["x_heel_2"]].set(0.0)
        .at[ph.C["ground_next"]].set(0.0)
        .at[ph.C["knee_2"]].set(ph.LATCHED)
        .at[ph.C["shank_1_strike"]].set(q_new[geo.SHANK_1])
        .at[ph.C["shank_2_strike"]].set(q_new[geo.SHANK_2])
    )  # fmt: skip
    return jnp.concatenate([q_new, qd[perm]]), ctx_new, shift


def _event_status(guard, q, qd, params, ctx, pulls, slides, buckles):
    """Status after ``guard`` fired (``IN_PROGRESS`` if the walk goes on); ``pulls``,
    ``slides``, ``buckles``: the impact's impulse checks (:func:`impulse_failures`),
    in the order of the force guards (a pulling contact, a pulled knee stop, a slide)."""
    is_ = lambda g: guard == g
    heel_velocity = jax.jvp(lambda q_: geo.free_foot(q_, params, 2)[0], (q,), (qd,))[1]
    status = jnp.select(
        [is_(FALL) | is_(LEG_RANGE), is_(STALL), is_(RUNNING), is_(SCUFF)],
        [jnp.int8(Status.FELL), jnp.int8(Status.STALLED), jnp.int8(Status.RUNNING), jnp.int8(Status.SCUFFING)],
        jnp.int8(Status.IN_PROGRESS),
    )
    released = is_(HEEL_STRIKE) & (ctx[ph.C["knee_2"]] == ph.RELEASED)
    status = jnp.where(released, jnp.int8(Status.SHANK_RELEASING), status)
    # The heel gate opened on a heel already below ground and rising: a scuff, not a strike.
    status = jnp.where(is_(HEEL_STRIKE) & (heel_velocity[1] >= 0.0), jnp.int8(Status.SCUFFING), status)
    status = jnp.where((status == Status.IN_PROGRESS) & pulls, jnp.int8(Status.RUNNING), status)
    status = jnp.where((status == Status.IN_PROGRESS) & buckles, jnp.int8(Status.KNEE_BUCKLED), status)
    status = jnp.where((status == Status.IN_PROGRESS) & slides, jnp.int8(Status.SLIPPING), status)
    status = jnp.select(
        [status != Status.IN_PROGRESS, is_(SLIP), is_(BUCKLE), is_(FOOT_ROLL)],
        [status, jnp.int8(Status.SLIPPING), jnp.int8(Status.KNEE_BUCKLED), jnp.int8(Status.FOOT_ROLLING)],
        status,
    )
    return status


def _next_flat_phase(guard, flat, extremum):
    """The phase after ``guard`` as the base walker has it, from the flat phase ``flat``."""
    is_ = lambda g: guard == g
    from_push_off = flat == ph.PUSH_OFF
    in_air = (flat == ph.SWING) | (flat == ph.LOCKED_SWING)
    return jnp.select(
        [is_(UNLOCK), is_(KNEE_FLEX), is_(TOE_OFF), is_(KNEE_STRIKE), is_(HEEL_STRIKE), extremum >= 0],
        [
            flat,
            jnp.where(from_push_off, ph.SHANK_RELEASE, ph.SWING),
            jnp.where(from_push_off, ph.LOCKED_SWING, ph.SWING),
            jnp.where(in_air, ph.LOCKED_SWING, ph.PUSH_OFF),
            ph.HEEL_PIVOT,
            flat,
        ],
        ph.PUSH_OFF,
    )


def _next_phase(model, guard, phase, extremum):
    """The phase after ``guard`` in ``phase``: leg 2's events keep a raised stance
    heel raised (the heel-up twin of the flat successor); :mod:`heel_rise`'s two
    events move between the twins."""
    following = _next_flat_phase(guard, ph.FLAT_PHASE[phase], extremum)
    twin = ph.HEEL_UP[phase] & (following >= ph.SWING) & (following <= ph.HEEL_PIVOT)
    following = jnp.where(twin, following + ph.HEEL_UP_OFFSET, following).astype(jnp.int32)
    return heel_rise.next_phase(guard, phase, following) if model.heel_rise else following


def on_event(model, guard, t, y, params, phase, ctx):
    """The reset after ``guard`` crossed zero in ``phase`` (see the module docstring)."""
    q, qd = model.split(y)
    is_ = lambda g: guard == g
    heel_pt, _ = geo.free_foot(q, params, 2)
    knee = ph.C["knee_2"]
    heel_code, toe_code = extremum_codes(model)
    extremum = jnp.select([is_(heel_code), is_(toe_code)], [0, 1], -1)
    ctx_new = jnp.select(
        [is_(UNLOCK), is_(KNEE_FLEX), is_(TOE_OFF), is_(KNEE_STRIKE), is_(HEEL_STRIKE), extremum >= 0],
        [
            _log(ctx, UNLOCK, t, "t_unlock").at[knee].set(ph.RELEASED),
            _log(ctx, KNEE_FLEX, t, "t_knee_flex"),
            _log(ctx, TOE_OFF, t, "t_toe_off"),
            _log(ctx, KNEE_STRIKE, t, "t_knee_strike").at[knee].set(_latch_after_strike(q, params, phase, ctx)),
            _log(ctx, HEEL_STRIKE, t, "t_heel_strike").at[ph.C["x_heel_2"]].set(heel_pt[0]),
            ctx,  # extrema of the swing foot's height are not logged: they are not phases
        ],
        _log(ctx, guard, t),
    )
    next_phase = _next_phase(model, guard, phase, extremum)

    # One impact, onto the constraints that hold after the event (none for the others).
    onto_next = is_(KNEE_STRIKE) | is_(HEEL_STRIKE)
    if model.heel_rise:
        onto_next = onto_next | is_(heel_rise.HEEL_DROP)
    mask = jnp.select(
        [onto_next, is_(TOE_STRIKE)], [ph.PHASE_MASKS[next_phase], ph.TOE_STRIKE_MASK], jnp.zeros(ph.N_CONSTRAINTS)
    )
    y_imp, impulses = model.apply_impact(y, params, ctx_new, mask)
    pulls, slides, buckles = impulse_failures(q, impulses, params, ctx_new)

    status = _event_status(guard, q, qd, params, ctx, pulls, slides, buckles)

    # Toe-strike ends the step: swap the legs and move the frame.
    done = is_(TOE_STRIKE)
    y_swap, ctx_swap, shift = swap_legs(y_imp, params, ctx_new)
    if model.heel_rise:
        ctx_swap = heel_rise.relax_trailing_spring(y_swap[:6], params, ctx_swap)
    y_next = jnp.where(done, y_swap, y_imp)
    ctx_next = jnp.where(done, ctx_swap, ctx_new)

    next_phase, ctx_next, guards = settle(model, t, y_next, params, next_phase, ctx_next)
    ctx_next = clearance.update(ctx_next, y_next, params, phase, next_phase, extremum, _ground_under)
    status = jnp.where(status == Status.IN_PROGRESS, entry_failure(guards, next_phase), status)
    # The new trailing foot leaves flat: its heel must rise, not sink (a double flat stance is not modelled).
    sinks = done & (next_phase == ph.PUSH_OFF) & trailing_heel_sinks(y_next, params, ctx_next)
    status = jnp.where((status == Status.IN_PROGRESS) & sinks, jnp.int8(Status.SCUFFING), status)

    ok = status == Status.IN_PROGRESS
    reset = forces.reset_work(q, ctx_new, y_swap[:6], ctx_swap, params, phase, model.heel_rise)
    return Transition(
        phase=jnp.where(ok, next_phase, phase).astype(jnp.int32),
        y=jnp.where(ok, y_next, y),
        ctx=jnp.where(ok, ctx_next, _log(ctx, guard, t)),
        status=status,
        step_done=done & ok,
        shift=jnp.where(done & ok, shift, 0.0),
        work=jnp.where(done & ok, reset, 0.0),
    )
