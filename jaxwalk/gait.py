"""Periodic gaits: fixed points of the step map, their Jacobian and stability.

``find_gait`` is the paper's method (eqs. 17-22): Newton-Raphson on
``f(v) - v`` in independent section coordinates, with the Jacobian
``J = df/dv`` from forward-mode autodiff through the whole step (event times
included) instead of finite differences. ``lambda_max``, the spectral radius of
``J`` at the fixed point, is the paper's lambda_m: the gait is locally stable
when it is below 1.

Everything here is pure and batched with ``vmap``; a search that fails ends with
a status (the step's failure if a step failed, else ``NO_CONVERGENCE``) and NaN
numbers, never a number with status 0 that is wrong.
"""

from __future__ import annotations

import dataclasses
import functools
from typing import Callable, NamedTuple

import jax
import jax.numpy as jnp
from jaxtyping import Array, Complex, Float, Int8, Int32

from jaxwalk import mechanics
from jaxwalk.status import Status
from jaxwalk.step import SolverOptions, step_map
from jaxwalk.stepbase import state_dependent
from jaxwalk.walker import Params, Walker


@dataclasses.dataclass(frozen=True)
class NewtonOptions:
    """Static settings of the fixed-point search.

    Attributes:
        tol: converged when the Newton update's largest component is below ``tol``
            (section units: rad and rad per model time unit), or, with
            ``rate_test``, when the error the update leaves is estimated below
            it. Convergence is quadratic, so the point after an update of 1e-8
            is as accurate as the step map itself (integration noise: the
            residual's is ~1e-9 at rtol 1e-10, the update's that over the least
            singular value of ``J - I``, up to 2.5e-8 on the simplest walker's
            flattest slopes, docs/engine.md section 4); a much smaller ``tol``
            would chase that noise and never converge. A search that begins
            with chord steps (the flat-foot walker's lines) reports instead the
            point before such an update, within about ``tol`` of the gait
            (:func:`_newton_iteration`).
        rate_test: also converged when ``theta / (1 - theta) * |update| < tol``,
            ``theta = |update| / |previous update|`` the observed contraction
            (Hairer & Wanner, *Solving ODEs II*, IV.8): a bound on the error left
            under linear contraction; Newton's is quadratic and leaves about
            ``theta^2 |update|``. Where the last update contracted fast enough
            it saves the iteration that only confirmed convergence, and it stops
            Newton before it chases the step map's noise. Off: the update test
            alone (the sequence before 2026-12-06). Read by :func:`find_gait`
            (sweeps, continuation lines, the analyses built on them); the
            attractor's Newton on the k-step map (:mod:`jaxwalk.attractor`) keeps
            the update test alone: its halved retries make the contraction
            between its trips not Newton's.
        max_iter: iterations before ``NO_CONVERGENCE``.
        max_update: an update larger than this (inf-norm) is scaled down to it,
            which keeps a poor start from jumping out of the section's domain.
        predictor: where a sweep's continuation line starts Newton at its next
            point (:mod:`jaxwalk.continuation`): ``"secant"``, on the line
            through the gaits of the two points before (on a line that takes
            chord steps, on the parabola through three where there are
            three), with the gait of the point before as the fallback start; ``"previous"``, at the gait of
            the point before (order zero). Other searches (``find_gait``
            itself, ``bifurcation.follow``, the arclength continuation) start
            where they are told and do not read it.
    """

    tol: float = 1e-8
    max_iter: int = 25
    max_update: float = 0.2
    predictor: str = "secant"
    rate_test: bool = True

    def __post_init__(self):
        if self.predictor not in PREDICTORS:
            raise ValueError(f"predictor must be one of {', '.join(PREDICTORS)}, got {self.predictor!r}")


#: :attr:`NewtonOptions.predictor` values.
PREDICTORS = ("secant", "previous")


