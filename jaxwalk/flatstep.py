"""One step of a walker as one flat loop of integrator steps (the flat engine).

The nested engine (:mod:`jaxwalk.step`) runs one ``diffeqsolve`` per phase
inside a loop over phases, and the root finder inside that: under ``vmap``
every level waits for the batch's slowest lane, so a batch pays
(slowest phase count) x (slowest step count) x (slowest root find). Here one
``lax.while_loop`` iteration advances every lane by one integrator step in its
own current phase (the phase is data):

1. a Runge-Kutta step of diffrax's solver (``solver.step``, with its dense
   output and error estimate) and diffrax's PID controller
   (``adapt_step_size``) to accept or reject it;
2. on an accepted step whose smallest guard went from positive to non-positive
   (diffrax's rule for ``direction=False``), the event is located on the
   step's dense interpolant by a bracketed Newton method with a fixed
   iteration count (:func:`locate_event`); a step whose root does not
   converge in that count is retried at half the size;
3. the model's reset and the status rules (:func:`jaxwalk.stepbase.close_phase`)
   are applied to the lanes whose phase ended; the others go on.

Expensive parts that only some lanes need (event location, resets, the guard
at a new phase's start) run under a ``lax.cond`` on "any lane needs it"
(``equinox.internal.unvmap_any``, as diffrax does for its FSAL stage), so an
iteration where no lane has an event costs one RK step and one guard
evaluation per lane.

Derivatives: step sizes carry no tangent (as in diffrax, whose controller
stops gradients); event times get theirs from the implicit function theorem,
one Newton step ``t* = t_K - g(t_K)/g'(t_K)`` whose ``t_K`` and ``g'`` are
held constant (``stop_gradient``), so ``dt*/dp = -(dg/dp)/g'`` exactly,
whatever the root finder did before. The loop has one level, so ``jvp``
traces its body once (a nested loop re-traced every level's body until its
tangents were stable). With ``SolverOptions.reverse_mode`` the loop is
equinox's checkpointed while loop and ``jax.grad`` works through a step (the
same derivatives as forward mode: tests/test_flatstep.py).
"""

from __future__ import annotations

from typing import NamedTuple

import diffrax
import equinox as eqx
import equinox.internal as eqxi
import jax
import jax.numpy as jnp
from jaxtyping import Array, ArrayLike, Float, Int32

from jaxwalk.status import Status
from jaxwalk.stepbase import FIRST_STEP, SolverOptions, StepResult, close_phase, guard_offsets, state_dependent
from jaxwalk.walker import Params, Walker

sg = jax.lax.stop_gradient


class _Carry(NamedTuple):
    """One lane's loop state (every leaf batched under vmap)."""

    t: Array  # current time (end of the last accepted step)
    dt: Array  # next step size to try
    y: Array  # state at t
    phase: Array  # int32
    ctx: Array
    g: Array  # smallest guard (offsets added) at (t, y) in this phase
    offsets: Array  # the phase's guard offsets (stepbase.guard_offsets)
    fresh: Array  # bool: no step taken in this phase yet (FSAL stage invalid)
    f0: Array  # FSAL: vector field at (t, y)
    pid: tuple  # PID controller's two error memories
    n_steps: Array  # solver steps (accepted or rejected) in this phase
    t_start: Array  # when this phase began
    y_start: Array  # state when this phase began (for actuator work)
    length: Array
    status: Array
    n_events: Array
    work: Array
    ode_steps: Array  # solver steps (accepted or rejected) in the step: the phases' n_steps summed
    guard: Array  # int32, the guard of the last phase's event (-1: it ended without one)


def _solver(opts: SolverOptions):
    """The Runge-Kutta solver, its stages in a plain ``lax.scan`` (diffrax's
    default, a checkpointed scan, is reverse-mode only; ``ForwardMode`` does the
    same), or in equinox's bounded scan where ``opts.reverse_mode`` asks for
    ``jax.grad`` (a ``lax`` loop with a dynamic trip count has no transpose)."""
    kind = "bounded" if opts.reverse_mode else "lax"
    return eqx.tree_at(lambda s: s.scan_kind, opts.make_solver(), kind, is_leaf=lambda x: x is None)


