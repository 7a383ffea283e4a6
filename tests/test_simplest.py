"""The engine against the published simplest walker (Garcia et al. 1998)."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxwalk.gait import find_gait, step_jacobian
from jaxwalk.grid import analyse_grid
from jaxwalk.models import get_model
from jaxwalk.status import Status
from jaxwalk.step import SolverOptions, step_map

# Garcia, Chatterjee, Ruina, Coleman (1998), section just after heel-strike.
GARCIA_GAMMA = 0.009
GARCIA_THETA = 0.2003109005
GARCIA_THETA_DOT = -0.1998324730
GARCIA_STABILITY_LIMIT = 0.0151

MODEL = get_model("simplest")

#: One gait search from the model's guess, compiled once for the module.
_search = jax.jit(lambda p: find_gait(MODEL, p, MODEL.initial_guess(p)))


@pytest.fixture(scope="module")
def garcia_gait():
    params = {"gamma": jnp.asarray(GARCIA_GAMMA, jnp.float64)}  # float64, not weak: one signature
    return params, _search(params)


def test_fixed_point_matches_garcia(garcia_gait):
    _, gait = garcia_gait
    assert int(gait.status) == 0
    np.testing.assert_allclose(gait.v[0], GARCIA_THETA, atol=1e-8)
    np.testing.assert_allclose(gait.v[1], GARCIA_THETA_DOT, atol=1e-8)
    # Garcia's impact law: swing rate after heel-strike is theta_dot cos(2 theta).
    np.testing.assert_allclose(gait.v[2], GARCIA_THETA_DOT * np.cos(2 * GARCIA_THETA), atol=1e-8)


def test_fixed_point_is_stable_with_garcia_spectrum(garcia_gait):
    _, gait = garcia_gait
    # Two eigenvalues carry the dynamics; the third is the beta -> 0 direction (~0).
    assert 0.5 < float(gait.lambda_max) < 0.7
    assert abs(complex(gait.eigenvalues[2])) < 1e-6
    assert abs(complex(gait.eigenvalues[0]).imag) > 0.1  # a complex pair


def test_jacobian_matches_central_differences(garcia_gait):
    """jacfwd (event times included) against central differences of the map.

    Both at rtol = atol = 1e-12, so that the differences are not limited by the
    adaptive solver's noise (~1e-10 at the default tolerance, i.e. ~1e-5 in a
    difference quotient with h = 1e-5); then the default-tolerance Jacobian
    reported by Newton against the tight one.
    """
    params, gait = garcia_gait
    v = gait.v
    tight = SolverOptions(rtol=1e-12, atol=1e-12)
    step = jax.jit(jax.vmap(lambda v_: step_map(MODEL, v_, params, tight)[0]))
    jac = np.asarray(jax.jit(lambda v_: step_jacobian(MODEL, v_, params, tight))(v))
    # The map is strongly curved (second derivatives ~1e3), so plain central
    # differences carry an O(h^2) error ~1e-5 at h = 1e-5: extrapolate it away
    # (Richardson, (4 D(h) - D(2h)) / 3, error O(h^4)) and take h = 1e-4, where
    # the solver's noise (~1e-12 / h) stays below 1e-7. Measured: |J - FD| = 3e-7,
    # falling to 2e-7 at rtol 1e-13, while J itself moves by < 1e-8.
    h = 1e-4
    shifts = np.concatenate([np.eye(3), -np.eye(3), 2 * np.eye(3), -2 * np.eye(3)]) * h
    images = np.asarray(step(v + shifts))
    d_h = ((images[:3] - images[3:6]) / (2 * h)).T
    d_2h = ((images[6:9] - images[9:]) / (4 * h)).T
    fd = (4 * d_h - d_2h) / 3
    np.testing.assert_allclose(jac, fd, rtol=1e-6, atol=1e-6)
    # Newton reports the Jacobian at the fixed point it returns (default tolerance).
    np.testing.assert_allclose(np.asarray(gait.jacobian), jac, rtol=1e-5, atol=1e-6)


def test_continuation_finds_garcia_stability_limit():
    """Continuation follows the period-one gait past where it turns unstable."""
    gammas = np.linspace(0.0125, 0.0165, 9)
    out = analyse_grid(MODEL, {}, {"gamma": gammas}, continuation_axis="gamma")
    assert np.all(out["status"] == 0)
    lam = out["lambda_max"]
    assert np.all(np.diff(lam[3:]) > 0)  # rising through 1 past the Hopf-like loss of stability
    k = int(np.argmax(lam > 1.0))
    critical = np.interp(1.0, lam[k - 1 : k + 1], gammas[k - 1 : k + 1])
    assert abs(critical - GARCIA_STABILITY_LIMIT) < 2e-4
    # At 0.009 the continuation result equals the direct one.
    assert out["newton_iterations"].max() <= 8


def test_vmap_equals_single_runs(garcia_gait):
    """The batched step map equals single calls to round-off; gait searches agree
    to the step map's integration noise (~1e-10 in v; J then moves by
    |d2f/dv2| * 1e-10 ~ 1e-7, the map being strongly curved near the separatrix)."""
    params, gait = garcia_gait
    gammas = np.array([0.006, 0.009, 0.012])
    vs = np.stack([gait.v, gait.v * 0.98, gait.v * 1.02])
    single = jax.jit(lambda v, p: step_map(MODEL, v, p)[0])
    batched_map = jax.jit(jax.vmap(lambda v, p: step_map(MODEL, v, p)[0]))(vs, {"gamma": jnp.asarray(gammas)})
    for i, g in enumerate(gammas):
        np.testing.assert_allclose(batched_map[i], single(vs[i], {"gamma": jnp.asarray(g)}), rtol=0, atol=1e-13)

    # Padded to the 64 rows of tests/test_sensitivity.py's grids: the same program
    # (compiled once in one process; from the persistent cache on another worker).
    padded = np.concatenate([gammas, np.full(64 - len(gammas), gammas[-1])])
    batched = analyse_grid(MODEL, {}, {"gamma": padded}, continuation_axis=None)
    for i, g in enumerate(gammas):
        one = _search({"gamma": jnp.asarray(g, jnp.float64)})
        assert batched["status"][i] == one.status == 0
        np.testing.assert_allclose(batched["fixed_point"][i], one.v, atol=1e-9)
        np.testing.assert_allclose(batched["lambda_max"][i], one.lambda_max, atol=1e-6)


def test_failed_search_is_a_status_not_a_number():
    """On an uphill slope the passive walker cannot walk: named status, NaN numbers."""
    out = analyse_grid(MODEL, {}, {"gamma": np.array([-0.01])}, continuation_axis=None)
    assert out["status"][0] != 0
    assert np.isnan(out["lambda_max"][0]) and np.all(np.isnan(out["fixed_point"][0]))
    # Where (jaxwalk.analyses.failure, on by default): 1 + the index of the phase and of the event.
    assert out["failure_phase"][0] == 1 + MODEL.phases.index("single_support_early")
    assert out["failure_event"][0] == 1 + MODEL.guards.index("stall") and out["failure_limit"][0] == 0


@pytest.mark.parametrize("gamma, status, phase, guard", [
    (-0.01, Status.STALLED, "single_support_early", "stall"),  # uphill: it swings back
    (0.03, Status.SCUFFING, "single_support_early", "midstance"),  # the swing leg still behind at mid-stance
    (0.009, Status.OK, None, None),
])
def test_a_failed_search_keeps_where_its_step_failed(gamma, status, phase, guard):
    """GaitStats: the phase and the event of the step that ended the search, each
    consistent with the status (the stall guard stalls; the mid-stance check scuffs,
    at the end of the early phase); -1 where the search succeeded; no contact limits here."""
    gait = _search({"gamma": jnp.asarray(gamma, jnp.float64)})
    stats = gait.stats
    assert int(gait.status) == status
    assert (MODEL.phases[int(stats.failure_phase)] if phase else int(stats.failure_phase)) == (phase or -1)
    assert (MODEL.guards[int(stats.failure_guard)] if guard else int(stats.failure_guard)) == (guard or -1)
    assert int(stats.failure_limit) == -1


@pytest.mark.parametrize("gamma", [0.004, 0.012])
def test_matches_independent_scipy_implementation(gamma):
    """Garcia's exact beta -> 0 equations in SciPy (DOP853) against the engine."""
    from tests.reference import scipy_walkers as ref

    ours = analyse_grid(MODEL, {}, {"gamma": np.array([gamma])})
    theirs = ref.simplest_fixed_point(gamma)
    assert ours["status"][0] == 0 and theirs.status == "ok"
    np.testing.assert_allclose(ours["fixed_point"][0], theirs.v, atol=1e-8)
    np.testing.assert_allclose(ours["lambda_max"][0], theirs.lambda_max, atol=1e-6)
    np.testing.assert_allclose(ours["period"][0], theirs.step_info["step_time"], atol=1e-8)


