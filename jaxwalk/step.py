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

import dataclasses
from typing import NamedTuple

import diffrax
import jax
import jax.numpy as jnp

from jaxwalk.rootfind import BracketedNewton
from jaxwalk.status import Status
from jaxwalk.walker import Walker

Array = jax.Array


@dataclasses.dataclass(frozen=True)
class SolverOptions:
    """Static integration settings (hashable: part of the jit cache key).

    Attributes:
        rtol, atol: step-size controller tolerances.
        event_tol: tolerance of the event-time root finder (model time units).
        max_solver_steps: ODE steps allowed per phase before ``SOLVER_FAILED``.
        max_events: events allowed per step before ``TOO_MANY_EVENTS``.
        phase_time_limit: longest phase, in units of the model's ``time_scale``,
            before ``TIMEOUT``.
        start_guard_margin: a guard below ``-start_guard_margin`` when a phase
            starts is an event at once (see :func:`run_step`).
        solver: ``"dopri8"`` (default; 7th-order dense output keeps event times
            accurate at loose steps) or ``"tsit5"``.
    """

    rtol: float = 1e-10
    atol: float = 1e-10
    event_tol: float = 1e-13
    max_solver_steps: int = 2048
    max_events: int = 16
    phase_time_limit: float = 12.0
    start_guard_margin: float = 1e-9
    solver: str = "dopri8"

    def make_solver(self):
        return {"dopri8": diffrax.Dopri8, "tsit5": diffrax.Tsit5, "dopri5": diffrax.Dopri5}[self.solver]()


class StepResult(NamedTuple):
    """Outcome of :func:`run_step`; every leaf carries the batch shape under vmap.

    Attributes:
        y: ``(2 n_q,)`` state at the start of the next step (legs swapped), or the
            state where the step stopped.
        ctx: ``(n_ctx,)`` discrete state with ``y``.
        phase: int32 phase where the loop stopped.
        time: step duration (model time units).
        length: distance the stance foot moved (model length units).
        status: int8 :class:`~jaxwalk.status.Status`.
        n_events: number of events in the step.
        work: work done by the walker's actuators over the step (model energy
            units; 0 for passive walkers), summed phase by phase with
            :meth:`~jaxwalk.walker.Walker.actuator_work`.
    """

    y: Array
    ctx: Array
    phase: Array
    time: Array
    length: Array
    status: Array
    n_events: Array
    work: Array


def solve_phase(model: Walker, params, y, phase, ctx, t0, opts: SolverOptions, dense: bool = False):
    """Integrate ``phase`` from ``t0`` until an event or the time limit.

    Returns the diffrax ``Solution`` (saved at its end; with ``dense=True`` also
    its interpolation, which the recorder of ``jaxwalk simulate`` samples).
    """
    term = diffrax.ODETerm(model.vector_field)

    def smallest_guard(t, y, args, **kwargs):
        return jnp.min(model.guard_values(t, y, *args))

    event = diffrax.Event(
        smallest_guard,
        root_finder=BracketedNewton(rtol=opts.event_tol, atol=opts.event_tol),
        direction=False,
    )
    t1 = t0 + opts.phase_time_limit * model.time_scale(params)
    sol = diffrax.diffeqsolve(
        term,
        opts.make_solver(),
        t0=t0,
        t1=t1,
        dt0=None,
        y0=y,
        args=(params, phase, ctx),
        event=event,
        stepsize_controller=diffrax.PIDController(rtol=opts.rtol, atol=opts.atol),
        max_steps=opts.max_solver_steps,
        adjoint=diffrax.ForwardMode(),
        throw=False,
        saveat=diffrax.SaveAt(t1=True, dense=dense),
    )
    return sol


def _solve_phase(model: Walker, params, y, phase, ctx, t0, opts: SolverOptions):
    """End time, end state and diffrax result of :func:`solve_phase`."""
    sol = solve_phase(model, params, y, phase, ctx, t0, opts)
    return sol.ts[-1], sol.ys[-1], sol.result


class PhaseEnd(NamedTuple):
    """How a phase ended (:func:`end_phase`).

    Attributes:
        t_event: event time (the phase's start time where a guard was already past).
        y_event: ``(2 n_q,)`` state at the event, before the reset.
        guard: int32 index of the smallest guard at the event (the one that fired).
        event_happened: bool, the phase ended with an event (not the time limit
            or a solver failure).
        y_next, phase_next, ctx_next: the state after the reset; the state at the
            event where there was no event or the reset is not finite.
        shift: distance the stance foot moved in the reset (0 without one).
        step_done: bool, the reset ended the step.
        status: int8 :class:`~jaxwalk.status.Status` after the event
            (``IN_PROGRESS`` while the step goes on).
        n_events: events in the step, this one included.
    """

    t_event: Array
    y_event: Array
    guard: Array
    event_happened: Array
    y_next: Array
    phase_next: Array
    ctx_next: Array
    shift: Array
    step_done: Array
    status: Array
    n_events: Array


