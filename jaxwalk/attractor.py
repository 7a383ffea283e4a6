"""Attractors: the gait a walker settles on near its period-1 gait, of any period.

Where the period-1 gait is stable it is the attractor (period 1). Where it is
unstable (``lambda_max > 1``) the walker, started a little off it along its
dominant eigenvector, walks away from it: it settles on another gait (past a
flip, typically a stable period-2 gait), or falls, scuffs, never settles. We
walk it, step map after step map, for at most ``steps`` steps and watch the
iterates: the walk has *settled on period k* when ``|v_n - v_(n-k)|`` falls
below ``settle_tol`` for ``k`` in ``1, 2, 4, ..., max_period`` (the smallest
such ``k``). The settled point then starts Newton on the k-step map
``F(v) = f^k(v) - v`` with the exact forward-mode Jacobian of the whole k
steps (event times included, as :mod:`jaxwalk.gait`), and the cycle is
accepted only if Newton converges, its multipliers (eigenvalues of
``d f^k / dv``) are all inside the unit circle, and k is its minimal period
(a walk that repeated after k steps on a shorter cycle, as a slowly
converging 2-cycle may, is solved again at the shorter period).

Everything here is one configuration at a time and pure: ``vmap`` it. A
walk that cannot settle ends with a status (:mod:`jaxwalk.status`): the
failing step's (``FELL``, ``SCUFFING``, ...), ``NO_PERIODIC_ATTRACTOR`` (kept
walking for ``steps`` steps without repeating to ``settle_tol`` at any tested
period: quasi-periodic, chaotic, of a longer period, or converging too
slowly, as right at a bifurcation) or ``CYCLE_NOT_FOUND`` (it repeated, but
Newton on the k-step map found no stable genuine period-k cycle there).
"""

from __future__ import annotations

import dataclasses
import functools
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Complex, Float, Int8, Int32

from jaxwalk import mechanics, program_cache
from jaxwalk.gait import Gait, GaitStats, NewtonOptions, value_and_jacfwd
from jaxwalk.status import Status
from jaxwalk.step import SolverOptions, step_map
from jaxwalk.walker import Walker


@dataclasses.dataclass(frozen=True)
class AttractorOptions:
    """Static settings of the attractor search (hashable: part of the jit key).

    Attributes:
        max_period: longest period tested; a power of two (periods 1, 2, 4, ..., max_period).
        steps: most steps walked from the perturbed gait before ``NO_PERIODIC_ATTRACTOR``.
        perturbation: the start's distance from the unstable gait along its
            dominant eigenvector (inf-norm, section units: rad, rad per time unit).
        settle_tol: the walk has settled on period k when ``|v_n - v_(n-k)|``
            (inf-norm) is below this; Newton then polishes the cycle to ``NewtonOptions.tol``.
        distinct_tol: a converged k-cycle back within this of its start after
            fewer than k steps is a shorter cycle (:func:`minimal_period`).
    """

    max_period: int = 8
    steps: int = 200
    perturbation: float = 1e-3
    settle_tol: float = 1e-4
    distinct_tol: float = 1e-6

    def __post_init__(self):
        if self.max_period < 1 or self.max_period & (self.max_period - 1):
            raise ValueError(f"max_period must be a power of two >= 1, got {self.max_period}")
        if self.steps < 1:  # settle's loop is bounded by it (its condition)
            raise ValueError(f"steps must be >= 1, got {self.steps}")

    @property
    def periods(self) -> tuple[int, ...]:
        """The tested periods, ``(1, 2, 4, ..., max_period)``."""
        return tuple(1 << i for i in range(self.max_period.bit_length()))


#: Halvings of a Newton update whose k steps fail before the search gives up (:func:`find_cycle`).
MAX_HALVINGS = 8


