"""Basins of attraction on the Poincare section (Schwab & Wisse 2001), batched.

Around a gait's fixed point ``v*`` (section coordinates, ``(n_v,)``) a start
``v = v* + dv`` is walked by the step map on flat ground
(:func:`jaxwalk.global_stability.walks.walk_until`, the package's one walk
loop) for at most ``steps`` steps. Its fate:

* **returned** (``OK``): after some completed step ``n`` (``1 <= n <= steps``)
  the state is within ``tol`` of the target cycle, in the scaled norm below;
  ``n`` is its steps-to-return;
* **failed**: a step failed first; the failing step's status (``FELL``,
  ``SCUFFING``, ...);
* **not returned** (``NOT_RETURNED``): ``steps`` steps walked, never within
  ``tol`` (a slower return, another attractor, or none);
* **not a state** (``NOT_A_STATE``): the start is not a state of the walker
  (:meth:`Walker.into_section` moves it: the heel-rise walker's trailing foot
  below the ground, next to a heel-down gait on the section's edge); its walk's
  outcome is not read, and it counts neither as returned nor as failed. For
  models whose every section point is a state none is.

The target cycle is the gait itself where it is stable, or the attractor
cycle it settles on (``[analysis] attractors``' points, any period).

**Norm.** Distances and radii are Euclidean in scaled coordinates,
``|dv|_s = sqrt(sum_i (dv_i / scale_i)^2)``, ``scale_i`` in the coordinate's
own units, so radii are dimensionless. Where the options leave ``radius`` or
``scale`` unset (``None``) the model's are used (:attr:`Walker.basin_radius`,
:attr:`Walker.basin_scale`: about its default gait's basin; a ``None`` scale
is 1 for every coordinate). Only the section coordinates named in ``coordinates`` are
perturbed (default: all); the others stay at ``v*``. ``d`` below is their number.

**Basin fraction.** ``samples`` starts uniform in the ``d``-ball of radius
``radius`` (the same unit-ball points, from ``seed``, for every gait: common
random numbers, so a landscape over a grid is not speckled by sampling); the
fraction of those that are states which returned, and its binomial standard
error ``sqrt(f (1 - f) / n)``, ``n`` the states among the starts (NaN both if
none is, with every ``sample_status`` saying why).

**Ray radii.** Along each of ``directions`` unit directions (``d = 2``:
evenly spaced angles from the first coordinate's axis; ``d = 1``: both signs;
``d >= 3``: the ``2 d`` signed axes, then normalised Gaussian vectors from
``seed``), the starts at ``radius * j / scan``, ``j = 1..scan``; between the
last scanned start before the first failure and that failure, ``bisections``
bisections. The ray radius is the largest radius to which every start on the
ray that is a state was confirmed to return (the boundary lies within
``radius / scan / 2^bisections`` above it; ``radius`` itself, a lower bound,
where no scanned start failed; a start that is not a state is no failure, so
a ray with no state on it reads ``radius`` with nothing walked). ``basin_radius`` is
their minimum: the largest ball about ``v*`` inside the basin as far as the
directions see it. A ray can re-enter the basin beyond its first failure:
only the first boundary (to the scan's resolution) is found.
"""

from __future__ import annotations

import dataclasses
import functools
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from jaxwalk import program_cache
from jaxwalk.global_stability.walks import WalkEnd, pooled_walks, walk_until
from jaxwalk.status import Status
from jaxwalk.step import SolverOptions
from jaxwalk.walker import Walker, is_state

Array = jax.Array


@dataclasses.dataclass(frozen=True)
class BasinOptions:
    """Settings of the basin measure (hashable; module docstring for their meaning).

    Attributes:
        radius: the ball's radius (scaled norm, dimensionless); ``None``: the model's.
        samples: random starts in the ball.
        steps: most steps walked from a start.
        tol: a start has returned when within this of the target cycle (scaled norm).
        directions: rays of the radius search.
        scan: evenly spaced starts per ray before bisection.
        bisections: bisections of the first failing scan interval.
        scale: ``(n_v,)`` each section coordinate's scale, its own units; ``None``: the model's.
        coordinates: indices of the perturbed section coordinates; ``None``: all.
        seed: of the ball's points (and of the ``d >= 3`` directions).
    """

    radius: float | None = None
    samples: int = 256
    steps: int = 60
    tol: float = 1e-4
    directions: int = 16
    scan: int = 8
    bisections: int = 10
    scale: tuple[float, ...] | None = None
    coordinates: tuple[int, ...] | None = None
    seed: int = 0

    def for_model(self, model: Walker) -> "BasinOptions":
        """These options with an unset ``radius`` and ``scale`` taken from ``model``."""
        return dataclasses.replace(
            self,
            radius=model.basin_radius if self.radius is None else self.radius,
            scale=model.basin_scale if self.scale is None else self.scale,
        )

    def scales(self, n_v: int) -> np.ndarray:
        """``(n_v,)`` the scale of each section coordinate (1 where ``scale`` is ``None``)."""
        return np.ones(n_v) if self.scale is None else np.asarray(self.scale, np.float64)

    def perturbed(self, n_v: int) -> tuple[int, ...]:
        return tuple(range(n_v)) if self.coordinates is None else tuple(self.coordinates)


