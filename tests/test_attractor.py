"""Attractors near the simplest walker's gait past its period doublings, against
an independent SciPy computation and against direct simulation."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import xarray as xr

from jaxwalk.attractor import AttractorOptions
from jaxwalk.models import get_model
from jaxwalk.plot import make_figures
from jaxwalk.status import Status
from jaxwalk.step import step_map
from jaxwalk.sweep import loads_config, run_sweep
from tests.reference import cycles as ref_cycles
from tests.reference.fixed_points import simplest_fixed_point

pytestmark = pytest.mark.slow

MODEL = get_model("simplest")
#: Continued from Garcia's 0.009 up: stable, stable, period 2 (past the flip at 0.01509), period 4.
GAMMAS = np.array([0.009, 0.0125, 0.0155, 0.016, 0.017, 0.018])
P2, P4 = 3, 5  # gamma 0.016, 0.018


CONFIG = f"""
name = "doublings"
model = "simplest"
[grid]
gamma = {{ values = {GAMMAS.tolist()} }}
[analysis]
attractors = true
bifurcations = true
"""


@pytest.fixture(scope="module")
def sweep_path(tmp_path_factory):
    """The slope line as ``jaxwalk sweep`` writes it."""
    return run_sweep(loads_config(CONFIG), tmp_path_factory.mktemp("attractors"), progress=False, plot=False)


@pytest.fixture(scope="module")
def sweep(sweep_path):
    """Its variables, read back (complex ones joined)."""
    ds = xr.open_dataset(sweep_path, engine="zarr")
    results = {name: ds[name].values for name in ds.data_vars}
    results["eigenvalues"] = results["eigenvalues_real"] + 1j * results["eigenvalues_imag"]
    results["attractor_multipliers"] = results["attractor_multipliers_real"] + 1j * results["attractor_multipliers_imag"]
    return results


def test_dataset_layout(sweep):
    assert sweep["attractor_status"].dtype == np.int8 and sweep["attractor_period"].dtype == np.int32
    assert sweep["attractor_points"].shape == (len(GAMMAS), AttractorOptions().max_period, 3)


def test_stable_gait_is_its_own_attractor(sweep):
    stable = sweep["lambda_max"] < 1
    assert stable[:2].all()
    assert (sweep["attractor_status"][stable] == Status.OK).all()
    assert (sweep["attractor_period"][stable] == 1).all()
    np.testing.assert_array_equal(sweep["attractor_lambda_max"][stable], sweep["lambda_max"][stable])
    np.testing.assert_array_equal(sweep["attractor_points"][stable, 0], sweep["fixed_point"][stable])
    assert np.isnan(sweep["attractor_points"][stable, 1:]).all()


def test_periods_past_the_doublings(sweep):
    # The period-1 gait still exists (status 0) but is flip-unstable; the walker settles on period 2, then 4.
    assert (sweep["status"][2:] == Status.OK).all() and (sweep["lambda_max"][2:] > 1).all()
    assert (sweep["eigenvalues"][2:, 0].real < -1).all()
    np.testing.assert_array_equal(sweep["attractor_status"][2:], Status.OK)
    np.testing.assert_array_equal(sweep["attractor_period"], [1, 1, 2, 2, 2, 4])
    assert (sweep["attractor_lambda_max"][2:] < 1).all()
    k = sweep["attractor_period"]
    np.testing.assert_allclose(sweep["attractor_rate"], sweep["attractor_lambda_max"] ** (1.0 / k), rtol=1e-14)


@jax.jit
def _walk_200(params, v0):
    """The 200 iterates of the step map after ``v0`` and their statuses."""

    def one(v, _):
        v_next, res = step_map(MODEL, v, params)
        return v_next, (v_next, res.status)

    return jax.lax.scan(one, v0, None, length=200)[1]


def _match(points, reference):
    """``points`` rotated to start where ``reference[0]`` is (a cycle has no first point)."""
    shift = int(np.argmin(np.abs(points - reference[0]).max(axis=1)))
    return np.roll(points, -shift, axis=0)


def test_period_two_gait_matches_scipy(sweep):
    gamma = float(GAMMAS[P2])
    # The reference finds its own period-1 gait, walks off it and solves its two-step map.
    p1 = simplest_fixed_point(gamma, v0=simplest_fixed_point(0.0125).v)  # continued from a stable slope
    assert p1.status == "ok" and p1.lambda_max > 1
    iterates = ref_cycles.walk(p1.v + np.array([1e-3, 0, 0]), gamma, 120)
    two = ref_cycles.simplest_cycle(gamma, 2, iterates[-1])
    assert two.status == "ok"
    ref_points = ref_cycles.cycle_points(gamma, 2, two.v)
    points = _match(sweep["attractor_points"][P2, :2], ref_points)
    np.testing.assert_allclose(points, ref_points, atol=1e-8)
    np.testing.assert_allclose(np.sort_complex(sweep["attractor_multipliers"][P2]), np.sort_complex(two.eigenvalues), atol=1e-6)
    np.testing.assert_allclose(sweep["attractor_lambda_max"][P2], two.lambda_max, atol=1e-6)


@pytest.mark.parametrize("index,k", [(P2, 2), (P4, 4)])
def test_attractor_equals_direct_simulation(sweep, index, k):
    """Walk 200 steps from a state near the unstable gait (another direction than the search's
    perturbation): the last k steps are the attractor's cycle."""
    start = jnp.asarray(sweep["fixed_point"][index]) + jnp.array([1e-4, 0.0, 0.0])
    vs, status = _walk_200({"gamma": jnp.asarray(GAMMAS[index])}, start)
    assert (np.asarray(status) == Status.OK).all()
    last = np.asarray(vs[-k:])
    points = _match(sweep["attractor_points"][index, :k], last)
    np.testing.assert_allclose(points, last, atol=1e-8)
    assert np.isnan(sweep["attractor_points"][index, k:]).all()


def test_figures_draw_periods_and_rates(sweep_path):
    figures = make_figures(xr.open_dataset(sweep_path, engine="zarr"))
    assert {("attractor_period", "lines"), ("attractor_rate", "lines"), ("lambda_max", "lines")} <= set(figures)
    period_only = make_figures(xr.open_dataset(sweep_path, engine="zarr"), variables=["lambda_max"])
    assert set(period_only) == {("lambda_max", "lines")}


def test_bifurcation_table_in_the_dataset(sweep_path):
    """The sweep's table: the one flip on the line, at the published slope (0.0150884) to 1e-6."""
    ds = xr.open_dataset(sweep_path, engine="zarr")
    assert ds["bifurcation_kind"].dims == ("bifurcation",)
    assert ds["bifurcation_kind"].values.tolist() == [2] and "flip" in ds["bifurcation_kind"].attrs["flag_meanings"]
    assert abs(float(ds["bifurcation_parameter"][0]) - 0.0150884) < 1e-6
    assert ds["bifurcation_status"].values.tolist() == [0] and ds["bifurcation_line"].values.tolist() == [0]
    assert ds["bifurcation_point"].shape == (1, 3)
    assert ds.attrs["swept_parameters"] == "gamma" and ds.attrs["model"] == "simplest"  # the table kept them
