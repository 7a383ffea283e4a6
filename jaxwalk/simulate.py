"""Simulate a walker for N steps and record its trajectory (``jaxwalk simulate``).

A walk starts from the periodic gait's fixed point (found with
:func:`jaxwalk.gait.find_gait` from the model's initial guess) or from given
section coordinates ``v0``; optionally the ground at the first touchdown lies
lower by ``drop`` (a vertical step-down, as in :mod:`jaxwalk.stepdown`: the
context entry ``ground_next`` is ``-drop cos(gamma)``; afterwards the walker
stays on the new level).

Recording runs the same state machine as :func:`jaxwalk.step.run_step`, one
phase at a time in Python: a jitted solve of one phase (the same
``diffeqsolve`` as :func:`jaxwalk.step._solve_phase`, with dense output), the
model's ``on_event`` and the same status rules. Between events the state is
sampled on a regular time grid (multiples of ``dt`` in the walk's time) from
the solver's dense interpolant; at every event both the state just before and
the state just after the reset are recorded at the event time, so impacts
show as jumps. The state after each step's last event is run_step's result for
that step to round-off (``tests/test_simulate.py``).

Layout of the dataset: ``docs/simulate.md``. Config: the TOML shape of a sweep
without ``[grid]``, plus an optional ``[simulate]`` table::

    name = "kneed_walk"
    model = "kneed"
    [params]
    [simulate]
    steps = 4          # or --steps N
    drop = 0.0         # step-down at the first touchdown (model length units, vertical); or --drop H
    dt = 0.005         # output sampling interval (model time units)
    # v0 = [0.2385, -1.1095, -0.0577]   # start here (section coordinates) instead of the gait
"""

from __future__ import annotations

import dataclasses
import datetime as _dt
import functools
import json
import math
import os
import tempfile
from pathlib import Path
from typing import Any, Mapping

import numpy as np

from jaxwalk.models import get_model
from jaxwalk.status import STATUS_MEANINGS, Status, describe, flag_attributes
from jaxwalk.sweep.config import (
    ConfigError,
    _did_you_mean,
    _kind,
    _name,
    _params,
    parse_toml,
    read_config_text,
)
from jaxwalk.walker import Walker

SIMULATE_KEYS = ("steps", "drop", "dt", "v0")
TOP_LEVEL_KEYS = ("name", "model", "params", "simulate")
#: Most steps one walk may take (the trajectory is held in memory).
MAX_STEPS = 1000
#: Allowed output sampling interval, in units of the model's time scale sqrt(L/g).
DT_RANGE = (1e-4, 1.0)
#: Default sampling interval, in time scales (rounded to one significant digit).
DEFAULT_DT_SCALES = 0.02

#: ``sample_kind`` codes.
REGULAR, BEFORE_EVENT, AFTER_EVENT = 0, 1, 2
SAMPLE_KINDS = ("regular", "before_event", "after_event")


class GaitNotFound(ConfigError):
    """No periodic gait to start from (a one-line message naming the status)."""


# ---------------------------------------------------------------- config


@dataclasses.dataclass(frozen=True, eq=False)
class SimulateConfig:
    """A checked, resolved simulation.

    Attributes:
        name: output name (``<name>_trajectory.zarr``, ``<name>_stick.png``, ...).
        model: registry name of the model.
        params: the ``[params]`` table as written (floats).
        fixed: every parameter: the model's defaults updated by ``params``.
        steps: steps to take.
        drop: step-down at the first touchdown (model length units, vertical; 0 for none).
        dt: output sampling interval (model time units).
        v0: start from these section coordinates, or ``None`` for the periodic gait.
        source, text: where the config came from, and its TOML source.
    """

    name: str
    model: str
    params: dict[str, float]
    fixed: dict[str, float]
    steps: int
    drop: float = 0.0
    dt: float = 0.01
    v0: tuple[float, ...] | None = None
    source: str = "<config>"
    text: str | None = None

    def to_dict(self) -> dict[str, Any]:
        """The resolved config, itself a valid config (TOML/JSON-ready)."""
        sim: dict[str, Any] = {"steps": self.steps, "drop": self.drop, "dt": self.dt}
        if self.v0 is not None:
            sim["v0"] = list(self.v0)
        return {"name": self.name, "model": self.model, "params": dict(self.fixed), "simulate": sim}

    def to_json(self) -> str:
        return json.dumps(self.to_dict())


