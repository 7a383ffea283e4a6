"""Closed-form mass matrix and forces of a planar chain of point masses.

Every walker here puts its point masses at the hip plus fixed multiples of its
segments' unit vectors: with ``q = (x_h, y_h, a_1, ..., a_n)`` (absolute segment
angles, :mod:`jaxwalk.walker`'s convention) the ``i``-th point is

    p_i = hip + sum_k S_ik e(a_k),   e(a) = (sin a, -cos a),

for a matrix of *weights* ``S`` ``(n_points, n)`` (lengths) that depends on the
parameters only. Then, with ``t(a) = de/da = (cos a, sin a)`` and
``dt/da = -e``, the reduced mass matrix ``sum_i m_i T_i^T T_i`` and the forces
``sum_i T_i^T m_i (g - Tdot_i qd)`` of :mod:`jaxwalk.mechanics` are

    M_hh = m I_2,   M_hk = w_k t(a_k),   M_kl = W_kl cos(a_k - a_l),
    F_h = m g + sum_k w_k e(a_k) a_k'^2,
    F_k = w_k t(a_k).g + sum_l W_kl sin(a_l - a_k) a_l'^2,

with ``m = sum_i m_i``, ``w = m_i S_ik`` summed over ``i`` and
``W = S^T diag(m_i) S``. The same quantities as the automatic derivatives of
``points``, to rounding (other expressions, so other rounding); written out
they are a handful of XLA kernels where the derivatives are dozens. At one
configuration on the CPU most of a vector-field call's cost went with its
kernel count: the flat-foot walker's 82 -> 52 kernels, 7.1 -> 5.2 us
(benchmarks/README.md, "Closed-form chain dynamics").

Constraints on chain points get the same treatment (:func:`point_terms`,
:func:`distance_terms`): a point's Jacobian rows and its convective
acceleration ``Tdot qd`` in closed form, for a model that writes its
constraint Jacobian and ``Psi`` by hand (the flat-foot walker).

A model declares itself a chain by :meth:`jaxwalk.walker.Walker.chain_weights`;
``tests/test_chain.py`` checks that its points are what the weights say and
that both forms agree.
"""

from __future__ import annotations

import jax.numpy as jnp
from jaxtyping import Array, Float


def points(weights: Float[Array, "n_points n"], q: Float[Array, "2+n"]) -> Float[Array, "n_points 2"]:
    """``(n_points, 2)`` positions ``hip + S e(a)`` of the chain's point masses."""
    a = q[2:]
    e = jnp.stack([jnp.sin(a), -jnp.cos(a)], axis=-1)
    return q[None, :2] + weights @ e


def _moments(weights: Array, masses: Array) -> tuple[Array, Array, Array]:
    """Total mass ``m``, first moments ``w`` ``(n,)`` and second moments ``W`` ``(n, n)``."""
    weighted = masses[:, None] * weights
    first = jnp.sum(weighted, axis=0)
    second = jnp.sum(weighted[:, :, None] * weights[:, None, :], axis=0)
    return jnp.sum(masses), first, second


def _assemble(total: Array, first: Array, second: Array, a: Array) -> Array:
    cos, sin = jnp.cos(a), jnp.sin(a)
    hip = total * jnp.eye(2, dtype=a.dtype)
    coupling = jnp.stack([first * cos, first * sin])
    segments = second * jnp.cos(a[:, None] - a[None, :])
    return jnp.block([[hip, coupling], [coupling.T, segments]])


def mass_matrix(weights: Float[Array, "n_points n"], masses: Float[Array, "n_points"], q: Float[Array, "2+n"]) -> Float[Array, "2+n 2+n"]:
    """Reduced mass matrix ``(n_q, n_q)`` of the chain (module docstring)."""
    return _assemble(*_moments(weights, masses), q[2:])


def mass_matrix_and_forces(
    weights: Float[Array, "n_points n"], masses: Float[Array, "n_points"], gravity: Float[Array, "2"],
    q: Float[Array, "2+n"], qd: Float[Array, "2+n"],
) -> tuple[Float[Array, "2+n 2+n"], Float[Array, "2+n"]]:
    """The chain's mass matrix and its gravity and velocity-product forces ``(n_q,)``
    (module docstring); joint torques are added by the caller, as with
    :func:`jaxwalk.mechanics.mass_matrix_and_forces`."""
    total, first, second = _moments(weights, masses)
    a, rate_sq = q[2:], qd[2:] ** 2
    cos, sin = jnp.cos(a), jnp.sin(a)
    hip = total * gravity + jnp.stack([jnp.sum(first * sin * rate_sq), -jnp.sum(first * cos * rate_sq)])
    # sin(a_l - a_k) = -sin(a_k - a_l): row k of the segments' velocity products.
    products = -jnp.sum(second * jnp.sin(a[:, None] - a[None, :]) * rate_sq[None, :], axis=1)
    segments = first * (cos * gravity[0] + sin * gravity[1]) + products
    return _assemble(total, first, second, a), jnp.concatenate([hip, segments])


def point_terms(weights: Float[Array, "n"], q: Float[Array, "2+n"], qd: Float[Array, "2+n"]) -> tuple[Array, Array, Array, Array]:
    """Of one chain point ``hip + sum_k s_k e(a_k)`` (``weights`` = ``s``, lengths):
    its position ``(2,)``, velocity ``(2,)``, Jacobian ``(2, n_q)`` and convective
    acceleration ``-sum_k s_k e(a_k) a_k'^2`` ``(2,)`` (its acceleration at ``qdd = 0``)."""
    a, rate = q[2:], qd[2:]
    e = jnp.stack([jnp.sin(a), -jnp.cos(a)])
    t = jnp.stack([jnp.cos(a), jnp.sin(a)])
    jac = jnp.concatenate([jnp.eye(2, dtype=q.dtype), weights[None, :] * t], axis=1)
    position = q[:2] + jnp.sum(weights * e, axis=1)
    velocity = qd[:2] + jnp.sum(weights * rate * t, axis=1)
    convective = -jnp.sum(weights * rate**2 * e, axis=1)
    return position, velocity, jac, convective


def distance_terms(offset: Float[Array, "2"], velocity: Float[Array, "2"], jac: Float[Array, "2 n_q"],
                   convective: Float[Array, "2"]) -> tuple[Array, Array, Array]:
    """Of ``|offset|`` for a point at ``offset`` from a fixed anchor (velocity,
    Jacobian and convective acceleration from :func:`point_terms`): the distance,
    its Jacobian row ``(n_q,)`` and its second derivative at ``qdd = 0``,
    ``u . Tdot qd + (|v|^2 - (u . v)^2) / |offset|`` with ``u`` the unit offset."""
    distance = jnp.sqrt(jnp.sum(offset**2))
    unit = offset / distance
    along = jnp.sum(unit * velocity)
    row = jnp.sum(unit[:, None] * jac, axis=0)
    second = jnp.sum(unit * convective) + (jnp.sum(velocity**2) - along**2) / distance
    return distance, row, second
