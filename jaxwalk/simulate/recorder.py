"""Record a walk: the state machine of :func:`jaxwalk.step.run_step`, sampled.

Recording runs run_step's loop one phase at a time in Python: a jitted solve of
one phase (the same ``diffeqsolve`` as :func:`jaxwalk.step._solve_phase`, with
dense output), then :func:`jaxwalk.step.end_phase`, which run_step's loop calls
too (the event, the model's ``on_event`` and the status rules). Between events
the state is sampled on a regular time grid (multiples of ``dt`` in the walk's
time) from the solver's dense interpolant; at every event both the state just
before and the state just after the reset are recorded at the event time, so
impacts show as jumps. The state after each step's last event is run_step's
result for that step to round-off (``tests/test_simulate.py``).
"""

from __future__ import annotations

import dataclasses
import functools
import math

import numpy as np

from jaxwalk import compiling
from jaxwalk.status import Status
from jaxwalk.walker import Walker

#: ``sample_kind`` codes.
REGULAR, BEFORE_EVENT, AFTER_EVENT = 0, 1, 2
SAMPLE_KINDS = ("regular", "before_event", "after_event")


@dataclasses.dataclass
class Trajectory:
    """A recorded walk, numpy arrays. ``n`` samples, ``k`` steps attempted.

    Per sample: ``time`` (n,), ``step`` (n,) index of the step the sample belongs
    to (the state after the last step's final event has index ``steps_completed``),
    ``phase`` (n,), ``sample_kind`` (n,) :data:`SAMPLE_KINDS`, ``event_guard`` (n,)
    the guard that fired at an event sample (-1 elsewhere), ``y`` (n, 2 n_q),
    ``ctx`` (n, n_ctx), ``origin`` (n, 2) the step frame's origin in the first
    step's frame, ``contact_force`` (n, n_c) (NaN where a constraint is
    inactive), ``limit_use`` (n, n_limits) :meth:`~jaxwalk.walker.Walker.limit_use`
    (1 at a contact limit's edge), ``energy`` (n,) in the first step's frame,
    ``actuator_power`` and ``work`` (n,).

    Per step: ``step_status``, ``step_start_time``, ``step_duration``,
    ``step_length`` (k,), ``section_start``, ``section_end`` (k, n_v; NaN for a
    step that failed). ``status``: ``OK`` if every step was completed, else the
    failed step's status; ``steps_completed``.
    """

    time: np.ndarray
    step: np.ndarray
    phase: np.ndarray
    sample_kind: np.ndarray
    event_guard: np.ndarray
    y: np.ndarray
    ctx: np.ndarray
    origin: np.ndarray
    contact_force: np.ndarray
    limit_use: np.ndarray
    energy: np.ndarray
    actuator_power: np.ndarray
    work: np.ndarray
    step_status: np.ndarray
    step_start_time: np.ndarray
    step_duration: np.ndarray
    step_length: np.ndarray
    section_start: np.ndarray
    section_end: np.ndarray
    status: int
    steps_completed: int


def _observe(model: Walker, params, y, phase, ctx):
    """Contact forces (NaN where inactive), use of the contact limits, energy in
    the step's frame, actuator power."""
    import jax.numpy as jnp

    _, lam = model.dynamics(y, params, phase, ctx)
    lam = jnp.where(model.constraint_mask(phase, params) > 0, lam, jnp.nan)
    limits = model.limit_use(y, params, phase, ctx)
    energy = model.energy(y, params, phase, ctx)
    if model.actuated:
        q, qd = model.split(y)
        power = jnp.asarray(model.actuator_power(q, qd, params, phase, ctx), y.dtype)
    else:
        power = jnp.zeros((), y.dtype)
    return lam, limits, energy, power


