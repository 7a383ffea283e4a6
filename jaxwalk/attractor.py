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
from typing import Callable, NamedTuple

import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Complex, Float, Int8, Int32

from jaxwalk import compiling, event_log, mechanics, program_cache
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


class _CycleSolve(NamedTuple):
    """The carry of :func:`_solve_cycle`'s loop: one step of the step map per trip.

    The k steps of one evaluation of ``f^k`` are trips of the same loop as the
    Newton updates between them (the update is made in the trip after the k-th
    step), so under ``vmap`` a batch pays for its longest lane's total of steps,
    not for its most Newton iterations times its longest period.
    """

    k: Array  # int32, the period solved for
    x: Array  # (n_v,) the point after j steps of the current evaluation
    dx: Array  # (n_v, n_v) d x / d v (the chain of the steps' Jacobians)
    j: Array  # int32, steps of the current evaluation taken
    walked: Array  # (max_period, n_v): walked[i] after i steps, for i < j
    step_status: Array  # int8, the current evaluation's first failed step's (OK if none)
    v: Array  # (n_v,) the Newton iterate: where the current evaluation started
    it: Array  # int32, Newton iterations so far
    status: Array  # int8; IN_PROGRESS while the search goes on
    converged: Array  # bool: the last update fell below the tolerance
    jac: Array  # (n_v, n_v) d f^k / dv at the last iterate whose steps did not fail
    points: Array  # (max_period, n_v) the cycle's points there (cycle_map's)
    logged: Array  # (max_period,) int64 sequence code of each step of the current evaluation (jaxwalk.event_log)
    sequences: Array  # (max_period,) int64 those of the steps from ``points`` (event_log.NONE past k)
    v_prev: Array  # (n_v,) the iterate an update is halved back towards
    last: Array  # (n_v,) the last update
    halvings: Array  # int32, halvings of the current update
    trips: Array  # int32, Newton trips (iterations, halvings, the last evaluation) of this solve


def _fresh_solve(k: Array, v: Array, max_period: int) -> dict:
    """The carry's fields at the start of a Newton solve of ``f^k`` from ``v``."""
    n_v = v.shape[0]
    nan = jnp.full((), jnp.nan, v.dtype)
    return dict(k=k, x=v, dx=jnp.eye(n_v, dtype=v.dtype), j=jnp.zeros((), jnp.int32),
                walked=jnp.broadcast_to(v, (max_period, n_v)), step_status=jnp.int8(Status.OK), v=v,
                it=jnp.zeros((), jnp.int32), status=jnp.int8(Status.IN_PROGRESS), converged=jnp.asarray(False),
                jac=jnp.full((n_v, n_v), nan), points=jnp.full((max_period, n_v), nan),
                logged=jnp.full(max_period, event_log.NONE, jnp.int64), sequences=jnp.full(max_period, event_log.NONE, jnp.int64),
                v_prev=v,
                last=jnp.zeros_like(v), halvings=jnp.zeros((), jnp.int32), trips=jnp.zeros((), jnp.int32))


