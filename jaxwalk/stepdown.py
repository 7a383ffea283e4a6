"""Global stability: the largest step-down a walker survives (the paper's h_m).

Start on the limit cycle (the fixed point ``v*``), lower the ground at the
next touchdown by ``h`` (a vertical drop; the slope is unchanged), then let the
walker take ``n_steps`` more steps on the new level. It survives if every one
of those steps ends normally (status ``OK``).

Survival need not be monotone in ``h`` (a larger drop can happen to land in a
better phase of the swing), so ``h_max`` is defined as the largest tested
``h = k * dh`` such that *every* smaller tested drop survives as well: drops are
tried in increasing order and the search stops at the first failure. The
resolution is ``dh``; ``h_max = count * dh`` means the search reached its
upper limit without a failure (reported, not extrapolated).
"""

from __future__ import annotations

import dataclasses
from typing import NamedTuple

import jax
import jax.numpy as jnp

from jaxwalk.status import Status
from jaxwalk.step import SolverOptions, run_step
from jaxwalk.walker import Walker

Array = jax.Array


@dataclasses.dataclass(frozen=True)
class StepDownOptions:
    """Static settings of the step-down test.

    Attributes:
        dh: drop increment, the resolution of ``h_max`` (model length units).
        count: largest drop tried is ``count * dh``.
        n_steps: steps after the drop that the walker must complete.
    """

    dh: float = 0.0005
    count: int = 40
    n_steps: int = 10


class StepDownTrial(NamedTuple):
    """Outcome of one drop.

    Attributes:
        survived: bool.
        status: int8 status of the first step that failed (``OK`` if none).
        steps: steps completed, the drop step included.
    """

    survived: Array
    status: Array
    steps: Array


class StepDownResult(NamedTuple):
    """``h_max`` and how the search ended.

    Attributes:
        h_max: largest drop with every smaller tested drop survived (model length units).
        first_failure: status of the first failed drop (``OK`` if none failed up to the limit).
        failed_at: the first drop that failed (NaN if none).
    """

    h_max: Array
    first_failure: Array
    failed_at: Array


class _Walk(NamedTuple):
    """The carry of :func:`step_down_trial`'s loop, one iteration per step."""

    y: Array  # (2 n_q,) state at the start of the next step
    phase: Array  # int32
    ctx: Array  # (n_ctx,)
    status: Array  # int8, the last step's
    steps: Array  # int32, steps completed, the drop step included


def step_down_trial(
    model: Walker, params, v_star: Array, h: Array, n_steps: int, solver: SolverOptions = SolverOptions()
) -> StepDownTrial:
    """Drop the ground by ``h`` at the next touchdown from ``v*``; walk ``n_steps`` more.

    ``model`` needs the step-down capability (:meth:`jaxwalk.walker.Walker.with_ground_drop`).
    """
    y, phase, ctx = model.section_to_state(v_star, params)
    ctx = model.with_ground_drop(ctx, params, h)
    ok = jnp.int8(Status.OK)

    def cond(c: _Walk):
        return (c.status == ok) & (c.steps < n_steps + 1)

    def body(c: _Walk) -> _Walk:
        res = run_step(model, params, c.y, c.phase, c.ctx, solver)
        return _Walk(res.y, res.phase, res.ctx, res.status, c.steps + jnp.where(res.status == ok, 1, 0))

    c = jax.lax.while_loop(cond, body, _Walk(y=y, phase=phase, ctx=ctx, status=ok, steps=jnp.zeros((), jnp.int32)))
    return StepDownTrial(c.status == ok, c.status, c.steps)


def h_max(
    model: Walker, params, v_star: Array, options: StepDownOptions = StepDownOptions(), solver: SolverOptions = SolverOptions()
) -> StepDownResult:
    """The paper's h_m for one config (vmap it): drops ``dh, 2 dh, ...`` until the first failure."""
    ok = jnp.int8(Status.OK)

    def cond(carry):
        k, status = carry
        return (status == ok) & (k < options.count)

    def body(carry):
        k, _ = carry
        trial = step_down_trial(model, params, v_star, (k + 1) * options.dh, options.n_steps, solver)
        return k + jnp.where(trial.survived, 1, 0), trial.status

    k, status = jax.lax.while_loop(cond, body, (jnp.zeros((), jnp.int32), ok))
    finite = jnp.all(jnp.isfinite(v_star))
    failed = status != ok
    return StepDownResult(
        h_max=jnp.where(finite, k * options.dh, jnp.nan),
        first_failure=status,
        failed_at=jnp.where(finite & failed, (k + 1) * options.dh, jnp.nan),
    )