@program_cache.serializable
class Attractor(NamedTuple):
    """The attractor near a period-1 gait (batch shape in front under vmap).

    Attributes:
        status: int8: ``OK`` where an attractor was found; else why not (the
            gait's status where there is no period-1 gait, module docstring).
        period: int32 number of steps k of the attractor's cycle (0 where none).
        points: ``(max_period, n_v)`` the k points of the cycle in the order
            walked (fixed points of the k-step map), NaN rows beyond k.
        multipliers: ``(n_v,)`` complex eigenvalues of the k-step map's
            Jacobian at ``points[0]``, by modulus, largest first.
        lambda_max: spectral radius of that Jacobian (below 1: the cycle is stable).
        rate: per-step contraction ``lambda_max ** (1 / k)``.
        steps_walked: steps of the settling walk (0 where the gait is stable).
    """

    status: Int8[Array, "*batch"]
    period: Int32[Array, "*batch"]
    points: Float[Array, "*batch max_period n_v"]
    multipliers: Complex[Array, "*batch n_v"]
    lambda_max: Float[Array, "*batch"]
    rate: Float[Array, "*batch"]
    steps_walked: Int32[Array, "*batch"]


class _Cycle(NamedTuple):
    """The carry of :func:`cycle_map`'s loop, one iteration per step."""

    j: Array  # int32, steps taken
    v: Array  # (n_v,) the point after j steps
    status: Array  # int8, the last step's status
    points: Array  # (max_period, n_v): points[i] after i steps, for i < j


def cycle_map(model: Walker, params, v: Array, k: Array, max_period: int, solver: SolverOptions):
    """``f^k(v)``: ``k`` steps (an int, data; at most ``max_period``) of the step map.

    Returns ``(v_k, points, status)``: the point after ``k`` steps, the
    ``(max_period, n_v)`` points visited (``points[j]`` after ``j`` steps,
    ``points[0] = v``; rows from ``k`` on repeat ``v_k``), and the status of
    the first failed step (``OK`` if none). Forward-mode differentiable.
    """
    points0 = jnp.broadcast_to(v, (max_period,) + v.shape)

    def cond(c: _Cycle):
        return (c.j < k) & (c.j < max_period) & (c.status == Status.OK)

    def body(c: _Cycle) -> _Cycle:
        points = jax.lax.dynamic_update_index_in_dim(c.points, c.v, c.j, 0)
        v_next, res = step_map(model, c.v, params, solver)
        return _Cycle(c.j + 1, v_next, res.status.astype(jnp.int8), points)

    end = jax.lax.while_loop(cond, body, _Cycle(jnp.zeros((), jnp.int32), v, jnp.int8(Status.OK), points0))
    rows = jnp.arange(max_period)[:, None]
    return end.v, jnp.where(rows < end.j, end.points, end.v), end.status


def dominant_direction(jacobian: Array) -> Array:
    """The real part of the eigenvector of ``jacobian``'s largest-modulus
    eigenvalue, scaled to inf-norm 1 (``(n_v,)``)."""
    eig, vec = jnp.linalg.eig(jacobian)
    d = jnp.real(vec[:, jnp.argmax(jnp.abs(eig))])
    d = jnp.where(jnp.max(jnp.abs(d)) > 1e-12, d, jnp.real(vec[:, jnp.argmax(jnp.abs(eig))] * 1j))
    return d / jnp.max(jnp.abs(d))


class _Walk(NamedTuple):
    """The carry of :func:`settle`'s loop, one iteration per step walked."""

    n: Array  # int32, steps walked
    v: Array  # (n_v,) the last iterate
    history: Array  # (max_period, n_v): history[i] is v_(n-1-i)
    status: Array  # int8; IN_PROGRESS while the walk goes on
    k: Array  # int32, the period found (0: none yet)