class GaitStats(NamedTuple):
    """What finding a gait cost (batch shape in front under vmap); kept where the search failed.

    Attributes:
        newton_iterations: Newton iterations used (as :attr:`Gait.iterations`).
        events: events in the last step evaluated (the step from the fixed point
            when the search converged): :attr:`~jaxwalk.stepbase.StepResult.n_events`.
        ode_steps: ODE solver steps, accepted and rejected, over every phase of the
            last step evaluated: :attr:`~jaxwalk.stepbase.StepResult.ode_steps`.
        failure_phase: where the search failed because a step failed: the index in
            :attr:`~jaxwalk.walker.Walker.phases` of the phase in which that step
            stopped; -1 elsewhere (a gait found, Newton not converging).
        failure_guard: the index in :attr:`~jaxwalk.walker.Walker.guards` of the
            guard whose event ended that step (a failure guard, or a transition
            whose reset failed: an impact's impulse, the next phase's entry
            check); -1 elsewhere, and where no event ended it (a time limit, a
            solver failure).
        failure_limit: where that guard is one of the model's
            :attr:`~jaxwalk.walker.Walker.limit_guards`, the index in
            :attr:`~jaxwalk.walker.Walker.limits` of the limit at its edge there
            (the largest :meth:`~jaxwalk.walker.Walker.limit_use` at the
            failure's state); -1 elsewhere.
    """

    newton_iterations: Int32[Array, "*batch"]
    events: Int32[Array, "*batch"]
    ode_steps: Int32[Array, "*batch"]
    failure_phase: Int32[Array, "*batch"]
    failure_guard: Int32[Array, "*batch"]
    failure_limit: Int32[Array, "*batch"]

    @classmethod
    def none(cls) -> "GaitStats":
        """No search made (a gait given, not found): zero cost, no failure."""
        zero, none = jnp.zeros((), jnp.int32), jnp.full((), -1, jnp.int32)
        return cls(zero, zero, zero, none, none, none)


class Gait(NamedTuple):
    """A periodic gait and its local stability (batch shape in front under vmap).

    Attributes:
        v: ``(n_v,)`` fixed point in section coordinates.
        jacobian: ``(n_v, n_v)`` ``df/dv`` at ``v``.
        eigenvalues: ``(n_v,)`` complex eigenvalues of ``jacobian``, by modulus, largest first.
        lambda_max: spectral radius of ``jacobian`` (stable if < 1).
        period: step duration (model time units).
        step_length: distance between successive stance feet (model length units).
        speed: ``step_length / period``.
        status: int8 :class:`~jaxwalk.status.Status`.
        iterations: Newton iterations used, chord steps included (both searches where :func:`find_gait` fell back to its second start).
        work: actuator work per step (model energy units; 0 for passive walkers).
        cost_of_transport: ``work / (weight * step_length)``, the actuators'
            mechanical cost of transport (dimensionless; 0 for passive walkers,
            whose energy comes from gravity: ``sin(gamma)`` per unit weight and distance).
        context: ``(n_ctx,)`` the model's discrete state (:attr:`~jaxwalk.walker.Walker.context`)
            at the end of the step from ``v``, after its last reset: what that
            step kept (event times; the flat-foot walker's ``min_clearance``),
            from the search's last evaluation, so an analysis reads it without
            walking the step again (:mod:`jaxwalk.analyses.clearance`).
        stats: :class:`GaitStats`, what the search cost.
    """

    v: Float[Array, "*batch n_v"]
    jacobian: Float[Array, "*batch n_v n_v"]
    eigenvalues: Complex[Array, "*batch n_v"]
    lambda_max: Float[Array, "*batch"]
    period: Float[Array, "*batch"]
    step_length: Float[Array, "*batch"]
    speed: Float[Array, "*batch"]
    status: Int8[Array, "*batch"]
    iterations: Int32[Array, "*batch"]
    work: Float[Array, "*batch"]
    cost_of_transport: Float[Array, "*batch"]
    context: Float[Array, "*batch n_ctx"]
    stats: GaitStats


def step_residual(model: Walker, params, opts: SolverOptions):
    """``v -> (f(v) - v, StepResult)``, the function Newton drives to zero."""

    def residual(v):
        v_next, res = step_map(model, v, params, opts)
        return v_next - v, res

    return residual


