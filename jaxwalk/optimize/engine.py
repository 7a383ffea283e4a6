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

from jaxwalk import analyses, compiling
from jaxwalk.analyses import gait
from jaxwalk.gait import NewtonOptions
from jaxwalk.sensitivity import gait_sensitivity
from jaxwalk.status import Status
from jaxwalk.step import SolverOptions
from jaxwalk.walker import Walker

#: The analyses beside the gait that declare a differentiable output, by output
#: (each computes its own, and may need a model capability: :meth:`~jaxwalk.analyses.base.Analysis.key_of`).
OWNERS = {o.name: a for a in analyses.plugins() for o in a.outputs(a.fullest()) if o.differentiable}
#: Quantities computed only when the problem names them (:func:`extra_program`).
EXTRA_QUANTITIES = tuple(OWNERS)
#: Quantities an objective or a held value may name: every output declared
#: ``differentiable`` (the gait's from :func:`jaxwalk.sensitivity.gait_sensitivity`).
QUANTITIES = tuple(o.name for o in gait.OUTPUTS if o.differentiable) + EXTRA_QUANTITIES


@functools.lru_cache(maxsize=None)
def extra_program(model: Walker, names: tuple[str, ...], solver: SolverOptions, newton: NewtonOptions):
    """``jit(vmap)``: ``(params batch, v0) -> {quantity: (value (B,), gradient (B, n_p))}`` for
    :data:`EXTRA_QUANTITIES`, each by its analysis (:meth:`jaxwalk.analyses.base.Analysis.gradient`;
    the gait sensitivity norm: :mod:`jaxwalk.global_stability.sensitivity_norm`)."""
    fns = {q: a.gradient(q, model, names, solver, newton) for q, a in OWNERS.items()}
    return compiling.jit(jax.vmap(lambda p, v0: {q: f(p, v0) for q, f in fns.items()}), model)


@functools.lru_cache(maxsize=None)
def sensitivity_program(model: Walker, names: tuple[str, ...], solver: SolverOptions, newton: NewtonOptions):
    """``jit(vmap(gait_sensitivity))``: ``(params batch, v0 (B, n_v)) -> Sensitivity`` batched.

    Cached per ``(model, names, solver, newton)``, so the optimiser, the tests and
    the benchmark share one compiled program per batch shape. A top-level
    program with the model's compiler options (:mod:`jaxwalk.compiling`): call
    it, lower it or ``vmap`` it, but not inside another ``jit``, ``grad`` or
    ``lax.map`` (JAX refuses options there, for the walkers that have them).
    """
    one = lambda p, v0: gait_sensitivity(model, p, v0, names, solver, newton)
    return compiling.jit(jax.vmap(one), model)


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


@dataclasses.dataclass
class _Starts:
    """Every start between two iterations (host arrays, ``S`` starts, ``n_p`` parameters).

    Attributes:
        x: ``(S, n_p)`` the point to evaluate next, in the unit box.
        v0: ``(S, n_v)`` where its gait search starts.
        good_x, good_v: the last accepted point and its fixed point.
        state: the optax state (one per start).
        multipliers: ``(S, n_hold)`` of the augmented Lagrangian.
        active: the starts still running; ``final_status``, ``ended_at`` of those that ended.
        scale: the step scale (halved at each failed step); ``failures`` in a row.
    """

    x: np.ndarray
    v0: np.ndarray
    good_x: np.ndarray
    good_v: np.ndarray
    state: object
    multipliers: np.ndarray
    active: np.ndarray
    final_status: np.ndarray
    ended_at: np.ndarray
    scale: np.ndarray
    failures: np.ndarray


class _Evaluation(NamedTuple):
    """One iteration's evaluation of every start."""

    status: np.ndarray  # (S,) int8
    f: np.ndarray  # (S,) the objective, sign included
    df: np.ndarray  # (S, n_p) its gradient in model units
    grad_x: np.ndarray  # (S, n_p) the Lagrangian's gradient in the unit box
    quantity: object  # name -> (value (S,), gradient (S, n_p))
    v: np.ndarray  # (S, n_v) the fixed points found


