"""Walks of many steps over given or random terrain, batched with ``vmap``.

Every step is the step map (:func:`jaxwalk.step.step_map`) from section
coordinates, with the ground at its touchdown lowered by that step's drop
``e_k`` (model length units, vertical; negative: a step-up) below its stance
foot. A walk ends at its first failed step (a fall, a scuff, ...), whose
status it keeps.

* :func:`walk_terrain`: a given drop sequence, every step recorded (the gait
  sensitivity norm's finite-difference check).
* :func:`walk_until`: the walk loop itself (a drop per step, a stop rule on
  the state); :func:`pooled_walks`: many of them on a few lanes in lockstep,
  each lane taking the next walk when its own ends (the basins' returns,
  :mod:`jaxwalk.global_stability.basin`, and the Monte Carlo walks);
* :func:`steps_to_fall`: i.i.d. ``N(0, sigma^2)`` drops until the first failure
  or ``max_steps``; :func:`monte_carlo` runs thousands at once and estimates the
  mean number of completed steps before a fall (the MFPT's direct check, also
  a user feature: ``jaxwalk.global_stability.monte_carlo``).
"""

from __future__ import annotations

import functools
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from jaxwalk import compiling, program_cache
from jaxwalk.batching import Rows, run_chunks, sub_batch_size
from jaxwalk.errors import ConfigError
from jaxwalk.status import Status
from jaxwalk.step import SolverOptions, step_map
from jaxwalk.walker import Walker, require

Array = jax.Array


class WalkRecord(NamedTuple):
    """Steps of :func:`walk_terrain`, ``N`` drops (batch shape in front under vmap).

    Attributes:
        v: ``(N + 1, n_v)`` section state before each step and after the last;
            after a failure it stays where the walk stopped.
        time, length: ``(N,)`` each step's duration and length; NaN from the
            failed step on.
        status: ``(N,)`` int8 status of each step; from the first failure on, that failure's.
    """

    v: Array
    time: Array
    length: Array
    status: Array


def walk_terrain(model: Walker, params, v0: Array, drops: Array, solver: SolverOptions = SolverOptions()) -> WalkRecord:
    """Walk from ``v0`` over the drops ``(N,)``, one step each (one walk; vmap it)."""
    ok = jnp.int8(Status.OK)

    def one(carry, e):
        v, status = carry
        v_next, res = step_map(model, v, params, solver, ground_drop=e)
        alive = status == ok
        new_status = jnp.where(alive, res.status, status).astype(jnp.int8)
        good = new_status == ok
        v_next = jnp.where(good, v_next, v)
        nan = jnp.nan * res.time
        return (v_next, new_status), (v_next, jnp.where(good, res.time, nan), jnp.where(good, res.length, nan), new_status)

    _, (vs, time, length, status) = jax.lax.scan(one, (v0, ok), drops)
    return WalkRecord(jnp.concatenate([v0[None], vs]), time, length, status)


@program_cache.serializable
class FallResult(NamedTuple):
    """One random walk of :func:`steps_to_fall`.

    Attributes:
        steps: int32 steps completed before the first failure (``max_steps`` if none).
        status: int8 status of the failed step (``OK``: it walked ``max_steps`` steps).
    """

    steps: Array
    status: Array


class WalkEnd(NamedTuple):
    """Where :func:`walk_until` stopped (batch shape in front under vmap).

    Attributes:
        v: ``(n_v,)`` the state after the last completed step (``v0`` if none).
        steps: int32 steps completed.
        status: int8 status of the failed step (``OK``: none failed).
        stopped: ``stop(v)`` held after a completed step (the walk ended there).
    """

    v: Array
    steps: Array
    status: Array
    stopped: Array


def walk_until(model: Walker, params, v0: Array, max_steps, drop=None, stop=None,
               solver: SolverOptions = SolverOptions()) -> WalkEnd:
    """Walk from ``v0`` until a step fails, ``stop(v)`` holds after a completed step,
    or ``max_steps`` steps are done (one walk; vmap it).

    The Monte Carlo walks and the basin's returns take their steps as this loop
    does (:func:`_one_step`); :func:`pooled_walks` runs many of them on a few lanes.

    Args:
        max_steps: the step limit, a Python int or an int32 scalar (a traced one
            lets one compiled program serve every limit).
        drop: ``drop(k) -> e_k``, step ``k``'s ground drop (model length units); default flat.
        stop: ``stop(v) -> bool`` of the state after a completed step; default never.
    """
    ok = jnp.int8(Status.OK)

    def cond(c: WalkEnd):
        return (c.status == ok) & (c.steps < max_steps) & ~c.stopped

    return jax.lax.while_loop(cond, lambda c: _one_step(model, params, c, drop, stop, solver), _walk_start(v0))


def _walk_start(v0: Array) -> WalkEnd:
    """A walk at ``v0`` before its first step."""
    return WalkEnd(v0, jnp.zeros((), jnp.int32), jnp.int8(Status.OK), jnp.asarray(False))


