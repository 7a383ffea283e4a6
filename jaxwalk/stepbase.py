"""What a step engine is given and gives back: solver settings, the step's
result, and the reset-and-status rules at the end of a phase.

Shared by the two step engines, the nested one (:mod:`jaxwalk.step`, one
``diffeqsolve`` per phase) and the flat one (:mod:`jaxwalk.flatstep`, one loop
of integrator steps per step), and by the recorder of ``jaxwalk simulate``.
"""

from __future__ import annotations

import dataclasses
import os
from typing import NamedTuple

import diffrax
import jax
import jax.numpy as jnp
from jaxtyping import Array, ArrayLike, Bool, Float, Int8, Int32

from jaxwalk.status import Status
from jaxwalk.walker import Params, Walker


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
            starts is an event at once (see :func:`run_step`); one in
            ``[-start_guard_margin, 0]`` (the guard whose event just ended the
            previous phase, zero to root-finding accuracy) is lifted by twice
            the margin for the phase (:func:`guard_offsets`).
        solver: the ODE solver, a diffrax solver object (``diffrax.Tsit5()``)
            or the name of one, ``"dopri8"`` (default; 7th-order dense output
            keeps event times accurate at loose steps), ``"tsit5"`` or
            ``"dopri5"`` (the names configs use). An object is part of the jit
            cache key by value (equinox modules compare and hash by their
            fields) and of the program cache's by its ``repr``. The flat engine
            needs an explicit Runge-Kutta solver (one with ``scan_kind``).
        engine: ``"nested"`` (one ``diffeqsolve`` per phase, :mod:`jaxwalk.step`)
            or ``"flat"`` (one loop of integrator steps per step, every lane
            in its own phase, :mod:`jaxwalk.flatstep`). The default is read from
            the environment variable ``JAXWALK_ENGINE`` (``nested`` if unset), so
            a whole test run can be repeated on either engine.
        event_iterations: root-finder iterations per located event in the flat
            engine (a fixed count; a step whose event does not converge in it is
            retried at half the size).
        reverse_mode: the flat engine's loop as a checkpointed while loop
            (equinox's, bounded by ``(max_events + 1) * max_solver_steps``
            iterations) and its Runge-Kutta stages in a bounded scan, so that
            ``jax.grad`` (reverse mode) differentiates a step; forward mode
            (``jvp``, ``jacfwd``) works either way and compiles faster without
            it. Needs ``engine="flat"``.
        pcoeff, icoeff, safety: the step-size controller's proportional and
            integral coefficients and its safety factor (diffrax's
            ``PIDController``; ``pcoeff = 0, icoeff = 1`` is the plain integral
            controller). ``safety = None`` (default): the walker's own,
            :attr:`jaxwalk.walker.Walker.step_safety`, diffrax's 0.9 but for
            the flat-foot walker's 0.75, where 0.9 had a quarter of the steps
            rejected (each phase's steps shrink toward its event and the
            controller proposes them a little too long): 0.75 takes 9.5 %
            fewer solver steps in its gait search, with gaits closer to rtol
            1e-12 and every status of the shoe walker's 64 x 64 map kept. On
            the simplest walker 0.75 saves 2 % and makes its ``lambda_max``
            noise reach 2.9e-6 (8.9e-7 at 0.9), so the passive walkers keep
            0.9. No PI setting tried takes fewer steps. Not settable from a
            config's ``[analysis]`` (benchmarks/bench_controller.py,
            benchmarks/README.md).
        carry_step: start each phase with the step the controller proposed at
            the end of the phase before (the step's first phase, and every
            phase with ``False``, at :data:`FIRST_STEP`). ``None`` (default):
            the walker's own, :attr:`jaxwalk.walker.Walker.carry_step`, ``True``
            but for the simplest walker. Not settable from a config.
    """

    rtol: float = 1e-10
    atol: float = 1e-10
    event_tol: float = 1e-13
    max_solver_steps: int = 2048
    max_events: int = 16
    phase_time_limit: float = 12.0
    start_guard_margin: float = 1e-9
    solver: str | diffrax.AbstractSolver = "dopri8"
    engine: str = dataclasses.field(default_factory=lambda: os.environ.get("JAXWALK_ENGINE", "nested"))
    event_iterations: int = 8
    pcoeff: float = 0.0
    icoeff: float = 1.0
    safety: float | None = None
    carry_step: bool | None = None
    reverse_mode: bool = False

    def __post_init__(self):
        if self.reverse_mode and self.engine != "flat":
            raise ValueError(f"SolverOptions.reverse_mode needs engine='flat' (the nested engine's loops "
                             f"cannot be reverse-differentiated), got engine={self.engine!r}")
        # run_step's loop is bounded by max_events (its condition); a step has at least one event.
        if self.max_events < 1:
            raise ValueError(f"SolverOptions.max_events must be >= 1, got {self.max_events}")
        if isinstance(self.solver, str) and self.solver not in SOLVERS:
            raise ValueError(f"SolverOptions.solver must be one of {', '.join(SOLVERS)} or a diffrax solver, got {self.solver!r}")
        if not isinstance(self.solver, (str, diffrax.AbstractSolver)):
            raise TypeError(f"SolverOptions.solver must be a name or a diffrax solver, got {type(self.solver).__name__}")
        if self.safety is not None and not 0.0 < self.safety <= 1.0:
            raise ValueError(f"SolverOptions.safety must be in (0, 1] or None, got {self.safety!r}")
        if self.pcoeff < 0.0 or self.icoeff <= 0.0:
            raise ValueError(f"SolverOptions.pcoeff must be >= 0 and icoeff > 0, got {self.pcoeff!r}, {self.icoeff!r}")

    def make_solver(self) -> diffrax.AbstractSolver:
        """The diffrax solver: :attr:`solver` itself, or a new one of the class it names."""
        return SOLVERS[self.solver]() if isinstance(self.solver, str) else self.solver

    def make_controller(self, model) -> diffrax.PIDController:
        """The step-size controller of every phase's solve of ``model``, in both engines."""
        safety = model.step_safety if self.safety is None else self.safety
        return diffrax.PIDController(rtol=self.rtol, atol=self.atol, pcoeff=self.pcoeff, icoeff=self.icoeff,
                                     safety=safety)

    def carries_step(self, model) -> bool:
        """Whether ``model``'s phases start with the step proposed at the end of the one before."""
        return model.carry_step if self.carry_step is None else self.carry_step

    def as_record(self, model=None) -> dict:
        """The settings as plain data for a dataset's attributes: every field, the
        solver by its name (an object by its ``repr``, e.g. ``"Tsit5()"``, where
        ``dataclasses.asdict`` would keep only its fields and lose its class),
        and with ``model`` the safety factor and first-step rule its solves used
        (``safety`` and ``carry_step`` of ``None`` resolved to the walker's
        :attr:`~jaxwalk.walker.Walker.step_safety` and :attr:`~jaxwalk.walker.Walker.carry_step`)."""
        record = dataclasses.asdict(self)
        if model is not None and self.safety is None:
            record["safety"] = model.step_safety
        if model is not None and self.carry_step is None:
            record["carry_step"] = model.carry_step
        record["solver"] = self.solver if isinstance(self.solver, str) else repr(self.solver)
        return record


