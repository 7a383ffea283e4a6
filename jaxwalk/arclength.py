"""Pseudo-arclength continuation of period-k gaits in one model parameter.

A period-k gait is a zero of ``F(u) = P^k(v; p) - v`` with ``u = (v, p)``:
``n_v`` equations in ``n_v + 1`` unknowns, a curve in ``(v, p)`` space
(section units; the parameter in its own units). Natural-parameter
continuation (:mod:`jaxwalk.continuation`) fixes ``p`` and cannot pass a
fold, where the curve turns back in ``p``; here the curve is followed by its
arclength instead (Keller's method):

- **tangent** ``t``: the unit null vector of the augmented Jacobian
  ``[dF/dv, dF/dp]`` (``n_v x (n_v + 1)``, exact: one forward-mode pass of
  ``n_v + 1`` tangents through the k steps, event times included), from
  ``[J; t_prev^T] x = e_(n_v+1)``, ``t = x / |x|``: this keeps its
  orientation, ``t . t_prev > 0``, so the branch never reverses by itself;
- **predictor** ``u_pred = u + ds t``;
- **corrector**: Newton on ``F(u) = 0`` with ``t . (u - u_prev) = ds`` (the
  pseudo-arclength constraint), ``(n_v + 1)``-square, regular through folds;
  every iterate is kept in the walker's section (:meth:`CycleProblem.project`);
- **step-size control**: a step whose corrector fails (a step of the walker
  failing, no convergence in ``max_corrector``, a non-finite number) or whose
  tangent turns by more than ``max_turn`` is retried with ``ds * shrink``;
  an accepted one sets ``ds * grow`` after an easy corrector (at most
  ``easy_iterations``), ``ds * shrink`` after a slow one (at least
  ``slow_iterations``), inside ``[ds_min, ds_max]``.

The branch stops (:class:`Stop`) at a parameter bound (the first point past
it is kept), after ``max_steps`` points, when a step fails with ``ds`` below
``ds_min``, after ``max_attempts`` tries, or when the start is not found.
Everything is one configuration at a time, one ``lax.while_loop`` with a
:class:`BranchCarry`, the bound in its condition: ``vmap`` it over branches
(start points, parameter sets). Bifurcations along a branch are located by
:mod:`jaxwalk.branchpoints`.
"""

from __future__ import annotations

import dataclasses
import enum
import math
from typing import NamedTuple

import jax
import jax.numpy as jnp

from jaxwalk import mechanics
from jaxwalk.attractor import cycle_map, spectrum
from jaxwalk.gait import value_and_jacfwd
from jaxwalk.status import Status
from jaxwalk.step import SolverOptions
from jaxwalk.walker import Walker

Array = jax.Array


class Stop(enum.IntEnum):
    """Why a branch ended (values are file format: append, never renumber)."""

    PARAMETER_BOUND = 1
    MAX_STEPS = 2
    STEP_TOO_SMALL = 3
    START_FAILED = 4
    MAX_ATTEMPTS = 5
    RUNNING = 127  # internal: never in a result


STOP_MEANINGS = {
    Stop.PARAMETER_BOUND: "reached a parameter bound (the last point is the first one past it)",
    Stop.MAX_STEPS: "the step budget: max_steps points after the start",
    Stop.STEP_TOO_SMALL: "a step failed with ds below ds_min (the failing corrector's status is the branch's failure)",
    Stop.START_FAILED: "the corrector found no gait at the start (the branch's failure says why)",
    Stop.MAX_ATTEMPTS: "max_attempts predictor-corrector tries, accepted or not",
}


@dataclasses.dataclass(frozen=True)
class ArclengthOptions:
    """Static settings of the continuation (hashable: part of the jit key).

    Attributes:
        ds: first step (arclength in ``(v, p)``: section units and parameter units together).
        ds_min, ds_max: bounds of the step; a failure below ``ds_min`` stops the branch.
        grow, shrink: factors after an easy corrector (or a failure / slow corrector).
        easy_iterations, slow_iterations: corrector evaluations counting as easy / slow.
        max_steps: points after the start (the record holds ``max_steps + 1``).
        max_attempts: predictor-corrector tries in all (accepted or not).
        max_corrector: corrector evaluations before a try fails.
        tol: the corrector has converged when its update (inf-norm) is below this.
        max_update: an update larger than this (inf-norm) is scaled down to it.
        max_turn: largest angle (rad) between successive tangents of accepted points.
    """

    ds: float = 2e-3
    ds_min: float = 1e-6
    ds_max: float = 1e-2
    grow: float = 1.5
    shrink: float = 0.5
    easy_iterations: int = 4
    slow_iterations: int = 8
    max_steps: int = 100
    max_attempts: int = 400
    max_corrector: int = 12
    tol: float = 1e-9
    max_update: float = 0.05
    max_turn: float = 0.5

    def __post_init__(self):
        if not 0 < self.ds_min <= self.ds <= self.ds_max:
            raise ValueError(f"need 0 < ds_min <= ds <= ds_max, got {self.ds_min}, {self.ds}, {self.ds_max}")
        if not (self.grow >= 1.0 and 0.0 < self.shrink < 1.0):
            raise ValueError(f"need grow >= 1 and 0 < shrink < 1, got {self.grow}, {self.shrink}")
        if self.max_steps < 1:
            raise ValueError(f"max_steps must be >= 1, got {self.max_steps}")


