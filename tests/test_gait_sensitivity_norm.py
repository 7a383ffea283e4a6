"""The gait sensitivity norm (jaxwalk.global_stability.sensitivity_norm) against truth.

Truth: Hobbelen & Wisse's own procedure, with no derivative taken by the
engine: walk from the gait over a one-step floor disturbance +-eps (then flat),
record the indicators of every step, central differences (Richardson over eps
and 2 eps) give the impulse response, and the norm is the root of its summed
squares over 60 steps (the response decays like lambda_max^k, ~0.6^k here).
"""

import functools

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxwalk.gait import find_gait
from jaxwalk.global_stability.sensitivity_norm import gait_sensitivity_norm, h2_norm, norm_and_gradient
from jaxwalk.global_stability.walks import walk_terrain
from jaxwalk.models import get_model
from jaxwalk.step import SolverOptions

N_STEPS = 60


@functools.partial(jax.jit, static_argnames=("model", "solver"))
def _norm(model, params, v, solver=SolverOptions()):
    """The norm at ``v``, one compiled program per model and solver for every test here."""
    return gait_sensitivity_norm(model, params, v, solver=solver)


def _defaults(model):
    return {s.name: jnp.asarray(s.default, jnp.float64) for s in model.parameters}


@pytest.fixture(scope="module", params=["simplest", "compass"])
def gait(request):
    model = get_model(request.param)
    params = _defaults(model)
    g = find_gait(model, params, model.initial_guess(params))
    assert int(g.status) == 0
    return model, params, g


def _finite_difference_norm(model, params, v_star, eps):
    walks = jax.jit(jax.vmap(lambda e0: walk_terrain(model, params, v_star, jnp.zeros(N_STEPS).at[0].set(e0))))
    rec = walks(jnp.array([eps, -eps, 2 * eps, -2 * eps]))
    assert int(jnp.max(rec.status)) == 0
    y = np.stack([np.asarray(rec.time), np.asarray(rec.length)], -1)  # (4, N, 2)
    d1, d2 = (y[0] - y[1]) / (2 * eps), (y[2] - y[3]) / (4 * eps)
    response = (4 * d1 - d2) / 3
    # Decayed to the differences' noise floor (~1e-10 / eps): the sum is complete.
    assert np.abs(response[-5:]).max() < 2e-5 * np.abs(response).max()
    return float(np.sqrt(np.sum(response**2)))


def test_norm_equals_finite_differences_of_perturbed_walks(gait):
    model, params, g = gait
    norm = float(_norm(model, params, g.v))
    fd = _finite_difference_norm(model, params, g.v, 3e-5)
    # FD error: integration noise ~1e-10 over eps 3e-5 and the O(eps^4) remainder.
    assert norm == pytest.approx(fd, rel=2e-5)


def test_h2_norm_of_a_known_system():
    # Scalar x+ = a x + b e, y = c x + d e: ||G||^2 = d^2 + c^2 b^2 / (1 - a^2).
    a, b, c, d = 0.9, 0.5, 2.0, 0.3
    value = h2_norm(jnp.array([[a]]), jnp.array([b]), jnp.array([[c]]), jnp.array([d]), jnp.asarray(a))
    assert float(value) == pytest.approx(np.sqrt(d**2 + c**2 * b**2 / (1 - a**2)), rel=1e-13)
    assert np.isinf(float(h2_norm(jnp.array([[1.2]]), jnp.array([b]), jnp.array([[c]]), jnp.array([d]), jnp.asarray(1.2))))


