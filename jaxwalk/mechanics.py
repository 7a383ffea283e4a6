"""Constrained Lagrangian mechanics of planar point-mass systems, by autodiff.

A walker is described by where its point masses are, ``points(q) -> (n_points, 2)``,
and by holonomic constraints ``constraints(q) -> (n_c,)`` (feet on the ground,
locked knees). Everything else, the paper's eqs. 3-7 and 11-16, follows here by
automatic differentiation rather than by hand-typed matrices:

* ``T = dpoints/dq`` (the paper's T, shape ``(n_points, 2, n_q)``),
* ``M_r = T^T M T`` (eq. 6) and ``F_r = T^T (F - M * Tdot qdot)`` (eq. 7),
* ``Sigma = dxi/dq`` (eq. 3) and ``Psi = (d(Sigma qdot)/dq) qdot`` (eq. 4),
* the equations of motion (eq. 5) as one KKT system,
* inelastic impacts (eqs. 13, 16) as the same KKT system on velocities.

Coordinates live in the *slope frame*: x along the ground (downhill positive),
y normal to it; gravity is ``g (sin gamma, -cos gamma)``. All quantities are in the
model's units (dimensionless for the flat-foot walker: M = L = g = 1).

Constraints that are not active in a phase are switched off by a 0/1 mask rather
than removed, so every phase has the same array shapes (a requirement for
``vmap``): an inactive row of the KKT system reads ``lambda_i = 0``.
"""

from __future__ import annotations

from typing import Callable

import jax
import jax.numpy as jnp

Array = jax.Array


def second_derivative_along(fn: Callable[[Array], Array], q: Array, qd: Array) -> Array:
    """``(d/ds)^2 fn(q + s qd)`` at ``s = 0``: the convective term ``Jdot(q, qd) qd``.

    This is the paper's Psi (eq. 4) for a constraint function and the
    velocity-product part of the points' accelerations for ``points``.
    """
    first = lambda q_: jax.jvp(fn, (q_,), (qd,))[1]
    return jax.jvp(first, (q,), (qd,))[1]


def mass_matrix(points: Callable[[Array], Array], masses: Array, q: Array) -> Array:
    """Reduced mass matrix ``M_r = sum_i m_i T_i^T T_i``, shape ``(n_q, n_q)``.

    Args:
        points: ``q -> (n_points, 2)`` positions of the point masses.
        masses: ``(n_points,)`` masses.
        q: ``(n_q,)`` generalized coordinates.
    """
    jac = jax.jacfwd(points)(q)  # (n_points, 2, n_q)
    return jnp.einsum("i,iak,ial->kl", masses, jac, jac)


def applied_forces(
    points: Callable[[Array], Array], masses: Array, gravity: Array, q: Array, qd: Array
) -> Array:
    """Generalized gravity and velocity-product forces ``F_r`` (eq. 7), ``(n_q,)``.

    ``F_r = sum_i T_i^T m_i (g - Tdot_i qd)``; joint torques are added by the caller.
    """
    jac = jax.jacfwd(points)(q)
    convective = second_derivative_along(points, q, qd)  # (n_points, 2)
    per_point = masses[:, None] * (gravity[None, :] - convective)
    return jnp.einsum("iak,ia->k", jac, per_point)


def mass_matrix_and_forces(
    points: Callable[[Array], Array], masses: Array, gravity: Array, q: Array, qd: Array
) -> tuple[Array, Array]:
    """:func:`mass_matrix` and :func:`applied_forces` sharing one Jacobian of ``points``."""
    jac = jax.jacfwd(points)(q)
    convective = second_derivative_along(points, q, qd)
    mass = jnp.einsum("i,iak,ial->kl", masses, jac, jac)
    per_point = masses[:, None] * (gravity[None, :] - convective)
    return mass, jnp.einsum("iak,ia->k", jac, per_point)


def kinetic_energy(points: Callable[[Array], Array], masses: Array, q: Array, qd: Array) -> Array:
    """``sum_i m_i |v_i|^2 / 2`` for point masses, a scalar."""
    velocities = jax.jvp(points, (q,), (qd,))[1]
    return 0.5 * jnp.sum(masses * jnp.sum(velocities**2, axis=-1))


def gravity_potential(points: Callable[[Array], Array], masses: Array, gravity: Array, q: Array) -> Array:
    """``-sum_i m_i g . p_i``, a scalar (zero at the slope-frame origin)."""
    return -jnp.sum(masses * (points(q) @ gravity))


def _kkt_matrix(mass: Array, sigma: Array, mask: Array) -> Array:
    """``[[M, -Sigma^T], [Sigma, I - diag(mask)]]`` with inactive rows masked out.

    With ``mask_i = 0`` row i of the lower block reads ``lambda_i = 0`` and column
    i of ``Sigma^T`` is zero, so an inactive constraint neither acts nor constrains.
    """
    sigma_active = sigma * mask[:, None]
    n_c = sigma.shape[0]
    top = jnp.concatenate([mass, -sigma_active.T], axis=1)
    bottom = jnp.concatenate([sigma_active, jnp.diag(1.0 - mask)], axis=1)
    del n_c
    return jnp.concatenate([top, bottom], axis=0)


def constrained_accelerations(
    mass: Array, forces: Array, sigma: Array, psi: Array, mask: Array
) -> tuple[Array, Array]:
    """Solve the equations of motion with active constraints (paper eq. 5).

    ``M qdd = F + Sigma^T lambda`` and ``Sigma qdd + Psi = 0`` for active rows.

    Args:
        mass: ``(n_q, n_q)`` reduced mass matrix.
        forces: ``(n_q,)`` applied generalized forces.
        sigma: ``(n_c, n_q)`` constraint Jacobian.
        psi: ``(n_c,)`` convective constraint term ``Sigmadot qd``.
        mask: ``(n_c,)`` 1.0 for active constraints, 0.0 otherwise.

    Returns:
        ``qdd`` of shape ``(n_q,)`` and the multipliers ``lambda`` of shape
        ``(n_c,)``: the generalized constraint forces (for a foot-height
        constraint, the ground's normal force on the foot, positive upward).
    """
    n_q = mass.shape[0]
    kkt = _kkt_matrix(mass, sigma, mask)
    rhs = jnp.concatenate([forces, -psi * mask])
    sol = jnp.linalg.solve(kkt, rhs)
    return sol[:n_q], sol[n_q:]


def impact(mass: Array, qd_minus: Array, sigma: Array, mask: Array) -> tuple[Array, Array]:
    """Perfectly inelastic impact onto the active constraints (eqs. 13 and 16, e = 0).

    ``M (qd+ - qd-) = Sigma^T Lambda`` and ``Sigma qd+ = 0`` for active rows.

    Returns:
        ``qd_plus`` of shape ``(n_q,)`` and the impulses ``Lambda`` of shape ``(n_c,)``.
    """
    n_q = mass.shape[0]
    kkt = _kkt_matrix(mass, sigma, mask)
    rhs = jnp.concatenate([mass @ qd_minus, jnp.zeros(sigma.shape[0], qd_minus.dtype)])
    sol = jnp.linalg.solve(kkt, rhs)
    return sol[:n_q], sol[n_q:]