class Branch(NamedTuple):
    """One continued branch (batch shape in front under vmap); ``N = max_steps + 1`` points.

    Attributes:
        stop: int8 :class:`Stop`.
        failure: int8 :class:`~jaxwalk.status.Status` of the last failed corrector (``OK`` if none).
        n_points: int32 points recorded (the start included; 0 if it failed).
        attempts: int32 predictor-corrector tries.
        p: ``(N,)`` the parameter at each point; NaN beyond ``n_points``.
        v: ``(N, n_v)`` the fixed point of the k-step map there (section coordinates).
        tangent: ``(N, n_v + 1)`` the unit tangent ``(dv, dp) / ds`` there.
        multipliers: ``(N, n_v)`` complex eigenvalues of ``d P^k / dv``, largest modulus first.
        lambda_max: ``(N,)`` their largest modulus (below 1: a stable gait).
        ds: ``(N,)`` the step that reached the point (0 at the start).
        iterations: ``(N,)`` int32 corrector evaluations for the point.
        status: ``(N,)`` int8 ``OK`` at recorded points, ``NOT_COMPUTED`` beyond.
    """

    stop: Array
    failure: Array
    n_points: Array
    attempts: Array
    p: Array
    v: Array
    tangent: Array
    multipliers: Array
    lambda_max: Array
    ds: Array
    iterations: Array
    status: Array


class BranchCarry(NamedTuple):
    """The loop's state: the last accepted point, the next step, the record so far."""

    u: Array
    t: Array
    ds: Array
    stop: Array
    failure: Array
    attempts: Array
    record: Branch


def with_parameter(params, name: str, p: Array) -> dict:
    """``params`` with ``name`` set to ``p``."""
    return {**params, name: p}


@dataclasses.dataclass(frozen=True)
class CycleProblem:
    """The period-``k`` gaits of ``model`` in parameter ``name``: ``F(u) = P^k(v; p) - v``.

    Hashable by value (part of the jit key). Any object with this
    ``residual(params)`` and ``period`` serves the continuation: ``residual``
    returns ``u = (v, p) -> (F(u) (n_v,), int8 status)``, forward-mode differentiable;
    an optional ``project(params)`` (``u -> u``) keeps the corrector's iterates
    where ``F`` is defined.
    """

    model: Walker
    name: str
    k: int = 1
    solver: SolverOptions = SolverOptions()

    @property
    def period(self) -> int:
        return self.k

    def residual(self, params):
        k_ = jnp.asarray(self.k, jnp.int32)

        def residual(u):
            p = with_parameter(params, self.name, u[-1])
            v_k, _, status = cycle_map(self.model, p, u[:-1], k_, self.k, self.solver)
            return v_k - u[:-1], status

        return residual

    def project(self, params):
        """``u -> u`` with ``v`` moved into the walker's section at ``u``'s parameter
        (:meth:`~jaxwalk.walker.Walker.into_section`; a state is left bit for bit),
        so that the corrector goes on from the section's edge where its linear
        step crossed it, as Newton does in :func:`jaxwalk.gait.find_gait`."""

        def project(u):
            p = with_parameter(params, self.name, u[-1])
            return jnp.concatenate([self.model.into_section(u[:-1], p), u[-1:]])

        return project


def equations(problem, params):
    """``(residual, project)`` of ``problem`` at ``params``: ``project`` keeps a corrector's
    iterate in the section (``problem.project(params)``; the identity for a problem without one)."""
    project = problem.project(params) if hasattr(problem, "project") else (lambda u: u)
    return problem.residual(params), project