def end_phase(model: Walker, params, t0, y0, phase, ctx, solved, n_events, opts: SolverOptions) -> PhaseEnd:
    """The event that ended a phase started at ``(t0, y0, phase, ctx)``, the model's
    reset and the status rules: the body of :func:`run_step`'s loop after the solve,
    shared with the recorder (:mod:`jaxwalk.simulate.recorder`).

    Args:
        solved: ``(t_event, y_event, result)`` of the phase's ``diffeqsolve`` (:func:`_solve_phase`).
        n_events: events in the step before this one.
    """
    in_progress = jnp.asarray(Status.IN_PROGRESS, jnp.int8)
    t_event, y_event, result = solved
    # A guard already negative when a phase starts never "crosses" zero, and
    # while it is the smallest it hides every other guard: treat it as an
    # event at the phase's start (a swing foot landing behind the hip after a
    # large drop, a knee that must already pull). The margin keeps a guard
    # that ended the previous phase (zero to root-finding accuracy) quiet.
    at_start = jnp.min(model.guard_values(t0, y0, params, phase, ctx)) < -opts.start_guard_margin
    t_event = jnp.where(at_start, t0, t_event)
    y_event = jnp.where(at_start, y0, y_event)
    result = diffrax.RESULTS.where(at_start, diffrax.RESULTS.event_occurred, result)
    guards = model.guard_values(t_event, y_event, params, phase, ctx)
    which = jnp.argmin(guards)
    tr = model.on_event(which, t_event, y_event, params, phase, ctx)
    step_status = jnp.where(tr.step_done & (tr.status == in_progress), jnp.int8(Status.OK), tr.status)
    n_events = n_events + 1
    # Solver outcome overrides the model's reading of the event.
    event_happened = result == diffrax.RESULTS.event_occurred
    reached_t1 = result == diffrax.RESULTS.successful
    new_status = jnp.where(event_happened, step_status, jnp.where(reached_t1, jnp.int8(Status.TIMEOUT), jnp.int8(Status.SOLVER_FAILED)))
    finite = jnp.all(jnp.isfinite(tr.y)) & jnp.isfinite(t_event)
    new_status = jnp.where(finite, new_status, jnp.int8(Status.NONFINITE))
    new_status = jnp.where(
        (new_status == in_progress) & (n_events >= opts.max_events), jnp.int8(Status.TOO_MANY_EVENTS), new_status
    )
    keep = event_happened & finite
    return PhaseEnd(
        t_event=t_event,
        y_event=y_event,
        guard=which.astype(jnp.int32),
        event_happened=event_happened,
        y_next=jnp.where(keep, tr.y, y_event),
        phase_next=jnp.where(keep, tr.phase, phase).astype(jnp.int32),
        ctx_next=jnp.where(keep, tr.ctx, ctx),
        shift=jnp.where(keep, tr.shift, 0.0),
        step_done=tr.step_done & keep,
        status=new_status.astype(jnp.int8),
        n_events=n_events,
    )


def run_step(model: Walker, params, y0: Array, phase0: Array, ctx0: Array, opts: SolverOptions = SolverOptions()) -> StepResult:
    """Run one step from a full state. Pure; ``jit``/``vmap``/``jacfwd`` ready.

    Args:
        model: the walker (static).
        params: dict of scalar parameters.
        y0: ``(2 n_q,)`` initial state; ``phase0`` int32; ``ctx0`` ``(n_ctx,)``.
        opts: static solver settings.
    """
    in_progress = jnp.asarray(Status.IN_PROGRESS, jnp.int8)

    def cond(carry):
        return carry[5] == in_progress

    def body(carry):
        t, y, phase, ctx, length, status, n_events, work = carry
        solved = _solve_phase(model, params, y, phase, ctx, t, opts)
        end = end_phase(model, params, t, y, phase, ctx, solved, n_events, opts)
        # Work over the phase, from its start to the event (before the reset,
        # which may relabel the legs); impacts do not move the joints.
        work = work + model.actuator_work(y, end.y_event, params)
        length = length + end.shift
        return (end.t_event, end.y_next, end.phase_next, end.ctx_next, length, end.status, end.n_events, work)

    dtype = y0.dtype
    carry0 = (
        jnp.zeros((), dtype),
        y0,
        jnp.asarray(phase0, jnp.int32),
        ctx0,
        jnp.zeros((), dtype),
        in_progress,
        jnp.zeros((), jnp.int32),
        jnp.zeros((), dtype),
    )
    t, y, phase, ctx, length, status, n_events, work = jax.lax.while_loop(cond, body, carry0)
    return StepResult(y, ctx, phase, t, length, status, n_events, work)


def step_map(model: Walker, v: Array, params, opts: SolverOptions = SolverOptions(), ground_drop: Array | float = 0.0):
    """The Poincaré map on section coordinates: ``v_next, StepResult``.

    Args:
        v: ``(n_v,)`` section coordinates (``model.section_names``).
        ground_drop: height (model length units, vertical) by which the ground
            at the next touchdown lies below the stance foot; 0 for the periodic
            gait, ``h`` for the paper's step-down test.
    """
    y0, phase0, ctx0 = model.section_to_state(v, params)
    if "ground_next" in model.context:
        i = model.ctx_index("ground_next")
        ctx0 = ctx0.at[i].set(-ground_drop * jnp.cos(params["gamma"]))
    res = run_step(model, params, y0, phase0, ctx0, opts)
    return model.state_to_section(res.y, params, res.ctx), res
