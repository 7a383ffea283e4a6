"""Derivatives at the gait (jaxwalk.sensitivity) against finite differences.

Every derivative is checked against central differences of the
undifferentiated quantity: the fixed point and lambda_max as the sweep computes
them (``jaxwalk.grid.analyse_grid``, independent Newton searches), so the
implicit fixed-point derivative is compared with differences of converged fixed
points. Differences are Richardson-extrapolated (steps h and 2h): the step map's
second derivatives are large near the simplest walker's separatrix, and the
noise of the computed gait (adaptive steps: ~1e-10 in v*, ~1e-6 in J and
lambda_max) limits how small h can be. Measured (simplest walker, gamma =
0.006, 0.009, 0.012): the differences approach the implicit derivatives as h
grows from 2e-5 to 2e-4 (noise-limited below), where they agree to 9e-5
(relative) for lambda_max, 2e-6 for the period, 5e-6 (absolute, values ~5-10)
for v*. Tolerances are about three times those.
"""

from __future__ import annotations

import os

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxwalk.gait import NewtonOptions
from jaxwalk.grid import analyse_grid
from jaxwalk.models import get_model
from jaxwalk.models.flatfoot.model import PAPER_PARAMS
from jaxwalk.optimize.engine import sensitivity_program
from jaxwalk.sensitivity import spectral_radius
from jaxwalk.status import Status
from jaxwalk.step import SolverOptions

SIMPLEST = get_model("simplest")
#: Batch of the compiled sensitivity program (shared with test_optimize: one compile).
GAMMAS = np.array([0.006, 0.009, 0.012, 0.05])  # the last one has no gait
H = 2e-4  # slope step (rad): smaller steps hit the noise floor of lambda_max (FD error ~1e-6 / H), see the docstring
GRID_ROWS = 64  # every analyse_grid call here pads to this many rows: one compile


def richardson(f_m2, f_m1, f_p1, f_p2, h):
    """Central difference with error O(h^4) from steps h and 2h."""
    return (8.0 * (f_p1 - f_m1) - (f_p2 - f_m2)) / (12.0 * h)


def grid_at(gammas: np.ndarray) -> dict[str, np.ndarray]:
    """``analyse_grid`` of the simplest walker at ``gammas`` (independent searches),
    padded to :data:`GRID_ROWS` values so every call shares one program."""
    n = len(gammas)
    padded = np.concatenate([gammas, np.full(GRID_ROWS - n, gammas[-1])])
    out = analyse_grid(SIMPLEST, {}, {"gamma": padded})
    return {k: v[:n] for k, v in out.items()}


def simplest_sensitivity():
    program = sensitivity_program(SIMPLEST, ("gamma",), SolverOptions(), NewtonOptions())
    params = {"gamma": jnp.asarray(GAMMAS)}
    v0 = jax.vmap(SIMPLEST.initial_guess)(params)
    return jax.tree_util.tree_map(np.asarray, program(params, v0))


@pytest.fixture(scope="module")
def sens():
    return simplest_sensitivity()


@pytest.fixture(scope="module")
def differences():
    """Richardson differences of the sweep's outputs at the three walking slopes."""
    g = GAMMAS[:3]
    points = np.concatenate([g - 2 * H, g - H, g + H, g + 2 * H])
    out = grid_at(points)
    assert (out["status"] == 0).all()
    split = lambda x: np.split(x, 4)
    return {k: richardson(*split(out[k]), H) for k in ("fixed_point", "lambda_max", "speed", "step_length", "period")}


def test_spectral_radius_derivative_real_and_complex():
    """d|mu| from left/right eigenvectors against differences of max |eig|, for a real
    dominant eigenvalue and for a dominant complex pair; vmap of jvp too."""
    rng = np.random.default_rng(0)
    real_dominant = np.diag([0.9, -0.3, 0.2]) + 0.05 * rng.standard_normal((3, 3))
    rotation = 0.7 * np.array([[np.cos(1.0), -np.sin(1.0), 0], [np.sin(1.0), np.cos(1.0), 0], [0, 0, 0.3]])
    complex_pair = rotation + 0.05 * rng.standard_normal((3, 3))
    mats = jnp.asarray(np.stack([real_dominant, complex_pair]))
    dirs = jnp.asarray(rng.standard_normal((2, 3, 3)))
    eigs = np.linalg.eigvals(np.asarray(complex_pair))
    assert abs(np.sort(np.abs(eigs))[-1] - np.sort(np.abs(eigs))[-2]) < 1e-12  # a conjugate pair leads
    _, dr = jax.vmap(lambda a, d: jax.jvp(spectral_radius, (a,), (d,)))(mats, dirs)
    h = 1e-6
    rho = lambda a: np.max(np.abs(np.linalg.eigvals(a)))
    for a, d, got in zip(np.asarray(mats), np.asarray(dirs), np.asarray(dr)):
        fd = (rho(a + h * d) - rho(a - h * d)) / (2 * h)
        assert got == pytest.approx(fd, rel=1e-7, abs=1e-9)


@pytest.mark.slow
def test_fixed_point_derivative_is_the_implicit_one(sens, differences):
    """dv*/dgamma = (I - J)^-1 df/dgamma against differences of converged fixed points."""
    assert (sens.status[:3] == 0).all()
    np.testing.assert_allclose(sens.d_v[:3, :, 0], differences["fixed_point"], rtol=1e-5, atol=2e-5)