def load_simulate_config(path: str | Path, *, steps: int | None = None, drop: float | None = None) -> SimulateConfig:
    """Read and check the TOML config at ``path``; ``steps``/``drop`` (the command
    line's ``--steps``/``--drop``) override ``[simulate]``. Raises :class:`ConfigError`."""
    text = read_config_text(path)
    return loads_simulate_config(text, source=str(path), steps=steps, drop=drop)


def loads_simulate_config(
    text: str, *, source: str = "<config>", steps: int | None = None, drop: float | None = None
) -> SimulateConfig:
    """Parse and check a config from TOML text. Raises :class:`ConfigError`."""
    return parse_simulate_config(parse_toml(text, source=source), source=source, text=text, steps=steps, drop=drop)


def parse_simulate_config(
    data: Mapping[str, Any],
    *,
    source: str = "<config>",
    text: str | None = None,
    steps: int | None = None,
    drop: float | None = None,
) -> SimulateConfig:
    """Check a config given as a mapping and resolve it (``steps``/``drop`` override
    ``[simulate]``). Raises :class:`ConfigError` with a one-line message."""

    def fail(message: str) -> ConfigError:
        return ConfigError(f"{source}: {message}")

    if not isinstance(data, Mapping):
        raise fail("a config must be a TOML table")
    for key in data:
        if key == "grid":
            raise fail("[grid] is for sweeps (jaxwalk sweep); a simulation runs one parameter set: put fixed values in [params]")
        if key not in TOP_LEVEL_KEYS:
            kind = "section" if isinstance(data[key], Mapping) else "key"
            raise fail(f"unknown top-level {kind} '{key}'{_did_you_mean(key, TOP_LEVEL_KEYS)} (allowed: {', '.join(TOP_LEVEL_KEYS)})")
    for key in ("params", "simulate"):
        if key in data and not isinstance(data[key], Mapping):
            raise fail(f"'{key}' must be a table ([{key}]), got {_kind(data[key])}")

    name = _name(data, fail)
    model_name = data.get("model")
    if model_name is None:
        raise fail("missing 'model' (e.g. model = \"kneed\")")
    if not isinstance(model_name, str):
        raise fail(f"'model' must be a string, got {_kind(model_name)}")
    try:
        model = get_model(model_name)
    except KeyError as err:
        raise fail(err.args[0]) from None
    specs = model.param_specs
    params = _params(data.get("params", {}), specs, model_name, fail)
    fixed = {p: float(spec.default) for p, spec in specs.items()}
    fixed.update(params)

    table = data.get("simulate", {})
    where = "[simulate]"
    for key in table:
        if key not in SIMULATE_KEYS:
            raise fail(f"{where}: unknown key '{key}'{_did_you_mean(key, SIMULATE_KEYS)} (allowed: {', '.join(SIMULATE_KEYS)})")

    def check_steps(n, what):
        if isinstance(n, bool) or not isinstance(n, int) or n < 1:
            raise fail(f"{what} must be a positive integer, got {n!r}")
        if n > MAX_STEPS:
            raise fail(f"{what} = {n} is more than the limit of {MAX_STEPS} steps")
        return n

    def check_drop(h, what):
        if isinstance(h, bool) or not isinstance(h, (int, float)) or not math.isfinite(h) or h < 0:
            raise fail(f"{what} must be a number >= 0 (a vertical step-down at the first touchdown, in {model.units['length']}), got {h!r}")
        if h > 0 and "ground_next" not in model.context:
            raise fail(f"{what}: model '{model_name}' has no step-down (no 'ground_next' in its context)")
        return h

    # The file's values are checked even where the command line overrides them.
    n = check_steps(table["steps"], f"{where} steps") if "steps" in table else None
    if steps is not None:
        n = check_steps(steps, "--steps")
    if n is None:
        raise fail("no step count: give --steps N or [simulate] steps = N")
    h = check_drop(table.get("drop", 0.0), f"{where} drop")
    if drop is not None:
        h = check_drop(drop, "--drop")

    scale = float(model.time_scale({k: np.float64(v) for k, v in fixed.items()}))
    lo, hi = DT_RANGE[0] * scale, DT_RANGE[1] * scale
    if "dt" in table:
        dt = table["dt"]
        if isinstance(dt, bool) or not isinstance(dt, (int, float)) or not math.isfinite(dt) or not (lo <= dt <= hi):
            raise fail(
                f"{where} dt (output sampling interval) must be a number from {lo:.3g} to {hi:.3g} "
                f"{_time_unit(model)} ({DT_RANGE[0]:g} to {DT_RANGE[1]:g} times the time scale sqrt(L/g) = {scale:.4g}), got {dt!r}"
            )
        dt = float(dt)
    else:
        dt = float(f"{DEFAULT_DT_SCALES * scale:.1g}")

    v0 = None
    if "v0" in table:
        v0 = table["v0"]
        names = model.section_names
        ok = isinstance(v0, list) and len(v0) == len(names) and all(
            not isinstance(x, bool) and isinstance(x, (int, float)) and math.isfinite(x) for x in v0
        )
        if not ok:
            raise fail(f"{where} v0 must be an array of {len(names)} finite numbers ({', '.join(names)}), got {v0!r}")
        v0 = tuple(float(x) for x in v0)

    return SimulateConfig(
        name=name, model=model_name, params=params, fixed=fixed, steps=int(n), drop=float(h), dt=dt, v0=v0,
        source=source, text=text,
    )


