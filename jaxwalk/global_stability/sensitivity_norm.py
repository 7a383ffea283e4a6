"""The gait sensitivity norm (Hobbelen & Wisse 2007).

Linearise the step map around the gait ``v*`` in the section state ``x = v - v*``
and the floor-height disturbance ``e_k`` of step ``k`` (the drop of the ground at
that step's touchdown below its stance foot, model length units, vertical;
:func:`jaxwalk.step.step_map`'s ``ground_drop``)::

    x_{k+1} = J x_k + B e_k,        y_k = C x_k + D e_k,

where ``y`` are gait indicators of step ``k`` (default: its duration and its
length, :data:`DEFAULT_INDICATORS`). All four matrices come from one
forward-mode pass of the step at ``(v*, e = 0)`` with ``n_v + 1`` tangents
(event-time terms included). The gait sensitivity norm is the H2 norm of
``e -> y``: the root of the summed squared indicator deviations after a unit
one-step disturbance, ``sqrt(D^2 + sum_{k>=0} |C J^k B|^2)``, per unit of ``e``
(units: the indicators' units per model length; the default mixes time and
length in the model's units, unscaled, as Hobbelen & Wisse did).

The sum is the observability Gramian ``W = sum_k (J^T)^k C^T C J^k``, the
solution of the discrete Lyapunov equation ``W = J^T W J + C^T C``, solved by
Smith's doubling (``W <- W + A^T W A``, ``A <- A^2``): after ``n`` doublings it
holds the first ``2^n`` terms exactly, so 48 of them leave an error of order
``lambda_max^(2^48)``. It uses only matrix products (no LAPACK call, so no
batched one either: see ``jaxwalk.mechanics.solve``), is forward-differentiable, and unlike a truncated
impulse response does not need a horizon chosen by hand: this project's step
maps are strongly non-normal (``||J^k|| > 1`` for several steps) and near the
loss of stability ``lambda_max -> 1`` needs ``>> 1/(1 - lambda_max)`` terms.
Where ``lambda_max >= 1`` the response does not decay and the norm is ``inf``.
"""

from __future__ import annotations

from typing import NamedTuple, Sequence

import jax
import jax.numpy as jnp

from jaxwalk.gait import value_and_jacfwd
from jaxwalk.step import SolverOptions, StepResult, step_map
from jaxwalk.walker import Walker

Array = jax.Array

#: Gait indicators of one step, from its :class:`~jaxwalk.step.StepResult`.
INDICATORS = {
    "step_time": lambda res: res.time,
    "step_length": lambda res: res.length,
}
#: Hobbelen & Wisse's choice: step time and step length.
DEFAULT_INDICATORS = ("step_time", "step_length")
#: Smith doublings: the first 2^48 terms of the Gramian's series.
DOUBLINGS = 48


class Linearisation(NamedTuple):
    """The linearised step-to-step system at a gait (one configuration).

    Attributes:
        J: ``(n_v, n_v)`` ``df/dv``.
        B: ``(n_v,)`` ``df/de`` (per model length of ground drop).
        C: ``(n_y, n_v)`` indicator derivatives ``dy/dv``.
        D: ``(n_y,)`` ``dy/de``.
        step: the :class:`~jaxwalk.step.StepResult` at the gait (undisturbed).
    """

    J: Array
    B: Array
    C: Array
    D: Array
    step: StepResult


def indicator_values(res: StepResult, indicators: Sequence[str]) -> Array:
    """``(n_y,)`` the named indicators of a step."""
    return jnp.stack([INDICATORS[name](res) for name in indicators])


def linearise(
    model: Walker, params, v: Array, indicators: Sequence[str] = DEFAULT_INDICATORS, solver: SolverOptions = SolverOptions()
) -> Linearisation:
    """``J, B, C, D`` at ``(v, e = 0)``: one forward pass with ``n_v + 1`` tangents."""
    n_v = v.shape[0]

    def f(z):
        v_next, res = step_map(model, z[:n_v], params, solver, ground_drop=z[n_v])
        return jnp.concatenate([v_next, indicator_values(res, indicators)]), res

    z = jnp.concatenate([v, jnp.zeros((1,), v.dtype)])
    _, jac, res = value_and_jacfwd(f, z)
    return Linearisation(jac[:n_v, :n_v], jac[:n_v, n_v], jac[n_v:, :n_v], jac[n_v:, n_v], res)


def observability_gramian(J: Array, C: Array, doublings: int = DOUBLINGS) -> Array:
    """``W = sum_k (J^T)^k C^T C J^k`` (``(n_v, n_v)``) by Smith's doubling."""

    def double(_, carry):
        w, a = carry
        return w + a.T @ w @ a, a @ a

    w, _ = jax.lax.fori_loop(0, doublings, double, (C.T @ C, J))
    return w


def h2_norm(J: Array, B: Array, C: Array, D: Array, lambda_max: Array) -> Array:
    """H2 norm of ``x+ = J x + B e, y = C x + D e`` (single input); ``inf`` if ``lambda_max >= 1``."""
    stable = lambda_max < 1.0
    # An unstable J would overflow the doubling: run it on a zero matrix instead.
    w = observability_gramian(jnp.where(stable, J, 0.0), C)
    value = jnp.sqrt(D @ D + B @ w @ B)
    return jnp.where(stable, value, jnp.inf)


def gait_sensitivity_norm(
    model: Walker,
    params,
    v: Array,
    indicators: Sequence[str] = DEFAULT_INDICATORS,
    solver: SolverOptions = SolverOptions(),
) -> Array:
    """The gait sensitivity norm at the fixed point ``v`` (one configuration; vmap it).

    A function of ``(params, v)`` in forward mode: with ``v = v*(params)`` from
    :func:`jaxwalk.sensitivity.gait_metrics` its derivative is the total one.
    NaN where ``v`` is not finite (no gait) or the step at ``v`` fails.
    """
    lin = linearise(model, params, jnp.where(jnp.isfinite(v), v, 0.0), indicators, solver)
    lam = jnp.max(jnp.abs(jnp.linalg.eigvals(jax.lax.stop_gradient(lin.J))))
    value = h2_norm(lin.J, lin.B, lin.C, lin.D, lam)
    ok = jnp.all(jnp.isfinite(v)) & (lin.step.status == 0)
    return jnp.where(ok, value, jnp.nan)


def norm_and_gradient(
    model: Walker,
    params,
    v0: Array,
    names: Sequence[str],
    solver: SolverOptions = SolverOptions(),
    newton=None,
    indicators: Sequence[str] = DEFAULT_INDICATORS,
) -> tuple[Array, Array]:
    """The gait sensitivity norm at the gait found from ``v0`` and its gradient ``(n_p,)``
    with respect to the parameters ``names`` (one configuration; vmap it).

    The fixed point's derivative is the implicit one
    (:func:`jaxwalk.sensitivity.gait_metrics`); the norm's is then forward over
    forward through the step (``J, B, C, D`` along ``(dv*, dp)``). NaN where no gait.
    """
    from jaxwalk.gait import NewtonOptions, jacfwd_with_aux
    from jaxwalk.sensitivity import gait_metrics

    newton = NewtonOptions() if newton is None else newton
    names = tuple(names)
    rest = {k: val for k, val in params.items() if k not in names}

    def of(x):
        p = {**rest, **dict(zip(names, x))}
        metrics = gait_metrics(model, p, v0, solver, newton)
        value = gait_sensitivity_norm(model, p, metrics.v, indicators, solver)
        return value, value

    x = jnp.stack([jnp.asarray(params[n], jnp.float64) for n in names])
    grad, value = jacfwd_with_aux(of, x)
    return value, grad