#: The first step of a step's first phase (model time units), and of every
#: phase without :attr:`SolverOptions.carry_step`. It is what a ``diffeqsolve``
#: with ``dt0=None`` starts with: diffrax wraps the term (``WrapTerm``) before
#: its initial-step heuristic, which then returns 0.01. diffrax's heuristic
#: proper (two vector-field evaluations) chose 0.04 on the simplest walker and
#: made lambda_max 3x less accurate (1.2e-6 against 3.7e-7 at rtol 1e-10,
#: gamma 0.004): the first steps of a solve are the ones whose error the
#: controller has not yet measured.
FIRST_STEP = 0.01

#: The solvers :attr:`SolverOptions.solver` can name.
SOLVERS = {"dopri8": diffrax.Dopri8, "tsit5": diffrax.Tsit5, "dopri5": diffrax.Dopri5}


class StepResult(NamedTuple):
    """Outcome of :func:`run_step`; every leaf carries the batch shape under vmap.

    Attributes:
        y: ``(2 n_q,)`` state at the start of the next step (legs swapped), or the
            state where the step stopped.
        ctx: ``(n_ctx,)`` discrete state with ``y``.
        phase: int32 phase where the loop stopped (a failed step: the phase in
            which it failed).
        time: step duration (model time units).
        length: distance the stance foot moved (model length units).
        status: int8 :class:`~jaxwalk.status.Status`.
        n_events: number of events in the step.
        work: work done by the walker's actuators over the step (model energy
            units; 0 for passive walkers), summed phase by phase with
            :meth:`~jaxwalk.walker.Walker.actuator_work`, plus the resets' own
            (:attr:`~jaxwalk.walker.Transition.work`).
        ode_steps: ODE solver steps, accepted and rejected, summed over the
            step's phases (what the step cost; :class:`jaxwalk.gait.GaitStats`).
        guard: int32 index in :attr:`~jaxwalk.walker.Walker.guards` of the guard
            whose event ended the step's last phase (with ``phase``: where and
            by what a failed step failed); -1 where that phase ended without an
            event (its time limit, a solver failure).
    """

    y: Float[Array, "*batch 2*n_q"]
    ctx: Float[Array, "*batch n_ctx"]
    phase: Int32[Array, "*batch"]
    time: Float[Array, "*batch"]
    length: Float[Array, "*batch"]
    status: Int8[Array, "*batch"]
    n_events: Int32[Array, "*batch"]
    work: Float[Array, "*batch"]
    ode_steps: Int32[Array, "*batch"]
    guard: Int32[Array, "*batch"]