def value_and_jacfwd(fn, v: Array):
    """``fn(v)``, its Jacobian ``(n_out, n_v)`` and aux, in one forward-mode pass.

    ``fn`` returns ``(value, aux)``. Pushing all ``n_v`` tangents through one
    ``jvp`` under ``vmap`` evaluates the primal (the whole step) once, where
    ``jax.jacfwd`` followed by a separate call would run it twice.
    """
    eye = jnp.eye(v.shape[0], dtype=v.dtype)
    push = lambda t: jax.jvp(fn, (v,), (t,), has_aux=True)
    value, jac, aux = jax.vmap(push, out_axes=(None, -1, None))(eye)
    return value, jac, aux


def jacfwd_with_aux(fn, x: Array):
    """``jax.jacfwd(fn, has_aux=True)(x)`` for ``x`` of shape ``(n,)``: ``(jacobian (..., n), aux)``.

    With one direction (``n = 1``, a derivative with respect to one parameter)
    it is a plain ``jvp``, without ``jacfwd``'s ``vmap`` over the basis: the
    batching rules of the nested while loops under it are most of a
    second-order program's trace (the simplest walker's gait sensitivity norm
    and its gradient traced in 27 s under ``jacfwd``, 15 s as one ``jvp``; the
    same program to 1e-15, benchmarks/README.md).
    """
    if x.shape != (1,):
        return jax.jacfwd(fn, has_aux=True)(x)
    _, tangent, aux = jax.jvp(fn, (x,), (jnp.ones_like(x),), has_aux=True)
    return jax.tree_util.tree_map(lambda t: t[..., None], tangent), aux


def _stability(jacobian: Array) -> tuple[Array, Array]:
    eig = jnp.linalg.eigvals(jacobian)
    order = jnp.argsort(-jnp.abs(eig))
    eig = eig[order]
    return eig, jnp.abs(eig[0])


# Jitted: a direct call compiles once per model, settings and shape (an
# unjitted call compiled its while loop anew each time, 12 s for the simplest
# walker), and inside other programs its transformed jaxprs are cached
# (jaxwalk.step._solve_phase).
@functools.partial(jax.jit, static_argnames=("model", "solver", "newton"))
def find_gait(
    model: Walker,
    params: Params,
    v0: Float[Array, "n_v"],
    solver: SolverOptions = SolverOptions(),
    newton: NewtonOptions = NewtonOptions(),
    fallback: "Fallback | None" = None,
    jacobian_guess: Float[Array, "n_v n_v"] | None = None,
) -> Gait:
    """Newton-Raphson fixed point of the step map from ``v0`` (one config; vmap it).

    Each iteration evaluates ``f(v) - v`` and its Jacobian ``J - I`` in one
    forward-mode pass and updates ``v -= (J - I)^-1 (f(v) - v)`` (paper eqs. 21-22).
    After the update that ends the search (below ``tol``, or leaving an error
    below it by :attr:`NewtonOptions.rate_test`), one more evaluation at the
    converged point gives the reported Jacobian, period, step length and
    the step's end context (:attr:`Gait.context`).

    With a :class:`Fallback` whose ``use`` holds, a search from ``v0`` that
    fails (any status but OK), has not converged after ``fallback.max_iter``
    iterations, or converges farther than ``fallback.max_jump`` from ``v0``
    starts once more from ``fallback.v``, in the same loop, and the result is
    that second search's (its status where it fails too); :attr:`Gait.iterations`
    counts both. Continuation lines start from an extrapolated point with the
    neighbour's gait as the fallback (:mod:`jaxwalk.continuation`).

    With a finite ``jacobian_guess`` (``df/dv`` near the fixed point, the
    neighbour's on a continuation line), the search starts with chord
    iterations: primal steps only, each updated with ``jacobian_guess - I``,
    until the same stopping test ends it; it goes on with full Newton where a
    chord update contracts by :data:`CHORD_MAX_THETA` or more, after
    :data:`CHORD_MAX_ITER` of them, and after a fallback, and starts again from
    ``v0`` with full Newton after a chord step that fails, diverges or is cut
    (:func:`_newton_iteration`). Once a chord update is small enough, the next
    evaluation carries the tangents (a probe), and in a search that began with
    chord steps any such evaluation whose Newton update is below ``tol`` ends
    the search at its own iterate, within about ``tol`` of the gait. The
    reported point is always one evaluated with tangents, so the reported
    Jacobian is the gait's own. A ``lax.cond`` picks the evaluation, so this saves work only
    in a program that is not vmapped (one row per sub-batch,
    :func:`jaxwalk.batching.in_sub_batches`); under ``vmap`` both would run.
    """
    running = jnp.int8(Status.IN_PROGRESS)
    n_v, dtype = v0.shape[0], v0.dtype
    into_section = functools.partial(model.into_section, params=params)
    v0 = into_section(v0)
    nan = jnp.full((), jnp.nan, dtype)
    zero = jnp.zeros((), jnp.int32)
    y0, _, ctx0 = jax.eval_shape(model.section_to_state, v0, params)  # the shapes of a step's state
    fallback = Fallback(v0, jnp.asarray(False)) if fallback is None else fallback._replace(v=into_section(fallback.v))
    carry0 = _Newton(v0, zero, running, jnp.asarray(False), jnp.full((n_v, n_v), jnp.nan, dtype), nan, nan, nan, zero, zero,
                     zero - 1, zero - 1, jnp.full(y0.shape, jnp.nan, y0.dtype), jnp.full(ctx0.shape, jnp.nan, ctx0.dtype),
                     jnp.asarray(fallback.use, bool), zero, jnp.full((), jnp.inf, dtype))
    chord = jnp.asarray(False) if jacobian_guess is None else jnp.all(jnp.isfinite(jacobian_guess))
    carry0 = carry0._replace(chord=chord, chorded=chord)
    carry0 = jax.tree_util.tree_map(lambda x: state_dependent(x, v0), carry0)  # one trace of the body under vmap
    body = _newton_iteration(step_residual(model, params, solver), newton, jnp.eye(n_v, dtype=dtype), into_section,
                             jacobian_guess, v0)
    body = _fall_back(body, v0, fallback)

    def cond(c: _Newton):
        # The status ends the loop (NO_CONVERGENCE once k reaches max_iter, and
        # k stops counting after convergence), so the bound never decides alone.
        return (c.status == running) & (c.k <= newton.max_iter)

    return _gait(model, params, jax.lax.while_loop(cond, body, carry0))