def _min_guard(model: Walker, params, t, y, phase, ctx, offsets):
    return jnp.min(model.guard_values(t, y, params, phase, ctx) + offsets)


def _phase_start(model: Walker, params, t, y, phase, ctx, opts: SolverOptions):
    """``(g, offsets)`` of a phase starting at ``(t, y)``: its smallest guard (offsets
    added) and its :func:`~jaxwalk.stepbase.guard_offsets`, from one evaluation of
    the guards (a dynamics solve for the flat-foot walker) shared by both."""
    g0 = model.guard_values(t, y, params, phase, ctx)
    offsets = guard_offsets(g0, opts)
    return jnp.min(g0 + offsets), offsets


def locate_event(guard, lower, upper, g_lower, g_upper, iterations: int, tol: float):
    """Root of ``guard`` in ``[lower, upper]``, where ``g_lower = guard(lower) > 0 >= g_upper``.

    Newton's method kept in the bracket (a Newton step that would leave it
    bisects instead), ``iterations`` times from the regula-falsi point.
    Returns ``(t, converged)``: ``converged`` when the last update or the
    bracket is below ``tol (1 + |t|)``. Differentiate the root with
    :func:`implicit_root`, not through these iterations (give ``guard``
    ``stop_gradient``-ed data: :func:`_locate_in_step`).
    """
    denom = g_lower - g_upper
    t0 = jnp.where(denom > 0, upper - g_upper * (upper - lower) / jnp.where(denom > 0, denom, 1.0), 0.5 * (lower + upper))
    t0 = jnp.clip(t0, lower, upper)

    def body(_, c):
        lo, hi, t, _ = c
        g, dg = jax.jvp(guard, (t,), (jnp.ones_like(t),))
        neg = g <= 0
        lo, hi = jnp.where(neg, lo, t), jnp.where(neg, t, hi)
        step = g / jnp.where(dg == 0, 1.0, dg)
        newton = t - step
        inside = (dg != 0) & (newton > lo) & (newton < hi)
        # A converged Newton step is below one ulp of t: t itself is a bracket
        # end then, and "inside" fails; bisecting there would throw the root away.
        done = (g == 0) | ((dg != 0) & (jnp.abs(step) < tol * (1.0 + jnp.abs(t))))
        nxt = jnp.where(done, newton, jnp.where(inside, newton, 0.5 * (lo + hi)))
        return lo, hi, nxt, jnp.abs(nxt - t)

    lo, hi, t_k, last = jax.lax.fori_loop(0, iterations, body, (lower, upper, t0, jnp.full_like(t0, jnp.inf)))
    scale = tol * (1.0 + jnp.abs(t_k))
    converged = (last < scale) | (hi - lo < scale)
    return sg(t_k), converged


def implicit_root(guard, t_k):
    """``t_k`` (a root of ``guard``) with the implicit-function tangent ``-(dg/dp) / (dg/dt)``.

    The primal value is ``t_k`` itself; ``guard`` carries the tangents of
    whatever it depends on (parameters, the step's dense output).
    """
    g, dg = jax.jvp(guard, (t_k,), (jnp.ones_like(t_k),))
    dg = sg(dg)
    return t_k - (g - sg(g)) / jnp.where(dg == 0, 1.0, dg)


def _locate_in_step(model, params, opts: SolverOptions, interp_cls, t0, t1, g0, g1, dense, phase, ctx, offsets):
    """Event time and state inside the accepted step ``[t0, t1]`` (guards ``g0 > 0 >= g1``
    at its ends): ``(t_event, y_event, converged)``."""

    def make(p, dense_, ctx_, a, b):
        interp = interp_cls(t0=a, t1=b, **dense_)
        return interp, lambda t: _min_guard(model, p, t, interp.evaluate(t), phase, ctx_, offsets)

    _, frozen = make(sg(params), sg(dense), sg(ctx), sg(t0), sg(t1))
    t_k, converged = locate_event(frozen, sg(t0), sg(t1), sg(g0), sg(g1), opts.event_iterations, opts.event_tol)
    interp, live = make(params, dense, ctx, t0, t1)
    t_event = implicit_root(live, t_k)
    return t_event, interp.evaluate(t_event), converged


