"""The nested engine's event root finder (jaxwalk.rootfind.BracketedNewton) on scalar functions."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import optimistix as optx
import pytest

from jaxwalk.rootfind import BracketedNewton


def _solve(fn, lower, upper, start, finder=BracketedNewton(rtol=1e-13, atol=1e-13)):
    sol = optx.root_find(lambda t, _: fn(t), finder, jnp.asarray(start), options=dict(lower=lower, upper=upper),
                         max_steps=256, throw=False)
    return float(sol.value), int(sol.stats["num_steps"]), sol.result


@pytest.mark.parametrize("target", [2.0, 3.0, 0.7])
def test_the_root_is_found_to_the_tolerance(target):
    """sqrt(target) from the bracket's upper end, to ``atol + rtol |t|`` (1e-13 each),
    in Newton's steps: a converged step is taken, not bisected (bisecting it threw
    the root away and halved the bracket down to the tolerance, some 40 steps here;
    benchmarks/bench_event_root.py)."""
    value, steps, result = _solve(lambda t: t * t - target, 0.5, 2.0, 2.0)
    assert result == optx.RESULTS.successful
    assert abs(value - np.sqrt(target)) <= 1e-13 * (1.0 + np.sqrt(target))
    assert steps <= 8, steps


def test_a_guard_that_leaves_the_bracket_is_bisected_to_its_root():
    """A guard whose Newton steps from the start leave the bracket (a dip and rise of the
    swing foot within one step): bisection keeps the search inside, and the root found is
    the bracket's, not the other one outside it."""
    fn = lambda t: jnp.cos(3.0 * t) + 0.2  # roots near 0.6 and 1.49; the bracket holds only the first
    value, _, result = _solve(fn, 0.0, 1.0, 1.0)
    assert result == optx.RESULTS.successful
    assert value == pytest.approx(np.arccos(-0.2) / 3.0, abs=1e-13)
    assert 0.0 < value < 1.0


def test_the_root_is_differentiable_implicitly():
    """d root / d p of t^2 - p is 1 / (2 sqrt p), from optimistix's implicit derivative."""
    root = lambda p: optx.root_find(lambda t, p: t * t - p, BracketedNewton(rtol=1e-13, atol=1e-13), jnp.asarray(2.0),
                                    args=p, options=dict(lower=0.5, upper=2.0)).value
    np.testing.assert_allclose(jax.grad(root)(jnp.asarray(2.0)), 0.5 / np.sqrt(2.0), rtol=1e-12)
