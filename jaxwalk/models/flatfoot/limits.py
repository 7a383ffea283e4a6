"""How much of each contact limit the flat-foot walker uses (``Walker.limit_use``).

The failure guards ``slip`` and ``foot_roll`` (:mod:`events`) each take the least
of several limits, so a step that ends ``SLIPPING`` or ``FOOT_ROLLING`` does not
say which contact left its cone, nor over which edge the foot rolls. Sampled
along a recorded walk (``jaxwalk simulate``), these ratios do: each is 1 exactly
where its part of the guard is zero.

* ``stance_friction``: ``|T| / (mu N)`` of the flat stance foot's ground force.
* ``heel_friction``: the same for the landing heel (heel pivot only).
* ``cop_toe``: the stance foot's centre of pressure ahead of its ankle, as a
  fraction of the toe arm ``a_t`` (1: the foot tips onto its toe; NaN while
  the heel-rise walker's stance heel is up, as ``cop_heel``).
* ``cop_heel``: the centre of pressure behind the ankle, as a fraction of the
  heel arm ``a_h`` (1: the foot tips onto its heel).

The trailing toe's friction is not among them: the toe leaves the ground when
its force reaches the cone's edge (``toe_off``), a transition, not a failure.
Where a contact's normal force does not push (``N <= 0``, the ``running``
guard's failure, or a landing heel that pulls) its limits read ``inf``.
"""

from __future__ import annotations

import jax.numpy as jnp

from jaxwalk.models.flatfoot import forces
from jaxwalk.models.flatfoot import geometry as geo
from jaxwalk.models.flatfoot import phases as ph

LIMIT_NAMES = ("stance_friction", "heel_friction", "cop_toe", "cop_heel")


def _ratio(load, capacity):
    """``load / capacity`` for a capacity that must be positive (``inf`` where it is not)."""
    safe = jnp.where(capacity > 0.0, capacity, 1.0)
    return jnp.where(capacity > 0.0, load / safe, jnp.inf)


def limit_use(model, y, params, phase, ctx):
    """``(4,)`` use of the limits :data:`LIMIT_NAMES` in ``(y, phase, ctx)`` (1: at the edge)."""
    q, _ = model.split(y)
    _, lam = model.dynamics(y, params, phase, ctx)
    stance, _, _, heel = forces.contact_reactions(q, lam, params, phase, ctx, model.heel_rise)
    a_h, a_t = geo.foot_arms(params)
    mu = params["mu"]
    # Moment form, as the foot_roll guard: tau = N * cop.
    tau = forces.stance_ankle_torque(q, params, ctx)
    heel_friction = jnp.where(ph.ON_HEEL[phase], _ratio(jnp.abs(heel[0]), mu * heel[1]), jnp.nan)
    flat = ~ph.HEEL_UP[phase]  # a foot on its toe has no centre of pressure to move
    return jnp.stack(
        [
            _ratio(jnp.abs(stance[0]), mu * stance[1]),
            heel_friction,
            jnp.where(flat, _ratio(tau, a_t * stance[1]), jnp.nan),
            jnp.where(flat, _ratio(-tau, a_h * stance[1]), jnp.nan),
        ]
    )