def settle(model: Walker, params, v0: Array, options: AttractorOptions, solver: SolverOptions,
           active: Array | bool = True):
    """Walk from ``v0`` until the iterates repeat with a tested period.

    Returns ``(v, k, steps, status)``: the last iterate, the smallest tested
    period ``k`` with ``|v_n - v_(n-k)| < settle_tol`` (0 if none), the steps
    walked, and ``OK`` (settled), the failing step's status, or
    ``NO_PERIODIC_ATTRACTOR``. Where ``active`` is false no step is taken
    (``(v0, 0, 0, IN_PROGRESS)``): under vmap such lanes idle.
    """
    periods = jnp.asarray(options.periods, jnp.int32)
    n_hist = options.max_period
    running = jnp.int8(Status.IN_PROGRESS)

    def cond(c: _Walk):
        # The body stops the walk (NO_PERIODIC_ATTRACTOR) at options.steps steps,
        # so the bound never decides alone; it shows how long the loop can run.
        return (c.status == running) & (c.n < options.steps)

    def body(c: _Walk) -> _Walk:
        v, history = c.v, c.history
        v_next, res = step_map(model, v, params, solver)
        n = c.n + 1
        # history[i] is v_(n-1-i): v_next repeats with period k if it is within tol of history[k-1].
        dist = jnp.max(jnp.abs(history[periods - 1] - v_next), axis=-1)
        repeats = (dist < options.settle_tol) & (periods <= n)
        k = jnp.where(jnp.any(repeats), periods[jnp.argmax(repeats)], 0)
        status = jnp.select(
            [res.status != Status.OK, k > 0, n >= options.steps],
            [res.status.astype(jnp.int8), jnp.int8(Status.OK), jnp.int8(Status.NO_PERIODIC_ATTRACTOR)],
            running,
        )
        history = jnp.concatenate([v_next[None], history[:-1]])
        return _Walk(n, v_next, history, status, k.astype(jnp.int32))

    history0 = jnp.full((n_hist,) + v0.shape, jnp.inf, v0.dtype)
    c0 = _Walk(n=jnp.zeros((), jnp.int32), v=v0, history=history0, status=running, k=jnp.zeros((), jnp.int32))
    cond_active = lambda c: cond(c) & jnp.asarray(active)
    c = jax.lax.while_loop(cond_active, body, c0)
    return c.v, c.k, c.n, c.status


class _CycleNewton(NamedTuple):
    """The carry of :func:`find_cycle`'s loop, one Newton iteration or halving per trip."""

    v: Array  # (n_v,) the iterate
    it: Array  # int32, Newton iterations so far
    status: Array  # int8; IN_PROGRESS while the search goes on
    converged: Array  # bool: the last update fell below the tolerance
    jac: Array  # (n_v, n_v) d f^k / dv at the last iterate whose steps did not fail
    points: Array  # (max_period, n_v) the cycle's points there
    v_prev: Array  # (n_v,) the iterate an update is halved back towards
    last: Array  # (n_v,) the last update
    halvings: Array  # int32, halvings of the current update
    trips: Array  # int32, loop trips (bounded)


def find_cycle(model: Walker, params, v0: Array, k: Array, max_period: int,
               solver: SolverOptions = SolverOptions(), newton: NewtonOptions = NewtonOptions()):
    """Newton-Raphson fixed point of the k-step map ``f^k`` from ``v0`` (one config).

    As :func:`jaxwalk.gait.find_gait` with ``f^k`` for ``f``: each iteration
    evaluates ``f^k(v) - v`` and its exact Jacobian in one forward-mode pass;
    after the update that falls below ``newton.tol`` one more evaluation gives
    the Jacobian at the converged point.

    An update whose steps fail is halved (up to :data:`MAX_HALVINGS` times)
    instead of ending the search.

    Returns ``(v, jacobian, points, status)``: the fixed point ``(n_v,)``,
    ``d f^k/dv`` there ``(n_v, n_v)``, the cycle's points ``(max_period, n_v)``
    (:func:`cycle_map`), and ``OK``, a failing step's status or ``NO_CONVERGENCE``.
    """
    n_v = v0.shape[0]
    eye = jnp.eye(n_v, dtype=v0.dtype)
    running = jnp.int8(Status.IN_PROGRESS)

    def residual(v):
        v_k, points, status = cycle_map(model, params, v, k, max_period, solver)
        return v_k - v, (points, status)

    # Each trip counts a Newton iteration, a halving (at most MAX_HALVINGS per
    # iteration) or the last evaluation at the converged point.
    max_trips = newton.max_iter * (MAX_HALVINGS + 1) + 1

    def cond(c: _CycleNewton):
        return (c.status == running) & (c.trips < max_trips)

    def body(c: _CycleNewton) -> _CycleNewton:
        r, jac_r, (points, step_status) = value_and_jacfwd(residual, c.v)
        update = -mechanics.solve(jac_r, r)
        size = jnp.max(jnp.abs(update))
        update = update * jnp.minimum(1.0, newton.max_update / jnp.maximum(size, 1e-300))
        failed = step_status != Status.OK
        # Damped Newton: an update whose k steps fail (a k-step map's Newton
        # step can overshoot into scuffing) is halved, up to MAX_HALVINGS times.
        retry = failed & (c.it > 0) & (c.halvings < MAX_HALVINGS)
        bad = ~jnp.all(jnp.isfinite(update))
        it = c.it + jnp.where(c.converged | retry, 0, 1)
        status = jnp.select(
            [retry, failed, c.converged, bad | (it >= newton.max_iter)],
            [running, step_status, jnp.int8(Status.OK), jnp.int8(Status.NO_CONVERGENCE)],
            running,
        ).astype(jnp.int8)
        move = ~(failed | bad | c.converged)
        half = 0.5 * c.last
        return _CycleNewton(
            v=jnp.where(retry, c.v_prev + half, jnp.where(move, c.v + update, c.v)), it=it, status=status,
            converged=c.converged | (~failed & (size < newton.tol)),
            jac=jnp.where(failed, c.jac, jac_r + eye), points=jnp.where(failed, c.points, points),
            v_prev=jnp.where(failed, c.v_prev, c.v), last=jnp.where(retry, half, update),
            halvings=jnp.where(retry, c.halvings + 1, 0), trips=c.trips + 1)

    c0 = _CycleNewton(v=v0, it=jnp.zeros((), jnp.int32), status=running, converged=jnp.asarray(False),
                      jac=jnp.full((n_v, n_v), jnp.nan, v0.dtype), points=jnp.full((max_period, n_v), jnp.nan, v0.dtype),
                      v_prev=v0, last=jnp.zeros_like(v0), halvings=jnp.zeros((), jnp.int32), trips=jnp.zeros((), jnp.int32))
    out = jax.lax.while_loop(cond, body, c0)
    return out.v, out.jac, out.points, out.status


