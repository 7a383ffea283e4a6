"""Derivatives of a gait with respect to the model's parameters.

The fixed point ``v*(p)`` of the step map ``f(v, p)`` is found by Newton's
method (:func:`jaxwalk.gait.find_gait`), which is not differentiated: its
iterations are only a way to reach ``v*``. Its derivative comes from the
implicit function theorem at the converged point, in forward mode::

    v* = f(v*, p)   =>   dv* = (I - J)^-1 (df/dp) dp,    J = df/dv at (v*, p).

Every other quantity is an ordinary function of ``(v*, p)``: the Jacobian ``J``
itself, the period, the step length, the actuator work. Forward-mode
differentiation of those functions along ``(dv*, dp)`` gives their total
derivatives; for ``J`` that is the step map's second derivative along
``(dv*, dp)`` (forward over forward through the whole step, event times
included).

``lambda_max = |mu|`` for the dominant eigenvalue ``mu`` of ``J``. With ``w`` its
right and ``u`` its left eigenvector (``J w = mu w``, ``u^H J = mu u^H``)::

    d mu = u^H dJ w / (u^H w),     d|mu| = Re(conj(mu) d mu) / |mu|.

Where this holds and where it does not:

* a complex-conjugate pair (``mu``, ``conj(mu)``) has one modulus, and the
  formula gives the same ``d|mu|`` for both members: the spectral radius is
  differentiable there;
* two eigenvalues of equal modulus that are not conjugates (``0.8`` and
  ``-0.8``; two real ones crossing in modulus) make ``lambda_max`` a maximum of
  two smooth functions, with a kink: the derivative reported is that of the
  eigenvalue sorted first (a one-sided derivative). :func:`gait_metrics` reports
  the relative ``modulus_gap`` to the next non-conjugate eigenvalue so callers
  can see how close they are;
* a repeated, defective eigenvalue (``u^H w = 0``) and a fold of the gait
  (``I - J`` singular: an eigenvalue at +1) have no derivative: the status is
  :attr:`~jaxwalk.status.Status.NOT_DIFFERENTIABLE` (values are still reported).

Everything here is pure and composes with ``jax.jvp``, ``jax.jacfwd`` and
``jax.vmap``. A failed gait search gives NaN values and NaN derivatives with the
search's (non-zero) status; reverse mode is not supported (the step is a dynamic
while loop).
"""

from __future__ import annotations

import functools
from typing import NamedTuple, Sequence

import jax
import jax.numpy as jnp
from jaxtyping import Array, Float, Int8, Int32

from jaxwalk.gait import NewtonOptions, find_gait, jacfwd_with_aux, value_and_jacfwd
from jaxwalk.status import Status
from jaxwalk.step import SolverOptions, step_map
from jaxwalk.walker import Walker


#: ``I - J`` with a condition number above this, or a dominant eigenvalue with
#: ``|u^H w| / (|u| |w|)`` below ``EIGEN_CONDITION_MIN``, has no usable derivative.
FOLD_CONDITION_MAX = 1e12
EIGEN_CONDITION_MIN = 1e-8


class GaitMetrics(NamedTuple):
    """Gait quantities as differentiable functions of the parameters.

    Shapes are for one configuration (batch shape in front under vmap); every
    float is NaN where ``status != 0`` (and so is its derivative).

    Attributes:
        v: ``(n_v,)`` fixed point (section coordinates).
        jacobian: ``(n_v, n_v)`` ``df/dv`` at ``v``.
        lambda_max: spectral radius of ``jacobian``.
        speed: step length / period (model length / time units).
        step_length: model length units.
        period: model time units.
        cost_of_transport: actuator work per step (:attr:`jaxwalk.stepbase.StepResult.work`)
            / (:meth:`~jaxwalk.walker.Walker.weight` x step length), dimensionless; 0 for a passive walker.
        modulus_gap: ``(|mu_1| - |mu_k|) / |mu_1|`` for the largest eigenvalue
            ``mu_k`` that is not ``mu_1``'s conjugate (0: ``lambda_max`` has a kink).
        status: int8 :class:`~jaxwalk.status.Status` (the search's, or
            ``NOT_DIFFERENTIABLE`` for a fold or a defective dominant eigenvalue).
        iterations: Newton iterations used.
    """

    v: Float[Array, "*batch n_v"]
    jacobian: Float[Array, "*batch n_v n_v"]
    lambda_max: Float[Array, "*batch"]
    speed: Float[Array, "*batch"]
    step_length: Float[Array, "*batch"]
    period: Float[Array, "*batch"]
    cost_of_transport: Float[Array, "*batch"]
    modulus_gap: Float[Array, "*batch"]
    status: Int8[Array, "*batch"]
    iterations: Int32[Array, "*batch"]


# ---------------------------------------------------------------- the fixed point