def _newton_trip(c: _CycleSolve, newton: NewtonOptions,
                 into_section: Callable[[Float[Array, "n_v"]], Float[Array, "n_v"]]) -> _CycleSolve:
    """The Newton update after an evaluation of ``f^k`` (as :func:`jaxwalk.gait.find_gait`'s):
    a converged iterate ends the solve after one more evaluation (its Jacobian);
    an update whose k steps fail is halved, up to :data:`MAX_HALVINGS` times (a
    k-step map's Newton step can overshoot into scuffing). The new iterate is
    kept in the section (:meth:`Walker.into_section`)."""
    eye = jnp.eye(c.v.shape[0], dtype=c.v.dtype)
    rows = jnp.arange(c.walked.shape[0])[:, None]
    points = jnp.where(rows < c.j, c.walked, c.x)
    r, jac_r = c.x - c.v, c.dx - eye
    update = -mechanics.solve(jac_r, r)
    size = jnp.max(jnp.abs(update))
    update = update * jnp.minimum(1.0, newton.max_update / jnp.maximum(size, 1e-300))
    failed = c.step_status != Status.OK
    retry = failed & (c.it > 0) & (c.halvings < MAX_HALVINGS)
    bad = ~jnp.all(jnp.isfinite(update))
    it = c.it + jnp.where(c.converged | retry, 0, 1)
    trips = c.trips + 1
    max_trips = newton.max_iter * (MAX_HALVINGS + 1) + 1
    status = jnp.select(
        [retry, failed, c.converged, bad | (it >= newton.max_iter) | (trips >= max_trips)],
        [jnp.int8(Status.IN_PROGRESS), c.step_status, jnp.int8(Status.OK), jnp.int8(Status.NO_CONVERGENCE)],
        jnp.int8(Status.IN_PROGRESS),
    ).astype(jnp.int8)
    move = ~(failed | bad | c.converged)
    half = 0.5 * c.last
    v = into_section(jnp.where(retry, c.v_prev + half, jnp.where(move, c.v + update, c.v)))
    return c._replace(
        v=v, it=it, status=status, converged=c.converged | (~failed & (size < newton.tol)),
        jac=jnp.where(failed, c.jac, jac_r + eye), points=jnp.where(failed, c.points, points),
        sequences=jnp.where(failed, c.sequences, jnp.where(rows[:, 0] < c.j, c.logged, event_log.NONE)),
        v_prev=jnp.where(failed, c.v_prev, c.v), last=jnp.where(retry, half, update),
        halvings=jnp.where(retry, c.halvings + 1, 0), trips=trips)


def _solve_cycle(model: Walker, params, v0: Array, k: Array, max_period: int, solver: SolverOptions,
                 newton: NewtonOptions, restart: AttractorOptions | None):
    """Newton on ``f^k`` from ``v0`` in one flat loop (:class:`_CycleSolve`).

    With ``restart``, a converged cycle whose minimal period (:func:`minimal_period`)
    is shorter than k is solved again, from its first point, at that period.
    Returns ``(v, k, jacobian, points, status, sequences)``.
    """
    running = jnp.int8(Status.IN_PROGRESS)
    rows = jnp.arange(max_period)[:, None]

    def evaluated(c: _CycleSolve):
        return (c.status == running) & ((c.j >= c.k) | (c.step_status != Status.OK))

    def update(c: _CycleSolve) -> _CycleSolve:
        done = evaluated(c)
        n = _newton_trip(c, newton, functools.partial(model.into_section, params=params))
        if restart is not None:
            k_min = minimal_period(n.points, n.k, restart)
            again = (n.status == Status.OK) & (k_min < n.k)
            fresh = _CycleSolve(**_fresh_solve(k_min, n.points[0], max_period))
            n = jax.tree_util.tree_map(lambda a, b: jnp.where(again, a, b), fresh, n)
        # The next evaluation starts at the (new) iterate.
        n = n._replace(x=n.v, dx=jnp.eye(n.v.shape[0], dtype=n.v.dtype), j=jnp.zeros((), jnp.int32),
                       walked=jnp.broadcast_to(n.v, n.walked.shape), step_status=jnp.int8(Status.OK))
        return jax.tree_util.tree_map(lambda a, b: jnp.where(done, a, b), n, c)

    def body(c: _CycleSolve) -> _CycleSolve:
        c = update(c)
        stepping = (c.status == running) & (c.j < c.k)
        x_next, jac_step, res = value_and_jacfwd(lambda x: step_map(model, x, params, solver), c.x)
        stepped = c._replace(x=x_next, dx=jac_step @ c.dx, j=c.j + 1, step_status=res.status.astype(jnp.int8),
                             walked=jnp.where(rows == c.j, c.x, c.walked),
                             logged=jnp.where(rows[:, 0] == c.j, event_log.sequence_code(model, res.ctx), c.logged))
        return jax.tree_util.tree_map(lambda a, b: jnp.where(stepping, a, b), stepped, c)

    start = _CycleSolve(**_fresh_solve(k, model.into_section(v0, params), max_period))
    c = jax.lax.while_loop(lambda c: c.status == running, body, start)
    return c.v, c.k, c.jac, c.points, c.status, c.sequences


