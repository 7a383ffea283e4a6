"""Gradient-based optimisation of gait metrics over model parameters, many starts at once.

Each iteration evaluates every start's gait and its gradients in one batched
program (``vmap`` of :func:`jaxwalk.sensitivity.gait_sensitivity`, Newton warm
started from the start's last fixed point), then takes one optax step per
start (host side; the arithmetic is tiny).

* **Scaling and bounds.** Each optimised parameter ``p`` in ``[lo, hi]`` is
  mapped to ``x = (p - lo) / (hi - lo)`` in ``[0, 1]``, so one learning rate
  (a fraction of the box per step) serves parameters of any size; after every
  optax update ``x`` is projected (clipped) back into the box.
* **Optimisers** (optax, applied to each start on its own under ``vmap``):
  ``"normalized"`` (default): steps of length ``learning_rate`` along
  ``-grad / |grad|``, cosine-decayed to a twentieth. ``lambda_max`` has kinks
  wherever a complex pair of multipliers turns real, with a gradient that jumps
  by orders of magnitude there; a normalised step still converges onto such a
  kink as the step decays, where Adam's second moment, once it has seen the
  steep side, shrinks every later step (measured on the simplest walker: Adam
  stalled 0.0005-0.0025 rad of slope short of the minimum in 40 steps).
  ``"adam"`` and ``"sgd"`` are there for smooth objectives.
* **Held quantities** (``hold = {speed = 0.09}``): an augmented Lagrangian.
  With ``c = (q - target) / |target|`` (relative), each start minimises
  ``L = f + lambda c + rho/2 c^2`` and every ``dual_every`` (10) steps its
  multiplier moves ``lambda += rho c`` (method of multipliers; a dual step
  after every primal step overshot and sent test problems to the bounds, the
  primal needs a few steps to follow). A penalty alone would stop short of the target by ``O(1/rho)``;
  projection onto ``q = target`` would need a gait solve along the constraint.
* **Losing the gait.** A step that lands where the search fails (a fold, a
  fall) is recorded with its status and undone: the start goes back to its
  last good point with its step scale halved and its momentum cleared. After
  ``max_retries`` such failures in a row, or if the first point has no gait,
  the start ends with that status.
"""

from __future__ import annotations

import dataclasses
import functools
from typing import Mapping, NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from jaxwalk.gait import NewtonOptions
from jaxwalk.sensitivity import gait_sensitivity
from jaxwalk.status import Status
from jaxwalk.step import SolverOptions
from jaxwalk.walker import Walker

#: Quantities an objective or a held value may name.
QUANTITIES = ("lambda_max", "speed", "step_length", "period", "cost_of_transport", "gait_sensitivity_norm")
#: Quantities computed only when the problem names them (:func:`extra_program`).
EXTRA_QUANTITIES = ("gait_sensitivity_norm",)


@functools.lru_cache(maxsize=None)
def extra_program(model: Walker, names: tuple[str, ...], solver: SolverOptions, newton: NewtonOptions):
    """``jit(vmap)``: ``(params batch, v0) -> {quantity: (value (B,), gradient (B, n_p))}`` for
    :data:`EXTRA_QUANTITIES` (the gait sensitivity norm: :mod:`jaxwalk.global_stability.sensitivity_norm`)."""
    from jaxwalk.global_stability.sensitivity_norm import norm_and_gradient

    one = lambda p, v0: {"gait_sensitivity_norm": norm_and_gradient(model, p, v0, names, solver, newton)}
    return jax.jit(jax.vmap(one))


@functools.lru_cache(maxsize=None)
def sensitivity_program(model: Walker, names: tuple[str, ...], solver: SolverOptions, newton: NewtonOptions):
    """``jit(vmap(gait_sensitivity))``: ``(params batch, v0 (B, n_v)) -> Sensitivity`` batched.

    Cached per ``(model, names, solver, newton)``, so the optimiser, the tests and
    the benchmark share one compiled program per batch shape.
    """
    one = lambda p, v0: gait_sensitivity(model, p, v0, names, solver, newton)
    return jax.jit(jax.vmap(one))