def _time_unit(model: Walker) -> str:
    unit = model.units["time"]
    return "(model time units)" if unit == "1" else unit


# ---------------------------------------------------------------- start


def as_params(fixed: Mapping[str, float]) -> dict:
    """Parameters as a pytree of float64 scalars."""
    import jax.numpy as jnp

    return {k: jnp.asarray(v, jnp.float64) for k, v in fixed.items()}


@functools.lru_cache(maxsize=None)
def _gait_search(model: Walker, solver, newton):
    import jax

    from jaxwalk.gait import find_gait

    return jax.jit(lambda params, v0: find_gait(model, params, v0, solver, newton))


def find_start_gait(model: Walker, params, solver=None, newton=None):
    """The periodic gait from the model's initial guess (:class:`jaxwalk.gait.Gait`, numpy leaves)."""
    import jax

    from jaxwalk.gait import NewtonOptions
    from jaxwalk.step import SolverOptions

    solver = solver or SolverOptions()
    newton = newton or NewtonOptions()
    gait = _gait_search(model, solver, newton)(params, model.initial_guess(params))
    return jax.tree_util.tree_map(np.asarray, gait)


def initial_state(model: Walker, params, v, drop: float = 0.0):
    """``(y, phase, ctx)`` at the start of a step from section coordinates ``v``,
    with the ground at the first touchdown lower by ``drop`` (vertical)."""
    import jax.numpy as jnp

    y, phase, ctx = model.section_to_state(jnp.asarray(v, jnp.float64), params)
    if "ground_next" in model.context:
        ctx = ctx.at[model.ctx_index("ground_next")].set(-drop * jnp.cos(params["gamma"]))
    elif drop:
        raise ValueError(f"model '{model.name}' has no step-down (no 'ground_next' in its context)")
    return y, phase, ctx


# ---------------------------------------------------------------- recording


@dataclasses.dataclass
class Trajectory:
    """A recorded walk, numpy arrays. ``n`` samples, ``k`` steps attempted.

    Per sample: ``time`` (n,), ``step`` (n,) index of the step the sample belongs
    to (the state after the last step's final event has index ``steps_completed``),
    ``phase`` (n,), ``sample_kind`` (n,) :data:`SAMPLE_KINDS`, ``event_guard`` (n,)
    the guard that fired at an event sample (-1 elsewhere), ``y`` (n, 2 n_q),
    ``ctx`` (n, n_ctx), ``origin`` (n, 2) the step frame's origin in the first
    step's frame, ``contact_force`` (n, n_c) (NaN where a constraint is
    inactive), ``energy`` (n,) in the first step's frame, ``actuator_power`` and
    ``work`` (n,).

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
    """Contact forces (NaN where inactive), energy in the step's frame, actuator power."""
    import jax.numpy as jnp

    _, lam = model.dynamics(y, params, phase, ctx)
    lam = jnp.where(model.constraint_mask(phase, params) > 0, lam, jnp.nan)
    energy = model.energy(y, params, phase, ctx)
    power_fn = getattr(model, "actuator_power", None)
    if power_fn is None:
        power = jnp.zeros((), y.dtype)
    else:
        q, qd = model.split(y)
        power = jnp.asarray(power_fn(q, qd, params, phase, ctx), y.dtype)
    return lam, energy, power