def find_cycle(model: Walker, params, v0: Array, k: Array, max_period: int,
               solver: SolverOptions = SolverOptions(), newton: NewtonOptions = NewtonOptions()):
    """Newton-Raphson fixed point of the k-step map ``f^k`` from ``v0`` (one config).

    As :func:`jaxwalk.gait.find_gait` with ``f^k`` for ``f``: each iteration
    evaluates ``f^k(v) - v`` and its exact Jacobian (the chain of the k steps'
    forward-mode Jacobians, event times included); after the update that falls
    below ``newton.tol`` one more evaluation gives the Jacobian at the converged
    point. An update whose steps fail is halved (up to :data:`MAX_HALVINGS`
    times) instead of ending the search.

    Returns ``(v, jacobian, points, status, sequences)``: the fixed point ``(n_v,)``,
    ``d f^k/dv`` there ``(n_v, n_v)``, the cycle's points ``(max_period, n_v)``
    (:func:`cycle_map`), ``OK``, a failing step's status or ``NO_CONVERGENCE``,
    and the sequence codes of the cycle's k steps ``(max_period,)`` int64
    (:mod:`jaxwalk.event_log`; ``NONE`` past k and for models that log no events).
    """
    v, _, jac, points, status, sequences = _solve_cycle(model, params, v0, k, max_period, solver, newton, None)
    return v, jac, points, status, sequences


def polish_cycle(model: Walker, params, v0: Array, k: Array, options: AttractorOptions,
                 solver: SolverOptions, newton: NewtonOptions):
    """Newton on ``f^k`` from ``v0`` (:func:`find_cycle`), then at the cycle's
    minimal period if that is shorter (a walk that repeats after k steps may
    have settled on a shorter cycle: a slowly converging 2-cycle can repeat to
    ``settle_tol`` after 4 steps first). Returns ``(k, jacobian, points, status)``.

    Both solves are trips of one flat loop (:func:`_solve_cycle`), so the step is traced once.
    """
    _, k, jac, points, status, _ = _solve_cycle(model, params, v0, k, options.max_period, solver, newton, options)
    return k, jac, points, status


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
    never waits in lockstep for them), in sub-batches of :data:`WALK_SUB_BATCH`.

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


#: Walks one worker thread advances together (at most the model's
#: ``lockstep_batch``). Walks differ far more than gait searches do (from 3 to
#: 200 steps), and a grid's unstable points are usually few: a sub-batch padded
#: with copies of its last row to 64 lanes costs as much as 64 walks (17
#: unstable points of the simplest walker's slope line: 1.04 s at 64 lanes,
#: 0.43 s at 17; benchmarks/README.md), while 64 real walks run only 1.3x
#: faster 64 wide than 16 wide.
WALK_SUB_BATCH = 16


@functools.lru_cache(maxsize=None)
def _attractor_program(model: Walker, settings: AttractorOptions, solver: SolverOptions, newton: NewtonOptions):
    from jaxwalk.batching import over_rows

    def one(p, g: PeriodOne):
        gait = Gait(v=g.v, jacobian=g.jacobian, eigenvalues=g.eigenvalues, lambda_max=g.lambda_max,
                    period=jnp.nan, step_length=jnp.nan, speed=jnp.nan, status=jnp.int8(Status.OK),
                    iterations=jnp.zeros((), jnp.int32), work=jnp.nan, cost_of_transport=jnp.nan,
                    context=jnp.full(len(model.context), jnp.nan), stats=GaitStats.none())
        return find_attractor(model, p, gait, settings, solver, newton)

    program = compiling.jit(over_rows(one, min(model.lockstep_batch, WALK_SUB_BATCH)), model)
    program_cache.register(program, "attractor", model, solver, newton, settings)
    return program