def _one_step(model: Walker, params, c: WalkEnd, drop, stop, solver: SolverOptions) -> WalkEnd:
    """One step of a walk (the body of :func:`walk_until`)."""
    e = jnp.zeros((), c.v.dtype) if drop is None else drop(c.steps)
    v_next, res = step_map(model, c.v, params, solver, ground_drop=e)
    good = res.status == Status.OK
    v = jnp.where(good, v_next, c.v)
    stopped = jnp.asarray(False) if stop is None else good & stop(v)
    return WalkEnd(v, c.steps + jnp.where(good, 1, 0), res.status.astype(jnp.int8), stopped)


class _Pool(NamedTuple):
    """The carry of :func:`pooled_walks`: ``lanes`` walks in progress, the finished ones."""

    walk: Array  # (lanes,) int32 the walk each lane walks; >= n_walks: the lane is idle
    now: WalkEnd  # (lanes,) each lane's walk so far
    next: Array  # int32 the first walk not yet started
    out: WalkEnd  # (n_walks,) the finished walks


def pooled_walks(model: Walker, params, v0: Array, max_steps: Array, lanes: int, drop=None, stop=None,
                 valid: Array | None = None, solver: SolverOptions = SolverOptions()) -> WalkEnd:
    """:func:`walk_until` of ``n`` walks, ``lanes`` at a time in lockstep, each lane
    starting the next walk as soon as its own ends.

    A batch of walks run together (``vmap``) lasts as long as its longest walk,
    and walk lengths spread widely (steps to a fall on random terrain are
    roughly geometric: the simplest walker's 2000 Monte Carlo walks, 22 steps
    on average, kept sub-batches of 64 lanes busy 4.4x longer than their walks'
    steps). Here the cost is the walks' total steps plus one longest walk's
    tail. Every walk's result is :func:`walk_until`'s, whatever lane runs it.

    Args:
        params: the parameters of each walk, every leaf ``(n,)``.
        v0: ``(n, n_v)`` the starts; ``max_steps``: ``(n,)`` int32 step limits
            (a walk with limit 0 ends unwalked, as in :func:`walk_until`).
        lanes: walks advanced together (at most ``n``); the batch of every step map.
        drop: ``drop(i, k) -> e``, walk ``i``'s ground drop at its step ``k``; default flat.
        stop: ``stop(i, v) -> bool`` after a completed step of walk ``i``; default never.
        valid: ``(n,)`` bool, True on a prefix of the rows (a call's padding follows
            it, :func:`jaxwalk.batching.run_chunks`): only those are walked.

    Returns:
        :class:`WalkEnd` with leading axis ``n`` (zeros at rows not walked).
    """
    n = v0.shape[0]
    n_real = n if valid is None else jnp.sum(valid).astype(jnp.int32)
    lanes = max(1, min(lanes, n))
    lane_ids = jnp.arange(lanes, dtype=jnp.int32)
    row = lambda walk: jnp.minimum(walk, n - 1)  # noqa: E731  (an idle lane re-walks the last row, unused)

    def starts(walk):
        return jax.vmap(_walk_start)(v0[row(walk)])

    def advance(walk, now):
        def one(i, c):
            p = jax.tree_util.tree_map(lambda x: x[i], params)
            return _one_step(model, p, c, None if drop is None else (lambda k: drop(i, k)),
                             None if stop is None else (lambda v: stop(i, v)), solver)

        return jax.vmap(one)(row(walk), now)

    def lane_where(mask, a, b):
        return jax.tree_util.tree_map(lambda x, y: jnp.where(mask.reshape(mask.shape + (1,) * (x.ndim - 1)), x, y), a, b)

    def body(pool: _Pool) -> _Pool:
        active, limit = pool.walk < n_real, max_steps[row(pool.walk)]
        due = active & (pool.now.steps >= limit)  # a limit of 0: no step
        now = lane_where(due, pool.now, advance(pool.walk, pool.now))
        ended = due | (active & ((now.status != Status.OK) | now.stopped | (now.steps >= limit)))
        slot = jnp.where(ended, pool.walk, n)  # out of range: not written
        out = jax.tree_util.tree_map(lambda o, x: o.at[slot].set(x, mode="drop"), pool.out, now)
        walk = jnp.where(ended, pool.next + jnp.cumsum(ended) - 1, pool.walk).astype(jnp.int32)
        return _Pool(walk, lane_where(ended, starts(walk), now), pool.next + jnp.sum(ended).astype(jnp.int32), out)

    empty = jax.tree_util.tree_map(lambda x: jnp.zeros((n,) + x.shape, x.dtype), _walk_start(v0[0]))
    pool = _Pool(lane_ids, starts(lane_ids), jnp.asarray(lanes, jnp.int32), empty)
    return jax.lax.while_loop(lambda pool: jnp.any(pool.walk < n_real), body, pool).out


