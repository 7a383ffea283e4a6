"""One step of a walker: a ``lax.while_loop`` state machine over its phases.

Each iteration integrates the current phase with diffrax until the smallest
guard crosses zero; the crossing time is found by Newton's method on the dense
interpolant, so forward-mode derivatives of the step map include the
event-time terms. The model's reset then gives the next phase (or the end of
the step, or a failure status).

The loop is written for ``vmap``: one ``diffeqsolve`` per iteration whatever
the phase (the phase is data, ``args``), and every failure ends the loop with a
status instead of raising.
"""

from __future__ import annotations

import functools
from typing import NamedTuple

import diffrax
import jax
import jax.numpy as jnp
from jaxtyping import Array, ArrayLike, Bool, Float, Int32

from jaxwalk.flatstep import run_step_flat
from jaxwalk.rootfind import BracketedNewton
from jaxwalk.status import Status
from jaxwalk.stepbase import FIRST_STEP, PhaseEnd, SolverOptions, StepResult, close_phase, guard_offsets, state_dependent  # noqa: F401 (re-exported)
from jaxwalk.walker import Params, Walker


def start_guards(model: Walker, params, t0, y0, phase, ctx) -> Float[Array, "n_guards"]:
    """``(n_guards,)`` guard values at the start ``(t0, y0)`` of ``phase``, without tangents.

    Evaluated once per phase and shared by :func:`solve_phase` (the phase's
    :func:`guard_offsets`) and :func:`end_phase` (the same offsets, and the test
    for an event at the phase's start): the flat-foot walker's guards solve its
    constrained dynamics, and each evaluation under ``jvp`` is some 14,000
    lines of the step's program. Only signs and comparisons of these values are
    used, so their tangents would be dead code.
    """
    return jax.lax.stop_gradient(model.guard_values(t0, y0, params, phase, ctx))


class ProposingState(NamedTuple):
    """:class:`ProposingController`'s state."""

    pid: tuple  # the inner PIDController's state
    proposed: Array  # the step it proposes next (model time units, in diffrax's direction-normalised time)


class ProposingController(diffrax.AbstractAdaptiveStepSizeController):
    """diffrax's ``PIDController`` whose state also keeps the step it proposes next.

    A solve saved with ``SaveAt(controller_state=True)`` then says what step
    the controller would have taken after the phase's last one: the next
    phase's first step (:meth:`SolverOptions.carries_step`). Steps, verdicts and
    error memories are the inner controller's, unchanged.
    """

    inner: diffrax.PIDController
    rtol: float
    atol: float

    def __init__(self, inner: diffrax.PIDController):
        self.inner, self.rtol, self.atol = inner, inner.rtol, inner.atol

    @property
    def norm(self):
        return self.inner.norm

    def wrap(self, direction):
        return ProposingController(self.inner.wrap(direction))

    def init(self, terms, t0, t1, y0, dt0, args, func, error_order):
        t_next, state = self.inner.init(terms, t0, t1, y0, dt0, args, func, error_order)
        return t_next, ProposingState(state, t_next - t0)

    def adapt_step_size(self, t0, t1, y0, y1_candidate, args, y_error, error_order, controller_state):
        keep, t_next0, t_next1, jump, state, result = self.inner.adapt_step_size(
            t0, t1, y0, y1_candidate, args, y_error, error_order, controller_state.pid
        )
        return keep, t_next0, t_next1, jump, ProposingState(state, t_next1 - t_next0), result


def solve_phase(model: Walker, params, y, phase, ctx, t0, g0: Float[Array, "n_guards"], opts: SolverOptions,
                dense: bool = False, empty: Bool[ArrayLike, ""] = False, dt0: Float[ArrayLike, ""] = FIRST_STEP):
    """Integrate ``phase`` from ``t0`` until an event or the time limit.

    Args:
        g0: ``(n_guards,)`` guard values at ``(t0, y)`` (:func:`start_guards`).
        empty: solve over the empty interval ``[t0, t0]`` instead (no solver step).
        dt0: the first step (model time units).

    Returns the diffrax ``Solution`` (saved at its end, with the controller's
    state, whose last entry is the step it proposes next; with ``dense=True``
    also its interpolation, which the recorder of ``jaxwalk simulate`` samples).
    """
    term = diffrax.ODETerm(model.vector_field)
    offsets = guard_offsets(g0, opts)

    def smallest_guard(t, y, args, **kwargs):
        return jnp.min(model.guard_values(t, y, *args) + offsets)

    event = diffrax.Event(
        smallest_guard,
        root_finder=BracketedNewton(rtol=opts.event_tol, atol=opts.event_tol),
        direction=False,
    )
    t1 = jnp.where(empty, t0, t0 + opts.phase_time_limit * model.time_scale(params))
    sol = diffrax.diffeqsolve(
        term,
        opts.make_solver(),
        t0=t0,
        t1=t1,
        dt0=jax.lax.stop_gradient(jnp.asarray(dt0, y.dtype)),
        y0=y,
        args=(params, phase, ctx),
        event=event,
        stepsize_controller=ProposingController(opts.make_controller(model)),
        max_steps=opts.max_solver_steps,
        adjoint=diffrax.ForwardMode(),
        throw=False,
        saveat=diffrax.SaveAt(t1=True, dense=dense, controller_state=True),
    )
    return sol


