"""The simplest walker's bifurcation diagram against the independent SciPy reference:
``run_branches`` (the period-1 branch, its flip, the switch onto the period-2
branch and that branch's own flip) held to SciPy's two-step map, and the gaits
around gamma = 0.019, where Garcia et al. report no stable gait and a fold was
expected (docs/continuation.md, "What the simplest walker shows")."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxwalk.arclength import Stop
from jaxwalk.bifurcation import Kind
from jaxwalk.branches.config import parse_continue_config
from jaxwalk.branches.run import run_branches
from jaxwalk.gait import find_gait
from jaxwalk.models import get_model
from jaxwalk.status import Status
from jaxwalk.step import step_map
from tests.reference import cycles as ref_cycles
from tests.reference.fixed_points import simplest_fixed_point
from tests.reference.gait_checks import simplest_gait_checks
from tests.reference.models import garcia_to_v, simplest_guess

pytestmark = pytest.mark.slow

SIMPLEST = get_model("simplest")
#: Garcia et al.'s simplest walker: its period-1 gait flips at this slope (to 7 digits).
FIRST_DOUBLING = 0.0150884
#: Garcia et al. (1998), Table 1, as quoted in a public MATLAB script (floquet_Garcia.m):
#: the short-period gait at gamma = 0.009, (theta, theta_dot) just after heel-strike,
#: multipliers 4.000 and 0.459.
GARCIA_SHORT_0009 = (0.19393736960624, -0.20386692731962)
TOL = 1e-6
#: The engine's two-step multipliers at its default rtol = atol = 1e-10 against the SciPy
#: reference (rtol 1e-12, which agrees with 1e-13 to 1e-8): measured 2e-6 to 9e-6 along
#: the period-2 branch (3e-7 with the engine at rtol 1e-12, so it is the engine's
#: integration error); its cycle points to 1.2e-8.
MU_TOL = 2e-5
V_TOL = 3e-8

_find_gait = jax.jit(lambda gamma, v0: find_gait(SIMPLEST, {"gamma": gamma}, v0))

CONFIG = {
    "name": "bifcheck", "model": "simplest",
    "continuation": {"parameter": "gamma", "start": 0.0145, "min": 0.014, "max": 0.018, "ds": 2e-3,
                     "ds_max": 1e-2, "max_steps": 20, "switch_branches": True, "switch_eps": 1e-2,
                     "switch_max_steps": 20, "tol": TOL},
}


@pytest.fixture(scope="module")
def continued_and_said():
    """The run, and what it said on stderr (its stage lines and bars)."""
    import contextlib
    import io

    said = io.StringIO()
    with contextlib.redirect_stderr(said):
        out = run_branches(parse_continue_config(CONFIG), progress=True)
    return out, said.getvalue()


@pytest.fixture(scope="module")
def continued(continued_and_said):
    return continued_and_said[0]


def test_the_run_says_each_stage(continued_and_said):
    """``jaxwalk continue`` runs minutes cold: every stage is announced, the branch's
    point count and time when it ends, the location's rounds on a bar."""
    said = continued_and_said[1]
    assert "continuing 1 branch of the simplest model in gamma (the first run of a model compiles" in said
    assert "switching onto the period-2 branch at 1 flip" in said
    assert said.count(" points in ") == 2 and "locating folds, flips and Neimark-Sacker points" in said


@pytest.fixture(scope="module")
def reference_flip():
    """The SciPy reference's period-2 flip: Brent's method on its two-step multiplier (about 2 s)."""
    p1 = simplest_fixed_point(0.0176)
    start = ref_cycles.walk(p1.v + np.array([1e-3, 0.0, 0.0]), 0.0176, 200)[-1]
    return ref_cycles.simplest_flip(2, 0.0176, 0.0178, start)


def test_reference_flip_is_a_period_doubling_of_a_genuine_two_cycle(reference_flip):
    gamma, cycle = reference_flip
    assert 0.01766 < gamma < 0.01768  # jaxwalk's continuation located it at 0.01766937 (docs)
    assert abs(ref_cycles.critical_multiplier(cycle) + 1.0) < 1e-8  # brentq's xtol 1e-12 times d mu / d gamma ~ -961
    points = ref_cycles.cycle_points(gamma, 2, cycle.v)
    assert np.max(np.abs(points[1] - points[0])) > 1e-2  # two distinct steps, not the period-1 gait


def test_run_branches_switches_once_at_the_first_flip(continued):
    branches, labels, period, origin = continued
    assert period.tolist() == [1, 2] and origin.tolist() == [-1, 0]
    assert branches.stop.tolist() == [Stop.PARAMETER_BOUND] * 2
    assert labels.kind.tolist() == [Kind.FLIP, Kind.FLIP] and labels.period.tolist() == [1, 2]
    assert labels.branch.tolist() == [0, 1] and (labels.status == Status.OK).all()
    assert abs(labels.parameter[0] - FIRST_DOUBLING) < TOL
    n = int(branches.n_points[1])
    p = branches.p[1, :n]
    assert (p > labels.parameter[0]).all()  # supercritical: the period-2 gaits lie beyond the flip
    assert p[-1] > CONFIG["continuation"]["max"]  # and cross the second flip before the bound