class PhaseEnd(NamedTuple):
    """How a phase ended (:func:`end_phase`).

    Attributes:
        t_event: event time (the phase's start time where a guard was already past).
        y_event: ``(2 n_q,)`` state at the event, before the reset.
        guard: int32 index of the guard the event names (:meth:`~jaxwalk.walker.Walker.named_guard`).
        event_happened: bool, the phase ended with an event (not the time limit
            or a solver failure).
        y_next, phase_next, ctx_next: the state after the reset; the state at the
            event where there was no event or the reset is not finite.
        shift: distance the stance foot moved in the reset (0 without one).
        work: actuator work done in the reset (:attr:`~jaxwalk.walker.Transition.work`; 0 without one).
        step_done: bool, the reset ended the step.
        status: int8 :class:`~jaxwalk.status.Status` after the event
            (``IN_PROGRESS`` while the step goes on).
        n_events: events in the step, this one included.
    """

    t_event: Float[Array, ""]
    y_event: Float[Array, "2*n_q"]
    guard: Int32[Array, ""]
    event_happened: Bool[Array, ""]
    y_next: Float[Array, "2*n_q"]
    phase_next: Int32[Array, ""]
    ctx_next: Float[Array, "n_ctx"]
    shift: Float[Array, ""]
    work: Float[Array, ""]
    step_done: Bool[Array, ""]
    status: Int8[Array, ""]
    n_events: Int32[Array, ""]


