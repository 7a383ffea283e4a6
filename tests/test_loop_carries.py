"""Loop carries marked state-dependent (:func:`jaxwalk.stepbase.state_dependent`):
the same values, fewer transformations of the loop bodies under ``jvp`` and
``vmap``, and the same numbers as unmarked carries, on both step engines.

The comparisons with unmarked carries run in a subprocess
(``tests/loop_carries_check.py``): they patch jaxwalk's modules and clear JAX's
caches, which in this process would cost every later test on the worker its
compiled programs.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxwalk.stepbase import state_dependent


@pytest.mark.parametrize("value", [0.0, 0.01, -1, np.int8(3), True])
def test_the_value_is_unchanged_whatever_the_state(value):
    for y in (jnp.array([0.3, 1.0]), jnp.array([jnp.nan, 1.0]), jnp.array([jnp.inf, 0.0])):
        out = jax.jit(state_dependent)(value, y)
        assert out.dtype == jnp.asarray(value).dtype and out == value


def test_the_marked_value_has_a_tangent_and_a_batch_axis():
    marked = lambda y_: state_dependent(0.5, y_)
    unmarked = lambda y_: jnp.asarray(0.5)
    tangent_uses_dy = lambda f: (lambda jx: any(v is jx.invars[1] for e in jx.eqns for v in e.invars))(
        jax.make_jaxpr(lambda y, dy: jax.jvp(f, (y,), (dy,))[1])(jnp.ones(2), jnp.ones(2)).jaxpr)
    assert tangent_uses_dy(marked) and not tangent_uses_dy(unmarked)
    assert jax.vmap(unmarked, out_axes=None)(jnp.ones((3, 2))) == 0.5  # unbatched output allowed
    with pytest.raises(ValueError):
        jax.vmap(marked, out_axes=None)(jnp.ones((3, 2)))  # the marked one has a batch axis


@pytest.fixture(scope="module")
def check() -> dict:
    """What ``tests/loop_carries_check.py`` measured (its docstring says how)."""
    script = Path(__file__).with_name("loop_carries_check.py")
    out = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, timeout=600)
    assert out.returncode == 0, out.stderr[-2000:]
    return json.loads(out.stdout.strip().splitlines()[-1])


def test_marked_loops_take_fewer_transformation_passes(check):
    """A vmapped gait search: fewer loops take a second pass, and fewer passes in all (the
    unmarked phase loop's second pass re-transforms its nested loops, which adds loops)."""
    marked, unmarked = check["passes"]["marked"], check["passes"]["unmarked"]
    assert marked and min(marked) >= 1
    assert sum(p > 1 for p in marked) < sum(p > 1 for p in unmarked)
    assert sum(marked) < sum(unmarked)


@pytest.mark.parametrize("engine", ["nested", "flat"])
def test_marked_and_unmarked_steps_under_jvp_give_the_same_numbers(check, engine):
    """The phase loop's marking on each engine: the same step and tangent to the last bit (the
    gait searches of three walkers likewise: benchmarks/bench_loop_carries.py)."""
    assert check["same_numbers"][engine] is True