class _Newton(NamedTuple):
    """The carry of :func:`find_gait`'s loop (one configuration)."""

    v: Array  # (n_v,) current iterate
    k: Array  # int32, iterations counted
    status: Array  # int8; IN_PROGRESS while the search goes on
    converged: Array  # bool: the last update ended the search (_small; this evaluation is at the fixed point)
    jac: Array  # (n_v, n_v) df/dv at the last evaluation
    period: Array  # the last evaluated step's duration, length and actuator work
    length: Array
    work: Array
    events: Array  # int32, events in the last evaluated step
    ode_steps: Array  # int32, its ODE solver steps
    phase: Array  # int32, the phase where it stopped
    guard: Array  # int32, the guard of its last event (StepResult.guard)
    y_end: Array  # (2 n_q,) the state where it stopped
    ctx_end: Array  # (n_ctx,)
    has_fallback: Array  # bool: the first search, which may still start again from its fallback (once)
    spent: Array  # int32, iterations of a search abandoned for the fallback
    last_update: Array  # the previous update's size in this search (inf before the first)
    chord: Array = False  # bool: the next iteration is a chord step (find_gait's jacobian_guess)
    chorded: Array = False  # bool: the search began with chord steps and has not started again (_newton_iteration)


#: A chord update that contracts by this much or more (its size over the one before)
#: ends the chord iterations: full Newton takes over from there (:func:`find_gait`'s
#: ``jacobian_guess``; on the shoe walker's map, from the secant's start: 0.001-0.023).
CHORD_MAX_THETA = 0.25
#: Chord iterations after which full Newton takes over.
CHORD_MAX_ITER = 4
#: The contraction a chord step is taken to leave (the error after it over its
#: update): a fixed guess, not the search's measured contraction (on the shoe
#: walker's map lines from the parabola through three gaits: median 0.008, 90 %
#: below 0.017, benchmarks/results/chord_probe.json). Once the last chord update
#: times it is below ``tol``, the next evaluation carries the tangents (a probe):
#: where its Newton update is below ``tol`` too, the search ends there
#: (:func:`_newton_iteration`).
CHORD_EXPECTED_THETA = 0.01