class _Polish(NamedTuple):
    """The carry of :func:`polish_cycle`'s loop, one Newton solve of ``f^k`` per iteration."""

    k: Array  # int32, the period solved for
    v: Array  # (n_v,) its start
    jac: Array  # (n_v, n_v) the k-step map's Jacobian at the cycle
    points: Array  # (max_period, n_v) the cycle (cycle_map's)
    status: Array  # int8, the last solve's
    shorter: Array  # bool: the cycle has a shorter period; solve again at it


def polish_cycle(model: Walker, params, v0: Array, k: Array, options: AttractorOptions,
                 solver: SolverOptions, newton: NewtonOptions):
    """Newton on ``f^k`` from ``v0`` (:func:`find_cycle`), then at the cycle's
    minimal period if that is shorter (a walk that repeats after k steps may
    have settled on a shorter cycle: a slowly converging 2-cycle can repeat to
    ``settle_tol`` after 4 steps first). Returns ``(k, jacobian, points, status)``.

    Both solves are one ``while_loop`` body, so the k-step Newton is traced once.
    """
    n_v = v0.shape[0]

    # Another solve only at a strictly shorter tested period (1, 2, 4, ...,
    # max_period): at most len(options.periods) solves.
    def cond(c: _Polish):
        return c.shorter

    def body(c: _Polish) -> _Polish:
        _, jac, points, status = find_cycle(model, params, c.v, c.k, options.max_period, solver, newton)
        k_min = minimal_period(points, c.k, options)
        shorter = (status == Status.OK) & (k_min < c.k)
        return _Polish(jnp.where(shorter, k_min, c.k), jnp.where(shorter, points[0], c.v), jac, points, status, shorter)

    nan = jnp.full((), jnp.nan, v0.dtype)
    c0 = _Polish(k=k, v=v0, jac=jnp.full((n_v, n_v), nan), points=jnp.full((options.max_period, n_v), nan),
                 status=jnp.int8(Status.OK), shorter=jnp.asarray(True))
    c = jax.lax.while_loop(cond, body, c0)
    return c.k, c.jac, c.points, c.status