@dataclasses.dataclass(frozen=True)
class _Setup:
    """What every iteration uses: the problem, the box, the programs."""

    model: Walker
    problem: Problem
    lo: np.ndarray
    width: np.ndarray
    held: tuple[str, ...]
    target: np.ndarray
    fixed: Mapping[str, np.ndarray]
    program: object
    extra_fn: object
    wanted: frozenset


def optimise(
    model: Walker,
    problem: Problem,
    fixed: Mapping[str, np.ndarray],
    starts: np.ndarray,
    solver: SolverOptions = SolverOptions(),
    newton: NewtonOptions = NewtonOptions(),
    progress=None,
    before_running=None,
    guesses: np.ndarray | None = None,
) -> Path:
    """Run ``problem`` from every start at once.

    Args:
        model: the walker.
        problem: names, bounds, objective, settings.
        fixed: every parameter not optimised, as ``(S,)`` arrays (a start may
            have its own value of a fixed parameter, e.g. one foot length each).
        starts: ``(S, n_p)`` initial values of the optimised parameters, inside the bounds.
        progress: called with the row index after each evaluation.
        before_running: called once the programs are compiled (ahead of time,
            for the starts' shapes), before the first evaluation runs: the
            caller's own work (``jaxwalk optimize``'s background grid) may use
            the cores while XLA compiles, and is waited for here, so that no two
            programs run at once (jaxlib's batched LAPACK kernels, as the
            optimiser's eigenvalues of thousands of starts, split over the
            thread pool and can wait on it for good when every pool thread runs
            a program: jaxwalk.mechanics).
        guesses: ``(S, n_v)`` where each start's first gait search begins (the
            model's section coordinates), or ``None`` for the model's
            ``initial_guess`` at the start's parameters.
    """
    setup = _setup(model, problem, fixed, starts.shape[0], solver, newton)
    opt = make_optimizer(problem)
    opt_update = jax.jit(jax.vmap(opt.update))  # one optimiser per start: norms are per start
    run = _begin(setup, opt, starts, guesses)
    if before_running is not None:
        setup = _compiled(setup, run)
        before_running()
    rows = problem.iterations + 1
    path = _empty_path(rows, starts.shape, setup)
    for k in range(rows):
        ev = _evaluate(setup, run)
        _store(path, k, run, ev, setup)
        if progress is not None:
            progress(k)
        _judge(setup, run, ev, k)
        if k == rows - 1 or not run.active.any():
            break
        _advance(run, ev, opt_update)
    return _finish_path(path, run, setup)


def _setup(model, problem: Problem, fixed, n_start: int, solver, newton) -> _Setup:
    names = problem.names
    held = tuple(problem.hold)
    wanted = frozenset({problem.objective, *held} & set(EXTRA_QUANTITIES))
    return _Setup(
        model=model, problem=problem, lo=np.asarray(problem.lower, np.float64),
        width=np.asarray(problem.upper, np.float64) - np.asarray(problem.lower, np.float64),
        held=held, target=np.array([problem.hold[h] for h in held], np.float64),
        fixed={k: np.broadcast_to(np.asarray(v, np.float64), (n_start,)) for k, v in fixed.items() if k not in names},
        program=sensitivity_program(model, names, solver, newton),
        extra_fn=extra_program(model, names, solver, newton) if wanted else None, wanted=wanted,
    )


def _compiled(setup: _Setup, run: _Starts) -> _Setup:
    """``setup`` with its jitted programs compiled for the starts' shapes (every
    iteration calls them with the same shapes); stand-ins without ``lower`` kept."""
    batch, v0 = _arguments(setup, run)
    aot = lambda fn: fn.lower(batch, v0).compile() if hasattr(fn, "lower") else fn
    extra = None if setup.extra_fn is None else aot(setup.extra_fn)
    return dataclasses.replace(setup, program=aot(setup.program), extra_fn=extra)