def _newton_iteration(residual, newton: NewtonOptions, eye: Array,
                      into_section: Callable[[Float[Array, "n_v"]], Float[Array, "n_v"]],
                      jacobian_guess: Array | None = None, v0: Array | None = None):
    """The body of :func:`find_gait`'s loop: one evaluation and update, the new
    iterate kept in the section (:meth:`Walker.into_section`); a chord step
    (primal only, ``jacobian_guess - I``) where the carry says so.

    A chord step that fails (its step fails, its update is not a number, it
    moves away, ``theta >= 1``, or it is cut to ``max_update`` or moved into the
    section) starts the search again from ``v0`` with full Newton, its
    iterations counted in ``spent``: where a chord goes wrong, the search is
    the one full Newton makes from the same start.

    Where the last chord update times :data:`CHORD_EXPECTED_THETA` is below
    ``tol`` (the iterate is likely within ``tol`` of the gait), the next
    evaluation carries the tangents instead of being a chord step: a probe. A
    probe whose step fails, or whose update is not a number or is cut, starts
    the search again from ``v0`` as a failed chord step does; otherwise its
    update is Newton's own and is taken. In a search that began with chord
    steps (and has not started again, from ``v0`` or its fallback), any
    evaluation with tangents, a probe or full Newton's after it, whose Newton
    update is below ``tol`` ends the search at its own iterate: the update,
    made with the iterate's own Jacobian, is the iterate's distance to the
    gait to second order, so the iterate lies within about ``tol`` of the gait
    (plus the step map's noise), as the chord's rate test allows, and its
    Jacobian, period and step are the reported ones. A probe that ends the
    search saves the primal step after which the rate test would have stopped
    the chord and the evaluation with tangents at its end. A search without
    chord steps ends as Newton's does, one update past its last evaluation's
    and then evaluated there."""

    def full(carry: _Newton):
        r, jac_r, res = value_and_jacfwd(residual, carry.v)
        return r, jac_r, jac_r + eye, res

    if jacobian_guess is None:
        return lambda carry: _advance(carry, *full(carry), newton, into_section)
    chord_matrix = jnp.where(jnp.isfinite(jacobian_guess), jacobian_guess, 0.0) - eye

    def chord(carry: _Newton):
        r, res = residual(carry.v)
        return r, chord_matrix, carry.jac, res

    running = jnp.int8(Status.IN_PROGRESS)

    def body(carry: _Newton) -> _Newton:
        on_chord = carry.chord & ~carry.converged
        probe = on_chord & (carry.last_update * CHORD_EXPECTED_THETA < newton.tol)  # inf before the first update
        chording = on_chord & ~probe
        new = _advance(carry, *jax.lax.cond(chording, chord, full, carry), newton, into_section)
        theta = new.last_update / carry.last_update  # 0 after the first update (inf before it)
        ended = (new.status != running) & (new.status != Status.OK)
        # A probe's update is Newton's own, so only a failed step or an update not taken as made fails it.
        failed = on_chord & (ended | ~jnp.isfinite(new.last_update) | (chording & (theta >= 1.0)))
        # In a search that began with chord steps, an evaluation with tangents
        # whose Newton update is below tol ends it at its own iterate.
        there = (carry.chorded & ~chording & ~carry.converged & ~failed & (new.status == running)
                 & (new.last_update < newton.tol))
        keep = chording & ~failed & (theta < CHORD_MAX_THETA) & (new.k < CHORD_MAX_ITER)
        return new._replace(
            v=jnp.where(failed, v0, jnp.where(there, carry.v, new.v)),
            k=jnp.where(failed, 0, new.k),
            status=jnp.where(failed, running, jnp.where(there, jnp.int8(Status.OK), new.status)),
            converged=(new.converged | there) & ~failed,
            last_update=jnp.where(failed, jnp.inf, new.last_update),
            spent=new.spent + jnp.where(failed, new.k, 0),
            chord=keep,
            chorded=carry.chorded & ~failed,
        )

    return body