@pytest.mark.slow
def test_gradient_equals_finite_differences_of_the_norm():
    """d GSN / d gamma of the simplest walker (forward over forward, implicit dv*/dp) against
    Richardson-extrapolated central differences of the norm, each norm from its own gait search.

    The norm amplifies integration noise (GSN = 642 here: lambda_max is near 1): at
    rtol = atol = 1e-12 and 1e-13 it differs by 2.5e-5 (4e-8 relative), so a central
    difference of step h carries ~2.5e-5 / h of noise. Steps of 1e-6 (noise ~10)
    once made AD look 1.4e-3 off. Here h = 1e-4 and 5e-5 at rtol = atol = 1e-12,
    extrapolated to h -> 0 (their h^2 terms differ by 7.5: -2127.09, -2129.08):
    noise <= 0.4, 2e-4 relative; the estimates at (4e-4, 2e-4), (2e-4, 1e-4) and
    (1e-4, 5e-5) spread over 0.18 (measured 2026-12-02)."""
    model = get_model("simplest")
    gamma, h = 0.009, 1e-4
    tight = SolverOptions(rtol=1e-12, atol=1e-12)

    def norm_at(g_, solver):
        # The gait fixture's and test_norm_equals_...'s programs at the default solver.
        p = {"gamma": jnp.asarray(g_, jnp.float64)}
        return _norm(model, p, find_gait(model, p, model.initial_guess(p), solver).v, solver)

    def central(step):
        return (float(norm_at(gamma + step, tight)) - float(norm_at(gamma - step, tight))) / (2 * step)

    value, grad = jax.jit(lambda p, v0: norm_and_gradient(model, p, v0, ("gamma",)))(
        {"gamma": jnp.asarray(gamma)}, model.initial_guess({"gamma": jnp.asarray(gamma)})
    )
    fd = central(h / 2) + (central(h / 2) - central(h)) / 3
    assert float(value) == pytest.approx(float(norm_at(jnp.asarray(gamma), SolverOptions())), rel=1e-12)
    assert float(grad[0]) == pytest.approx(fd, rel=3e-4)


CONFIG = """
name = "gs"
model = "simplest"
[grid]
gamma = { values = [0.009] }
[analysis]
"""


def test_config_keys_resolve_and_reject_bad_input():
    from jaxwalk.sweep.config import ConfigError, loads_config

    plain = loads_config(CONFIG)
    assert plain.global_stability == {} and "gait_sensitivity" not in plain.to_dict()["analysis"]
    on = loads_config(CONFIG + "gait_sensitivity = true\n")
    assert on.to_dict()["analysis"]["gait_sensitivity"] == {"indicators": ["step_time", "step_length"]}
    one = loads_config(CONFIG + 'gait_sensitivity = { indicators = ["step_length"] }\n')
    assert one.global_stability["gait_sensitivity"]["indicators"] == ["step_length"]
    for bad, words in [
        ('gait_sensitivity = { indicators = ["step_tim"] }', "did you mean 'step_time'"),
        ("gait_sensitivity = 3", "must be true, false or a table"),
        ("mfpt = { mesh = 5 }", "needs sigma"),
        ("mfpt = { sigma = -1.0 }", "sigma must be a number >= 0"),
        ("mfpt = { sigma = 0.1, mesh = 2 }", "mesh must be an integer >= 3"),
    ]:
        with pytest.raises(ConfigError, match=words):
            loads_config(CONFIG + bad + "\n")


def test_sweep_output_equals_the_function(gait):
    """analyse_grid with [analysis] gait_sensitivity gives the norm at each gait found."""
    import dataclasses

    from jaxwalk.global_stability.options import GlobalOptions
    from jaxwalk.grid import AnalysisOptions, analyse_grid

    model, params, g = gait
    if model.name != "simplest":
        pytest.skip("one walker proves the hook")
    options = dataclasses.replace(AnalysisOptions(), global_stability=GlobalOptions(gait_sensitivity=("step_time", "step_length")))
    out = analyse_grid(model, {}, {"gamma": np.array([0.009, 0.0095])}, "gamma", options)
    assert out["status"].tolist() == [0, 0]
    expected = float(_norm(model, params, g.v))
    assert out["gait_sensitivity_norm"][0] == pytest.approx(expected, rel=1e-7)