@functools.lru_cache(maxsize=None)
def _compiled(model: Walker, opts):
    """Jitted pieces of the recorder for one model and solver settings."""
    import jax

    from jaxwalk.step import end_phase, event_at_start, next_first_step, solve_phase, start_guards

    def advance(params, y, phase, ctx, t0, n_events, dt0):
        g0 = start_guards(model, params, t0, y, phase, ctx)
        sol = solve_phase(model, params, y, phase, ctx, t0, g0, opts, dense=True, dt0=dt0)
        solved = (sol.ts[-1], sol.ys[-1], sol.result)
        # As run_step, which solves a phase that ends at its start over an empty
        # interval: no step taken, so the next phase starts with this one's first step.
        dt_next = next_first_step(model, sol, opts, dt0, event_at_start(g0, opts))
        return end_phase(model, params, t0, y, phase, ctx, g0, solved, n_events, opts), sol.interpolation, dt_next

    def sample(interp, ts, params, phase, ctx):
        ys = jax.vmap(interp.evaluate)(ts)
        lam, limits, energy, power = jax.vmap(lambda y: _observe(model, params, y, phase, ctx))(ys)
        return ys, (lam, limits), energy, power

    def observe(params, ys, phases, ctxs):
        return jax.vmap(lambda y, p, c: _observe(model, params, y, p, c))(ys, phases, ctxs)

    def section(params, y, ctx):
        return model.state_to_section(y, params, ctx)

    jit = lambda fn: compiling.jit(fn, model)
    return jit(advance), jit(sample), jit(observe), jit(section)


def _padded(n: int) -> int:
    # Few distinct sizes, so few compilations of the sampler (each ~2 s on CPU).
    return max(256, 1 << max(n - 1, 0).bit_length())


def record_walk(model: Walker, params, y0, phase0, ctx0, n_steps: int, dt: float, opts=None, progress=None) -> Trajectory:
    """Walk ``n_steps`` steps from the full state ``(y0, phase0, ctx0)`` and record it.

    The walk stops early at the first step that does not end with status ``OK``
    (its samples up to the failing event are kept).

    Args:
        model: the walker; ``params`` its parameters (a dict of scalars).
        y0, phase0, ctx0: the state at the start of the first step.
        n_steps: steps to take.
        dt: sampling interval (model time units); samples lie at multiples of
            ``dt`` of the walk's time, plus two at every event.
        opts: :class:`jaxwalk.step.SolverOptions` (default settings if ``None``).
        progress: called with no argument after each step (a progress bar's update).
    """
    import jax.numpy as jnp

    from jaxwalk.step import SolverOptions

    programs = _compiled(model, opts or SolverOptions())
    _, _, observe, section = programs
    masses = np.asarray(model.masses(params))
    samples = _Samples(weight=masses.sum() * np.asarray(model.gravity(params)))  # total weight in the slope frame
    st = _Walk(y=jnp.asarray(y0), phase=jnp.asarray(phase0, jnp.int32), ctx=jnp.asarray(ctx0), origin=np.zeros(2))
    # (A batch of two, the shape every event uses: one compilation.)
    lam, limits, energy, power = observe(params, jnp.stack([st.y, st.y]), jnp.stack([st.phase, st.phase]), jnp.stack([st.ctx, st.ctx]))
    samples.add(0.0, 0, int(st.phase), REGULAR, -1, st.y[None], st.ctx, st.origin, (lam[:1], limits[:1]), energy[:1], power[:1], st.work)

    steps: dict[str, list] = {k: [] for k in ("status", "start", "duration", "length", "section_start", "section_end")}
    status = int(Status.OK)
    for k in range(n_steps):
        steps["section_start"].append(np.asarray(section(params, st.y, st.ctx)))
        steps["start"].append(st.t_walk)
        code, duration, length = _record_step(programs, model.actuated, params, st, k, dt, samples)
        steps["status"].append(code)
        steps["duration"].append(duration)
        steps["length"].append(length)
        st.t_walk += duration
        if progress is not None:
            progress()
        if code == int(Status.OK):
            steps["section_end"].append(np.asarray(section(params, st.y, st.ctx)))
        else:
            steps["section_end"].append(np.full(len(model.section_names), np.nan))
            status = code
            break
    return _trajectory(samples.arrays(), steps, status, len(model.section_names))