def guard_offsets(g0: Float[Array, "n_guards"], opts: SolverOptions) -> Float[Array, "n_guards"]:
    """``(n_guards,)`` added to the guards while a phase runs, from ``g0``, the
    ``(n_guards,)`` guard values at the phase's start (``model.guard_values(t0, y0,
    params, phase, ctx)``).

    The engines evaluate ``g0`` once per phase and share it (here, the test for an
    event at the phase's start, and the flat engine's first smallest guard): each
    evaluation of the guards may be a full dynamics solve (the flat-foot walker's
    contact forces), and a repeated one is as many more lines of program to compile.

    A phase watches the smallest guard for a crossing from positive to
    non-positive. A guard that starts at zero's rounding error below zero (the
    one whose event just ended the last phase: -6e-17 was seen) would be that
    smallest guard, already non-positive, and hide every other guard's crossing
    until it rose: a swing-foot extremum 0.01 later went unseen, the guard stayed
    negative, and the walker fell through the floor until the phase's time limit
    (``TIMEOUT`` at 180 points of a flat-foot map). Lifting such a guard by twice
    ``start_guard_margin`` starts every guard positive; it can fire again in the
    phase once it falls below ``-2 margin``. Guards already below ``-margin`` are
    left as they are: they are the events at the phase's start. The offsets are
    constants (no tangent): only ``g0``'s signs decide them.
    """
    g0 = jax.lax.stop_gradient(g0)
    just_fired = (g0 <= 0.0) & (g0 >= -opts.start_guard_margin)
    return jnp.where(just_fired, 2.0 * opts.start_guard_margin, 0.0).astype(g0.dtype)


def close_phase(
    model: Walker, params, t_event, y_event, result, phase, ctx, n_events, opts: SolverOptions, offsets=0.0, at_start=False
) -> PhaseEnd:
    """The model's reset and the status rules for a phase that ended at ``(t_event, y_event)``.

    ``result`` is diffrax's: ``event_occurred`` (the reset follows), ``successful``
    (the phase's time limit: ``TIMEOUT``) or any other (``SOLVER_FAILED``). Shared by
    :func:`end_phase` and the flat engine (:mod:`jaxwalk.flatstep`). ``offsets``:
    the phase's :func:`guard_offsets`, so the guard named is the one that crossed;
    ``at_start``: the phase ended where it started (:meth:`~jaxwalk.walker.Walker.named_guard`).
    """
    in_progress = jnp.asarray(Status.IN_PROGRESS, jnp.int8)
    guards = model.guard_values(t_event, y_event, params, phase, ctx) + offsets
    which = model.named_guard(guards, at_start)
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
    # A failed step stops in the phase where it failed, whatever phase the
    # model's transition names (the compass walker's names the next one).
    failed = (new_status != in_progress) & (new_status != Status.OK)
    return PhaseEnd(
        t_event=t_event,
        y_event=y_event,
        guard=which.astype(jnp.int32),
        event_happened=event_happened,
        y_next=jnp.where(keep, tr.y, y_event),
        phase_next=jnp.where(keep & ~failed, tr.phase, phase).astype(jnp.int32),
        ctx_next=jnp.where(keep, tr.ctx, ctx),
        shift=jnp.where(keep, tr.shift, 0.0),
        work=jnp.where(keep, tr.work, 0.0),
        step_done=tr.step_done & keep,
        status=new_status.astype(jnp.int8),
        n_events=n_events,
    )


def state_dependent(value: ArrayLike, y: Float[Array, " n"]) -> Array:
    """``value``, unchanged, but marked as a function of ``y`` for ``jvp`` and ``vmap``.

    JAX's while-loop rules for ``jvp`` and ``vmap`` trace the body again until
    the set of carries with a tangent (a batch axis) stops growing. A carry
    that starts as a constant (a step's time, length, work, first ``dt``; under
    a ``vmap`` over configurations its phase, status and counters too; a
    Newton search's iteration count and last Jacobian) and depends on the
    state after one iteration costs one more trace of the whole loop body,
    nested loops and all (the flat-foot step under ``jvp``: 2.4 of its 9.2 s
    of tracing). Selected against ``y``, such a carry has its
    tangent (batch axis) from the start. XLA folds the constant select away;
    the optimised programs still differ by a few operations in how XLA
    arranges them, and compute the same numbers (bit for bit on every program
    measured: benchmarks/bench_loop_carries.py, and on both engines in
    tests/test_loop_carries.py).
    ``y``: any array with a tangent and batch axis wherever the carry will
    have them (the loop's state); its first element is read.
    """
    value = jnp.asarray(value)
    return jnp.where(False, jnp.zeros_like(value) + y[0].astype(value.dtype), value)
