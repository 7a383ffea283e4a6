"""The heel-rise walker's two events: the stance heel rising and dropping back.

In the heel-rise walker (``flatfoot_heel_rise``, docs/model.md "The heel-rise
walker") the flat stance foot tips onto its toe when its centre of pressure
reaches the toe in swing, locked swing or heel pivot, instead of the step ending
``FOOT_ROLLING``:

* ``heel_rise`` (the toe side of ``foot_roll``, ``a_t N - tau``): the phase goes
  to its heel-up twin, with no impact (ankle 1 is at rest as it starts to lift,
  so the velocity already satisfies the toe circle).
* ``heel_drop`` (ankle 1's height, gated on it falling): back to the flat phase
  through an inelastic impact onto ankle 1's pin.

No entry check is needed: at the crossing the toe circle's multiplier is
horizontal (the foot is flat), so ankle 1's vertical force is the spring's
reaction across the foot, ``tau / a_t``, where the pin supplied ``N``; its
vertical acceleration in the twin has the sign of ``tau / a_t - N``, that is
of ``-heel_rise``: zero at the crossing and positive after it (and positive on
entering with the guard already below zero). The tests check that the heel rises.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp

from jaxwalk.models.flatfoot import geometry as geo
from jaxwalk.models.flatfoot import phases as ph

#: Guard codes of the two events (below 16: the event log is base 16); the
#: swing foot's extremum guards, never logged, follow them.
HEEL_RISE, HEEL_DROP = 14, 15
NAMES = ("heel_rise", "heel_drop")
#: Leg lengths below its toe at which the trailing ankle counts as sunk into the
#: floor. A flat trailing foot's ankle is the last step's stance ankle, held at the
#: ground only as closely as the integrator keeps its pin (8.2e-11 below it at the
#: shoe gait's toe-strike; 2.2e-10 above in the SciPy reference), and push-off's
#: guards are checked on entry at toe-strike with no margin; 1e-6 leaves that drift
#: four orders of room and counts a micrometre-deep start as flat.
SUNK_TOL = 1e-6


def _may_rise(phase):
    """Phases whose stance foot may tip onto its toe: swing, locked swing, heel pivot (flat)."""
    return (phase == ph.SWING) | (phase == ph.LOCKED_SWING) | (phase == ph.HEEL_PIVOT)


def _ankle_1_height_and_rate(q, qd, params):
    return jax.jvp(lambda q_: geo.ankle(q_, params, 1)[1], (q,), (qd,))


def guards(q, qd, params, phase, toe_margin, heel_margin):
    """``(foot_roll, heel_rise, heel_drop)`` of the heel-rise walker in ``phase``.

    Args:
        toe_margin, heel_margin: ``a_t N - tau`` and ``tau + a_h N`` of the flat
            stance foot (the two sides of the base walker's ``foot_roll``).

    ``foot_roll`` keeps both sides in push-off and shank release, only the heel
    side where the heel may rise, and is 1 with the heel up (a foot on its toe
    has no centre of pressure to move).
    """
    one = jnp.ones_like(toe_margin)
    heel_up = ph.HEEL_UP[phase]
    may_rise = _may_rise(phase)
    foot_roll = jnp.where(heel_up, one, jnp.where(may_rise, heel_margin, jnp.minimum(toe_margin, heel_margin)))
    heel_rise = jnp.where(may_rise, toe_margin, one)
    height, rate = _ankle_1_height_and_rate(q, qd, params)
    heel_drop = jnp.where(heel_up & (rate < 0.0), height, one)
    return foot_roll, heel_rise, heel_drop


def next_phase(guard, phase, next_phase_):
    """The phase after ``guard``: a twin on ``heel_rise``, the flat phase on ``heel_drop``."""
    return jnp.select(
        [guard == HEEL_RISE, guard == HEEL_DROP],
        [phase + ph.HEEL_UP_OFFSET, phase - ph.HEEL_UP_OFFSET],
        next_phase_,
    ).astype(jnp.int32)


def relax_trailing_spring(q, params, ctx):
    """``ctx`` with the trailing spring's toe-strike angle taken as its ankle angle.

    ``ankle_reset`` relaxes a standing spring at the leg's angle at toe-strike
    (:func:`forces.rest_angles`); the base walker's trailing foot is flat there,
    so that is the shank's angle. A foot raised on its toe sits at its toe-pivot
    angle, so the ankle's angle is the shank's less the foot's, and the spring
    starts the step relaxed as it does in the base walker.
    """
    _, toe_2, _, _ = ph.anchors(params, ctx)
    angle = q[geo.SHANK_2] - geo.toe_pivot_angle(geo.ankle(q, params, 2), toe_2)
    return ctx.at[ph.C["shank_2_strike"]].set(angle)


def trailing_heel_landing(q, qd, params, phase, ctx):
    """The raised trailing foot's height to flat (leg lengths), in push-off and shank
    release (1 elsewhere): ankle 2's height above its toe, while it falls or is below
    the toe.

    A foot pivoting toe-down on its toe has its heel above the ground; the heel
    lands when the ankle comes down to the toe's height, and the step ends
    ``SCUFFING`` there (a double flat stance is not modelled). The base walker's
    trailing foot starts flat and must rise at once (``events.trailing_heel_sinks``);
    this walker's may start raised.

    Below the toe (by more than :data:`SUNK_TOL`) the guard is active whichever way
    the ankle moves: a section point with the trailing heel in the floor (the
    section's formulas continue there, docs/model.md) starts with this guard below
    zero, and the engine ends such a step at its start, ``SCUFFING`` (unless a
    failure earlier in the model's order is due there too, or the trailing toe
    lifts at once, leaving push-off). A flat trailing foot, at zero height to the
    integrator's drift, keeps it inactive.
    """
    _, toe_2, _, _ = ph.anchors(params, ctx)
    height, rate = jax.jvp(lambda q_: geo.ankle(q_, params, 2)[1], (q,), (qd,))
    above_toe = height - toe_2[1]
    watched = (rate < 0.0) | (above_toe < -SUNK_TOL)
    return jnp.where(ph.ON_TOE[phase] & watched, above_toe, jnp.ones_like(height))