#: Per-sample columns of a recording, in :class:`_Samples`.
_COLUMNS = ("time", "step", "phase", "kind", "guard", "y", "ctx", "origin", "lam", "limits", "energy", "power", "work")


class _Samples:
    """The recorded samples, appended a block at a time (numpy columns, :data:`_COLUMNS`)."""

    def __init__(self, weight: np.ndarray):
        self.weight = weight  # (2,) total weight vector in the slope frame
        self.rows: dict[str, list] = {k: [] for k in _COLUMNS}

    def add(self, time, step, phase, kind, guard, ys, ctx, origin, forces, energy, power, work) -> None:
        """Append ``len(ys)`` samples; ``forces`` is ``(contact_force, limit_use)``."""
        rows = self.rows
        n = len(ys)
        if n == 0:  # a phase with no grid point inside (shorter than dt, or an event at its start)
            return
        rows["time"].append(np.asarray(time, np.float64).reshape(n))
        rows["step"].append(np.full(n, step, np.int32))
        rows["phase"].append(np.full(n, phase, np.int32))
        rows["kind"].append(np.full(n, kind, np.int8))
        rows["guard"].append(np.full(n, guard, np.int8))
        rows["y"].append(np.asarray(ys).reshape(n, -1))
        rows["ctx"].append(np.tile(np.asarray(ctx), (n, 1)))
        rows["origin"].append(np.tile(origin, (n, 1)))
        lam, limits = forces
        rows["lam"].append(np.asarray(lam).reshape(n, -1))
        rows["limits"].append(np.asarray(limits).reshape(n, -1))
        # Gravity potential in the first step's frame: -weight . (p + origin).
        rows["energy"].append(np.asarray(energy).reshape(n) - self.weight @ origin)
        rows["power"].append(np.asarray(power).reshape(n))
        rows["work"].append(np.asarray(work, np.float64).reshape(n))

    def arrays(self) -> dict[str, np.ndarray]:
        return {k: np.concatenate(v) for k, v in self.rows.items()}


@dataclasses.dataclass
class _Walk:
    """Where the walk is: the full state in its step's frame, that frame's origin
    (in the first step's frame), the actuator work so far, the step's start time."""

    y: object
    phase: object
    ctx: object
    origin: np.ndarray
    work: float = 0.0
    t_walk: float = 0.0


def _record_step(programs, actuated: bool, params, st: _Walk, k: int, dt: float, samples: _Samples) -> tuple[int, float, float]:
    """Step ``k`` from ``st`` (advanced in place), phase by phase: its status, duration and length."""
    import jax.numpy as jnp

    from jaxwalk.step import FIRST_STEP

    advance, sample, observe, _ = programs
    t_local, n_events, length = 0.0, 0, 0.0
    first_step = jnp.asarray(FIRST_STEP, st.y.dtype)  # the type advance returns: one compilation
    step_code = int(Status.IN_PROGRESS)
    while step_code == int(Status.IN_PROGRESS):
        out, interp, first_step = advance(params, st.y, st.phase, st.ctx, jnp.asarray(t_local), jnp.asarray(n_events, jnp.int32), first_step)
        n_events += 1
        t_event = float(out.t_event)
        _sample_phase(sample, interp, actuated, params, st, k, (t_local, t_event), dt, samples)
        step_code = _record_event(observe, params, out, st, k, samples)
        length += float(out.shift)
        t_local = t_event
    return step_code, t_local, length