@functools.lru_cache(maxsize=None)
def _compiled(model: Walker, opts):
    """Jitted pieces of the recorder for one model and solver settings."""
    import diffrax
    import jax
    import jax.numpy as jnp

    from jaxwalk.rootfind import BracketedNewton

    in_progress = jnp.int8(Status.IN_PROGRESS)

    def advance(params, y, phase, ctx, t0, n_events):
        # The phase solve of jaxwalk.step._solve_phase, with dense output.
        term = diffrax.ODETerm(model.vector_field)

        def smallest_guard(t, y, args, **kwargs):
            return jnp.min(model.guard_values(t, y, *args))

        event = diffrax.Event(
            smallest_guard, root_finder=BracketedNewton(rtol=opts.event_tol, atol=opts.event_tol), direction=False
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
            saveat=diffrax.SaveAt(t1=True, dense=True),
        )
        t_event, y_event, result = sol.ts[-1], sol.ys[-1], sol.result
        # The body of jaxwalk.step.run_step's loop.
        guards = model.guard_values(t_event, y_event, params, phase, ctx)
        which = jnp.argmin(guards)
        tr = model.on_event(which, t_event, y_event, params, phase, ctx)
        step_status = jnp.where(tr.step_done & (tr.status == in_progress), jnp.int8(Status.OK), tr.status)
        n_events = n_events + 1
        event_happened = result == diffrax.RESULTS.event_occurred
        reached_t1 = result == diffrax.RESULTS.successful
        status = jnp.where(
            event_happened, step_status, jnp.where(reached_t1, jnp.int8(Status.TIMEOUT), jnp.int8(Status.SOLVER_FAILED))
        )
        finite = jnp.all(jnp.isfinite(tr.y)) & jnp.isfinite(t_event)
        status = jnp.where(finite, status, jnp.int8(Status.NONFINITE))
        status = jnp.where((status == in_progress) & (n_events >= opts.max_events), jnp.int8(Status.TOO_MANY_EVENTS), status)
        keep = event_happened & finite
        out = {
            "t_event": t_event,
            "y_event": y_event,
            "guard": which.astype(jnp.int32),
            "event_happened": event_happened,
            "y_next": jnp.where(keep, tr.y, y_event),
            "phase_next": jnp.where(keep, tr.phase, phase).astype(jnp.int32),
            "ctx_next": jnp.where(keep, tr.ctx, ctx),
            "shift": jnp.where(keep, tr.shift, 0.0),
            "step_done": tr.step_done & keep,
            "status": status.astype(jnp.int8),
        }
        return out, sol.interpolation

    def sample(interp, ts, params, phase, ctx):
        ys = jax.vmap(interp.evaluate)(ts)
        lam, energy, power = jax.vmap(lambda y: _observe(model, params, y, phase, ctx))(ys)
        return ys, lam, energy, power

    def observe(params, ys, phases, ctxs):
        return jax.vmap(lambda y, p, c: _observe(model, params, y, p, c))(ys, phases, ctxs)

    def section(params, y, ctx):
        return model.state_to_section(y, params, ctx)

    return jax.jit(advance), jax.jit(sample), jax.jit(observe), jax.jit(section)


def _padded(n: int) -> int:
    # Few distinct sizes, so few compilations of the sampler (each ~2 s on CPU).
    return max(256, 1 << max(n - 1, 0).bit_length())