# A jit boundary around a phase's solve and around a whole step: JAX caches a
# jitted function's jvp and vmap of its jaxpr, so the fixpoint iterations of
# the enclosing while loops' batching and jvp rules (Newton's, the phase
# loop's; one pass each since their carries are marked state-dependent, more
# under the transformations of a caller's loops) transform these only once per
# distinct input batching. Tracing the simplest walker's
# second-order sensitivity program fell from 66 to 40 s; the compiled program
# and every number are unchanged (benchmarks/bench_jit_boundaries.py).
@functools.partial(jax.jit, static_argnums=(0, 7))
def _solve_phase(model: Walker, params, y, phase, ctx, t0, g0, opts: SolverOptions, empty=False, dt0=FIRST_STEP):
    """End time, end state and diffrax result of :func:`solve_phase`, its
    solver steps (accepted and rejected), and the next phase's first step."""
    sol = solve_phase(model, params, y, phase, ctx, t0, g0, opts, empty=empty, dt0=dt0)
    solved = (sol.ts[-1], sol.ys[-1], sol.result)
    return solved, jnp.asarray(sol.stats["num_steps"], jnp.int32), next_first_step(model, sol, opts, dt0, empty)


def next_first_step(model: Walker, sol, opts: SolverOptions, dt0, stepped_none: Bool[ArrayLike, ""]) -> Float[Array, ""]:
    """The first step (model time units) of the phase after ``sol``'s, which began with ``dt0``.

    What its controller proposed after its last step (:meth:`SolverOptions.carries_step`;
    otherwise :data:`FIRST_STEP`), or ``dt0`` itself where the solve took no step
    (``stepped_none``: an empty interval, or a phase that ended at its start) or
    the proposal is not a positive number. (Over an empty interval diffrax
    flips time, ``t1 <= t0``, and the proposal there is ``-dt0``.)
    """
    if not opts.carries_step(model):
        return jnp.full((), FIRST_STEP, sol.ts.dtype)
    proposed = jax.lax.stop_gradient(sol.controller_state.proposed)
    keep = stepped_none | ~(jnp.isfinite(proposed) & (proposed > 0))
    return jnp.where(keep, jax.lax.stop_gradient(dt0), proposed)


def event_at_start(g0: Float[Array, "n_guards"], opts: SolverOptions) -> Bool[Array, ""]:
    """Whether a phase ends where it starts: a guard is already negative.

    Such a guard never "crosses" zero, and while it is the smallest it hides
    every other guard: the phase ends at its start (a swing foot landing behind
    the hip after a large drop, a knee that must already pull, a stance foot
    outside its friction cone in the step's first phase). The margin keeps a
    guard that ended the previous phase (zero to root-finding accuracy) quiet;
    the solve watches it lifted by :func:`guard_offsets`, so it hides no other guard.
    """
    return jnp.min(g0) < -opts.start_guard_margin


def _solve_unless_ended(model: Walker, params, y, phase, ctx, t0, g0, opts: SolverOptions, dt0):
    """:func:`_solve_phase` over an empty interval where the phase ends at its
    start or its state is not finite (:func:`close_phase` then says ``NONFINITE``).

    A full solve there would run to the solver's step limit in vain (no guard
    can cross while a negative one is the smallest; a NaN state's error estimate
    rejects every step): 2048 Dopri8 steps, 2-4 s on the flat-foot walker, at
    every grid point whose first phase starts outside a friction cone and, in
    the analyses that walk from each gait (``h_max``, the basin, ...),
    at every point without a gait (its fixed point is NaN). An empty interval
    (``t1 = t0``) takes no solver step, also in a vmapped batch, where a
    ``lax.cond`` on a batched condition would run the full solve anyway."""
    ends = event_at_start(g0, opts) | ~jnp.all(jnp.isfinite(y))
    return _solve_phase(model, params, y, phase, ctx, t0, g0, opts, ends, dt0)


def end_phase(model: Walker, params, t0, y0, phase, ctx, g0, solved, n_events, opts: SolverOptions) -> PhaseEnd:
    """The event that ended a phase started at ``(t0, y0, phase, ctx)``, the model's
    reset and the status rules: the body of :func:`run_step`'s loop after the solve,
    shared with the recorder (:mod:`jaxwalk.simulate.recorder`).

    Args:
        g0: ``(n_guards,)`` guard values at ``(t0, y0)`` (:func:`start_guards`),
            the ones the phase's solve was given.
        solved: ``(t_event, y_event, result)`` of the phase's ``diffeqsolve`` (:func:`_solve_phase`).
        n_events: events in the step before this one.
    """
    t_event, y_event, result = solved
    at_start = event_at_start(g0, opts)
    t_event = jnp.where(at_start, t0, t_event)
    y_event = jnp.where(at_start, y0, y_event)
    result = diffrax.RESULTS.where(at_start, diffrax.RESULTS.event_occurred, result)
    offsets = guard_offsets(g0, opts)
    return close_phase(model, params, t_event, y_event, result, phase, ctx, n_events, opts, offsets, at_start)