def _sample_phase(sample, interp, actuated: bool, params, st: _Walk, k: int, span, dt: float, samples: _Samples) -> None:
    """The regular samples strictly inside a phase (on the walk's grid ``k dt``)
    and, for an actuated model, the work by Simpson's rule between them."""
    import jax.numpy as jnp

    t_local, t_event = span
    a, b = st.t_walk + t_local, st.t_walk + t_event
    ks = np.arange(math.floor(a / dt), math.ceil(b / dt) + 1)
    grid = ks * dt
    grid = grid[(grid > a) & (grid < b)]
    local = grid - st.t_walk
    nodes = np.concatenate([[t_local], local, [t_event]])
    ts = nodes if not actuated else np.concatenate([nodes, 0.5 * (nodes[:-1] + nodes[1:])])
    pad = np.full(_padded(len(ts)), t_event)
    pad[: len(ts)] = ts
    ys, (lam, limits), energy, power = sample(interp, jnp.asarray(pad), params, st.phase, st.ctx)
    power = np.asarray(power)
    if actuated:
        m = len(nodes)
        p_nodes, p_mid = power[:m], power[m : 2 * m - 1]
        pieces = np.diff(nodes) / 6.0 * (p_nodes[:-1] + 4.0 * p_mid + p_nodes[1:])
        work_nodes = st.work + np.concatenate([[0.0], np.cumsum(pieces)])
    else:
        work_nodes = np.full(len(nodes), st.work)
    inner = slice(1, len(nodes) - 1)
    samples.add(grid, k, int(st.phase), REGULAR, -1, ys[inner], st.ctx, st.origin, (lam[inner], limits[inner]), energy[inner], power[inner], work_nodes[inner])
    st.work = float(work_nodes[-1])


def _record_event(observe, params, out, st: _Walk, k: int, samples: _Samples) -> int:
    """The states just before an event and, if the walk goes on, just after its
    reset (at the same time); moves ``st`` past it. Returns the step's status."""
    import jax.numpy as jnp

    b = st.t_walk + float(out.t_event)
    step_code = int(out.status)
    guard = int(out.guard) if bool(out.event_happened) else -1
    both_y = jnp.stack([out.y_event, out.y_next])
    lam2, limits2, energy2, power2 = observe(params, both_y, jnp.stack([st.phase, out.phase_next]), jnp.stack([st.ctx, out.ctx_next]))
    samples.add(b, k, int(st.phase), BEFORE_EVENT, guard, both_y[:1], st.ctx, st.origin, (lam2[:1], limits2[:1]), energy2[:1], power2[:1], st.work)
    if step_code in (int(Status.IN_PROGRESS), int(Status.OK)):
        st.work += float(out.work)  # the reset's own (walker.Transition.work): after it, not before
        next_step = k + 1 if bool(out.step_done) else k
        if bool(out.step_done):
            # Same hip, new frame: the frame moved by the hip's change of coordinates.
            st.origin = st.origin + np.asarray(out.y_event[:2] - out.y_next[:2])
        samples.add(b, next_step, int(out.phase_next), AFTER_EVENT, guard, both_y[1:], out.ctx_next, st.origin,
                    (lam2[1:], limits2[1:]), energy2[1:], power2[1:], st.work)
    st.y, st.phase, st.ctx = out.y_next, out.phase_next, out.ctx_next
    return step_code


def _trajectory(cat: dict[str, np.ndarray], steps: dict[str, list], status: int, n_v: int) -> Trajectory:
    return Trajectory(
        time=cat["time"],
        step=cat["step"],
        phase=cat["phase"],
        sample_kind=cat["kind"],
        event_guard=cat["guard"],
        y=cat["y"],
        ctx=cat["ctx"],
        origin=cat["origin"],
        contact_force=cat["lam"],
        limit_use=cat["limits"],
        energy=cat["energy"],
        actuator_power=cat["power"],
        work=cat["work"],
        step_status=np.asarray(steps["status"], np.int8),
        step_start_time=np.asarray(steps["start"]),
        step_duration=np.asarray(steps["duration"]),
        step_length=np.asarray(steps["length"]),
        section_start=np.asarray(steps["section_start"]).reshape(-1, n_v),
        section_end=np.asarray(steps["section_end"]).reshape(-1, n_v),
        status=status,
        steps_completed=int(sum(1 for s in steps["status"] if s == int(Status.OK))),
    )