@pytest.mark.slow
def test_lambda_max_derivative_through_the_sweep(sens, differences):
    """d lambda_max / d gamma against differences of the sweep's lambda_max
    (a dominant complex pair at these slopes: the spectral radius is smooth)."""
    np.testing.assert_allclose(sens.d_lambda_max[:3, 0], differences["lambda_max"], rtol=3e-4)
    assert (sens.metrics.modulus_gap[:3] > 0.1).all()


@pytest.mark.slow
@pytest.mark.parametrize("name", ["speed", "step_length", "period"])
def test_step_metric_derivatives(sens, differences, name):
    np.testing.assert_allclose(getattr(sens, f"d_{name}")[:3, 0], differences[name], rtol=1e-5)


@pytest.mark.slow
def test_failed_gait_gives_status_and_nan_derivatives(sens):
    """No gait at gamma = 0.05: a non-zero status, NaN values and derivatives, never a silent NaN."""
    assert sens.status[3] != Status.OK
    for d in (sens.d_v, sens.d_lambda_max, sens.d_speed, sens.d_step_length, sens.d_period, sens.d_cost_of_transport):
        assert np.isnan(d[3]).all()
    assert np.isnan(sens.metrics.lambda_max[3])
    # and the walking slopes have finite derivatives with status 0
    assert np.isfinite(sens.d_lambda_max[:3]).all() and (sens.status[:3] == 0).all()


@pytest.mark.slow
def test_simplest_optimum_confirmed_by_a_fine_grid():
    """Minimising lambda_max over the slope from four starts ends where a fine grid
    puts the minimum: at the kink where the complex pair of multipliers turns
    real (gamma ~ 0.0137). The kink is not differentiable, so the iterates
    straddle it; the test asks for the grid's spacing, not more.

    An optimiser test, kept in this module because it runs this module's two
    compiled programs (the sensitivity program at the batch of GAMMAS, and
    grid_at's): CI deals whole modules to its two workers (``--dist loadfile``),
    and from another module it compiled both again on the other worker."""
    from jaxwalk.optimize.engine import Problem, optimise

    problem = Problem(names=("gamma",), lower=(0.004,), upper=(0.0145,), iterations=40, learning_rate=0.05)
    starts = GAMMAS[:, None].copy()  # the sensitivity tests' batch: the same compiled program
    starts[-1] = 0.0144
    path = optimise(SIMPLEST, problem, {}, starts)
    assert (path.final_status == 0).all()
    fine = np.linspace(0.0125, 0.0145, 64)
    grid = grid_at(fine)
    assert (grid["status"] == 0).all()
    best = fine[np.argmin(grid["lambda_max"])]
    spacing = fine[1] - fine[0]
    lam_best = path.metrics["lambda_max"][path.best_row, np.arange(4)]
    for s in range(4):
        assert abs(path.best_params[s, 0] - best) <= spacing
        assert abs(path.final_params[s, 0] - best) <= 2 * spacing
        assert lam_best[s] <= grid["lambda_max"].min() + 1e-3


@pytest.mark.slow
@pytest.mark.skipif(
    not os.environ.get("JAXWALK_FLATFOOT_GRADIENT"),
    reason="tracing and compiling the flat-foot walker's second-order program takes about 4 min on two cores "
    "(benchmarks/README.md); set JAXWALK_FLATFOOT_GRADIENT=1 to run",
)
def test_flatfoot_lambda_max_fixed_point_and_cost_of_transport():
    """The paper's flat-foot walker: d/dr of lambda_max, v* and the cost of
    transport against central differences of converged gaits (one device, the
    setting this check was first measured in).

    The step h = 1e-3 is where central differences of the converged gaits settle
    (2026-12-02, r = 0.4: d CoT/dr 1.035403e-4, 1.034942e-4, 1.034934e-4,
    1.033985e-4, 1.030864e-4 at h = 3e-3, 1e-3, 3e-4, 1e-4, 3e-5; forward mode
    1.034975e-4): below it the gaits' integration noise divided by 2h takes over
    (at h = 1e-4 the difference quotient of the cost of transport was off by
    1.6e-3 relative), above it the truncation error. Forward mode's d lambda_max/dr
    6.93939 against 6.93992 (h = 1e-3) and 6.93917 (h = 3e-4)."""
    model = get_model("flatfoot")
    d = {**model.default_params(), **PAPER_PARAMS}  # the paper's walker, where the step h was chosen
    h = 1e-3
    # Four configurations, like the four foot lengths of results/optimize: one compiled program.
    r = d["r"] + np.array([0.0, -h, h, 0.0])
    params = {k: jnp.full(r.shape, v) for k, v in d.items()}
    params["r"] = jnp.asarray(r)
    v0 = jax.vmap(model.initial_guess)(params)
    program = sensitivity_program(model, ("r",), SolverOptions(), NewtonOptions())
    sens = jax.tree_util.tree_map(np.asarray, program(params, v0))
    assert (sens.status == 0).all()
    m = sens.metrics
    fd = lambda x: (x[2] - x[1]) / (2 * h)
    np.testing.assert_allclose(sens.d_lambda_max[0, 0], fd(m.lambda_max), rtol=5e-4)
    np.testing.assert_allclose(sens.d_v[0, :, 0], fd(m.v), rtol=1e-4, atol=1e-5)
    np.testing.assert_allclose(sens.d_cost_of_transport[0, 0], fd(m.cost_of_transport), rtol=1e-3)