def _advance(carry: _Newton, r: Array, jac_r: Array, jac: Array, res, newton: NewtonOptions, into_section) -> _Newton:
    """The carry after an evaluation at ``carry.v``: residual ``r``, the matrix
    ``jac_r`` (``J - I``, or its chord stand-in) the update solves with, the
    Jacobian ``jac`` to report and the step's result ``res``."""
    running = jnp.int8(Status.IN_PROGRESS)
    # Once an update ended the search, the next iteration evaluates at the
    # converged point and only records it: J, period and length are reported at
    # the fixed point itself, not at the last iterate (the step map is strongly
    # curved near the separatrix, second derivatives ~1e3 for the simplest
    # walker, so 1e-8 matters for J). Searches that begin with chord steps end
    # one update earlier (_newton_iteration): the flat-foot walker's map, whose
    # lines take them, moved lambda_max by 8.4e-7 that way.
    v, k, converged = carry.v, carry.k, carry.converged
    update = -mechanics.solve(jac_r, r)  # unrolled for small n_v (mechanics.solve)
    size = jnp.max(jnp.abs(update))
    update = update * jnp.minimum(1.0, newton.max_update / jnp.maximum(size, 1e-300))
    step_failed = res.status != Status.OK
    bad_number = ~jnp.all(jnp.isfinite(update))
    k = k + jnp.where(converged, 0, 1)
    status = jnp.select(
        [step_failed, converged, bad_number, k >= newton.max_iter],
        [res.status, jnp.int8(Status.OK), jnp.int8(Status.NO_CONVERGENCE), jnp.int8(Status.NO_CONVERGENCE)],
        running,
    ).astype(jnp.int8)
    move = ~(step_failed | bad_number | converged)
    kept = into_section(v + update)
    return carry._replace(
        v=jnp.where(move, kept, v),
        k=k,
        status=status,
        converged=converged | _small(size, carry.last_update, newton),
        # A step cut to max_update, or moved back into the section, did not
        # go where Newton sent it: no contraction is measured across it.
        last_update=jnp.where((size > newton.max_update) | jnp.any(kept != v + update), jnp.inf, size),
        jac=jac,
        period=res.time,
        length=res.length,
        work=res.work,
        events=res.n_events,
        ode_steps=res.ode_steps,
        phase=res.phase,
        guard=res.guard,
        y_end=res.y,
        ctx_end=res.ctx,
    )


def _small(size: Array, last: Array, newton: NewtonOptions) -> Array:
    """Whether an update of ``size`` (inf-norm) after one of ``last`` ends the search (:class:`NewtonOptions`)."""
    if not newton.rate_test:
        return size < newton.tol
    theta = size / last  # 0 before the first update's successor (last = inf): no estimate yet
    contracting = jnp.isfinite(last) & (theta < 1)
    left = theta / jnp.where(contracting, 1 - theta, 1) * size
    return (size < newton.tol) | (contracting & (left < newton.tol))


class Fallback(NamedTuple):
    """A second start for :func:`find_gait` (one configuration; batch shape in front under vmap).

    Attributes:
        v: ``(n_v,)`` the second start.
        use: bool; False: no second search.
        max_iter: int32, iterations after which a first search not yet
            converged is abandoned for the second.
        max_jump: a first search that converges farther than this from its
            start (largest component, section units) is abandoned for the
            second: a sign that it reached another gait than the one meant.
    """

    v: Array
    use: Array
    max_iter: Array | int = 1 << 30
    max_jump: Array | float = float("inf")