class _Attempt(NamedTuple):
    """One integrator step tried from a lane's state (before events)."""

    t1: Array  # where the step ends
    y1: Array
    f1: Array  # FSAL stage at (t1, y1)
    g1: Array  # smallest guard at (t1, y1)
    keep: Array  # the controller accepts the step
    dt: Array  # the controller's next step size
    pid: tuple
    dense: dict


def _attempt(model, params, opts: SolverOptions, solver, controller, c: _Carry, t_limit) -> _Attempt:
    """One Runge-Kutta step from ``(c.t, c.y)`` and the controller's verdict."""
    term = diffrax.ODETerm(model.vector_field)
    args = (params, c.phase, c.ctx)
    t1 = jnp.minimum(c.t + c.dt, t_limit)
    y1, y_err, dense, (_, f1), _ = solver.step(term, c.t, t1, c.y, args, (c.fresh, c.f0), c.fresh)
    y_err = jnp.where(jnp.isnan(y_err), jnp.inf, y_err)  # as diffrax: a NaN step is rejected
    keep, t_next0, t_next1, _, (e1, e2, _), _ = controller.adapt_step_size(
        c.t, t1, c.y, y1, args, y_err, solver.error_order(term), (c.pid[0], c.pid[1], False)
    )
    g1 = _min_guard(model, params, t1, y1, c.phase, c.ctx, c.offsets)
    return _Attempt(t1, y1, f1, g1, keep, sg(t_next1 - t_next0), (e1, e2), dense)


def _close_phase(model: Walker, params, opts: SolverOptions, c: _Carry, go_on: _Carry, t_ev, y_ev, result, at_start) -> _Carry:
    """A lane whose phase ended at ``(t_ev, y_ev)`` with diffrax ``result`` (``at_start``:
    where it started): the reset, the statuses, and a fresh start of the next phase from ``go_on``."""
    end = close_phase(model, params, t_ev, y_ev, result, c.phase, c.ctx, c.n_events, opts, c.offsets, at_start)
    g, offsets = _phase_start(model, params, end.t_event, end.y_next, end.phase_next, end.ctx_next, opts)
    one = jnp.ones((), c.t.dtype)
    return go_on._replace(
        t=end.t_event,
        # A phase that ended at its start took no step: its proposal is the one it was given.
        dt=jnp.where(at_start, c.dt, go_on.dt) if opts.carries_step(model) else jnp.full((), FIRST_STEP, c.t.dtype),
        y=end.y_next,
        phase=end.phase_next,
        ctx=end.ctx_next,
        g=g,
        offsets=offsets,
        fresh=jnp.asarray(True),
        pid=(one, one),
        n_steps=jnp.zeros_like(c.n_steps),
        t_start=end.t_event,
        y_start=end.y_next,
        length=c.length + end.shift,
        status=end.status,
        n_events=end.n_events,
        guard=jnp.where(end.event_happened, end.guard, -1),
        # Work over the phase, from its start to the event (before the reset,
        # which may relabel the legs; impacts do not move the joints), and the reset's own.
        work=c.work + model.actuator_work(c.y_start, end.y_event, params, c.phase, c.ctx) + end.work,
    )


