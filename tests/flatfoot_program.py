"""The flat-foot step program the flat-foot test modules share, and their Newton and walk helpers.

One jitted function at import, so every module of a test process that steps the
walker reuses one compiled program (a step map and a separate ``jvp`` would
compile twice; the ``jvp``'s primal is the step map).
"""

from __future__ import annotations

import functools

import jax
import jax.numpy as jnp

from jaxwalk import compiling
from jaxwalk.gait import failure_cause
from jaxwalk.models import get_model
from jaxwalk.models.flatfoot import forces
from jaxwalk.models.flatfoot.model import PAPER_PARAMS
from jaxwalk.simulate import AFTER_EVENT
from jaxwalk.step import step_map

MODEL = get_model("flatfoot")
#: ``[params]`` lines of a sweep config for the paper's walker (``PAPER_PARAMS``).
PAPER_TOML = "\n".join(f"{name} = {value!r}" for name, value in PAPER_PARAMS.items())
LEVEL = jnp.zeros((), jnp.float64)
NO_TANGENT = jnp.zeros(2, jnp.float64)


# Compiled as a sweep compiles the walker's programs (jaxwalk.compiling): the
# code generator these tests check is the one a sweep runs, and it compiles 1.3x faster.
@functools.partial(compiling.jit, model=MODEL)
def STEP_PROGRAM(v, dv, params, drop):
    """``(v, dv, params, drop) -> (v_next, StepResult, dv_next)``: one step onto
    ground ``drop`` lower and its forward derivative along ``dv``."""
    (v1, res), (dv1, _) = jax.jvp(lambda v_: step_map(MODEL, v_, params, ground_drop=drop), (v,), (dv,))
    return v1, res, dv1


def step_fn(v, params):
    """``(v_next, StepResult)`` on level ground."""
    return STEP_PROGRAM(v, NO_TANGENT, params, LEVEL)[:2]


def tangent_fn(v, dv, params):
    """``(v_next, dv_next)``: one column of the Jacobian at a time."""
    v1, _, dv1 = STEP_PROGRAM(v, dv, params, LEVEL)
    return v1, dv1


def with_params(params, **changes):
    """``params`` with ``changes``, float64 like the defaults (one compiled signature)."""
    return dict(params, **{k: jnp.asarray(v, jnp.float64) for k, v in changes.items()})


def newton(params, step, tangent, iterations=4):
    """Newton from the model's stored guess for ``params``; returns ``(v, J, residual)``."""
    v = MODEL.initial_guess(params)
    eye = jnp.eye(2)
    for _ in range(iterations):
        v1, _ = step(v, params)
        jac = jnp.stack([tangent(v, eye[i], params)[1] for i in range(2)], axis=1)
        res = v1 - v
        if float(jnp.linalg.norm(res)) < 1e-10:
            break
        v = v - jnp.linalg.solve(jac - eye, res)
    return v, jac, float(jnp.linalg.norm(res))


@jax.jit
def _failure_cause(params, res):
    return failure_cause(MODEL, params, res.status, res.phase, res.guard, res.y, res.ctx)


def failure_names(params, res):
    """``(phase, guard, limit)`` names of where a failed step failed (``jaxwalk.gait.failure_cause``,
    what a gait search keeps and a sweep writes); ``limit`` ``None`` where none is at its edge."""
    phase, guard, limit = (int(i) for i in _failure_cause(params, res))
    return MODEL.phases[phase], MODEL.guards[guard], MODEL.limits[limit] if limit >= 0 else None


def walk_phases(walk):
    """A recorded walk's samples split into continuous phases: lists of ``(y, phase, ctx)``
    (the last list is the next step's first instant)."""
    out, current = [], []
    for i in range(len(walk.time)):
        if walk.sample_kind[i] == AFTER_EVENT and current:
            out.append(current)
            current = []
        current.append((jnp.asarray(walk.y[i]), int(walk.phase[i]), jnp.asarray(walk.ctx[i])))
    return out + [current]


def energy_drifts(model, params, walk):
    """``[(phase name, drift)]``: for every sample of every continuous phase of a
    recorded walk, the change of energy less the actuators' work since the phase
    began (zero up to integration error where the bookkeeping is right)."""
    energy, out = _jitted_energy(model), []
    for states in walk_phases(walk)[:-1]:
        y0, phase, ctx = states[0]
        e0 = float(energy(y0, params, phase, ctx))
        for y, _, _ in states[1:]:
            work = float(forces.actuator_work(y0[:6], y[:6], params, phase, ctx))
            out.append((model.phases[phase], float(energy(y, params, phase, ctx)) - work - e0))
    return out


@functools.lru_cache(maxsize=None)
def _jitted_energy(model):
    return jax.jit(model.energy)
