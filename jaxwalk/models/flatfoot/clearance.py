"""Minimum swing-foot clearance, tracked by events.

The swing foot's lowest points are its heel and toe (a straight bar through
the ankle). Their heights are smooth within a phase, so each minimum is a zero
of the height's rate. A guard ``dir * rate`` per point (``dir`` = +1 while the
point rises, -1 while it falls, kept in ``ctx``) crosses zero downward at every
extremum; the event flips ``dir`` and, at a minimum, folds the height above
the ground into ``ctx["min_clearance"]``. An impact (knee-strike) that turns a
falling point into a rising one is a minimum too. Lift-off and touchdown are
not minima of the swing: there the point is on the ground by construction.

``min_clearance`` is in leg lengths, negative below the ground; it reaches the
step result through ``ctx`` (:func:`min_clearance` reads it).
"""

from __future__ import annotations

import jax
import jax.numpy as jnp

from jaxwalk.models.flatfoot import geometry as geo
from jaxwalk.models.flatfoot import phases as ph

_DIRS = ("heel_dir", "toe_dir")


def in_air(phase):
    """True in the phases with foot 2 in the air (swing, locked swing and their heel-up twins)."""
    flat = ph.FLAT_PHASE[phase]
    return (flat == ph.SWING) | (flat == ph.LOCKED_SWING)


def heights(q, qd, params, ctx, ground_under):
    """``(2,)`` heel and toe heights above the ground below them, and ``(2,)`` their vertical rates."""

    def ys(q_):
        heel, toe = geo.free_foot(q_, params, 2)
        return jnp.stack([heel[1], toe[1]]), jnp.stack([heel[0], toe[0]])

    (y, x), (rate, _) = jax.jvp(ys, (q,), (qd,))
    ground = jnp.stack([ground_under(x[0], ctx, params), ground_under(x[1], ctx, params)])
    return y - ground, rate


def guards(q, qd, params, phase, ctx, ground_under):
    """``(2,)`` extremum guards of heel and toe (1 outside the swing phases)."""
    _, rate = heights(q, qd, params, ctx, ground_under)
    dirs = jnp.stack([ctx[ph.C[d]] for d in _DIRS])
    return jnp.where(in_air(phase), dirs * rate, 1.0)


def update(ctx, y, params, phase_before, phase_after, extremum, ground_under):
    """``ctx`` after an event: directions reset from the rates after it, minima recorded.

    ``extremum`` is 0 or 1 (heel or toe) when the event is that point's
    extremum, -1 otherwise. At the extremum the rate is zero, so the direction
    flips instead of being read off it.
    """
    q, qd = y[:6], y[6:]
    h, rate = heights(q, qd, params, ctx, ground_under)
    old = jnp.stack([ctx[ph.C[d]] for d in _DIRS])
    new = jnp.where(rate >= 0.0, 1.0, -1.0)
    which = jnp.arange(2)
    new = jnp.where(which == extremum, -old, new)
    # A minimum: a point falling before the event and rising after it, in the air throughout.
    minimum = in_air(phase_before) & in_air(phase_after) & (old < 0.0) & (new > 0.0)
    lowest = jnp.min(jnp.where(minimum, h, ph.NO_MINIMUM))
    ctx = ctx.at[ph.C["min_clearance"]].min(lowest)
    for i, d in enumerate(_DIRS):
        ctx = ctx.at[ph.C[d]].set(new[i])
    return ctx


def min_clearance(ctx):
    """The step's minimum swing clearance from a step result's ``ctx`` (NaN if none)."""
    value = ctx[..., ph.C["min_clearance"]]
    return jnp.where(value >= ph.NO_MINIMUM, jnp.nan, value)