def unit_ball(d: int, samples: int, seed: int) -> np.ndarray:
    """``(samples, d)`` points uniform in the unit ``d``-ball (NumPy ``default_rng(seed)``)."""
    rng = np.random.default_rng(seed)
    x = rng.standard_normal((samples, d))
    x /= np.linalg.norm(x, axis=1, keepdims=True)
    return x * rng.uniform(size=(samples, 1)) ** (1.0 / d)


def ray_directions(d: int, count: int, seed: int) -> np.ndarray:
    """``(count, d)`` unit directions (module docstring)."""
    if d == 1:
        return np.array([[1.0], [-1.0]] * ((count + 1) // 2))[:count]
    if d == 2:
        angle = 2.0 * np.pi * np.arange(count) / count
        return np.stack([np.cos(angle), np.sin(angle)], -1)
    axes = np.concatenate([np.eye(d), -np.eye(d)])
    extra = np.random.default_rng(seed + 1).standard_normal((max(0, count - 2 * d), d))
    extra /= np.linalg.norm(extra, axis=1, keepdims=True)
    return np.concatenate([axes, extra])[:count]


def embed(offsets: Array, v_star: Array, scale: Array, coordinates: tuple[int, ...]) -> Array:
    """``v* + dv`` for scaled offsets ``(..., d)`` of the perturbed coordinates -> ``(..., n_v)``."""
    idx = jnp.asarray(coordinates)
    dv = jnp.zeros(offsets.shape[:-1] + v_star.shape, v_star.dtype).at[..., idx].set(offsets * scale[idx])
    return v_star + dv


def cycle_distance(v: Array, targets: Array, scale: Array) -> Array:
    """Scaled distance from ``v`` ``(n_v,)`` to the nearest finite row of ``targets`` ``(P, n_v)``."""
    d = jnp.sqrt(jnp.sum(((v - targets) / scale) ** 2, axis=-1))
    return jnp.min(jnp.where(jnp.all(jnp.isfinite(targets), axis=-1), d, jnp.inf))


@program_cache.serializable
class Fate(NamedTuple):
    """Where a start went (batch shape in front).

    Attributes:
        status: int8 ``OK`` (returned), the failing step's status, or ``NOT_RETURNED``
            (:func:`fates` also ``NOT_A_STATE``: the start is not a state of the walker).
        steps: int32 steps walked (to the return, to the failure, or ``steps``).
        distance: scaled distance to the target cycle at the end.
    """

    status: Array
    steps: Array
    distance: Array


def fate(model: Walker, params, v0: Array, targets: Array, scale: Array, options: BasinOptions,
         solver: SolverOptions = SolverOptions()) -> Fate:
    """The fate of one start ``v0`` (module docstring; one walk, vmap it). It does not ask
    whether ``v0`` is a state (:func:`fates` does): ``NOT_A_STATE`` is never its status."""
    end = walk_until(model, params, v0, options.steps, stop=lambda v: cycle_distance(v, targets, scale) < options.tol,
                     solver=solver)
    return fate_of(end, targets, scale)


def fate_of(end: WalkEnd, targets: Array, scale: Array) -> Fate:
    """The :class:`Fate` of one walk that ended at ``end``."""
    status = jnp.where(end.status != Status.OK, end.status,
                       jnp.where(end.stopped, jnp.int8(Status.OK), jnp.int8(Status.NOT_RETURNED))).astype(jnp.int8)
    return Fate(status, end.steps, cycle_distance(end.v, targets, scale))


def fates(model: Walker, params, starts: Array, targets: Array, scale: Array, options: BasinOptions,
          solver: SolverOptions = SolverOptions()) -> Fate:
    """:func:`fate` of every row of ``starts`` ``(n, n_v)``: ``model.lockstep_batch`` walks in
    lockstep, each lane taking the next start when its own walk ends
    (:func:`~jaxwalk.global_stability.walks.pooled_walks`); ``NOT_A_STATE`` where the
    start is not a state of the walker (:func:`jaxwalk.walker.is_state`)."""
    n = starts.shape[0]
    each = jax.tree_util.tree_map(lambda x: jnp.broadcast_to(x, (n,) + jnp.shape(x)), params)
    end = pooled_walks(model, each, starts, jnp.full(n, options.steps, jnp.int32), min(model.lockstep_batch, n),
                       stop=lambda _, v: cycle_distance(v, targets, scale) < options.tol, solver=solver)
    out = jax.vmap(lambda e: fate_of(e, targets, scale))(end)
    state = jax.vmap(lambda v: is_state(model, v, params))(starts)
    return out._replace(status=jnp.where(state, out.status, jnp.int8(Status.NOT_A_STATE)))


@program_cache.serializable
class Basin(NamedTuple):
    """The basin measure of one gait (module docstring).

    Attributes:
        fraction: share of the ball's starts that are states which returned (NaN: none is a state).
        fraction_error: its binomial standard error.
        ray_radius: ``(directions,)`` each ray's radius.
        radius: their minimum.
        sample_status: ``(samples,)`` int8 fate of each ball start.
    """

    fraction: Array
    fraction_error: Array
    ray_radius: Array
    radius: Array
    sample_status: Array


class BasinStart(NamedTuple):
    """The input of :func:`basin_program` beside the parameters (``(n, ...)`` under it)."""

    v_star: Array  # (n_v,) the gait's fixed point
    targets: Array  # (P, n_v) the cycle returned to (NaN rows ignored)


def basin(model: Walker, params, v_star: Array, targets: Array, options: BasinOptions,
          solver: SolverOptions = SolverOptions()) -> Basin:
    """The basin fraction and ray radii of the gait at ``v_star`` (one configuration; vmap
    or ``lax.map`` it). ``targets``: ``(P, n_v)`` the cycle returned to (NaN rows ignored)."""
    options = options.for_model(model)
    n_v = v_star.shape[0]
    coords = options.perturbed(n_v)
    scale = jnp.asarray(options.scales(n_v), v_star.dtype)
    ball = jnp.asarray(unit_ball(len(coords), options.samples, options.seed)) * options.radius
    dirs = jnp.asarray(ray_directions(len(coords), options.directions, options.seed))
    grid = options.radius * jnp.arange(1, options.scan + 1) / options.scan  # (scan,)
    rays = dirs[:, None, :] * grid[None, :, None]  # (D, scan, d)
    starts = embed(jnp.concatenate([ball, rays.reshape(-1, len(coords))]), v_star, scale, coords)
    out = fates(model, params, starts, targets, scale, options, solver).status
    sample_status, ray_ok = out[: options.samples], _no_failure(out[options.samples:]).reshape(rays.shape[:2])
    states = jnp.sum(sample_status != Status.NOT_A_STATE).astype(v_star.dtype)  # float64: not float32 as a bool mean
    returned = jnp.sum(sample_status == Status.OK).astype(v_star.dtype) / jnp.where(states > 0, states, jnp.nan)

    first_fail = jnp.argmin(ray_ok, axis=1)  # the first False (0 if all returned: see none_failed)
    none_failed = jnp.all(ray_ok, axis=1)
    lo = jnp.where(first_fail > 0, grid[jnp.maximum(first_fail - 1, 0)], 0.0)
    hi = grid[first_fail]

    def bisect(_, bounds):
        lo, hi = bounds
        mid = 0.5 * (lo + hi)
        ok = _no_failure(fates(model, params, embed(dirs * mid[:, None], v_star, scale, coords), targets, scale, options, solver).status)
        return jnp.where(ok, mid, lo), jnp.where(ok, hi, mid)

    lo, _ = jax.lax.fori_loop(0, options.bisections, bisect, (lo, hi))
    ray_radius = jnp.where(none_failed, options.radius, lo)
    error = jnp.sqrt(returned * (1.0 - returned) / states)
    return Basin(returned, error, ray_radius, jnp.min(ray_radius), sample_status)


def _no_failure(status: Array) -> Array:
    """Where a ray's start did not fail: it returned, or it is not a state (nothing to fail)."""
    return (status == Status.OK) | (status == Status.NOT_A_STATE)


@functools.lru_cache(maxsize=None)
def basin_program(model: Walker, options: BasinOptions, solver: SolverOptions):
    """``jit``: :class:`~jaxwalk.batching.Rows` (parameters, inputs :class:`BasinStart`)
    -> :class:`Basin` of each row, one row at a time (its walks are the batch)."""
    from jaxwalk.analyses.base import row_program

    def one(p, start: BasinStart):
        return basin(model, p, start.v_star, start.targets, options, solver)

    return row_program(one, 1, "basin", model, options, solver)
