"""Newton's stopping test (jaxwalk.gait.NewtonOptions.rate_test): the error an
update leaves, estimated from the observed contraction, ends the search an
evaluation earlier where the contraction was fast, at the same gait."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxwalk.gait import NewtonOptions, _Newton, _newton_iteration, _small, find_gait
from jaxwalk.models import get_model
from jaxwalk.status import Status
from jaxwalk.step import SolverOptions
from tests.step_stand_in import StepStandIn

RATE, UPDATE = NewtonOptions(), NewtonOptions(rate_test=False)


@pytest.mark.parametrize("size, last, stops", [
    (1e-6, 1e-3, True),  # theta 1e-3: 1e-9 left
    (1e-6, 1e-4, False),  # theta 1e-2: 1e-8 left, not below tol
    (5e-7, 1e-4, True),  # theta 5e-3: 2.5e-9 left
    (9e-9, 1e-8, True),  # below tol whatever the rate
    (2e-8, 2.5e-8, False),  # noise-sized updates that do not contract
    (3e-8, 2e-8, False),  # growing
    (1e-6, np.inf, False),  # the first update: no rate yet
])
def test_the_rate_test_bounds_the_error_left(size, last, stops):
    assert bool(_small(jnp.asarray(size), jnp.asarray(last), RATE)) == stops
    assert bool(_small(jnp.asarray(size), jnp.asarray(last), UPDATE)) == (size < 1e-8)


@pytest.mark.parametrize("name, params, saved", [
    ("simplest", {"gamma": 0.009}, 1),  # updates 3.3e-5, 1.9e-7: 1.1e-9 left by the bound
    ("compass", None, 1),  # 3.8e-4, 4.2e-7: 4.6e-10 left
    ("simplest", {"gamma": 0.002}, 0),  # from 0.009's guess: 3.0e-4, 4.3e-6: 6.5e-8 left, so on to 2.4e-9
])
def test_the_rate_test_stops_where_its_bound_holds_at_the_same_gait(name, params, saved):
    """From the model's stored guess (made at its defaults), two walkers (the kneed
    walker's saving, 4 -> 3 iterations, is in benchmarks/bench_newton_stop.py): the same
    gait to Newton's tolerance, the same ``lambda_max`` to 1e-6 (its accuracy
    against the SciPy references), and at least one iteration fewer where the
    second-to-last update's bound fires, never more (the iterates are the same
    until the rate test stops; how many more the update test alone takes after
    that depends on the noise of its updates, 1e-9 to 1.8e-8 at slope 0.002)."""
    model = get_model(name)
    p = {k: jnp.asarray(v) for k, v in (params or model.default_params()).items()}
    v0 = model.initial_guess(model.default_params())
    gaits = {o.rate_test: find_gait(model, p, v0, SolverOptions(), o) for o in (RATE, UPDATE)}
    assert all(int(g.status) == Status.OK for g in gaits.values())
    np.testing.assert_allclose(gaits[True].v, gaits[False].v, atol=1e-8)
    assert abs(float(gaits[True].lambda_max) - float(gaits[False].lambda_max)) < 1e-6
    assert int(gaits[False].iterations) - int(gaits[True].iterations) >= saved


def test_no_contraction_is_measured_across_a_step_cut_to_max_update():
    """A residual whose Newton update is 10 (cut to ``max_update`` = 0.2) records no
    previous update for the next rate; one of 0.1 (not cut) records 0.1. Otherwise
    the next update, 9.8, would be compared with 10 as if the iterate had moved by it.
    An update moved back into the walker's section records none either."""
    zero = jnp.zeros(())
    result = StepStandIn(jnp.int8(Status.OK), zero, zero, zero, jnp.int32(0), jnp.int32(0), jnp.int32(0), jnp.int32(0),
                     jnp.zeros(2), jnp.zeros(1))

    def carry_after(offset, into_section=lambda v: v):
        body = _newton_iteration(lambda v: (v - offset, result), RATE, jnp.eye(2), into_section)
        nan, i0 = jnp.full((), jnp.nan), jnp.zeros((), jnp.int32)
        carry = _Newton(jnp.zeros(2), i0, jnp.int8(Status.IN_PROGRESS), jnp.asarray(False), jnp.full((2, 2), nan), nan,
                        nan, nan, i0, i0, i0 - 1, i0 - 1, jnp.zeros(2), jnp.zeros(1), jnp.asarray(False), i0,
                        jnp.full((), jnp.inf))
        return body(carry)

    cut, whole = carry_after(10.0), carry_after(0.1)
    np.testing.assert_allclose(cut.v, [0.2, 0.2])
    assert np.isinf(float(cut.last_update))
    np.testing.assert_allclose(whole.v, [0.1, 0.1])
    assert float(whole.last_update) == pytest.approx(0.1)
    # Moved back into a section (here v <= 0.05) it did not go where Newton sent it either.
    kept = carry_after(0.1, lambda v: jnp.minimum(v, 0.05))
    np.testing.assert_allclose(kept.v, [0.05, 0.05])
    assert np.isinf(float(kept.last_update))