def minimal_period(points: Array, k: Array, options: AttractorOptions) -> Array:
    """The smallest tested period ``p`` dividing ``k`` after which the cycle
    ``points`` (:func:`cycle_map`'s, from a fixed point of ``f^k``) is back
    within ``distinct_tol`` of its start; ``k`` itself if none shorter (0 stays 0)."""
    periods = jnp.asarray(options.periods, jnp.int32)
    back = jnp.max(jnp.abs(points[periods % options.max_period] - points[0]), axis=-1) < options.distinct_tol
    candidate = back & (periods < k) & (k % periods == 0)
    return jnp.where(jnp.any(candidate), periods[jnp.argmax(candidate)], k).astype(jnp.int32)


def spectrum(jacobian: Array) -> tuple[Array, Array]:
    """Eigenvalues by modulus, largest first, and the spectral radius."""
    eig = jnp.linalg.eigvals(jacobian)
    eig = eig[jnp.argsort(-jnp.abs(eig))]
    return eig, jnp.abs(eig[0])


def find_attractor(model: Walker, params, gait: Gait, options: AttractorOptions = AttractorOptions(),
                   solver: SolverOptions = SolverOptions(), newton: NewtonOptions = NewtonOptions()) -> Attractor:
    """The attractor the walker settles on from ``gait``'s neighbourhood (one config; vmap it).

    A stable period-1 gait is its own attractor and costs nothing more; an
    unstable one is left along its dominant eigenvector, walked until it
    repeats (:func:`settle`), and the repeating cycle polished by Newton on
    the k-step map (:func:`find_cycle`) and checked (module docstring).
    Where ``gait`` has no gait (``status != OK``) the status is the gait's.
    """
    n_v = gait.v.shape[-1]
    dtype = gait.v.dtype
    have_gait = gait.status == Status.OK
    stable = have_gait & (gait.lambda_max < 1.0)
    unstable = have_gait & ~stable
    jac = jnp.where(unstable, gait.jacobian, jnp.eye(n_v, dtype=dtype))
    start = jnp.where(unstable, gait.v + options.perturbation * dominant_direction(jac), gait.v)
    # Stable points and points without a gait walk no step (under vmap they
    # idle while the batch's unstable ones walk: jaxwalk.grid's hook runs only
    # the unstable points).
    v_set, k, walked, walk_status = settle(model, params, jnp.nan_to_num(start), options, solver, unstable)
    k_walk = jnp.where(unstable & (walk_status == Status.OK), k, 0)
    k_newton, jac_k, points, cycle_status = polish_cycle(model, params, v_set, k_walk, options, solver, newton)
    eig_k, lam_k = spectrum(jnp.where(jnp.isfinite(jac_k).all(), jac_k, jnp.eye(n_v, dtype=dtype)))
    genuine = (cycle_status == Status.OK) & (lam_k < 1.0) & (minimal_period(points, k_newton, options) == k_newton) & (k_newton > 0)

    status = jnp.select(
        [~have_gait, stable, walk_status != Status.OK, genuine],
        [gait.status.astype(jnp.int8), jnp.int8(Status.OK), walk_status, jnp.int8(Status.OK)],
        jnp.int8(Status.CYCLE_NOT_FOUND),
    ).astype(jnp.int8)
    found_cycle = unstable & (status == Status.OK)
    period = jnp.select([stable, found_cycle], [1, k_newton], 0).astype(jnp.int32)
    rows = jnp.arange(options.max_period)[:, None]
    p1_points = jnp.where(rows < 1, gait.v, jnp.nan)
    k_points = jnp.where(rows < k_newton, points, jnp.nan)
    points = jnp.where(stable, p1_points, jnp.where(found_cycle, k_points, jnp.nan))
    multipliers = jnp.where(stable, gait.eigenvalues, jnp.where(found_cycle, eig_k, jnp.nan))
    lam = jnp.where(stable, gait.lambda_max, jnp.where(found_cycle, lam_k, jnp.nan))
    rate = lam ** (1.0 / jnp.maximum(period, 1))
    return Attractor(status, period, points, multipliers, lam, jnp.where(period > 0, rate, jnp.nan), walked)


