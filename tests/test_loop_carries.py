"""Loop carries marked state-dependent (:func:`jaxwalk.stepbase.state_dependent`):
the same values, one transformation of the step's loop body under ``jvp`` and
``vmap``, and the same numbers as unmarked carries."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxwalk import gait, step
from jaxwalk.gait import find_gait
from jaxwalk.models import get_model
from jaxwalk.stepbase import state_dependent

MODEL = get_model("simplest")
PARAMS = {"gamma": jnp.asarray(0.009)}


@pytest.mark.parametrize("value", [0.0, 0.01, -1, np.int8(3), True])
def test_the_value_is_unchanged_whatever_the_state(value):
    for y in (jnp.array([0.3, 1.0]), jnp.array([jnp.nan, 1.0]), jnp.array([jnp.inf, 0.0])):
        out = jax.jit(state_dependent)(value, y)
        assert out.dtype == jnp.asarray(value).dtype and out == value


def test_the_marked_value_has_a_tangent_and_a_batch_axis():
    y, dy = jnp.array([0.3, 1.0]), jnp.array([2.0, 0.0])
    _, tangent = jax.jvp(lambda y_: state_dependent(0.5, y_), (y,), (dy,))
    assert tangent == 0.0  # the value's derivative, now carried as a number
    batched = jax.vmap(lambda y_: state_dependent(0.5, y_))(jnp.ones((3, 2)))
    assert batched.shape == (3,)


def _loop_passes(fn, *args) -> list[int]:
    """Passes of JAX's while-loop jvp and batching fixpoints per loop while tracing ``fn``."""
    from jax._src.interpreters import ad, batching
    from jax._src.lax.control_flow import loops

    passes = []

    def counted(rule, module, name):
        def wrapper(*a, **kw):
            body, count, inner = kw["body_jaxpr"], [0], getattr(module, name)

            def transform(jaxpr, *b, **k):
                count[0] += jaxpr is body
                return inner(jaxpr, *b, **k)

            setattr(module, name, transform)
            try:
                return rule(*a, **kw)
            finally:
                setattr(module, name, inner)
                passes.append(count[0])
        return wrapper

    jvp_rule = ad.primitive_jvps[loops.while_p]
    batch_rule = batching.fancy_primitive_batchers[loops.while_p]
    ad.primitive_jvps[loops.while_p] = lambda p, t, **kw: counted(loops._while_loop_jvp, ad, "jvp_jaxpr")(p, t, **kw)
    batching.fancy_primitive_batchers[loops.while_p] = counted(batch_rule, batching, "batch_jaxpr")
    try:
        jax.clear_caches()
        jax.jit(fn).trace(*args)
    finally:
        ad.primitive_jvps[loops.while_p] = jvp_rule
        batching.fancy_primitive_batchers[loops.while_p] = batch_rule
    return passes


def _unmarked(monkeypatch):
    for module in (step, gait):
        monkeypatch.setattr(module, "state_dependent", lambda value, y: jnp.asarray(value))


def test_the_phase_and_newton_loops_are_transformed_once(monkeypatch):
    """A vmapped gait search: every loop of jaxwalk's transformed in one pass; unmarked, some take two."""
    batch = {"gamma": jnp.linspace(0.008, 0.010, 3)}
    search = jax.vmap(lambda p, v: find_gait(MODEL, p, v))
    args = (batch, jax.vmap(MODEL.initial_guess)(batch))
    marked = _loop_passes(search, *args)
    _unmarked(monkeypatch)
    unmarked = _loop_passes(search, *args)
    assert marked and max(marked) >= 1
    # diffrax's own loops may take two passes either way; the count of two-pass loops must fall.
    assert sum(p > 1 for p in marked) < sum(p > 1 for p in unmarked)
    assert sum(marked) < sum(unmarked)


def test_marked_and_unmarked_searches_give_the_same_numbers(monkeypatch):
    batch = {"gamma": jnp.linspace(0.004, 0.012, 4)}
    v0 = jax.vmap(MODEL.initial_guess)(batch)
    search = lambda: jax.jit(jax.vmap(lambda p, v: find_gait(MODEL, p, v)))(batch, v0)
    jax.clear_caches()
    marked = jax.tree_util.tree_leaves(search())
    _unmarked(monkeypatch)
    jax.clear_caches()
    unmarked = jax.tree_util.tree_leaves(search())
    for a, b in zip(marked, unmarked):
        np.testing.assert_array_equal(np.asarray(a), np.asarray(b))
