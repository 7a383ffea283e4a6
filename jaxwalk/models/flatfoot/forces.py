"""Forces of the flat-foot walker: ankle springs, hip torque, ground reactions.

Ankle springs are written as a potential of ``q``: a foot touching the ground has
its angle ``phi(q)`` fixed by contact (0 when flat, by the ankle's position when it
pivots on its heel or toe), so ``V = k/2 (shank - phi(q) - rest)^2`` and the
generalized spring force ``-dV/dq`` carries both the torque on the shank and the
force the massless foot passes to the ankle. A standing foot's ``rest`` is
:func:`rest_angles`' (0 at the defaults: the shank perpendicular to the foot). A
foot in the air sits at its relaxed angle (``phi = shank``, turned toe-up by
``swing_dorsi``) and stores nothing; in heel pivot the spring is relaxed at that
landing angle.

The hip torque is a constant ``P`` between the thighs, ``+P`` on the swing thigh and
``-P`` on the stance thigh: the generalized force of the potential
``-P (thigh_2 - thigh_1)``, so within a step energy minus actuator work is conserved.
The hip spring (``k_hip``) is a potential like the ankle springs, in every phase.
The swing torque (``swing_torque``) adds to ``P`` in phase ``swing`` and its heel-up
twin (foot 2 in the air, its knee free: from toe-off to knee-strike, or to
heel-strike where the knee has not locked): constant within its phase, so again
the force of a potential, and its work is counted with the hip torque's.

While both feet touch the ground (push-off, shank release, heel pivot) only the
fraction ``hip_double_support`` of the hip torque and of the hip spring's force
acts (default 1: all of it). The spring's energy is stored in full in every phase
(so no event changes it); the part withheld in double support is an actuator
holding the spring back, whose potential is ``-(1 - g) k_hip/2 (thigh_2 - thigh_1)^2``
and whose work is counted with the hip torque's.

The ankle push-off torque (``ankle_push``) is a second actuator: a constant torque
at the trailing ankle while its foot pivots on its toe (push-off, shank release),
acting with the ankle spring to turn the foot toe-down against the shank. It is the
force of the potential ``-ankle_push * deflection`` (the deflection the toe spring
stores), so its work is ``ankle_push`` times the change of that deflection.
The heel-brake torque (``heel_brake``) is its counterpart on the landing foot: a
constant dorsiflexor torque while foot 2 pivots on its heel, resisting the
foot's fall to flat, the potential ``heel_brake * stretch`` of the heel spring's
stretch. Both load their contact: the ground forces include them.

In the heel-rise walker's heel-up phases (:data:`phases.HEEL_UP`) the stance
foot pivots on its toe, and its spring is the same potential with ``phi_1`` the
toe-pivot angle of ankle 1; no actuator acts at the stance ankle.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp

from jaxwalk.models.flatfoot import geometry as geo
from jaxwalk.models.flatfoot import phases as ph


def rest_angles(params, ctx):
    """``(stance, trailing)``: the shank angles from the foot's perpendicular (rad)
    at which the ankle springs of foot 1 (standing) and foot 2 (on its toe) are relaxed.

    ``ankle_rest`` plus ``ankle_reset`` times the leg's ankle angle at the
    step's toe-strike (``ctx``: the shank's angle, less the foot's where the
    heel-rise walker's trailing foot stands raised), for the trailing spring times ``trailing_reset``
    as well: with ``ankle_reset = 1`` and ``ankle_rest = 0`` both springs start
    the step relaxed (``trailing_reset = 1``, the default), or only the stance
    spring (``trailing_reset = 0``: the trailing spring is relaxed at
    ``ankle_rest``, so it keeps the part of what it stored in stance that lies
    beyond that angle). Both angles are functions of the state at the section,
    so the section stays as it is. Moving a rest angle at toe-strike changes
    the energy the spring holds there: with ``ankle_reset = 1`` the trailing
    leg's spring lets go of what it stored in stance, energy a push-off would
    have used (:func:`reset_work` counts what a move winds up).
    """
    reset = params["ankle_reset"]
    return (params["ankle_rest"] + reset * ctx[ph.C["shank_1_strike"]],
            params["ankle_rest"] + reset * params["trailing_reset"] * ctx[ph.C["shank_2_strike"]])


def _toe_deflection(ankle_2, shank_2, params, ctx):
    """The trailing ankle's deflection from relaxed while foot 2 pivots on its toe
    (rad; positive with the shank turned back, ankle ahead of knee, from its
    rest angle on the foot, :func:`rest_angles`)."""
    _, toe_2, _, _ = ph.anchors(params, ctx)
    return shank_2 - geo.toe_pivot_angle(ankle_2, toe_2) - rest_angles(params, ctx)[1]


def _stance_toe_deflection(ankle_1, shank_1, params, ctx):
    """The stance ankle's deflection while foot 1 pivots on its toe (heel up; rad,
    positive with the shank turned back from its rest angle on the foot)."""
    toe_1, _, _, _ = ph.anchors(params, ctx)
    return shank_1 - geo.toe_pivot_angle(ankle_1, toe_1) - rest_angles(params, ctx)[0]


def _stance_toe_spring(ankle_1, shank_1, params, ctx):
    return 0.5 * params["k"] * _stance_toe_deflection(ankle_1, shank_1, params, ctx) ** 2


def _stance_deflection(q, params, phase, ctx, heel_rise):
    """The stance ankle's deflection in ``phase``: foot 1 flat, or on its toe where
    the heel is up (only in the heel-rise walker, ``heel_rise``: a Python bool, so
    the base walker's programs hold no toe branch)."""
    flat = q[geo.SHANK_1] - rest_angles(params, ctx)[0]
    if not heel_rise:
        return flat
    on_toe = _stance_toe_deflection(geo.ankle(q, params, 1), q[geo.SHANK_1], params, ctx)
    return jnp.where(ph.HEEL_UP[phase], on_toe, flat)


def _toe_spring(ankle_2, shank_2, params, ctx):
    return 0.5 * params["k"] * _toe_deflection(ankle_2, shank_2, params, ctx) ** 2


def _toe_push(ankle_2, shank_2, params, ctx):
    # The push-off torque's potential: it adds ankle_push to the spring's torque
    # k * deflection, as a spring relaxed ankle_push / k further toe-down would.
    return -params["ankle_push"] * _toe_deflection(ankle_2, shank_2, params, ctx)


def _toe_load(ankle_2, shank_2, params, ctx):
    """Everything the ankle feels from a toe-pivoting foot: spring and push-off torque."""
    return _toe_spring(ankle_2, shank_2, params, ctx) + _toe_push(ankle_2, shank_2, params, ctx)


def _heel_stretch(ankle_2, shank_2, params, ctx):
    """The landing ankle's deflection from its landing angle while foot 2 pivots on
    its heel (rad; grows as the foot falls toward flat)."""
    _, _, heel_2, _ = ph.anchors(params, ctx)
    rest = shank_2 + params["swing_dorsi"]
    return rest - geo.heel_pivot_angle(ankle_2, heel_2)


def _heel_spring(ankle_2, shank_2, params, ctx):
    # Relaxed at the landing angle (shank + swing_dorsi), so heel-strike stores
    # nothing: the dorsiflexor that held the foot in the air yields with the
    # spring's stiffness until the foot is flat, and lets go at toe-strike (a loss).
    return 0.5 * params["k"] * _heel_stretch(ankle_2, shank_2, params, ctx) ** 2


def _heel_brake(ankle_2, shank_2, params, ctx):
    # The heel-brake torque's potential: it adds heel_brake to the spring's torque
    # k * stretch, resisting the foot's fall from the first instant of heel pivot.
    return params["heel_brake"] * _heel_stretch(ankle_2, shank_2, params, ctx)


def _heel_load(ankle_2, shank_2, params, ctx):
    """Everything the ankle feels from a heel-pivoting foot: spring and heel-brake torque."""
    return _heel_spring(ankle_2, shank_2, params, ctx) + _heel_brake(ankle_2, shank_2, params, ctx)


def ankle_deflections(q, params, phase, ctx, heel_rise=False):
    """``(stance, trailing)``: how far foot 1's and foot 2's ankle springs are turned
    from relaxed in ``phase`` (rad; ``shank - phi - rest``, positive with the shank
    turned back; 0 for a foot in the air).

    Leg 1 stands flat (``phi = 0``) or, heel up, on its toe; leg 2 pivots on its toe in push-off
    and shank release, on its heel in heel pivot (relaxed at its landing angle,
    ``rest = -swing_dorsi``), and is relaxed in swing. A foot standing on the
    ground (flat or on its toe) is relaxed at its :func:`rest_angles` (the
    defaults: the shank perpendicular to the foot). ``heel_rise`` (Python bool):
    the heel-rise walker's phases, where the stance foot may stand on its toe.
    """
    stance = _stance_deflection(q, params, phase, ctx, heel_rise)
    ankle_2, shank_2 = geo.ankle(q, params, 2), q[geo.SHANK_2]
    trailing = jnp.where(
        ph.ON_TOE[phase],
        _toe_deflection(ankle_2, shank_2, params, ctx),
        jnp.where(ph.ON_HEEL[phase], _heel_stretch(ankle_2, shank_2, params, ctx), 0.0),
    )
    return stance, trailing


def spring_energy(q, params, phase, ctx, heel_rise=False):
    """Elastic energy of both ankle springs (``k/2`` times their :func:`ankle_deflections`
    squared) and the hip spring in ``phase`` (scalar)."""
    stance = 0.5 * params["k"] * _stance_deflection(q, params, phase, ctx, heel_rise) ** 2
    ankle_2, shank_2 = geo.ankle(q, params, 2), q[geo.SHANK_2]
    trailing = jnp.where(
        ph.ON_TOE[phase],
        _toe_spring(ankle_2, shank_2, params, ctx),
        jnp.where(ph.ON_HEEL[phase], _heel_spring(ankle_2, shank_2, params, ctx), 0.0),
    )
    return stance + trailing + hip_spring_energy(q, params)


def reset_work(q_before, ctx_before, q_after, ctx_after, params, phase_before, heel_rise=False):
    """Work (>= 0, ``M g L``) an actuator must do on the ankle springs at toe-strike.

    At toe-strike each ankle spring changes its role at a fixed configuration:
    the landing foot's, relaxed at its landing angle in heel pivot, becomes the
    stance spring relaxed at its rest angle, and the stance foot's becomes the
    trailing toe's, whose rest angle moves with ``ankle_reset``
    (:func:`rest_angles`). Each change is a move of the spring's relaxed angle
    past a still foot: the energy a spring lets go on the way is lost (as an
    impact's loss is), the energy it is wound up with is an actuator's work,
    counted here rather than hidden in the event's energy balance. A move that
    takes the relaxed angle through the foot's angle (the deflection changes
    sign) lets all the energy go first and winds the spring from slack, so its
    work is the energy after; otherwise the rise, if any: the least positive
    work of any move between the two (docs/model.md, "Forces"). 0 at the
    defaults' gaits; positive wherever ``ankle_rest`` turns a standing spring
    past the foot's angle, and with ``ankle_reset = 1`` at every ``ankle_rest > 0``.

    Args:
        q_before: ``(n_q,)`` the configuration at toe-strike before the legs swap
            (heel pivot, discrete state ``ctx_before``); ``q_after``: the same
            configuration after the swap (push-off, ``ctx_after``).
        phase_before: the phase toe-strike ended (``heel_pivot``, or the heel-rise
            walker's ``heel_pivot_heel_up``, whose stance spring is on its toe;
            ``heel_rise``, a Python bool, says which walker).
        params: the walker's parameters (``k`` and the rest angles' options).
    """
    stance_before, landing_before = ankle_deflections(q_before, params, phase_before, ctx_before, heel_rise)
    stance_after, trailing_after = ankle_deflections(q_after, params, ph.PUSH_OFF, ctx_after)

    def wound(before, after):
        kept = jnp.where(before * after > 0.0, before**2, 0.0)  # through slack: nothing kept
        return 0.5 * params["k"] * jnp.maximum(after**2 - kept, 0.0)

    # The legs swap: the old stance spring trails, the landing spring stands.
    return wound(stance_before, trailing_after) + wound(landing_before, stance_after)


def hip_spring_energy(q, params):
    """Elastic energy of the hip spring, ``k_hip/2 (thigh_2 - thigh_1)^2``.

    Relaxed with the thighs together, so it is the same before and after the
    legs swap: it stores and returns energy within a step and does no net work.
    """
    return 0.5 * params["k_hip"] * (q[geo.THIGH_2] - q[geo.THIGH_1]) ** 2


def hip_gain(params, phase):
    """Fraction of the hip torque and hip spring force acting in ``phase`` (scalar):
    1 with foot 2 in the air, ``hip_double_support`` while both feet touch the ground."""
    both_down = ph.ON_TOE[phase] | ph.ON_HEEL[phase]
    return jnp.where(both_down, params["hip_double_support"], 1.0)


def ankle_potential(q, params, phase, ctx):
    """Potential of the trailing ankle's actuators in ``phase`` (scalar): the push-off
    torque on the toe, the heel-brake torque on the heel, 0 in the air."""
    ankle_2, shank_2 = geo.ankle(q, params, 2), q[geo.SHANK_2]
    return jnp.where(
        ph.ON_TOE[phase],
        _toe_push(ankle_2, shank_2, params, ctx),
        jnp.where(ph.ON_HEEL[phase], _heel_brake(ankle_2, shank_2, params, ctx), 0.0),
    )


def actuator_potential(q, params, phase, ctx):
    """Potential of every actuator in ``phase`` (scalar): the hip torque
    ``-(g P + b) (thigh_2 - thigh_1)`` (``b`` = ``swing_torque`` in phase ``swing``
    and its twin, else 0), the hold on the hip spring ``-(1 - g) V_hip``
    (``g`` = :func:`hip_gain`) and the ankle's push-off and heel-brake torques.

    Not stored energy: its force is the actuators', and its decrease over a phase
    is their work (:func:`actuator_work`), not part of the walker's energy.
    """
    g = hip_gain(params, phase)
    torque = g * params["P"] + jnp.where(ph.FLAT_PHASE[phase] == ph.SWING, params["swing_torque"], 0.0)
    hip = -torque * (q[geo.THIGH_2] - q[geo.THIGH_1])
    hold = -(1.0 - g) * hip_spring_energy(q, params)
    return hip + hold + ankle_potential(q, params, phase, ctx)


def joint_forces(q, params, phase, ctx, heel_rise=False):
    """Springs (``-dV/dq``) plus the actuators (``-dU/dq``, :func:`actuator_potential`), ``(n_q,)``."""
    spring = -jax.grad(lambda q_: spring_energy(q_, params, phase, ctx, heel_rise))(q)
    actuators = -jax.grad(actuator_potential)(q, params, phase, ctx)
    return spring + actuators


def actuator_power(q, qd, params, phase, ctx):
    """Power of the hip and ankle actuators, ``-dU/dt`` (:func:`actuator_potential`)."""
    return -jax.jvp(lambda q_: actuator_potential(q_, params, phase, ctx), (q,), (qd,))[1]


def actuator_work(q_start, q_end, params, phase, ctx):
    """Work of the hip and ankle actuators between two configurations of one phase."""
    return actuator_potential(q_start, params, phase, ctx) - actuator_potential(q_end, params, phase, ctx)


def _pivot_reaction(multiplier, ankle_2, shank_2, params, ctx, anchor, spring):
    """Ground force on a foot pivoting about ``anchor``: the force its ankle feels.

    The massless foot passes to the ankle the constraint force (``multiplier``
    along the foot) plus the spring's reaction (``-dV/d ankle``, across the foot),
    and the ground must supply the same force at the contact point.
    """
    radial = jax.grad(lambda a: jnp.linalg.norm(a - anchor))(ankle_2)
    across = -jax.grad(spring)(ankle_2, shank_2, params, ctx)
    return multiplier * radial + across


def stance_ankle_torque(q, params, ctx):
    """Moment about the stance ankle that foot 1's normal force must supply
    (scalar, ``M g L``; forward positive): ``N * cop``.

    Moment balance of the flat massless foot: the ankle spring's torque on it,
    ``k (shank_1 - rest)`` (:func:`rest_angles`), is held by the normal force
    acting at the centre of pressure, so ``N cop = -k (shank_1 - rest)``.
    """
    return -params["k"] * (q[geo.SHANK_1] - rest_angles(params, ctx)[0])


def contact_reactions(q, lam, params, phase, ctx, heel_rise=False):
    """Ground reactions (slope frame; y is the normal force, positive pushing up).

    Args:
        q: ``(n_q,)`` configuration; ``lam``: ``(n_c,)`` multipliers from
            ``Walker.dynamics`` in ``phase``.

    Returns:
        ``(stance, cop, toe_2, heel_2)``: the force on foot 1 ``(2,)``, its centre
        of pressure measured forward from the ankle (scalar; must lie in
        ``[-a_h, a_t]`` for the foot to stay flat; ``a_t`` with the heel up, the
        force then being the toe's), and the forces on the toe and heel of foot 2
        ``(2,)`` each, zero when not in contact. ``heel_rise`` (Python bool): the
        heel-rise walker, whose stance foot may stand on its toe.
    """
    toe_1, toe_2, heel_2, _ = ph.anchors(params, ctx)
    stance = jnp.stack([lam[ph.ANKLE_1_X], lam[ph.ANKLE_1_Y]])
    cop = stance_ankle_torque(q, params, ctx) / stance[1]
    if heel_rise:
        heel_up = ph.HEEL_UP[phase]
        on_toe = _pivot_reaction(
            lam[ph.TOE_1], geo.ankle(q, params, 1), q[geo.SHANK_1], params, ctx, toe_1, _stance_toe_spring
        )
        stance = jnp.where(heel_up, on_toe, stance)
        cop = jnp.where(heel_up, geo.foot_arms(params)[1], stance_ankle_torque(q, params, ctx) / stance[1])
    ankle_2, shank_2 = geo.ankle(q, params, 2), q[geo.SHANK_2]
    toe = _pivot_reaction(lam[ph.TOE_2], ankle_2, shank_2, params, ctx, toe_2, _toe_load)
    heel = _pivot_reaction(lam[ph.HEEL_2], ankle_2, shank_2, params, ctx, heel_2, _heel_load)
    toe = jnp.where(ph.ON_TOE[phase], toe, 0.0)
    heel = jnp.where(ph.ON_HEEL[phase], heel, 0.0)
    return stance, cop, toe, heel