@dataclasses.dataclass(frozen=True)
class Problem:
    """What to optimise.

    Attributes:
        names: the optimised parameters, in order.
        lower, upper: ``(n_p,)`` bounds (model units).
        objective: a name of :data:`QUANTITIES`; minimised.
        sign: +1 to minimise the quantity, -1 to maximise it (``"-speed"``).
        hold: ``{quantity: target}`` held by the augmented Lagrangian.
        penalty: ``rho`` of the augmented Lagrangian (per relative deviation squared).
        iterations: optax steps per start.
        learning_rate: initial step, as a fraction of each parameter's box;
            decays by a cosine schedule to a twentieth of it.
        max_retries: failed steps in a row (each halving the step) before a start ends.
        optimizer: ``"normalized"``, ``"adam"`` or ``"sgd"`` (module docstring).
        dual_every: steps between multiplier updates of the augmented Lagrangian.
    """

    names: tuple[str, ...]
    lower: tuple[float, ...]
    upper: tuple[float, ...]
    objective: str = "lambda_max"
    sign: float = 1.0
    hold: Mapping[str, float] = dataclasses.field(default_factory=dict)
    penalty: float = 10.0
    iterations: int = 30
    learning_rate: float = 0.02
    max_retries: int = 4
    optimizer: str = "normalized"
    dual_every: int = 10


#: Optimisers a config may name.
OPTIMIZERS = ("normalized", "adam", "sgd")


def make_optimizer(problem: Problem):
    """The optax transformation of ``problem`` (for one start; vmapped over starts)."""
    import optax

    schedule = optax.cosine_decay_schedule(problem.learning_rate, max(problem.iterations, 1), alpha=0.05)
    if problem.optimizer == "adam":
        return optax.adam(schedule)
    if problem.optimizer == "sgd":
        return optax.sgd(schedule)
    if problem.optimizer == "normalized":
        return optax.chain(optax.normalize_by_update_norm(), optax.sgd(schedule))
    raise ValueError(f"unknown optimizer {problem.optimizer!r} (known: {', '.join(OPTIMIZERS)})")


class Path(NamedTuple):
    """The optimisation path, ``K = iterations + 1`` rows (the start, then each step).

    Attributes:
        params: ``(K, S, n_p)`` the point evaluated at each row (model units); NaN
            after the start ended.
        objective: ``(K, S)`` the objective (sign included, without the multiplier terms).
        metrics: ``{quantity: (K, S)}`` every quantity of :data:`QUANTITIES`.
        gradient: ``(K, S, n_p)`` d objective / d params (model units).
        status: ``(K, S)`` int8 status of each evaluation (after a start ended: its final status).
        accepted: ``(K, S)`` bool, the point was kept (a failed step is undone).
        multipliers: ``(K, S, n_hold)`` the multipliers used at each row.
        final_params: ``(S, n_p)`` the last accepted point.
        best_params: ``(S, n_p)`` the accepted point of least merit
            ``objective + penalty/2 sum c^2`` (the objective itself without held
            quantities): at a kink of ``lambda_max`` the last iterates straddle
            it, the best one is the nearest.
        best_row: ``(S,)`` int32 its row (-1 where none was accepted).
        final_status: ``(S,)`` int8: OK, or the status the start ended with.
        ended_at: ``(S,)`` int32 row where the start ended (``K - 1`` if it ran to the end).
    """

    params: np.ndarray
    objective: np.ndarray
    metrics: dict[str, np.ndarray]
    gradient: np.ndarray
    status: np.ndarray
    accepted: np.ndarray
    multipliers: np.ndarray
    final_params: np.ndarray
    best_params: np.ndarray
    best_row: np.ndarray
    final_status: np.ndarray
    ended_at: np.ndarray


