"""Where a walk starts: the periodic gait's fixed point or given section coordinates.

The gait is found with :func:`jaxwalk.gait.find_gait` from the model's initial
guess. Optionally the ground at the first touchdown lies lower by ``drop`` (a
vertical step-down, as in :mod:`jaxwalk.stepdown`: the context entry
``ground_next`` is ``-drop cos(gamma)``; afterwards the walker stays on the
new level).
"""

from __future__ import annotations

import functools

import numpy as np

from jaxwalk import compiling
from jaxwalk.errors import ConfigError
from jaxwalk.walker import Walker, is_state


class GaitNotFound(ConfigError):
    """No periodic gait to start from (a one-line message naming the status)."""


@functools.lru_cache(maxsize=None)
def _gait_search(model: Walker, solver, newton):
    from jaxwalk.gait import find_gait

    return compiling.jit(lambda params, v0: find_gait(model, params, v0, solver, newton), model)


def find_start_gait(model: Walker, params, solver=None, newton=None):
    """The periodic gait from the model's initial guess (:class:`jaxwalk.gait.Gait`, numpy leaves)."""
    import jax

    from jaxwalk.gait import NewtonOptions
    from jaxwalk.step import SolverOptions

    solver = solver or SolverOptions()
    newton = newton or NewtonOptions()
    gait = _gait_search(model, solver, newton)(params, model.initial_guess(params))
    return jax.tree_util.tree_map(np.asarray, gait)


def check_start(model: Walker, params, v, where: str) -> None:
    """Refuse a given start ``v`` ``(n_v,)`` that is not a state of the walker
    (:func:`jaxwalk.walker.is_state`: the heel-rise walker's trailing ankle below
    the ground), with a :class:`~jaxwalk.errors.ConfigError` that names a state on
    the section's edge. Walked, such a start would end its first step with a
    failure of the start, not of the walker (``scuffing``)."""
    import jax.numpy as jnp

    v = jnp.asarray(v, jnp.float64)
    if not bool(is_state(model, v, params)):
        edge = [round(float(x), 12) for x in model.into_section(v, params)]
        given = [float(x) for x in v]
        raise ConfigError(f"{where} v0 = {given} is not a state of the {model.name} walker "
                          f"(outside its section; a state on the section's edge: {edge})")


def initial_state(model: Walker, params, v, drop: float = 0.0):
    """``(y, phase, ctx)`` at the start of a step from section coordinates ``v``,
    with the ground at the first touchdown lower by ``drop`` (vertical)."""
    import jax.numpy as jnp

    y, phase, ctx = model.section_to_state(jnp.asarray(v, jnp.float64), params)
    if model.ground_next is not None or drop:
        ctx = model.with_ground_drop(ctx, params, drop)  # ValueError for a drop the model cannot take
    return y, phase, ctx
