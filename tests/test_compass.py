"""The engine's compass walker against an independent SciPy implementation."""

import numpy as np
import pytest

from jaxwalk.grid import analyse_grid
from jaxwalk.models import get_model
from tests.reference import scipy_walkers as ref

MODEL = get_model("compass")

# Defaults (Goswami et al.'s symmetric walker at 3 deg) and two asymmetric designs.
CASES = [
    {},
    {"m_h": 5.0, "a": 0.6, "b": 0.4, "gamma": 0.04},
    {"m": 4.0, "a": 0.45, "b": 0.55},
]


@pytest.fixture(scope="module")
def engine_gaits():
    return [analyse_grid(MODEL, case, {"gamma": np.array([case.get("gamma", 0.0523598775598)])}) for case in CASES]


@pytest.mark.parametrize("i", range(len(CASES)))
def test_fixed_point_matches_scipy(engine_gaits, i):
    case = CASES[i]
    ours = engine_gaits[i]
    params = dict(ref.compass_params(), **case)
    theirs = ref.compass_fixed_point(params, v0=ours["fixed_point"][0] if ours["status"][0] == 0 else None)
    assert theirs.status == "ok"
    assert ours["status"][0] == 0
    np.testing.assert_allclose(ours["fixed_point"][0], theirs.v, atol=1e-8)
    eig_ours = np.sort_complex(ours["eigenvalues"][0])
    eig_theirs = np.sort_complex(theirs.eigenvalues)
    np.testing.assert_allclose(eig_ours, eig_theirs, atol=1e-6)
    np.testing.assert_allclose(ours["period"][0], theirs.step_info["step_time"], atol=1e-8)
    np.testing.assert_allclose(ours["step_length"][0], theirs.step_info["step_length"], atol=1e-8)


def test_units_scale_out(engine_gaits):
    """Masses scaled together and g = 1 give the same angles, rates scaled by sqrt(g)."""
    scaled = analyse_grid(MODEL, {"g": 1.0, "m": 1.0, "m_h": 2.0}, {"gamma": np.array([0.0523598775598])})
    base = engine_gaits[0]["fixed_point"][0]
    expect = base * np.array([1.0, 1 / np.sqrt(9.81), 1 / np.sqrt(9.81)])
    np.testing.assert_allclose(scaled["fixed_point"][0], expect, atol=1e-8)
    np.testing.assert_allclose(scaled["lambda_max"][0], engine_gaits[0]["lambda_max"][0], atol=1e-6)


def test_a_phase_that_ends_at_its_start_is_not_integrated():
    """A guard already negative when the step starts (the stance leg rotating
    backward: ``stall``), or a state that is not finite, ends the step at once
    with its status and without a solver step; the phase's solve would run to the
    solver's step limit in vain (docs/engine.md, Known limits)."""
    import jax
    import jax.numpy as jnp

    from jaxwalk.status import Status
    from jaxwalk.step import step_map

    params = MODEL.default_params()
    step = jax.jit(lambda v: step_map(MODEL, v, params)[1])
    backward = step(jnp.array([0.2, 0.5, -0.3]))  # alpha_1 dot > 0: stall = -alpha_1 dot < 0
    assert int(backward.status) == Status.STALLED
    assert int(backward.n_events) == 1 and int(backward.ode_steps) == 0 and float(backward.time) == 0.0
    nonfinite = step(jnp.array([jnp.nan, -1.0, 0.3]))
    assert int(nonfinite.status) == Status.NONFINITE
    assert int(nonfinite.ode_steps) == 0
    walking = step(jnp.array([0.2, -1.0, -0.3]))  # the same program, solving as usual
    assert int(walking.ode_steps) > 0
    # In a vmapped batch too, where the lanes share one solver loop.
    starts = jnp.array([[0.2, 0.5, -0.3], [jnp.nan, -1.0, 0.3], [0.2, -1.0, -0.3]])
    batch = jax.jit(jax.vmap(lambda v: step_map(MODEL, v, params)[1]))(starts)
    assert [int(s) for s in batch.status[:2]] == [Status.STALLED, Status.NONFINITE]
    assert [int(n) for n in batch.ode_steps] == [0, 0, int(walking.ode_steps)]