def steps_to_fall(
    model: Walker, params, v0: Array, key: Array, sigma, max_steps, solver: SolverOptions = SolverOptions()
) -> FallResult:
    """Walk from ``v0`` on i.i.d. ``N(0, sigma^2)`` drops until a failure (one walk; vmap it).

    Step ``k``'s drop is ``sigma * normal(fold_in(key, k))``: a walk's terrain
    depends only on its key, not on its batch neighbours. Raises
    :class:`~jaxwalk.errors.ConfigError` (when traced) for a model that cannot walk
    up a step (:attr:`Walker.cannot_step_up`).
    """
    require(model, "step_up", "steps_to_fall")
    drop = lambda k: sigma * jax.random.normal(jax.random.fold_in(key, k), dtype=v0.dtype)  # noqa: E731
    end = walk_until(model, params, v0, max_steps, drop=drop, solver=solver)
    return FallResult(end.steps, end.status)


class MonteCarlo(NamedTuple):
    """Steps-to-fall statistics of :func:`monte_carlo`.

    Attributes:
        steps: ``(n_walks,)`` steps completed by each walk.
        status: ``(n_walks,)`` how each ended (``OK``: still walking at ``max_steps``).
        mean: mean steps completed before a fall, counting walks that reached
            ``max_steps`` at ``max_steps`` (a lower bound if any did).
        standard_error: ``std(steps) / sqrt(n_walks)``.
        censored: walks that reached ``max_steps`` without falling.
    """

    steps: np.ndarray
    status: np.ndarray
    mean: float
    standard_error: float
    censored: int


class FallStart(NamedTuple):
    """The input of the Monte Carlo program beside the parameters, one walk per row."""

    v0: np.ndarray  # (n, n_v) the start (the gait's fixed point)
    key: np.ndarray  # (n, 2) uint32, the walk's random key
    sigma: np.ndarray  # (n,) standard deviation of the drops (model length units)
    max_steps: np.ndarray  # (n,) int32, the walk's step limit


#: Walks per call of the Monte Carlo program: any number of walks, any step
#: limit, runs in calls of this one shape (one compile;
#: :func:`jaxwalk.batching.run_chunks`).
CALL_WALKS = 1024


@functools.lru_cache(maxsize=None)
def _fall_program(model: Walker, solver: SolverOptions):
    # The engine's sub-batch size of lanes, each taking the next walk when its own ends.
    def program(rows: Rows) -> FallResult:
        start: FallStart = rows.inputs

        def drop(i, k):  # steps_to_fall's terrain: walk i's own key
            return start.sigma[i] * jax.random.normal(jax.random.fold_in(start.key[i], k), dtype=start.v0.dtype)

        end = pooled_walks(model, rows.params, start.v0, start.max_steps, sub_batch_size(model, solver), drop=drop,
                           valid=rows.valid, solver=solver)
        return FallResult(end.steps, end.status)

    program = compiling.jit(program, model)
    program_cache.register(program, "monte_carlo_walks", model, solver)
    return program


def monte_carlo(
    model: Walker,
    params,
    v0,
    sigma: float,
    n_walks: int = 2000,
    max_steps: int = 10_000,
    seed: int = 0,
    solver: SolverOptions = SolverOptions(),
) -> MonteCarlo:
    """``n_walks`` random walks from ``v0`` (the gait's fixed point), all at once.

    Walk ``i`` uses the key ``fold_in(PRNGKey(seed), i)``, so its steps are the
    same whatever lane runs it. Each worker thread runs the engine's sub-batch
    size of walks at a time, a lane taking the next walk when its own ends
    (:func:`pooled_walks`; calls of :data:`CALL_WALKS`, :func:`jaxwalk.batching.run_chunks`).
    Raises :class:`~jaxwalk.errors.ConfigError` for ``n_walks < 2``, a ``max_steps`` outside
    ``[1, 2**31)``, or a model that cannot walk up a step (:attr:`Walker.cannot_step_up`).
    """
    require(model, "step_up", "monte_carlo")
    if not (isinstance(n_walks, (int, np.integer)) and n_walks >= 2):
        raise ConfigError(f"monte_carlo: n_walks must be an integer >= 2 (a standard error needs two walks), got {n_walks!r}")
    if not (isinstance(max_steps, (int, np.integer)) and 1 <= max_steps < 2**31):
        raise ConfigError(f"monte_carlo: max_steps must be an integer in [1, 2**31), got {max_steps!r}")
    keys = np.asarray(jax.vmap(lambda i: jax.random.fold_in(jax.random.PRNGKey(seed), i))(jnp.arange(n_walks)))
    start = FallStart(np.repeat(np.asarray(v0, np.float64)[None], n_walks, 0), keys,
                      np.full(n_walks, float(sigma)), np.full(n_walks, int(max_steps), np.int32))
    rows = Rows({k: np.full(n_walks, float(x)) for k, x in params.items()}, start)
    out = run_chunks(_fall_program(model, solver), rows, CALL_WALKS, None)
    steps, status = np.asarray(out.steps), np.asarray(out.status)
    return MonteCarlo(
        steps=steps,
        status=status,
        mean=float(steps.mean()),
        standard_error=float(steps.std(ddof=1) / np.sqrt(n_walks)),
        censored=int((status == Status.OK).sum()),
    )