def _map_and_jacobian(model: Walker, solver: SolverOptions, v: Array, params):
    """``(f(v), J, period, length, work)`` at ``(v, params)``: one forward pass with ``n_v`` tangents."""

    def f(v_):
        v_next, res = step_map(model, v_, params, solver)
        return v_next, (res.time, res.length, res.work)

    v_next, jac, (period, length, work) = value_and_jacfwd(f, v)
    return v_next, jac, period, length, work


@functools.partial(jax.custom_jvp, nondiff_argnums=(0, 1))
def _gait_point(model: Walker, solver: SolverOptions, params, at):
    """``(v*, J, period, length, work)`` of a converged gait, as functions of ``params``.

    ``at`` holds those five values from an undifferentiated Newton search
    (:func:`jaxwalk.gait.find_gait`); the primal returns them unchanged, at no
    cost. Their tangents (ignored, zero) play no part: the derivative is the
    implicit one (module docstring). First derivatives only.
    """
    return at


@_gait_point.defjvp
def _gait_point_jvp(model, solver, primals, tangents):
    params, at = primals
    dparams = tangents[0]
    v_star, jac = at[0], at[1]
    n_v = v_star.shape[0]
    eye = jnp.eye(n_v, dtype=v_star.dtype)
    # One forward-over-forward pass of the step at (v*, p), along n_v + 1
    # directions: (e_j, 0) give the second derivatives d J / d v_j (and dT/dv,
    # dL/dv, dW/dv), (0, dp) gives df/dp dp and the parameter parts of the rest.
    # One copy of the nested program (not a pass for df/dp, then one along
    # (dv, dp)) keeps the compile time down; by linearity the total derivative
    # along (dv, dp) is assembled below.
    dirs_v = jnp.concatenate([eye, jnp.zeros((1, n_v), eye.dtype)])
    zeros_p = jax.tree_util.tree_map(jnp.zeros_like, dparams)
    dirs_p = jax.tree_util.tree_map(lambda z, d: jnp.stack([z] * n_v + [d]), zeros_p, dparams)
    point = lambda v_, p_: _map_and_jacobian(model, solver, v_, p_)
    push = lambda dv_, dp_: jax.jvp(point, (v_star, params), (dv_, dp_))[1]
    d_f, d_jac, d_period, d_length, d_work = jax.vmap(push)(dirs_v, dirs_p)
    # rows 0..n_v-1: derivatives along e_j; row n_v: along (0, dp).
    dv = jnp.linalg.solve(eye - jac, d_f[n_v])
    along = lambda d: jnp.tensordot(dv, d[:n_v], axes=1) + d[n_v]
    return at, (dv, along(d_jac), along(d_period), along(d_length), along(d_work))


# ---------------------------------------------------------------- the spectral radius


def _dominant_pair(jac: Array):
    """Dominant eigenvalue ``mu`` of ``jac``, right eigenvector ``w`` and left ``y``
    with ``y^T jac = mu y^T`` (so ``y = conj(u)``); ``y^T w`` and the modulus gap."""
    eig, right = jnp.linalg.eig(jac)
    i = jnp.argmax(jnp.abs(eig))
    mu, w = eig[i], right[:, i]
    eig_t, left = jnp.linalg.eig(jac.T)
    y = left[:, jnp.argmin(jnp.abs(eig_t - mu))]
    # The next modulus that is not mu's conjugate partner (for a real mu, not mu itself).
    others = jnp.where(jnp.arange(eig.shape[0]) == i, 0.0, jnp.abs(eig))
    partner = jnp.abs(eig - jnp.conj(mu)) <= 1e-12 * jnp.maximum(jnp.abs(mu), 1.0)
    partner = partner & (jnp.abs(jnp.imag(mu)) > 1e-12 * jnp.maximum(jnp.abs(mu), 1.0))
    others = jnp.where(partner, 0.0, others)
    gap = (jnp.abs(mu) - jnp.max(others)) / jnp.abs(mu)
    return mu, w, y, gap


@jax.custom_jvp
def spectral_radius(jac: Array) -> Array:
    """``max |eig(jac)|`` for a real ``(n, n)`` matrix, differentiable in forward mode
    through the dominant eigenvalue (module docstring)."""
    return jnp.max(jnp.abs(jnp.linalg.eigvals(jac)))


@spectral_radius.defjvp
def _spectral_radius_jvp(primals, tangents):
    (jac,), (djac,) = primals, tangents
    mu, w, y, _ = _dominant_pair(jac)
    dmu = (y @ djac.astype(w.dtype) @ w) / (y @ w)
    radius = jnp.abs(mu)
    return radius, jnp.real(jnp.conj(mu) * dmu) / radius


def eigen_condition(jac: Array) -> Array:
    """``|u^H w| / (|u| |w|)`` of the dominant eigenvalue (0: defective, no derivative)."""
    _, w, y, _ = _dominant_pair(jac)
    return jnp.abs(y @ w) / (jnp.linalg.norm(y) * jnp.linalg.norm(w))


# ---------------------------------------------------------------- the gait