def correct(residual, project, u_pred: Array, u_base: Array, t_base: Array, ds: Array, options: ArclengthOptions):
    """Newton on ``F(u) = 0``, ``t_base . (u - u_base) = ds`` from ``u_pred``, each
    iterate (the prediction too) passed through ``project`` (:func:`equations`).

    After the update that falls below ``tol`` one more evaluation gives the
    Jacobian at the converged point itself. Returns ``(u, jacobian, status,
    evaluations)``: ``jacobian = [dF/dv, dF/dp]`` ``(n_v, n_v + 1)`` at ``u``;
    ``status`` ``OK``, a failing step's, or ``NO_CONVERGENCE``.
    """
    n = u_pred.shape[0]
    running = jnp.int8(Status.IN_PROGRESS)

    def body(c):
        u, it, converged, _, _ = c
        r, jac, step_status = value_and_jacfwd(residual, u)
        g = jnp.concatenate([r, (jnp.dot(t_base, u - u_base) - ds)[None]])
        update = -mechanics.solve(jnp.concatenate([jac, t_base[None]]), g)
        size = jnp.max(jnp.abs(update))
        update = update * jnp.minimum(1.0, options.max_update / jnp.maximum(size, 1e-300))
        failed = step_status != Status.OK
        bad = ~jnp.all(jnp.isfinite(update))
        it = it + 1
        status = jnp.select(
            [failed, converged, bad | (it >= options.max_corrector)],
            [step_status.astype(jnp.int8), jnp.int8(Status.OK), jnp.int8(Status.NO_CONVERGENCE)],
            running,
        )
        move = ~(failed | bad | converged)
        return jnp.where(move, project(u + update), u), it, converged | (~failed & (size < options.tol)), status, jac

    c0 = (project(u_pred), jnp.zeros((), jnp.int32), jnp.asarray(False), running, jnp.full((n - 1, n), jnp.nan, u_pred.dtype))
    u, it, _, status, jac = jax.lax.while_loop(lambda c: c[3] == running, body, c0)
    return u, jac, status, it


def tangent(jac: Array, t_prev: Array) -> Array:
    """The unit null vector of ``jac`` ``(n_v, n_v + 1)`` on ``t_prev``'s side (``t . t_prev > 0``)."""
    e = jnp.zeros(jac.shape[1], jac.dtype).at[-1].set(1.0)
    x = mechanics.solve(jnp.concatenate([jac, t_prev[None]]), e)
    return x / jnp.linalg.norm(x)


def multipliers(jac: Array) -> tuple[Array, Array]:
    """Eigenvalues of ``dP^k/dv = dF/dv + I`` (largest modulus first) and the largest modulus."""
    n_v = jac.shape[0]
    jv = jac[:, :n_v] + jnp.eye(n_v, dtype=jac.dtype)
    return spectrum(jnp.where(jnp.isfinite(jv).all(), jv, jnp.eye(n_v, dtype=jac.dtype)))


def _write(record: Branch, i: Array, u: Array, t: Array, jac: Array, ds: Array, it: Array) -> Branch:
    """``record`` with point ``i`` set from a converged ``u``."""
    mu, lam = multipliers(jac)
    put = lambda buf, x: jax.lax.dynamic_update_index_in_dim(buf, jnp.asarray(x, buf.dtype), i, 0)
    return record._replace(
        n_points=i + 1, p=put(record.p, u[-1]), v=put(record.v, u[:-1]), tangent=put(record.tangent, t),
        multipliers=put(record.multipliers, mu), lambda_max=put(record.lambda_max, lam), ds=put(record.ds, ds),
        iterations=put(record.iterations, it), status=put(record.status, Status.OK),
    )


def _empty_record(n_v: int, n_points: int, dtype) -> Branch:
    nan = lambda *shape: jnp.full(shape, jnp.nan, dtype)
    return Branch(
        stop=jnp.int8(Stop.RUNNING), failure=jnp.int8(Status.OK), n_points=jnp.zeros((), jnp.int32),
        attempts=jnp.zeros((), jnp.int32), p=nan(n_points), v=nan(n_points, n_v), tangent=nan(n_points, n_v + 1),
        multipliers=nan(n_points, n_v).astype(jnp.complex128 if dtype == jnp.float64 else jnp.complex64),
        lambda_max=nan(n_points), ds=nan(n_points), iterations=jnp.zeros(n_points, jnp.int32),
        status=jnp.full(n_points, jnp.int8(Status.NOT_COMPUTED)),
    )


def _start(residual, project, u0: Array, t0: Array, ds0: Array, options: ArclengthOptions) -> BranchCarry:
    """The first point: the corrector on ``t0 . (u - u0) = ds0`` from ``u0 + ds0 t0``, its tangent along ``t0``."""
    u, jac, status, it = correct(residual, project, u0 + ds0 * t0, u0, t0, ds0, options)
    t = tangent(jac, t0)
    ok = (status == Status.OK) & jnp.all(jnp.isfinite(t))
    record = _empty_record(u0.shape[0] - 1, options.max_steps + 1, u0.dtype)
    written = _write(record, jnp.zeros((), jnp.int32), u, t, jac, jnp.zeros((), u0.dtype), it)
    record = jax.tree_util.tree_map(lambda a, b: jnp.where(ok, a, b), written, record)
    return BranchCarry(
        u=jnp.where(ok, u, u0), t=jnp.where(ok, t, t0), ds=jnp.asarray(options.ds, u0.dtype),
        stop=jnp.where(ok, jnp.int8(Stop.RUNNING), jnp.int8(Stop.START_FAILED)),
        failure=jnp.where(ok, jnp.int8(Status.OK), jnp.where(status == Status.OK, jnp.int8(Status.NONFINITE), status)),
        attempts=jnp.ones((), jnp.int32), record=record,
    )


