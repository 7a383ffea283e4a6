"""Forces of the flat-foot walker: ankle springs, hip torque, ground reactions.

Ankle springs are written as a potential of ``q``: a foot touching the ground has
its angle ``phi(q)`` fixed by contact (0 when flat, by the ankle's position when it
pivots on its heel or toe), so ``V = k/2 (shank - phi(q))^2`` and the generalized
spring force ``-dV/dq`` carries both the torque on the shank and the force the
massless foot passes to the ankle. A foot in the air sits at its relaxed angle
(``phi = shank``, turned toe-up by ``swing_dorsi``) and stores nothing; in heel
pivot the spring is relaxed at that landing angle.

The hip torque is a constant ``P`` between the thighs, ``+P`` on the swing thigh and
``-P`` on the stance thigh: the generalized force of the potential
``-P (thigh_2 - thigh_1)``, so within a step energy minus actuator work is conserved.
The hip spring (``k_hip``) is a potential like the ankle springs, in every phase.

The ankle push-off torque (``ankle_push``) is a second actuator: a constant torque
at the trailing ankle while its foot pivots on its toe (push-off, shank release),
acting with the ankle spring to turn the foot toe-down against the shank. It is the
force of the potential ``-ankle_push * deflection`` (the deflection the toe spring
stores), so its work is ``ankle_push`` times the change of that deflection.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp

from jaxwalk.models.flatfoot import geometry as geo
from jaxwalk.models.flatfoot import phases as ph


def _toe_deflection(ankle_2, shank_2, params, ctx):
    """The trailing ankle's deflection from relaxed while foot 2 pivots on its toe
    (rad; positive with the shank turned forward of the foot's perpendicular)."""
    _, toe_2, _, _ = ph.anchors(params, ctx)
    return shank_2 - geo.toe_pivot_angle(ankle_2, toe_2)


def _toe_spring(ankle_2, shank_2, params, ctx):
    return 0.5 * params["k"] * _toe_deflection(ankle_2, shank_2, params, ctx) ** 2


def _toe_push(ankle_2, shank_2, params, ctx):
    # The push-off torque's potential: it adds ankle_push to the spring's torque
    # k * deflection, as a spring relaxed ankle_push / k further toe-down would.
    return -params["ankle_push"] * _toe_deflection(ankle_2, shank_2, params, ctx)


def _toe_load(ankle_2, shank_2, params, ctx):
    """Everything the ankle feels from a toe-pivoting foot: spring and push-off torque."""
    return _toe_spring(ankle_2, shank_2, params, ctx) + _toe_push(ankle_2, shank_2, params, ctx)


def _heel_spring(ankle_2, shank_2, params, ctx):
    # Relaxed at the landing angle (shank + swing_dorsi), so heel-strike stores
    # nothing: the dorsiflexor that held the foot in the air yields with the
    # spring's stiffness until the foot is flat, and lets go at toe-strike (a loss).
    _, _, heel_2, _ = ph.anchors(params, ctx)
    rest = shank_2 + params["swing_dorsi"]
    return 0.5 * params["k"] * (rest - geo.heel_pivot_angle(ankle_2, heel_2)) ** 2


def spring_energy(q, params, phase, ctx):
    """Elastic energy of both ankle springs in ``phase`` (scalar).

    Leg 1 stands flat all step (``phi = 0``); leg 2 pivots on its toe in push-off
    and shank release, on its heel in heel pivot, and is relaxed in swing.
    """
    stance = 0.5 * params["k"] * q[geo.SHANK_1] ** 2
    ankle_2, shank_2 = geo.ankle(q, params, 2), q[geo.SHANK_2]
    trailing = jnp.where(
        ph.ON_TOE[phase],
        _toe_spring(ankle_2, shank_2, params, ctx),
        jnp.where(ph.ON_HEEL[phase], _heel_spring(ankle_2, shank_2, params, ctx), 0.0),
    )
    return stance + trailing + hip_spring_energy(q, params)


def hip_spring_energy(q, params):
    """Elastic energy of the hip spring, ``k_hip/2 (thigh_2 - thigh_1)^2``.

    Relaxed with the thighs together, so it is the same before and after the
    legs swap: it stores and returns energy within a step and does no net work.
    """
    return 0.5 * params["k_hip"] * (q[geo.THIGH_2] - q[geo.THIGH_1]) ** 2


def hip_torque(q, params):
    """Generalized force of the hip actuator, ``(n_q,)``."""
    P = params["P"]
    return jnp.zeros_like(q).at[geo.THIGH_2].set(P).at[geo.THIGH_1].set(-P)


def push_potential(q, params, phase, ctx):
    """Potential of the ankle push-off torque in ``phase`` (scalar; 0 off the toe).

    Not stored energy: an actuator's, so its change is the actuator's work
    (:func:`actuator_work`), not part of the walker's energy.
    """
    ankle_2, shank_2 = geo.ankle(q, params, 2), q[geo.SHANK_2]
    return jnp.where(ph.ON_TOE[phase], _toe_push(ankle_2, shank_2, params, ctx), 0.0)


def joint_forces(q, params, phase, ctx):
    """Springs (``-dV/dq``) plus hip torque and ankle push-off torque, ``(n_q,)``."""
    spring = -jax.grad(spring_energy)(q, params, phase, ctx)
    push = -jax.grad(push_potential)(q, params, phase, ctx)
    return spring + push + hip_torque(q, params)


def actuator_power(q, qd, params, phase, ctx):
    """Power of the hip and ankle actuators: ``P (thigh_2_dot - thigh_1_dot)`` plus
    the push-off torque's ``-d(push_potential)/dt``."""
    push = -jax.jvp(lambda q_: push_potential(q_, params, phase, ctx), (q,), (qd,))[1]
    return params["P"] * (qd[geo.THIGH_2] - qd[geo.THIGH_1]) + push


def actuator_work(q_start, q_end, params, phase, ctx):
    """Work of the hip and ankle actuators between two configurations of one phase."""
    spread = lambda q: q[geo.THIGH_2] - q[geo.THIGH_1]
    hip = params["P"] * (spread(q_end) - spread(q_start))
    push = push_potential(q_start, params, phase, ctx) - push_potential(q_end, params, phase, ctx)
    return hip + push


def _pivot_reaction(multiplier, ankle_2, shank_2, params, ctx, anchor, spring):
    """Ground force on a foot pivoting about ``anchor``: the force its ankle feels.

    The massless foot passes to the ankle the constraint force (``multiplier``
    along the foot) plus the spring's reaction (``-dV/d ankle``, across the foot),
    and the ground must supply the same force at the contact point.
    """
    radial = jax.grad(lambda a: jnp.linalg.norm(a - anchor))(ankle_2)
    across = -jax.grad(spring)(ankle_2, shank_2, params, ctx)
    return multiplier * radial + across


def contact_reactions(q, lam, params, phase, ctx):
    """Ground reactions (slope frame; y is the normal force, positive pushing up).

    Args:
        q: ``(n_q,)`` configuration; ``lam``: ``(n_c,)`` multipliers from
            ``Walker.dynamics`` in ``phase``.

    Returns:
        ``(stance, cop, toe_2, heel_2)``: the force on foot 1 ``(2,)``, its centre
        of pressure measured forward from the ankle (scalar; must lie in
        ``[-a_h, a_t]`` for the foot to stay flat), and the forces on the toe and
        heel of foot 2 ``(2,)`` each, zero when not in contact.
    """
    stance = jnp.stack([lam[ph.ANKLE_1_X], lam[ph.ANKLE_1_Y]])
    # Moment balance of the flat massless foot about its ankle: the spring's
    # torque on the foot, k (shank_1 - 0), is held by the normal force at the CoP.
    cop = -params["k"] * q[geo.SHANK_1] / stance[1]
    ankle_2, shank_2 = geo.ankle(q, params, 2), q[geo.SHANK_2]
    _, toe_2, heel_2, _ = ph.anchors(params, ctx)
    toe = _pivot_reaction(lam[ph.TOE_2], ankle_2, shank_2, params, ctx, toe_2, _toe_load)
    heel = _pivot_reaction(lam[ph.HEEL_2], ankle_2, shank_2, params, ctx, heel_2, _heel_spring)
    toe = jnp.where(ph.ON_TOE[phase], toe, 0.0)
    heel = jnp.where(ph.ON_HEEL[phase], heel, 0.0)
    return stance, cop, toe, heel