def _quantity(sens, name: str, extra=None):
    """``(value (S,), gradient (S, n_p))`` of a quantity from a batched Sensitivity
    (or, for :data:`EXTRA_QUANTITIES`, from ``extra``)."""
    if name in EXTRA_QUANTITIES:
        value, grad = extra[name]
        return np.asarray(value), np.asarray(grad)
    return np.asarray(getattr(sens.metrics, name)), np.asarray(getattr(sens, f"d_{name}"))


def optimise(
    model: Walker,
    problem: Problem,
    fixed: Mapping[str, np.ndarray],
    starts: np.ndarray,
    solver: SolverOptions = SolverOptions(),
    newton: NewtonOptions = NewtonOptions(),
    progress=None,
) -> Path:
    """Run ``problem`` from every start at once.

    Args:
        model: the walker.
        problem: names, bounds, objective, settings.
        fixed: every parameter not optimised, as ``(S,)`` arrays (a start may
            have its own value of a fixed parameter, e.g. one foot length each).
        starts: ``(S, n_p)`` initial values of the optimised parameters, inside the bounds.
        progress: called with the row index after each evaluation.
    """
    names = problem.names
    lo, hi = np.asarray(problem.lower, np.float64), np.asarray(problem.upper, np.float64)
    width = hi - lo
    n_start, n_p = starts.shape
    held = tuple(problem.hold)
    target = np.array([problem.hold[h] for h in held], np.float64)
    rows = problem.iterations + 1
    program = sensitivity_program(model, names, solver, newton)
    wanted = {problem.objective, *held} & set(EXTRA_QUANTITIES)
    extra_fn = extra_program(model, names, solver, newton) if wanted else None
    fixed = {k: np.broadcast_to(np.asarray(v, np.float64), (n_start,)) for k, v in fixed.items() if k not in names}

    opt = make_optimizer(problem)
    opt_update = jax.jit(jax.vmap(opt.update))  # one optimiser per start: norms are per start
    x = np.clip((starts - lo) / width, 0.0, 1.0)
    state = jax.vmap(opt.init)(jnp.asarray(x))
    v0 = np.stack([np.asarray(model.initial_guess({**{k: v[i] for k, v in fixed.items()}, **dict(zip(names, starts[i]))})) for i in range(n_start)])

    out_params = np.full((rows, n_start, n_p), np.nan)
    out_obj = np.full((rows, n_start), np.nan)
    out_metrics = {q: np.full((rows, n_start), np.nan) for q in QUANTITIES if q not in EXTRA_QUANTITIES or q in wanted}
    out_grad = np.full((rows, n_start, n_p), np.nan)
    out_status = np.zeros((rows, n_start), np.int8)
    out_accepted = np.zeros((rows, n_start), bool)
    out_mult = np.zeros((rows, n_start, len(held)))
    multipliers = np.zeros((n_start, len(held)))
    active = np.ones(n_start, bool)
    final_status = np.zeros(n_start, np.int8)
    ended_at = np.full(n_start, rows - 1, np.int32)
    good_x, good_v = x.copy(), v0.copy()
    scale = np.ones(n_start)
    failures = np.zeros(n_start, np.int32)

    for k in range(rows):
        p = lo + width * x
        batch = {**{n: jnp.asarray(p[:, i]) for i, n in enumerate(names)}, **{n: jnp.asarray(v) for n, v in fixed.items()}}
        sens = program(batch, jnp.asarray(v0))
        status = np.asarray(sens.status).astype(np.int8)
        # Newton again from the gait just found: one iteration.
        v_found = np.where(np.isfinite(np.asarray(sens.metrics.v)), np.asarray(sens.metrics.v), v0)
        extra = None if extra_fn is None else extra_fn(batch, jnp.asarray(v_found))
        f, df = _quantity(sens, problem.objective, extra)
        f, df = problem.sign * f, problem.sign * df
        grad_x = df * width  # chain rule into the unit box
        for j, h in enumerate(held):
            q, dq = _quantity(sens, h, extra)
            c = (q - target[j]) / abs(target[j])
            grad_x = grad_x + ((multipliers[:, j] + problem.penalty * c)[:, None] * dq / abs(target[j])) * width
        ok = status == Status.OK
        out_params[k][active] = p[active]
        out_obj[k][active] = f[active]
        for q in out_metrics:
            out_metrics[q][k][active] = _quantity(sens, q, extra)[0][active]
        out_grad[k][active] = (df)[active]
        out_status[k] = np.where(active, status, final_status)
        out_accepted[k] = active & ok
        out_mult[k] = multipliers
        if progress is not None:
            progress(k)

        # Failed points: undo, halve, clear momentum; too many in a row (or at the start): end.
        failed = active & ~ok
        failures = np.where(failed, failures + 1, np.where(active, 0, failures))
        end = failed & ((k == 0) | (failures > problem.max_retries))
        final_status[end] = status[end]
        ended_at[end] = k
        active &= ~end
        retry = failed & active
        good_x[active & ok] = x[active & ok]
        good_v[active & ok] = np.asarray(sens.metrics.v)[active & ok]
        for j, h in enumerate(held):
            q = _quantity(sens, h, extra)[0]
            c = (q - target[j]) / abs(target[j])
            dual_step = (k + 1) % problem.dual_every == 0
            multipliers[:, j] = np.where(active & ok & dual_step, multipliers[:, j] + problem.penalty * c, multipliers[:, j])
        scale = np.where(retry, 0.5 * scale, scale)
        if k == rows - 1 or not active.any():
            break

        g = np.where((active & ok)[:, None], grad_x, 0.0)
        updates, state = opt_update(jnp.asarray(g), state, jnp.asarray(x))
        state = _clear_rows(state, retry, n_start)
        step = np.asarray(updates) * scale[:, None]
        x_next = np.clip(good_x + np.where((active & ok)[:, None], step, 0.0), 0.0, 1.0)
        # A retry goes back to the last good point and tries half the step it had taken.
        x_retry = np.clip(good_x + 0.5 * (x - good_x), 0.0, 1.0)
        x = np.where(retry[:, None], x_retry, np.where(active[:, None], x_next, x))
        v0 = good_v.copy()

    merit = out_obj.copy()
    for j, h in enumerate(held):
        merit = merit + 0.5 * problem.penalty * ((out_metrics[h] - target[j]) / abs(target[j])) ** 2
    merit = np.where(out_accepted, merit, np.inf)
    best_row = np.where(out_accepted.any(0), np.argmin(merit, axis=0), -1).astype(np.int32)
    best_params = np.where((best_row >= 0)[:, None], out_params[np.maximum(best_row, 0), np.arange(n_start)], np.nan)
    return Path(
        params=out_params,
        objective=out_obj,
        metrics=out_metrics,
        gradient=out_grad,
        status=out_status,
        accepted=out_accepted,
        multipliers=out_mult,
        final_params=lo + width * good_x,
        best_params=best_params,
        best_row=best_row,
        final_status=final_status,
        ended_at=ended_at,
    )


def _clear_rows(state, rows: np.ndarray, n_start: int):
    """Zero the optimiser's moments for the starts in ``rows`` (float leaves; the step count stays)."""
    if not rows.any():
        return state
    mask = jnp.asarray(rows)

    def clear(leaf):
        if hasattr(leaf, "shape") and leaf.ndim >= 1 and leaf.shape[0] == n_start and jnp.issubdtype(leaf.dtype, jnp.floating):
            return jnp.where(mask.reshape((-1,) + (1,) * (leaf.ndim - 1)), 0.0, leaf)
        return leaf

    return jax.tree_util.tree_map(clear, state)
