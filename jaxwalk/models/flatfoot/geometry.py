"""Geometry of the flat-foot walker: segments, point masses and feet.

Generalized coordinates ``q = (x_h, y_h, thigh_1, shank_1, thigh_2, shank_2)``:
the hip in the slope frame, then absolute segment angles from the slope normal,
positive when the segment's distal end lies ahead of its proximal end (the
engine's convention). A segment of length ``l`` at angle ``a`` runs from its top
``p`` to ``p + l (sin a, -cos a)``.

Knee flexion is ``thigh - shank`` (positive when the shank folds back). A locked
knee holds the flexion at ``knee_lock`` (the flexion at which it locked).

Feet are massless rigid bars through the ankle (zero ankle height). The foot
angle ``phi`` is measured from the slope surface, positive toe-up; the foot's
heel-to-toe direction is ``(cos phi, sin phi)``. The heel lies
``a_h = l_f r / (1 + r)`` behind the ankle and the toe ``a_t = l_f / (1 + r)``
ahead of it. ``phi`` is not a coordinate: it is 0 for a flat foot, fixed by the
ankle's position for a foot pivoting on its heel or toe, and in swing equal to
the shank angle plus ``swing_dorsi`` (perpendicular to the shank, turned toe-up
by a dorsiflexion angle; the foot is massless, so this costs no dynamics).

All lengths in units of the leg length L, masses in units of the total mass M.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp

from jaxwalk.walker import distal as distal  # the engine's convention, (sin a, -cos a)

Array = jax.Array

# Indices into q.
X_H, Y_H, THIGH_1, SHANK_1, THIGH_2, SHANK_2 = range(6)
THIGH = {1: THIGH_1, 2: THIGH_2}
SHANK = {1: SHANK_1, 2: SHANK_2}

#: Names of the point masses, in the order of :func:`points`. Each segment is two
#: half masses at ``c l +- rho l`` along it: the same mass, centre of mass and
#: moment of inertia ``m (rho l)^2`` about that centre as a rigid segment with
#: radius of gyration ``rho l`` (exact for planar rigid bodies; ``rho = 0`` is
#: the paper's point mass).
POINT_NAMES = (
    "hip",
    "thigh_1_a", "thigh_1_b", "shank_1_a", "shank_1_b", "foot_1",
    "thigh_2_a", "thigh_2_b", "shank_2_a", "shank_2_b", "foot_2",
)  # fmt: skip


def foot_direction(phi: Array) -> Array:
    """Unit vector from heel to toe of a foot at angle ``phi``."""
    return jnp.stack([jnp.cos(phi), jnp.sin(phi)])


def foot_arms(params) -> tuple[Array, Array]:
    """``(a_h, a_t)``: ankle-to-heel and ankle-to-toe distances from ``l_f`` and ``r``."""
    l_f, r = params["l_f"], params["r"]
    return l_f * r / (1.0 + r), l_f / (1.0 + r)


def knee(q: Array, params, leg: int) -> Array:
    return q[:2] + params["l_t"] * distal(q[THIGH[leg]])


def ankle(q: Array, params, leg: int) -> Array:
    return knee(q, params, leg) + params["l_s"] * distal(q[SHANK[leg]])


def flexion(q: Array, leg: int) -> Array:
    """Knee flexion ``thigh - shank`` (rad)."""
    return q[THIGH[leg]] - q[SHANK[leg]]


def points(q: Array, params) -> Array:
    """``(11, 2)`` positions of the point masses, in the order of :data:`POINT_NAMES`."""
    hip = q[:2]
    out = [hip]
    l_t, l_s = params["l_t"], params["l_s"]
    g_t, g_s = params["rho_t"] * l_t, params["rho_s"] * l_s
    for leg in (1, 2):
        thigh_dir, shank_dir = distal(q[THIGH[leg]]), distal(q[SHANK[leg]])
        knee_ = hip + l_t * thigh_dir
        c_thigh = hip + params["c_t"] * l_t * thigh_dir
        c_shank = knee_ + params["c_s"] * l_s * shank_dir
        out += [
            c_thigh - g_t * thigh_dir,
            c_thigh + g_t * thigh_dir,
            c_shank - g_s * shank_dir,
            c_shank + g_s * shank_dir,
            knee_ + l_s * shank_dir,
        ]
    return jnp.stack(out)


def chain_weights(params) -> Array:
    """``(11, 4)`` :func:`points` as ``hip + S (sin a, -cos a)`` over the angles
    ``(thigh_1, shank_1, thigh_2, shank_2)`` (:mod:`jaxwalk.chain`)."""
    l_t, l_s = params["l_t"], params["l_s"]
    g_t, g_s = params["rho_t"] * l_t, params["rho_s"] * l_s
    c_t, c_s = params["c_t"] * l_t, params["c_s"] * l_s
    zero = jnp.zeros_like(l_t)
    # One leg's five points over that leg's (thigh, shank) angles.
    leg = [(c_t - g_t, zero), (c_t + g_t, zero), (l_t, c_s - g_s), (l_t, c_s + g_s), (l_t, l_s)]
    rows = [[zero] * 4]
    rows += [[thigh, shank, zero, zero] for thigh, shank in leg]
    rows += [[zero, zero, thigh, shank] for thigh, shank in leg]
    return jnp.stack([jnp.stack(row) for row in rows])


def masses(params) -> Array:
    """``(11,)`` point masses: hip, then thigh (two halves), shank (two halves), foot of each leg."""
    half_t, half_s = 0.5 * params["m_t"], 0.5 * params["m_s"]
    leg = [half_t, half_t, half_s, half_s, params["m_f"]]
    return jnp.stack([params["m_h"], *leg, *leg])


def chord(params) -> tuple[Array, Array]:
    """Hip-to-ankle distance ``A`` and offset ``delta`` of a leg with its knee locked.

    With flexion ``kappa = knee_lock`` the hip-to-ankle vector is
    ``A (sin psi, -cos psi)`` with ``psi = thigh - delta`` (the leg's *chord angle*).
    """
    l_t, l_s, kappa = params["l_t"], params["l_s"], params["knee_lock"]
    length = jnp.sqrt(l_t**2 + l_s**2 + 2.0 * l_t * l_s * jnp.cos(kappa))
    delta = jnp.arctan2(l_s * jnp.sin(kappa), l_t + l_s * jnp.cos(kappa))
    return length, delta


# ----------------------------------------------------------------- foot angles
def toe_pivot_angle(ankle_: Array, toe: Array) -> Array:
    """Foot angle of a foot whose toe rests at ``toe`` (negative: toe down)."""
    w = toe - ankle_
    return jnp.arctan2(w[1], w[0])


def heel_pivot_angle(ankle_: Array, heel: Array) -> Array:
    """Foot angle of a foot whose heel rests at ``heel`` (positive: toe up)."""
    w = ankle_ - heel
    return jnp.arctan2(w[1], w[0])


def free_foot_angle(q: Array, params, leg: int) -> Array:
    """Angle of a foot in the air: perpendicular to its shank, turned toe-up by ``swing_dorsi``."""
    return q[SHANK[leg]] + params["swing_dorsi"]


def free_foot(q: Array, params, leg: int) -> tuple[Array, Array]:
    """Heel and toe of a foot in the air (:func:`free_foot_angle`)."""
    a_h, a_t = foot_arms(params)
    a = ankle(q, params, leg)
    e = foot_direction(free_foot_angle(q, params, leg))
    return a - a_h * e, a + a_t * e