def _arguments(setup: _Setup, run: _Starts) -> tuple[dict, jax.Array]:
    """The programs' arguments at every start's point: ``(params batch, v0 (S, n_v))``."""
    p = setup.lo + setup.width * run.x
    names = setup.problem.names
    batch = {**{n: jnp.asarray(p[:, i]) for i, n in enumerate(names)}, **{n: jnp.asarray(v) for n, v in setup.fixed.items()}}
    return batch, jnp.asarray(run.v0)


def _begin(setup: _Setup, opt, starts: np.ndarray, guesses: np.ndarray | None) -> _Starts:
    """Every start at its initial point, Newton from ``guesses`` or the model's guess there."""
    n_start = starts.shape[0]
    names, fixed = setup.problem.names, setup.fixed
    x = np.clip((starts - setup.lo) / setup.width, 0.0, 1.0)
    if guesses is not None:
        n_v = len(setup.model.section_names)
        v0 = np.asarray(guesses, np.float64).reshape(-1, n_v)
        if v0.shape[0] not in (1, n_start):
            raise ValueError(f"guesses: {v0.shape[0]} points of {n_v} for {n_start} starts; give one, or one per start")
        v0 = np.broadcast_to(v0, (n_start, n_v)).copy()
    else:
        v0 = np.stack([np.asarray(setup.model.initial_guess({**{k: v[i] for k, v in fixed.items()}, **dict(zip(names, starts[i]))}))
                       for i in range(n_start)])
    return _Starts(
        x=x, v0=v0, good_x=x.copy(), good_v=v0.copy(), state=jax.vmap(opt.init)(jnp.asarray(x)),
        multipliers=np.zeros((n_start, len(setup.held))), active=np.ones(n_start, bool),
        final_status=np.zeros(n_start, np.int8), ended_at=np.full(n_start, setup.problem.iterations, np.int32),
        scale=np.ones(n_start), failures=np.zeros(n_start, np.int32),
    )


def _evaluate(setup: _Setup, run: _Starts) -> _Evaluation:
    """The gait, the objective and the Lagrangian's gradient at every start's point."""
    problem, width = setup.problem, setup.width
    batch, v0 = _arguments(setup, run)
    sens = setup.program(batch, v0)
    status = np.asarray(sens.status).astype(np.int8)
    # Newton again from the gait just found: one iteration.
    v_found = np.where(np.isfinite(np.asarray(sens.metrics.v)), np.asarray(sens.metrics.v), run.v0)
    extra = None if setup.extra_fn is None else setup.extra_fn(batch, jnp.asarray(v_found))
    quantity = functools.partial(_quantity, sens, extra=extra)
    f, df = quantity(problem.objective)
    f, df = problem.sign * f, problem.sign * df
    grad_x = df * width  # chain rule into the unit box
    finite = np.isfinite(f) & np.isfinite(grad_x).all(axis=-1)
    for j, h in enumerate(setup.held):
        q, dq = quantity(h)
        c = (q - setup.target[j]) / abs(setup.target[j])
        grad_x = grad_x + ((run.multipliers[:, j] + problem.penalty * c)[:, None] * dq / abs(setup.target[j])) * width
        finite &= np.isfinite(q) & np.isfinite(grad_x).all(axis=-1)
    # A gait whose objective, held values or their gradients are not finite (the gait
    # sensitivity norm of an unstable gait is inf) gives the optimiser nothing to step on.
    status = np.where((status == Status.OK) & ~finite, np.int8(Status.NOT_DIFFERENTIABLE), status).astype(np.int8)
    return _Evaluation(status, f, df, grad_x, quantity, np.asarray(sens.metrics.v))


