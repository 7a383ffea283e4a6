"""Newton's stopping test (jaxwalk.gait.NewtonOptions.rate_test): the error an
update leaves, estimated from the observed contraction, ends the search one
evaluation earlier, at the same gait."""

from __future__ import annotations

import jax.numpy as jnp
import numpy as np
import pytest

from jaxwalk.gait import NewtonOptions, _small, find_gait
from jaxwalk.models import get_model
from jaxwalk.status import Status
from jaxwalk.step import SolverOptions

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
    ("kneed", None, 1),  # 1.3e-4, 1.3e-8: 1.3e-12 left
    ("simplest", {"gamma": 0.002}, 0),  # from 0.009's guess: 3.0e-4, 4.3e-6: 6.5e-8 left, so on to 2.4e-9
])
def test_the_rate_test_stops_where_its_bound_holds_at_the_same_gait(name, params, saved):
    """From the model's stored guess (made at its defaults): the same gait to Newton's
    tolerance, the same ``lambda_max`` to 1e-7, one iteration fewer where the last
    update contracted fast enough, the same count where it did not (the iterates
    are the same until the rate test stops)."""
    model = get_model(name)
    p = {k: jnp.asarray(v) for k, v in (params or model.default_params()).items()}
    v0 = model.initial_guess(model.default_params())
    gaits = {o.rate_test: find_gait(model, p, v0, SolverOptions(), o) for o in (RATE, UPDATE)}
    assert all(int(g.status) == Status.OK for g in gaits.values())
    np.testing.assert_allclose(gaits[True].v, gaits[False].v, atol=1e-8)
    assert abs(float(gaits[True].lambda_max) - float(gaits[False].lambda_max)) < 1e-7
    assert int(gaits[False].iterations) - int(gaits[True].iterations) == saved