def _advance(model: Walker, params, opts: SolverOptions, c: _Carry) -> _Carry:
    """The loop body: one integrator step for the lane, and its phase's end if it came."""
    solver = _solver(opts)
    controller = opts.make_controller(model)
    t_limit = c.t_start + opts.phase_time_limit * model.time_scale(params)
    a = _attempt(model, params, opts, solver, controller, c, t_limit)

    # A guard already past when the phase starts is an event at the start (see step.end_phase).
    at_start = c.fresh & (c.g < -opts.start_guard_margin)
    crossed = a.keep & (c.g > 0) & (a.g1 <= 0) & ~at_start

    def locate():
        return _locate_in_step(
            model, params, opts, solver.interpolation_cls, c.t, a.t1, c.g, a.g1, a.dense, c.phase, c.ctx, c.offsets
        )

    t_ev, y_ev, located = jax.lax.cond(eqxi.unvmap_any(crossed), locate, lambda: (a.t1, a.y1, jnp.asarray(True)))
    retry = crossed & ~located  # the root did not converge: the same step at half the size
    moved = a.keep & ~crossed & ~at_start
    timeout = moved & (a.t1 >= t_limit)
    n_steps = c.n_steps + 1
    out_of_steps = ~at_start & ~crossed & ~timeout & (n_steps >= opts.max_solver_steps)
    event = at_start | (crossed & located)
    ended = event | timeout | out_of_steps
    # Out of steps on a rejected try: the lane ends where it is, at its last accepted step (as
    # diffrax does), not at the try (a NaN try would read NONFINITE; any other, a wrong state).
    # (A lane that moved without an event ends at its step's end: the located time is another lane's.)
    t_ev = jnp.where(at_start, c.t, jnp.where(event, t_ev, jnp.where(moved, a.t1, c.t)))
    y_ev = jnp.where(at_start, c.y, jnp.where(event, y_ev, jnp.where(moved, a.y1, c.y)))
    result = diffrax.RESULTS.where(
        event,
        diffrax.RESULTS.event_occurred,
        diffrax.RESULTS.where(timeout, diffrax.RESULTS.successful, diffrax.RESULTS.max_steps_reached),
    )

    go_on = _Carry(
        t=jnp.where(moved, a.t1, c.t),
        dt=jnp.where(retry, 0.5 * sg(a.t1 - c.t), a.dt),
        y=jnp.where(moved, a.y1, c.y),
        phase=c.phase,
        ctx=c.ctx,
        g=jnp.where(moved, a.g1, c.g),
        offsets=c.offsets,
        fresh=c.fresh & ~moved,
        f0=jnp.where(moved, a.f1, c.f0),
        pid=jax.tree_util.tree_map(lambda new, old: jnp.where(retry, old, new), a.pid, c.pid),
        n_steps=n_steps,
        t_start=c.t_start,
        y_start=c.y_start,
        length=c.length,
        status=c.status,
        n_events=c.n_events,
        work=c.work,
        ode_steps=c.ode_steps + 1,
        guard=c.guard,
    )

    close = lambda: _close_phase(model, params, opts, c, go_on, t_ev, y_ev, result, at_start)
    closed = jax.lax.cond(eqxi.unvmap_any(ended), close, lambda: go_on)
    return jax.tree_util.tree_map(lambda x, y: jnp.where(ended, x, y), closed, go_on)


def run_step_flat(model: Walker, params: Params, y0: Float[Array, "2*n_q"], phase0: Int32[ArrayLike, ""],
                  ctx0: Float[Array, "n_ctx"], opts: SolverOptions = SolverOptions()) -> StepResult:
    """One step from a full state, as :func:`jaxwalk.step.run_step` (same arguments and result)."""
    dtype = y0.dtype
    phase0 = jnp.asarray(phase0, jnp.int32)
    zero = jnp.zeros((), dtype)
    one = jnp.ones((), dtype)
    g0, offsets0 = _phase_start(model, params, zero, y0, phase0, ctx0, opts)
    carry0 = _Carry(
        t=zero,
        dt=jnp.full((), FIRST_STEP, dtype),
        y=y0,
        phase=phase0,
        ctx=ctx0,
        g=g0,
        offsets=offsets0,
        fresh=jnp.asarray(True),
        f0=jnp.zeros_like(y0),
        pid=(one, one),
        n_steps=jnp.zeros((), jnp.int32),
        t_start=zero,
        y_start=y0,
        length=zero,
        status=jnp.asarray(Status.IN_PROGRESS, jnp.int8),
        n_events=jnp.zeros((), jnp.int32),
        work=zero,
        ode_steps=jnp.zeros((), jnp.int32),
        guard=jnp.full((), -1, jnp.int32),
    )
    carry0 = jax.tree_util.tree_map(lambda x: state_dependent(x, y0), carry0)  # one trace of the body under jvp, vmap
    running = lambda c: c.status == Status.IN_PROGRESS
    body = lambda c: _advance(model, params, opts, c)
    if opts.reverse_mode:  # jax.grad through the step: a checkpointed loop with a bound on its trips
        bound = (opts.max_events + 1) * opts.max_solver_steps
        c = eqxi.while_loop(running, body, carry0, max_steps=bound, kind="checkpointed")
    else:
        c = jax.lax.while_loop(running, body, carry0)
    return StepResult(c.y, c.ctx, c.phase, c.t, c.length, c.status, c.n_events, c.work, c.ode_steps, c.guard)