def test_the_step_size_controller_settings_reach_the_solve():
    """``SolverOptions.safety`` (and the PI coefficients) are the controller's,
    the walker's own where it names none: the same step from Garcia's gait at
    the simplest walker's 0.9 and at 0.75 takes a different number of solver
    steps and lands on the same state."""
    default = SolverOptions()
    controller = SolverOptions(safety=0.6, pcoeff=0.1, icoeff=0.5).make_controller(MODEL)
    assert (controller.safety, controller.pcoeff, controller.icoeff) == (0.6, 0.1, 0.5)
    assert (default.safety, default.pcoeff, default.icoeff) == (None, 0.0, 1.0)
    assert default.make_controller(MODEL).safety == 0.9 == MODEL.step_safety
    assert default.make_controller(get_model("flatfoot")).safety == 0.75
    # A dataset records the safety the walker's solves used, not None.
    assert default.as_record(MODEL)["safety"] == 0.9 and default.as_record()["safety"] is None
    for bad in ({"safety": 0.0}, {"safety": 1.5}, {"icoeff": 0.0}, {"pcoeff": -0.1}):
        with pytest.raises(ValueError):
            SolverOptions(**bad)
    params = {"gamma": jnp.asarray(GARCIA_GAMMA, jnp.float64)}
    v = jnp.array([GARCIA_THETA, GARCIA_THETA_DOT, GARCIA_THETA_DOT * np.cos(2 * GARCIA_THETA)])
    steps = {}
    for safety in (None, 0.75):
        v_next, res = jax.jit(lambda v_: step_map(MODEL, v_, params, SolverOptions(safety=safety)))(v)
        assert int(res.status) == 0
        steps[safety] = (int(res.ode_steps), np.asarray(v_next))
    (n_a, v_a), (n_b, v_b) = steps.values()
    assert n_a != n_b
    np.testing.assert_allclose(v_a, v_b, atol=1e-8)