def _fall_back(body, v0: Array, fallback: Fallback):
    """``body`` (a :class:`_Newton` step) with the search from ``v0`` restarted
    once from ``fallback.v`` where it fails, stalls or jumps (:class:`Fallback`):
    ``k`` counts the new search, ``spent`` the old."""
    running = jnp.int8(Status.IN_PROGRESS)

    def wrapped(carry: _Newton) -> _Newton:
        new = body(carry)
        failed = (new.status != running) & (new.status != Status.OK)
        stalled = (new.status == running) & (new.k >= fallback.max_iter)
        jumped = (new.status == Status.OK) & (jnp.max(jnp.abs(new.v - v0)) > fallback.max_jump)
        retry = carry.has_fallback & (failed | stalled | jumped)
        return new._replace(
            v=jnp.where(retry, fallback.v, new.v),
            k=jnp.where(retry, 0, new.k),
            status=jnp.where(retry, running, new.status),
            converged=new.converged & ~retry,
            last_update=jnp.where(retry, jnp.inf, new.last_update),
            chord=new.chord & ~retry,
            chorded=new.chorded & ~retry,
            has_fallback=carry.has_fallback & ~retry,
            spent=new.spent + jnp.where(retry, new.k, 0),
        )

    return wrapped


def _gait(model: Walker, params, out: _Newton) -> Gait:
    """The :class:`Gait` of the search's last carry: NaN numbers unless it converged."""
    ok = out.status == Status.OK
    eye = jnp.eye(out.v.shape[0], dtype=out.v.dtype)
    eig, lam = _stability(jnp.where(ok, out.jac, eye))
    blank = lambda x: jnp.where(ok, x, jnp.nan)
    return Gait(
        v=blank(out.v),
        jacobian=blank(out.jac),
        eigenvalues=blank(eig),
        lambda_max=blank(lam),
        period=blank(out.period),
        step_length=blank(out.length),
        speed=blank(out.length / out.period),
        status=out.status,
        iterations=out.k + out.spent,
        work=blank(out.work),
        cost_of_transport=blank(out.work / (model.weight(params) * out.length)),
        context=blank(out.ctx_end),
        stats=_stats(model, params, out),
    )


def _stats(model: Walker, params, out: _Newton) -> GaitStats:
    """What the search cost, and where a failed step stopped (:class:`GaitStats`)."""
    cause = failure_cause(model, params, out.status, out.phase, out.guard, out.y_end, out.ctx_end)
    return GaitStats(out.k + out.spent, out.events, out.ode_steps, *cause)


def failure_cause(model: Walker, params, status, phase, guard, y, ctx) -> tuple[Array, Array, Array]:
    """``(phase, guard, limit)`` int32 indices (in ``model.phases``, ``model.guards``,
    ``model.limits``) of a failure with ``status`` of a step that stopped in
    ``phase`` at the state ``(y (2 n_q,), ctx)`` after the event of ``guard``
    (:attr:`~jaxwalk.stepbase.StepResult.guard`); each -1 where it does not apply
    (:class:`GaitStats`). ``NO_CONVERGENCE`` and ``OK`` are not a step's failure: all -1.

    The limit is read, not guessed: a limit guard is the least of its limits'
    margins (:attr:`~jaxwalk.walker.Walker.limit_guards`), so at its event the
    limit that ends the step is at its edge (use 1; past it where the phase
    began beyond it): the largest :meth:`~jaxwalk.walker.Walker.limit_use` among
    that guard's limits names it (a step that starts beyond several limits may
    be past others' edges too, and is named by its guard). Where none of them
    applies there or the contact does not push (every use inf or NaN), none is named.
    """
    step_failed = (status != Status.OK) & (status != Status.NO_CONVERGENCE)
    none = jnp.full((), -1, jnp.int32)
    limit = none
    if model.limit_guards:
        owned = jnp.asarray([model.guards.index(g) for g in model.limit_guards]) == guard
        use = model.limit_use(y, params, phase, ctx)
        use = jnp.where(jnp.isnan(use) | ~owned, -jnp.inf, use)  # NaN: the limit does not apply in this phase
        named = jnp.any(owned) & jnp.isfinite(jnp.max(use))
        limit = jnp.where(named, jnp.argmax(use), none)
    mark = lambda x: jnp.where(step_failed, x, none).astype(jnp.int32)
    return mark(phase), mark(guard), mark(limit)


def step_jacobian(model: Walker, v: Float[Array, "n_v"], params: Params,
                  solver: SolverOptions = SolverOptions()) -> Float[Array, "n_v n_v"]:
    """``J = df/dv`` at ``v`` by forward-mode autodiff, ``(n_v, n_v)``."""
    return jax.jacfwd(lambda v_: step_map(model, v_, params, solver)[0])(v)