def test_second_period_doubling_against_the_reference(continued, reference_flip):
    _, labels, _, _ = continued
    gamma_ref, _ = reference_flip
    gamma = float(labels.parameter[1])
    assert abs(gamma - gamma_ref) < TOL  # measured 9e-9
    # The engine's multipliers there against the reference's at the engine's slope.
    ref = ref_cycles.simplest_cycle(gamma, 2, labels.v[1])
    assert ref.status == "ok" and np.max(np.abs(ref.v - labels.v[1])) < V_TOL
    assert abs(ref_cycles.critical_multiplier(ref) - labels.multipliers[1].real.min()) < MU_TOL


def test_period_two_branch_points_are_the_reference_two_cycles(continued):
    branches, _, _, _ = continued
    n = int(branches.n_points[1])
    assert n >= 3
    for i in range(n):
        gamma, v = float(branches.p[1, i]), branches.v[1, i]
        ref = ref_cycles.simplest_cycle(gamma, 2, v)
        assert ref.status == "ok"
        np.testing.assert_allclose(v, ref.v, rtol=0, atol=V_TOL)
        assert abs(branches.lambda_max[1, i] - ref.lambda_max) < MU_TOL
        # the cycle's other point: one step of the reference's map from the engine's point
        other = ref_cycles.cycle_points(gamma, 2, v)[1]
        assert np.max(np.abs(other - v)) > 1e-3


@pytest.mark.parametrize("gamma", [0.020, 0.025, 0.05])
def test_long_period_gait_goes_on_past_0019_physical_and_without_a_fold(gamma):
    """No fold near 0.019: the reference's long-period gait exists beyond it, one
    multiplier below -1 and none near +1, and is a physical gait; the engine agrees."""
    v = simplest_guess(0.019)
    for g in [*np.arange(0.019, gamma, 0.0025), gamma]:  # one Newton from 0.019 to 0.05 leaves the domain
        ref = simplest_fixed_point(g, v0=v)
        assert ref.status == "ok"
        v = ref.v
    mu = ref.eigenvalues
    assert (np.abs(mu.imag) < 1e-12).all() and mu.real.min() < -1.0 and mu.real.max() < 0.5
    checks = simplest_gait_checks(ref.v, gamma)
    assert checks["swing_at_midstance"] > 0.1 and checks["min_compression"] > 0.7
    assert checks["strike_impulse"] > 0 and checks["trailing_lift"] > 0 and checks["lowest_foot_after"] > 0
    assert 3.9 < checks["step_time"] < 4.1
    gait = _find_gait(jnp.asarray(gamma), jnp.asarray(ref.v + 1e-4))
    assert gait.status == Status.OK
    np.testing.assert_allclose(np.asarray(gait.v), ref.v, rtol=0, atol=1e-8)  # measured 2e-9
    assert abs(float(gait.lambda_max) - ref.lambda_max) < 1e-5  # measured 8e-7


def test_garcia_short_period_gait_is_a_scuff_in_our_model():
    """Garcia's second gait exists under his rule (scuffing ignored all swing long), to
    8 digits of his table, and continues past 0.019 too; its swing leg trails at
    mid-stance, so its foot passes through the ground after it: a scuff by the engine's
    rule, which the reference's default rule and the engine both report."""
    v0 = garcia_to_v(GARCIA_SHORT_0009)
    short = simplest_fixed_point(0.009, v0=v0, scuffing="ignore")
    assert short.status == "ok"
    np.testing.assert_allclose(short.v[:2], GARCIA_SHORT_0009, rtol=0, atol=1e-8)
    assert short.eigenvalues.real[0] == pytest.approx(4.000, abs=0.005)
    assert short.eigenvalues.real[1] == pytest.approx(0.459, abs=0.001)
    checks = simplest_gait_checks(short.v, 0.009, scuffing="ignore")
    assert checks["swing_at_midstance"] < -0.05 and checks["lowest_foot_after"] < 0
    assert 3.0 < checks["step_time"] < 3.2  # the long-period gait's: 3.88
    assert simplest_fixed_point(0.009, v0=v0).status == "scuffing"
    _, res = jax.jit(lambda v: step_map(SIMPLEST, v, {"gamma": jnp.asarray(0.009)}))(jnp.asarray(short.v))
    assert res.status == Status.SCUFFING
    v, previous = short.v, short.v
    for g in np.arange(0.011, 0.0251, 0.002):  # secant steps along the short-period branch
        fp = simplest_fixed_point(g, v0=2 * v - previous, scuffing="ignore")
        assert fp.status == "ok" and fp.eigenvalues.real[0] > 1.0
        previous, v = v, fp.v
    assert fp.eigenvalues.real[0] > 5.5  # unstable all along, no multiplier returning to +1