def _step(residual, project, c: BranchCarry, p_min: Array, p_max: Array, options: ArclengthOptions) -> BranchCarry:
    """One predictor-corrector try and its step-size decision (the loop's body)."""
    u, jac, status, it = correct(residual, project, c.u + c.ds * c.t, c.u, c.t, c.ds, options)
    t = tangent(jac, c.t)
    turned = jnp.dot(t, c.t) < math.cos(options.max_turn)
    ok = (status == Status.OK) & jnp.all(jnp.isfinite(t)) & ~turned
    i = c.record.n_points
    written = _write(c.record, i, u, t, jac, c.ds, it)
    record = jax.tree_util.tree_map(lambda a, b: jnp.where(ok, a, b), written, c.record)
    factor = jnp.where(~ok | (it >= options.slow_iterations), options.shrink,
                       jnp.where(it <= options.easy_iterations, options.grow, 1.0))
    ds_next = c.ds * factor
    ds_next = jnp.where(ok, jnp.clip(ds_next, options.ds_min, options.ds_max), ds_next)
    attempts = c.attempts + 1
    stop = jnp.select(
        [ok & ((u[-1] < p_min) | (u[-1] > p_max)), ok & (i + 1 > options.max_steps),
         ~ok & (ds_next < options.ds_min), attempts >= options.max_attempts],
        [jnp.int8(Stop.PARAMETER_BOUND), jnp.int8(Stop.MAX_STEPS), jnp.int8(Stop.STEP_TOO_SMALL), jnp.int8(Stop.MAX_ATTEMPTS)],
        jnp.int8(Stop.RUNNING),
    )
    # A tangent that turned too far is a rejected step with a converged corrector: not Newton's
    # failure; a converged corrector with a non-finite tangent is a non-finite number.
    why = jnp.where(status != Status.OK, status,
                    jnp.where(jnp.all(jnp.isfinite(t)), jnp.int8(Status.NOT_LOCATED), jnp.int8(Status.NONFINITE)))
    return BranchCarry(u=jnp.where(ok, u, c.u), t=jnp.where(ok, t, c.t), ds=ds_next, stop=stop,
                       failure=jnp.where(ok, c.failure, why), attempts=attempts, record=record)


def continue_branch(problem, params, v0: Array, p0: Array, t0: Array, ds0: Array, p_min: Array, p_max: Array,
                    options: ArclengthOptions = ArclengthOptions()) -> Branch:
    """Continue the zeros of ``problem`` through ``(v0, p0)`` by pseudo-arclength (one branch; vmap it).

    Args:
        problem: a :class:`CycleProblem` (the period-k gaits of a walker in one parameter).
        params: the model's parameters (dict of scalars); the continuation parameter's entry is replaced.
        v0: ``(n_v,)`` a point near the start's fixed point of ``P^k``.
        p0: the start's parameter value.
        t0: ``(n_v + 1,)`` the start's constraint and the branch's initial direction:
            the start solves ``t0 . (u - (v0, p0)) = ds0`` and the first tangent
            has ``t . t0 > 0``. ``(0, ..., 0, +-1)`` with ``ds0 = 0`` starts at
            ``p = p0`` towards increasing / decreasing ``p`` (:func:`start_direction`);
            :func:`jaxwalk.branchpoints.switch_at_flip` starts off a flip this way too.
        p_min, p_max: the parameter bounds.

    Returns:
        :class:`Branch`.
    """
    residual, project = equations(problem, params)
    u0 = jnp.concatenate([v0, jnp.asarray(p0, v0.dtype)[None]])
    t0 = jnp.asarray(t0, v0.dtype) / jnp.linalg.norm(t0)
    carry = _start(residual, project, u0, t0, jnp.asarray(ds0, v0.dtype), options)
    cond = lambda c: (c.stop == Stop.RUNNING) & (c.attempts < options.max_attempts)
    out = jax.lax.while_loop(cond, lambda c: _step(residual, project, c, p_min, p_max, options), carry)
    return out.record._replace(stop=out.stop, failure=out.failure, attempts=out.attempts)


def start_direction(n_v: int, direction: float | Array = 1.0, dtype=jnp.float64) -> Array:
    """``(n_v + 1,)`` the unit vector of the parameter, signed: start at ``p0`` towards ``sign(direction) p``."""
    return jnp.zeros(n_v + 1, dtype).at[-1].set(jnp.sign(jnp.asarray(direction, dtype)))