def record_walk(model: Walker, params, y0, phase0, ctx0, n_steps: int, dt: float, opts=None) -> Trajectory:
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
    """
    import jax.numpy as jnp

    from jaxwalk.step import SolverOptions

    opts = opts or SolverOptions()
    advance, sample, observe, section = _compiled(model, opts)
    masses = np.asarray(model.masses(params))
    weight = masses.sum() * np.asarray(model.gravity(params))  # total weight vector in the slope frame
    has_power = getattr(model, "actuator_power", None) is not None

    rows: dict[str, list] = {k: [] for k in ("time", "step", "phase", "kind", "guard", "y", "ctx", "origin", "lam", "energy", "power", "work")}

    def add(time, step, phase, kind, guard, ys, ctx, origin, lam, energy, power, work):
        n = len(ys)
        rows["time"].append(np.asarray(time, np.float64).reshape(n))
        rows["step"].append(np.full(n, step, np.int32))
        rows["phase"].append(np.full(n, phase, np.int32))
        rows["kind"].append(np.full(n, kind, np.int8))
        rows["guard"].append(np.full(n, guard, np.int8))
        rows["y"].append(np.asarray(ys).reshape(n, -1))
        rows["ctx"].append(np.tile(np.asarray(ctx), (n, 1)))
        rows["origin"].append(np.tile(origin, (n, 1)))
        rows["lam"].append(np.asarray(lam).reshape(n, -1))
        # Gravity potential in the first step's frame: -weight . (p + origin).
        rows["energy"].append(np.asarray(energy).reshape(n) - weight @ origin)
        rows["power"].append(np.asarray(power).reshape(n))
        rows["work"].append(np.asarray(work, np.float64).reshape(n))

    y = jnp.asarray(y0)
    phase = jnp.asarray(phase0, jnp.int32)
    ctx = jnp.asarray(ctx0)
    origin = np.zeros(2)
    work = 0.0
    t_walk = 0.0  # time at the start of the current step
    # (A batch of two, the shape every event uses: one compilation.)
    lam, energy, power = observe(params, jnp.stack([y, y]), jnp.stack([phase, phase]), jnp.stack([ctx, ctx]))
    add(0.0, 0, int(phase), REGULAR, -1, y[None], ctx, origin, lam[:1], energy[:1], power[:1], work)

    step_status, step_start, step_duration, step_length, sec_start, sec_end = [], [], [], [], [], []
    status = int(Status.OK)
    for k in range(n_steps):
        sec_start.append(np.asarray(section(params, y, ctx)))
        step_start.append(t_walk)
        t_local, n_events, length = 0.0, 0, 0.0
        step_code = int(Status.IN_PROGRESS)
        while step_code == int(Status.IN_PROGRESS):
            out, interp = advance(params, y, phase, ctx, jnp.asarray(t_local), jnp.asarray(n_events, jnp.int32))
            n_events += 1
            t_event = float(out["t_event"])
            # Regular samples strictly inside the phase, on the walk's grid k dt.
            a, b = t_walk + t_local, t_walk + t_event
            ks = np.arange(math.floor(a / dt), math.ceil(b / dt) + 1)
            grid = ks * dt
            grid = grid[(grid > a) & (grid < b)]
            local = grid - t_walk
            nodes = np.concatenate([[t_local], local, [t_event]])
            ts = nodes if not has_power else np.concatenate([nodes, 0.5 * (nodes[:-1] + nodes[1:])])
            pad = np.full(_padded(len(ts)), t_event)
            pad[: len(ts)] = ts
            ys, lam, energy, power = sample(interp, jnp.asarray(pad), params, phase, ctx)
            power = np.asarray(power)
            if has_power:
                m = len(nodes)
                p_nodes, p_mid = power[:m], power[m : 2 * m - 1]
                pieces = np.diff(nodes) / 6.0 * (p_nodes[:-1] + 4.0 * p_mid + p_nodes[1:])
                work_nodes = work + np.concatenate([[0.0], np.cumsum(pieces)])
            else:
                work_nodes = np.full(len(nodes), work)
            inner = slice(1, len(nodes) - 1)
            ph = int(phase)
            add(grid, k, ph, REGULAR, -1, ys[inner], ctx, origin, lam[inner], energy[inner], power[inner], work_nodes[inner])
            work = float(work_nodes[-1])

            # The event: the state before it, and after it if the walk goes on.
            step_code = int(out["status"])
            guard = int(out["guard"]) if bool(out["event_happened"]) else -1
            both_y = jnp.stack([out["y_event"], out["y_next"]])
            lam2, energy2, power2 = observe(
                params, both_y, jnp.stack([phase, out["phase_next"]]), jnp.stack([ctx, out["ctx_next"]])
            )
            add(b, k, ph, BEFORE_EVENT, guard, both_y[:1], ctx, origin, lam2[:1], energy2[:1], power2[:1], work)
            length += float(out["shift"])
            goes_on = step_code in (int(Status.IN_PROGRESS), int(Status.OK))
            if goes_on:
                next_step = k + 1 if bool(out["step_done"]) else k
                if bool(out["step_done"]):
                    # Same hip, new frame: the frame moved by the hip's change of coordinates.
                    origin = origin + np.asarray(out["y_event"][:2] - out["y_next"][:2])
                add(b, next_step, int(out["phase_next"]), AFTER_EVENT, guard, both_y[1:], out["ctx_next"], origin,
                    lam2[1:], energy2[1:], power2[1:], work)
            y, phase, ctx = out["y_next"], out["phase_next"], out["ctx_next"]
            t_local = t_event
        step_status.append(step_code)
        step_duration.append(t_local)
        step_length.append(length)
        t_walk += t_local
        if step_code == int(Status.OK):
            sec_end.append(np.asarray(section(params, y, ctx)))
        else:
            sec_end.append(np.full(len(model.section_names), np.nan))
            status = step_code
            break

    cat = {k: np.concatenate(v) for k, v in rows.items()}
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
        energy=cat["energy"],
        actuator_power=cat["power"],
        work=cat["work"],
        step_status=np.asarray(step_status, np.int8),
        step_start_time=np.asarray(step_start),
        step_duration=np.asarray(step_duration),
        step_length=np.asarray(step_length),
        section_start=np.asarray(sec_start).reshape(-1, len(model.section_names)),
        section_end=np.asarray(sec_end).reshape(-1, len(model.section_names)),
        status=status,
        steps_completed=int(sum(1 for s in step_status if s == int(Status.OK))),
    )


# ---------------------------------------------------------------- dataset


def coordinate_units(model: Walker) -> tuple[list[str], list[str]]:
    """Units of ``q`` and ``qd``: the hip position is a length, the rest are angles
    (the engine's convention, :mod:`jaxwalk.walker`)."""
    from jaxwalk.sweep.dataset import output_units

    u = output_units(model)
    length, time = u["length"], u["time"]
    q_units = [length if i < 2 else "rad" for i in range(model.n_q)]
    if time == "1":  # dimensionless time: rates carry the units of their coordinates
        qd_units = list(q_units)
    else:
        rate = lambda unit: f"{time}-1" if unit == "1" else f"{unit} {time}-1"
        qd_units = [rate(unit) for unit in q_units]
    return q_units, qd_units


def _flags(names) -> dict[str, Any]:
    return {"flag_values": list(range(len(names))), "flag_meanings": " ".join(names)}


def build_trajectory_dataset(
    config: SimulateConfig,
    model: Walker,
    traj: Trajectory,
    *,
    gait=None,
    command: str | None = None,
    created: _dt.datetime | None = None,
    solver=None,
):
    """The trajectory dataset (layout: ``docs/simulate.md``).

    Args:
        config: the resolved config; ``model`` its model; ``traj`` the recorded walk.
        gait: the :class:`jaxwalk.gait.Gait` the walk started from (``None`` with ``v0``).
        command: the command line that made it; ``created`` the time (default now, UTC).
        solver: the :class:`jaxwalk.step.SolverOptions` used (recorded as JSON).
    """
    import xarray as xr

    from jaxwalk.sweep.dataset import output_units, package_versions, units_note

    units = output_units(model)
    q_units, qd_units = coordinate_units(model)
    n_q = model.n_q
    created = created or _dt.datetime.now(_dt.timezone.utc)
    created_s = created.isoformat(timespec="seconds")
    length_u, time_u = units["length"], units["time"]
    force_u = "1" if length_u == "1" else "N or N m"
    energy_u = "1" if length_u == "1" else "J"
    power_u = "1" if length_u == "1" else "W"

    coords = {
        "time": ("time", traj.time, {
            "long_name": "time since the start of the walk (repeated at each event: the states just before and just after it)",
            "units": time_u,
        }),
        "coordinate": ("coordinate", np.array(model.coordinates, dtype=object), {
            "long_name": "generalized coordinates q: hip position in the slope frame, then absolute segment angles from the slope normal",
        }),
        "q_units": ("coordinate", np.array(q_units, dtype=object), {"long_name": "units of q"}),
        "qd_units": ("coordinate", np.array(qd_units, dtype=object), {"long_name": "units of qd"}),
        "constraint": ("constraint", np.arange(model.n_constraints), {"long_name": "constraint row of the model (model.constraints)"}),
        "context": ("context", np.array(model.context, dtype=object), {"long_name": "entries of the discrete state ctx"}),
        "xy": ("xy", np.array(["x", "y"], dtype=object), {"long_name": "slope frame axes: x along the slope (downhill), y normal to it"}),
        "step_number": ("step_number", np.arange(len(traj.step_status)), {"long_name": "step index, from 0"}),
        "section": ("section", np.array(model.section_names, dtype=object), {"long_name": "section coordinates at the start of a step"}),
    }
    guard_flags = {"flag_values": list(range(-1, len(model.guards))), "flag_meanings": " ".join(("none", *model.guards))}
    data_vars = {
        "phase": ("time", traj.phase, {"long_name": "phase of the step", **_flags(model.phases)}),
        "step": ("time", traj.step, {
            "long_name": "index of the step the sample belongs to (the state after the last completed step's heel-strike has index steps_completed)",
            "units": "1",
        }),
        "sample_kind": ("time", traj.sample_kind, {"long_name": "regular sample (a multiple of dt) or the state just before/after an event", **_flags(SAMPLE_KINDS)}),
        "event_guard": ("time", traj.event_guard, {"long_name": "guard whose zero crossing caused the event (event samples only)", **guard_flags}),
        "q": (("time", "coordinate"), traj.y[:, :n_q], {
            "long_name": "generalized coordinates in the frame of the current step (slope frame, stance foot at the origin at the step's start; leg 1 = stance leg)",
            "units_per_coordinate": json.dumps(dict(zip(model.coordinates, q_units))),
        }),
        "qd": (("time", "coordinate"), traj.y[:, n_q:], {
            "long_name": "generalized velocities",
            "units_per_coordinate": json.dumps(dict(zip(model.coordinates, qd_units))),
        }),
        "contact_force": (("time", "constraint"), traj.contact_force, {
            "long_name": "constraint forces: the KKT multipliers lambda of model.dynamics (NaN where the constraint is inactive)",
            "units": force_u,
            "comment": "a force for a position constraint (foot x, y; positive y: the ground pushes up), a torque for an angle constraint (a knee lock); impulses at impacts are not included",
        }),
        "ctx": (("time", "context"), traj.ctx, {"long_name": "discrete state (contact anchors, ground level of the next touchdown), in the frame of the current step"}),
        "frame_origin": (("time", "xy"), traj.origin, {
            "long_name": "origin of the current step's frame in the first step's frame (slope frame); world = frame_origin + q[:2] for the hip",
            "units": length_u,
        }),
        "energy": ("time", traj.energy, {
            "long_name": "total mechanical energy (kinetic + gravity + springs), gravity potential measured in the first step's frame",
            "units": energy_u,
        }),
        "actuator_power": ("time", traj.actuator_power, {
            "long_name": "power of the actuators, qd . Q_actuator (model.actuator_power; 0 for a passive model)",
            "units": power_u,
        }),
        "work": ("time", traj.work, {
            "long_name": "cumulative actuator work since the start (Simpson's rule between samples on the dense solution)",
            "units": energy_u,
        }),
        "step_status": ("step_number", traj.step_status, {"long_name": "outcome of each step (0: completed)", **flag_attributes()}),
        "step_start_time": ("step_number", traj.step_start_time, {"long_name": "time at the start of the step", "units": time_u}),
        "step_duration": ("step_number", traj.step_duration, {"long_name": "duration of the step (to the event that ended it)", "units": time_u}),
        "step_length": ("step_number", traj.step_length, {"long_name": "distance the stance foot advanced in the step, along the slope", "units": length_u}),
        "section_start": (("step_number", "section"), traj.section_start, {"long_name": "section coordinates at the start of the step"}),
        "section_end": (("step_number", "section"), traj.section_end, {"long_name": "section coordinates at the end of the step (NaN if it failed)"}),
        "status": ((), np.int8(traj.status), {"long_name": "outcome of the walk: 0 if every step was completed, else the failed step's status", **flag_attributes()}),
        "steps_completed": ((), np.int32(traj.steps_completed), {"long_name": "steps completed", "units": "1"}),
    }
    start: dict[str, Any]
    if config.v0 is not None:
        start = {"start": "v0 (given section coordinates)", "start_section": json.dumps(list(config.v0))}
    else:
        start = {
            "start": "periodic gait (find_gait from the model's initial guess)",
            "start_section": json.dumps([float(x) for x in np.asarray(gait.v)]),
            "gait_lambda_max": float(gait.lambda_max),
            "gait_period": float(gait.period),
            "gait_step_length": float(gait.step_length),
            "gait_newton_iterations": int(gait.iterations),
        }
    versions = package_versions()
    attrs = {
        "title": f"jaxwalk simulation '{config.name}' of the {model.name} model",
        "Conventions": "CF-1.10",
        "name": config.name,
        "model": model.name,
        "model_description": model.description,
        "params": json.dumps(config.fixed),
        "parameter_units": json.dumps({p.name: p.units for p in model.parameters}),
        "units": json.dumps(units),
        "units_note": units_note(model),
        "steps_requested": config.steps,
        "drop": config.drop,
        "drop_comment": "vertical step-down of the ground at the first touchdown (model length units); later steps on the new level",
        "dt": config.dt,
        **start,
        "status_meanings": flag_attributes()["flag_descriptions"],
        "solver_options": json.dumps(dataclasses.asdict(solver) if solver is not None else {}, default=str),
        "config": config.to_json(),
        "config_toml": config.text if config.text is not None else "",
        "config_source": config.source,
        "created": created_s,
        "command": command or "",
        "history": f"{created_s}: {command or 'jaxwalk.simulate.run_simulation'}",
        **{f"{name}_version": v for name, v in versions.items()},
    }
    return xr.Dataset(data_vars, coords=coords, attrs=attrs)


# ---------------------------------------------------------------- outputs


def output_paths(out_dir: str | os.PathLike, name: str, *, plot: bool = True, gif: bool = True) -> dict[str, Path]:
    """The files a simulation writes: ``dataset``, and ``stick``/``timeseries`` (PNG), ``gif``."""
    out = Path(out_dir)
    paths = {"dataset": out / f"{name}_trajectory.zarr"}
    if plot:
        paths["stick"] = out / f"{name}_stick.png"
        paths["timeseries"] = out / f"{name}_timeseries.png"
    if gif:
        paths["gif"] = out / f"{name}_walk.gif"
    return paths


def check_outputs(out_dir, name: str, *, plot: bool = True, gif: bool = True, overwrite: bool = False) -> dict[str, Path]:
    """:func:`output_paths` if they can be written; creates nothing. Raises :class:`ConfigError`."""
    from jaxwalk.sweep.runner import check_output

    check_output(out_dir, f"{name}_trajectory", overwrite=overwrite)  # the directory, and the dataset
    paths = output_paths(out_dir, name, plot=plot, gif=gif)
    for path in paths.values():
        if (path.exists() or path.is_symlink()) and not overwrite:
            raise ConfigError(f"'{path}' already exists (pass --overwrite to replace it)")
    return paths


def check_drawable(model: Walker) -> None:
    """Raise :class:`ConfigError` if ``model`` lacks what the figures need."""
    missing = [m for m in ("skeleton", "foot_points") if not callable(getattr(model, m, None))]
    if missing:
        raise ConfigError(
            f"model '{model.name}' cannot be drawn: it has no {' or '.join(f'{m}()' for m in missing)} method "
            "(pass --no-plot --no-gif for the dataset alone)"
        )


def run_simulation(
    config: SimulateConfig,
    out_dir: str | os.PathLike,
    *,
    plot: bool = True,
    gif: bool = True,
    overwrite: bool = False,
    command: str | None = None,
    solver=None,
) -> tuple[dict[str, Path], Trajectory]:
    """Find the start, walk, write the dataset and figures; return their paths and the walk.

    Everything that can be checked is checked before computing (the outputs, the
    model's drawing methods); no gait from the initial guess is a
    :class:`GaitNotFound` before anything is written.
    """
    from jaxwalk.step import SolverOptions

    model = get_model(config.model)
    paths = check_outputs(out_dir, config.name, plot=plot, gif=gif, overwrite=overwrite)
    if plot or gif:
        check_drawable(model)
    solver = solver or SolverOptions()
    params = as_params(config.fixed)
    gait = None
    if config.v0 is None:
        gait = find_start_gait(model, params, solver)
        if int(gait.status) != Status.OK:
            code = int(gait.status)
            meaning = STATUS_MEANINGS.get(Status(code), "") if code in set(map(int, Status)) else ""
            raise GaitNotFound(
                f"{config.source}: no periodic gait found from the {model.name} model's initial guess: "
                f"status {describe(code)} ({meaning}); give [simulate] v0 = [...] to start from a state of your own"
            )
        v = gait.v
    else:
        v = np.asarray(config.v0)
    y0, phase0, ctx0 = initial_state(model, params, v, config.drop)
    traj = record_walk(model, params, y0, phase0, ctx0, config.steps, config.dt, solver)

    from jaxwalk.sweep.dataset import write_zarr

    ds = build_trajectory_dataset(config, model, traj, gait=gait, command=command, solver=solver)
    write_zarr(ds, paths["dataset"], overwrite=overwrite)
    if plot or gif:
        from jaxwalk.figures import save_animation, save_stick_diagram, save_time_series, walk_geometry

        geo = walk_geometry(ds, model)
        if plot:
            _atomic(paths["stick"], lambda p: save_stick_diagram(ds, model, p, geometry=geo))
            _atomic(paths["timeseries"], lambda p: save_time_series(ds, model, p, geometry=geo))
        if gif:
            _atomic(paths["gif"], lambda p: save_animation(ds, model, p, geometry=geo))
    return paths, traj


def _atomic(target: Path, write) -> None:
    """``write(path)`` into a hidden directory beside ``target``, then rename it into place."""
    import shutil

    target.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{target.name}.", suffix=".tmp", dir=target.parent))
    try:
        path = tmp / target.name
        write(path)
        os.replace(path, target)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
