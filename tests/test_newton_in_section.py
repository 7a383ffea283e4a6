"""Newton's iterates kept in the walker's section (:meth:`Walker.into_section`).

A gait can lie on the edge of a walker's section (the heel-rise walker's
heel-down gaits: the trailing ankle on the ground), and Newton's linear step
towards it can cross the edge, to a start the walker cannot have, whose step
fails at once. :func:`jaxwalk.gait.find_gait`'s update moves such an iterate
back onto the edge; so does the attractors' Newton on the k-step map. Shown
on a synthetic residual whose Newton overshoots (``atan``), eagerly, without
a walker: the loops' bodies are run by hand.
"""

from __future__ import annotations

from typing import NamedTuple

import jax.numpy as jnp
import numpy as np
import pytest

from jaxwalk.attractor import _CycleSolve, _fresh_solve, _newton_trip
from jaxwalk.gait import NewtonOptions, _Newton, _newton_iteration
from jaxwalk.models import MODELS
from jaxwalk.status import Status


class _Res(NamedTuple):
    """The fields of a ``StepResult`` that the Newton loop reads."""

    y: jnp.ndarray
    ctx: jnp.ndarray
    phase: jnp.ndarray
    time: jnp.ndarray
    length: jnp.ndarray
    status: jnp.ndarray
    n_events: jnp.ndarray
    work: jnp.ndarray
    ode_steps: jnp.ndarray
    guard: jnp.ndarray


def _residual(v, edge=0.0):
    """``f(v) - v`` of a map whose fixed point is ``(0, 0.3)``; a "step" from
    outside the section ``v[0] >= edge`` fails (with ``edge`` 0 the fixed point
    lies on the section's edge)."""
    outside = v[0] < edge
    zero = jnp.zeros(())
    res = _Res(jnp.zeros(2), jnp.zeros(1), jnp.zeros((), jnp.int32), zero, zero,
               jnp.where(outside, jnp.int8(Status.SCUFFING), jnp.int8(Status.OK)),
               jnp.zeros((), jnp.int32), zero, jnp.zeros((), jnp.int32), jnp.zeros((), jnp.int32))
    return jnp.stack([jnp.arctan(v[0]), v[1] - 0.3]), res


def _search(v0, into_section, edge=0.0, max_iter=10):
    newton = NewtonOptions()
    body = _newton_iteration(lambda v: _residual(v, edge), newton, jnp.eye(2), into_section)
    zero = jnp.zeros((), jnp.int32)
    c = _Newton(jnp.asarray(v0), zero, jnp.int8(Status.IN_PROGRESS), jnp.asarray(False), jnp.zeros((2, 2)),
                jnp.zeros(()), jnp.zeros(()), jnp.zeros(()), zero, zero, zero, zero, jnp.zeros(2), jnp.zeros(1),
                jnp.asarray(False), zero, jnp.asarray(jnp.inf))
    path = [np.asarray(c.v)]
    while int(c.status) == Status.IN_PROGRESS and int(c.k) <= max_iter:
        c = body(c)
        path.append(np.asarray(c.v))
    return c, np.array(path)


def test_an_update_that_leaves_the_section_goes_on_from_its_edge():
    start = [0.15, 0.3]  # Newton on atan from 0.15 lands at -0.0022: outside
    free, path = _search(start, lambda v: v)
    assert path[1][0] < 0 and Status(int(free.status)) == Status.SCUFFING
    kept, path = _search(start, lambda v: v.at[0].set(jnp.maximum(v[0], 0.0)))
    assert Status(int(kept.status)) == Status.OK and np.all(path[:, 0] >= 0.0)
    np.testing.assert_allclose(np.asarray(kept.v), [0.0, 0.3], atol=1e-12)


def test_inside_the_section_the_iterates_are_the_unprojected_ones_bit_for_bit():
    start = [0.9, 0.0]  # steps cut to max_update, then atan's Newton converging about 0 from both sides
    free, free_path = _search(start, lambda v: v, edge=-1.0)
    # The same search with the section x >= -1, which it never leaves.
    kept, kept_path = _search(start, lambda v: v.at[0].set(jnp.maximum(v[0], -1.0)), edge=-1.0)
    assert Status(int(free.status)) == Status.OK and np.any(free_path[:, 0] < 0.0)
    np.testing.assert_array_equal(kept_path, free_path)


@pytest.mark.parametrize("name", sorted(MODELS))
def test_every_models_guess_is_a_state_and_its_projection_idempotent(name):
    """A model's guess is kept as it is (bit for bit), and projecting twice is projecting once."""
    model = MODELS[name]
    params = model.default_params()
    guess = model.initial_guess(params)
    np.testing.assert_array_equal(np.asarray(model.into_section(guess, params)), np.asarray(guess))
    rng = np.random.default_rng(0)
    for _ in range(20):
        v = jnp.asarray(np.asarray(guess) + rng.normal(0.0, 0.2, guess.shape))
        once = model.into_section(v, params)
        np.testing.assert_array_equal(np.asarray(model.into_section(once, params)), np.asarray(once))


def _trip(v, image, status=Status.OK, **fields):
    """One Newton trip of the attractors' cycle solve (period 1) after an
    evaluation whose step from ``v`` reached ``image`` with ``status``."""
    c = _CycleSolve(**_fresh_solve(jnp.asarray(1, jnp.int32), jnp.asarray(v), 1))
    # f(v) = v + (atan(v_0), v_1 - 0.3): df/dv = I + diag(1 / (1 + v_0^2), 1).
    c = c._replace(x=jnp.asarray(image), dx=jnp.eye(2) + jnp.diag(jnp.asarray([1.0 / (1.0 + float(v[0]) ** 2), 1.0])),
                   j=jnp.asarray(1, jnp.int32), step_status=jnp.int8(status), **fields)
    return c


def test_the_cycle_solves_update_and_its_halved_retry_stay_in_the_section():
    """The attractors' Newton (on ``f^k``): the update from 0.15 of ``atan``'s
    residual lands outside and is moved to the edge; a retry after a failed
    step, halved back towards the previous iterate from outside, is moved too."""
    edge = lambda v: v.at[0].set(jnp.maximum(v[0], 0.0))
    v = jnp.asarray([0.15, 0.3])
    image = v + jnp.stack([jnp.arctan(v[0]), v[1] - 0.3])
    free = _newton_trip(_trip(v, image), NewtonOptions(), lambda u: u)
    kept = _newton_trip(_trip(v, image), NewtonOptions(), edge)
    assert float(free.v[0]) < 0.0 and float(kept.v[0]) == 0.0 and float(kept.v[1]) == 0.3
    # A failed evaluation after an update of -0.4 from 0.1: halved to -0.2, to -0.1, outside.
    failed = _trip(jnp.asarray([-0.3, 0.3]), jnp.asarray([-0.3, 0.3]), Status.SCUFFING,
                   it=jnp.asarray(1, jnp.int32), v_prev=jnp.asarray([0.1, 0.3]), last=jnp.asarray([-0.4, 0.0]))
    retried = _newton_trip(failed, NewtonOptions(), edge)
    assert int(retried.halvings) == 1 and Status(int(retried.status)) == Status.IN_PROGRESS
    np.testing.assert_array_equal(np.asarray(retried.v), [0.0, 0.3])