def _judge(setup: _Setup, run: _Starts, ev: _Evaluation, k: int) -> None:
    """Failed points: undo, halve, clear momentum; too many in a row (or at the start):
    end. Accepted points become the last good ones; the multipliers take their dual step."""
    problem = setup.problem
    ok = ev.status == Status.OK
    failed = run.active & ~ok
    run.failures = np.where(failed, run.failures + 1, np.where(run.active, 0, run.failures))
    end = failed & ((k == 0) | (run.failures > problem.max_retries))
    run.final_status[end] = ev.status[end]
    run.ended_at[end] = k
    run.active &= ~end
    retry = failed & run.active
    run.good_x[run.active & ok] = run.x[run.active & ok]
    run.good_v[run.active & ok] = ev.v[run.active & ok]
    for j, h in enumerate(setup.held):
        q = ev.quantity(h)[0]
        c = (q - setup.target[j]) / abs(setup.target[j])
        dual_step = (k + 1) % problem.dual_every == 0
        run.multipliers[:, j] = np.where(run.active & ok & dual_step, run.multipliers[:, j] + problem.penalty * c,
                                         run.multipliers[:, j])
    run.scale = np.where(retry, 0.5 * run.scale, run.scale)


def _advance(run: _Starts, ev: _Evaluation, opt_update) -> None:
    """The next point of every start: an optax step from the last good point, or
    (after a failure) half the step it had taken."""
    ok = ev.status == Status.OK
    retry = run.active & ~ok
    g = np.where((run.active & ok)[:, None], ev.grad_x, 0.0)
    updates, state = opt_update(jnp.asarray(g), run.state, jnp.asarray(run.x))
    run.state = _clear_rows(state, retry, run.x.shape[0])
    step = np.asarray(updates) * run.scale[:, None]
    x_next = np.clip(run.good_x + np.where((run.active & ok)[:, None], step, 0.0), 0.0, 1.0)
    x_retry = np.clip(run.good_x + 0.5 * (run.x - run.good_x), 0.0, 1.0)
    run.x = np.where(retry[:, None], x_retry, np.where(run.active[:, None], x_next, run.x))
    run.v0 = run.good_v.copy()


def _empty_path(rows: int, shape: tuple[int, int], setup: _Setup) -> Path:
    """A :class:`Path` of ``rows`` rows to fill in place; its per-start fields come at the end (:func:`_finish_path`)."""
    n_start, n_p = shape
    quantities = [q for q in QUANTITIES if q not in EXTRA_QUANTITIES or q in setup.wanted]
    return Path(
        params=np.full((rows, n_start, n_p), np.nan), objective=np.full((rows, n_start), np.nan),
        metrics={q: np.full((rows, n_start), np.nan) for q in quantities}, gradient=np.full((rows, n_start, n_p), np.nan),
        status=np.zeros((rows, n_start), np.int8), accepted=np.zeros((rows, n_start), bool),
        multipliers=np.zeros((rows, n_start, len(setup.held))),
        final_params=None, best_params=None, best_row=None, final_status=None, ended_at=None,
    )


def _store(path: Path, k: int, run: _Starts, ev: _Evaluation, setup: _Setup) -> None:
    """Row ``k`` of ``path``: the running starts' evaluation (an ended start keeps its final status)."""
    active = run.active
    path.params[k][active] = (setup.lo + setup.width * run.x)[active]
    path.objective[k][active] = ev.f[active]
    for q in path.metrics:
        path.metrics[q][k][active] = ev.quantity(q)[0][active]
    path.gradient[k][active] = ev.df[active]
    path.status[k] = np.where(active, ev.status, run.final_status)
    path.accepted[k] = active & (ev.status == Status.OK)
    path.multipliers[k] = run.multipliers


def _finish_path(path: Path, run: _Starts, setup: _Setup) -> Path:
    """``path`` with each start's last and best accepted point (least merit) and how it ended."""
    problem, n_start = setup.problem, run.x.shape[0]
    merit = path.objective.copy()
    for j, h in enumerate(setup.held):
        merit = merit + 0.5 * problem.penalty * ((path.metrics[h] - setup.target[j]) / abs(setup.target[j])) ** 2
    merit = np.where(path.accepted, merit, np.inf)
    best_row = np.where(path.accepted.any(0), np.argmin(merit, axis=0), -1).astype(np.int32)
    best_params = np.where((best_row >= 0)[:, None], path.params[np.maximum(best_row, 0), np.arange(n_start)], np.nan)
    return path._replace(final_params=setup.lo + setup.width * run.good_x, best_params=best_params, best_row=best_row,
                         final_status=run.final_status, ended_at=run.ended_at)


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