def grid_attractors(model: Walker, params: dict, gaits: dict, options) -> dict:
    """The attractor at every point of a grid block whose gaits are known.

    Stable gaits are their own attractors, filled in here; only the points with
    an unstable gait are walked (gathered into one batch, so the stable majority
    never waits in lockstep for them), in sub-batches of ``model.lockstep_batch``.

    Args:
        params: every parameter as an array of the block's shape ``S``.
        gaits: :func:`jaxwalk.grid.analyse_chunk`'s results for the block
            (``status``, ``lambda_max``, ``eigenvalues``, ``fixed_point``, ``jacobian``).
        options: a :class:`jaxwalk.grid.AnalysisOptions` with ``attractors`` set.

    Returns:
        The outputs :mod:`jaxwalk.analyses.attractors` declares, of shape ``S`` plus their trailing shape.
    """
    from jaxwalk.batching import Rows, run_chunks as _run_chunks

    settings: AttractorOptions = options.attractors
    shape = gaits["status"].shape
    n_v = gaits["fixed_point"].shape[-1]
    status = gaits["status"].reshape(-1)
    lam = gaits["lambda_max"].reshape(-1)
    out = {
        "attractor_status": status.astype(np.int8).copy(),
        "attractor_period": np.where(status == Status.OK, 1, 0).astype(np.int32),
        "attractor_lambda_max": np.where(status == Status.OK, lam, np.nan),
        "attractor_rate": np.where(status == Status.OK, lam, np.nan),
        "attractor_multipliers": np.asarray(gaits["eigenvalues"]).reshape(-1, n_v).astype(np.complex128),
        "attractor_points": np.full((status.size, settings.max_period, n_v), np.nan),
    }
    out["attractor_points"][:, 0] = np.asarray(gaits["fixed_point"]).reshape(-1, n_v)
    walk = np.flatnonzero((status == Status.OK) & ~(lam < 1.0))
    if walk.size:
        flat = lambda key: np.asarray(gaits[key]).reshape((-1,) + np.shape(gaits[key])[len(shape):])[walk]  # noqa: E731
        period_one = PeriodOne(flat("fixed_point"), flat("jacobian"), flat("eigenvalues"), flat("lambda_max"))
        rows = Rows({k: np.asarray(v).reshape(-1)[walk] for k, v in params.items()}, period_one)
        found = _run_chunks(_attractor_program(model, settings, options.solver, options.newton), rows, options.chunk_size, None)
        for key, field in (("attractor_status", "status"), ("attractor_period", "period"), ("attractor_lambda_max", "lambda_max"),
                           ("attractor_rate", "rate"), ("attractor_multipliers", "multipliers"), ("attractor_points", "points")):
            out[key][walk] = np.asarray(getattr(found, field))
    failed = out["attractor_status"] != Status.OK
    for key in ("attractor_lambda_max", "attractor_rate", "attractor_multipliers", "attractor_points"):
        value = out[key]
        out[key] = np.where(failed.reshape((-1,) + (1,) * (value.ndim - 1)), np.nan, value)
    return {k: v.reshape(shape + v.shape[1:]) for k, v in out.items()}


class PeriodOne(NamedTuple):
    """The attractor program's input beside the parameters: the row's period-1 gait."""

    v: Array  # (n_v,) fixed point
    jacobian: Array  # (n_v, n_v) step-to-step Jacobian there
    eigenvalues: Array  # (n_v,) complex, its eigenvalues
    lambda_max: Array  # their largest modulus


@functools.lru_cache(maxsize=None)
def _attractor_program(model: Walker, settings: AttractorOptions, solver: SolverOptions, newton: NewtonOptions):
    from jaxwalk.batching import over_rows

    def one(p, g: PeriodOne):
        gait = Gait(v=g.v, jacobian=g.jacobian, eigenvalues=g.eigenvalues, lambda_max=g.lambda_max,
                    period=jnp.nan, step_length=jnp.nan, speed=jnp.nan, status=jnp.int8(Status.OK),
                    iterations=jnp.zeros((), jnp.int32), work=jnp.nan, cost_of_transport=jnp.nan,
                    stats=GaitStats(*(jnp.zeros((), jnp.int32),) * 3))
        return find_attractor(model, p, gait, settings, solver, newton)

    program = jax.jit(over_rows(one, model.lockstep_batch))
    program_cache.register(program, "attractor", model, solver, newton, settings)
    return program