def gait_metrics(
    model: Walker,
    params,
    v0: Array,
    solver: SolverOptions = SolverOptions(),
    newton: NewtonOptions = NewtonOptions(),
) -> GaitMetrics:
    """The gait from ``v0`` and its metrics, differentiable with respect to ``params``.

    ``jax.jvp`` / ``jax.jacfwd`` with respect to ``params`` (a dict of scalars)
    give the total derivatives at the gait (module docstring); ``v0`` only
    starts the search and has no derivative. One configuration: ``vmap`` it.
    Undifferentiated, this costs one Newton search and one eigen-decomposition;
    each tangent adds one forward-over-forward pass of the step along
    ``n_v + 1`` directions.
    """
    gait = find_gait(model, jax.lax.stop_gradient(params), v0, solver, newton)
    ok = gait.status == Status.OK
    nan = jnp.full((), jnp.nan, v0.dtype)
    # A failed search has NaN v*: take v0 instead (finite, so the tangent pass
    # cannot run away) and blank everything afterwards, tangents included.
    at = (
        jnp.where(ok, gait.v, v0),
        jnp.where(ok, gait.jacobian, 0.0),
        gait.period,
        gait.step_length,
        gait.work,
    )
    at = jax.lax.stop_gradient(at)
    v, jac, period, length, work = _gait_point(model, solver, params, at)
    lam = spectral_radius(jac)
    weight = model.weight(params)

    eye = jnp.eye(v0.shape[0], dtype=v0.dtype)
    jac0 = at[1]
    _, _, _, gap = _dominant_pair(jac0)
    singular = (jnp.linalg.cond(eye - jac0) > FOLD_CONDITION_MAX) | (eigen_condition(jac0) < EIGEN_CONDITION_MIN)
    status = jnp.where(ok & singular, jnp.int8(Status.NOT_DIFFERENTIABLE), gait.status).astype(jnp.int8)
    blank = lambda x: jnp.where(ok, x, nan * x)  # nan * x: the tangent is NaN too
    return GaitMetrics(
        v=blank(v),
        jacobian=blank(jac),
        lambda_max=blank(lam),
        speed=blank(length / period),
        step_length=blank(length),
        period=blank(period),
        cost_of_transport=blank(work / (weight * length)),
        modulus_gap=jnp.where(ok, gap, jnp.nan),
        status=status,
        iterations=gait.iterations,
    )


class Sensitivity(NamedTuple):
    """Gait metrics and their derivatives with respect to ``names`` (one configuration).

    Attributes:
        metrics: :class:`GaitMetrics` at the parameters.
        names: the parameters differentiated (static, in order).
        d_v: ``(n_v, n_p)`` ``dv*/dp``.
        d_lambda_max, d_speed, d_step_length, d_period, d_cost_of_transport:
            ``(n_p,)`` gradients, in units of the quantity per unit of each parameter.
        status: int8; the metrics' status, or ``NOT_DIFFERENTIABLE`` where it was
            OK but a derivative came out non-finite. Derivatives are NaN where
            ``status != 0``.
    """

    metrics: GaitMetrics
    d_v: Float[Array, "*batch n_v n_p"]
    d_lambda_max: Float[Array, "*batch n_p"]
    d_speed: Float[Array, "*batch n_p"]
    d_step_length: Float[Array, "*batch n_p"]
    d_period: Float[Array, "*batch n_p"]
    d_cost_of_transport: Float[Array, "*batch n_p"]
    status: Int8[Array, "*batch"]


def gait_sensitivity(
    model: Walker,
    params,
    v0: Array,
    names: Sequence[str],
    solver: SolverOptions = SolverOptions(),
    newton: NewtonOptions = NewtonOptions(),
) -> Sensitivity:
    """Derivatives of the gait's metrics with respect to the parameters ``names``.

    One configuration (``vmap`` it); ``names`` is static. Forward mode: the
    parameters' ``n_p`` tangents go through :func:`gait_metrics` together
    (``jax.jacfwd``; one ``jvp`` for one parameter), so the Newton search runs once.
    """
    names = tuple(names)
    rest = {k: val for k, val in params.items() if k not in names}

    def of(x):
        return gait_metrics(model, {**rest, **dict(zip(names, x))}, v0, solver, newton)

    x = jnp.stack([jnp.asarray(params[n], jnp.float64) for n in names])
    floats = lambda m: (m.v, m.lambda_max, m.speed, m.step_length, m.period, m.cost_of_transport)

    def fn(x_):
        m = of(x_)
        return floats(m), m

    # has_aux keeps the integer status and the undifferentiated fields out of the tangents.
    jac, metrics = jacfwd_with_aux(fn, x)
    d_v, d_lam, d_speed, d_len, d_period, d_cot = jac
    needed = jnp.concatenate([d_v.ravel(), d_lam, d_speed, d_len, d_period, d_cot])
    status = metrics.status
    status = jnp.where((status == Status.OK) & ~jnp.all(jnp.isfinite(needed)), jnp.int8(Status.NOT_DIFFERENTIABLE), status)
    return Sensitivity(metrics, d_v, d_lam, d_speed, d_len, d_period, d_cot, status.astype(jnp.int8))