class _PhaseLoop(NamedTuple):
    """The carry of :func:`run_step`'s loop, one iteration per phase (scalars but ``y``, ``ctx``)."""

    t: Array  # time since the step began (model time units)
    y: Array  # (2 n_q,) state at the start of the current phase
    phase: Array  # int32
    ctx: Array  # (n_ctx,)
    length: Array  # distance the stance foot has moved so far
    status: Array  # int8; IN_PROGRESS while the step goes on
    n_events: Array  # int32, events so far
    work: Array  # actuator work so far (model energy units)
    ode_steps: Array  # int32, ODE solver steps so far (accepted and rejected)
    guard: Array  # int32, the guard of the last phase's event (-1: it ended without one)
    dt: Array  # the next phase's first step (model time units)


@functools.partial(jax.jit, static_argnums=(0, 5))  # see _solve_phase
def run_step(model: Walker, params: Params, y0: Float[Array, "2*n_q"], phase0: Int32[ArrayLike, ""],
             ctx0: Float[Array, "n_ctx"], opts: SolverOptions = SolverOptions()) -> StepResult:
    """Run one step from a full state. Pure; ``jit``/``vmap``/``jacfwd`` ready.

    Args:
        model: the walker (static).
        params: dict of scalar parameters.
        y0: ``(2 n_q,)`` initial state; ``phase0`` int32; ``ctx0`` ``(n_ctx,)``.
        opts: static solver settings; ``opts.engine == "flat"`` runs the flat
            engine (:func:`jaxwalk.flatstep.run_step_flat`) instead.
    """
    if opts.engine == "flat":
        return run_step_flat(model, params, y0, phase0, ctx0, opts)
    if opts.engine != "nested":
        raise ValueError(f"SolverOptions.engine must be 'nested' or 'flat', got {opts.engine!r}")
    in_progress = jnp.asarray(Status.IN_PROGRESS, jnp.int8)

    def cond(c: _PhaseLoop):
        # close_phase ends the step (TOO_MANY_EVENTS) at max_events events, so
        # the bound never decides alone; it shows how long the loop can run.
        return (c.status == in_progress) & (c.n_events < opts.max_events)

    def body(c: _PhaseLoop) -> _PhaseLoop:
        g0 = start_guards(model, params, c.t, c.y, c.phase, c.ctx)
        solved, ode_steps, dt = _solve_unless_ended(model, params, c.y, c.phase, c.ctx, c.t, g0, opts, c.dt)
        end = end_phase(model, params, c.t, c.y, c.phase, c.ctx, g0, solved, c.n_events, opts)
        # Work over the phase, from its start to the event (before the reset,
        # which may relabel the legs; impacts do not move the joints), and the reset's own.
        work = c.work + model.actuator_work(c.y, end.y_event, params, c.phase, c.ctx) + end.work
        return _PhaseLoop(end.t_event, end.y_next, end.phase_next, end.ctx_next, c.length + end.shift, end.status,
                          end.n_events, work, c.ode_steps + ode_steps, jnp.where(end.event_happened, end.guard, -1), dt)

    zero = jnp.zeros((), y0.dtype)
    c0 = _PhaseLoop(
        t=zero,
        y=y0,
        phase=jnp.asarray(phase0, jnp.int32),
        ctx=ctx0,
        length=zero,
        status=in_progress,
        n_events=jnp.zeros((), jnp.int32),
        work=zero,
        ode_steps=jnp.zeros((), jnp.int32),
        guard=jnp.full((), -1, jnp.int32),
        dt=jnp.full((), FIRST_STEP, y0.dtype),
    )
    c0 = jax.tree_util.tree_map(lambda x: state_dependent(x, y0), c0)
    c = jax.lax.while_loop(cond, body, c0)
    return StepResult(c.y, c.ctx, c.phase, c.t, c.length, c.status, c.n_events, c.work, c.ode_steps, c.guard)


def step_map(model: Walker, v: Float[Array, "n_v"], params: Params, opts: SolverOptions = SolverOptions(),
             ground_drop: Float[ArrayLike, ""] = 0.0) -> tuple[Float[Array, "n_v"], StepResult]:
    """The Poincaré map on section coordinates: ``v_next, StepResult``.

    Args:
        v: ``(n_v,)`` section coordinates (``model.section_names``).
        ground_drop: height (model length units, vertical) by which the ground
            at the next touchdown lies below the stance foot; 0 for the periodic
            gait, ``h`` for the paper's step-down test. Anything but a literal 0
            needs a model with a step-down (:attr:`Walker.ground_next`; configs
            refuse the analyses that would ask otherwise, :func:`jaxwalk.walker.check_supported`).
    """
    y0, phase0, ctx0 = model.section_to_state(v, params)
    if model.ground_next is not None or not (isinstance(ground_drop, (int, float)) and ground_drop == 0):
        ctx0 = model.with_ground_drop(ctx0, params, ground_drop)
    res = run_step(model, params, y0, phase0, ctx0, opts)
    return model.state_to_section(res.y, params, res.ctx), res
