"""The closed-form chain dynamics (:mod:`jaxwalk.chain`) against automatic derivatives.

A random chain first (the formulas, whatever the model), then every registered
model that declares itself a chain or writes its constraint terms by hand:
its points are what its weights say, and its closed forms equal the automatic
derivatives :mod:`jaxwalk.mechanics` and :meth:`Walker.constraint_terms` take,
at random states around the model's section state and at a second set of
parameters (segment inertias on, other lengths). All jitted: a few small
programs per model.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxwalk import chain, mechanics
from jaxwalk.models import MODELS
from jaxwalk.walker import Walker, overrides

#: Rounding of sums of O(1)..O(10) terms in float64 (measured: at most 3e-15).
TOL = 1e-12


def _random_chain(rng, n_points=5, n_angles=3):
    weights = jnp.asarray(rng.uniform(-1.0, 1.0, size=(n_points, n_angles)))
    masses = jnp.asarray(rng.uniform(0.1, 1.0, size=n_points))
    q = jnp.asarray(rng.normal(size=2 + n_angles))
    qd = jnp.asarray(rng.normal(size=2 + n_angles))
    return weights, masses, q, qd


def _from_points(weights):
    """The chain's points as :mod:`jaxwalk.mechanics` sees them: a function, differentiated."""
    return lambda q_: q_[None, :2] + jnp.stack([jnp.sum(weights * jnp.sin(q_[2:]), axis=1),
                                                -jnp.sum(weights * jnp.cos(q_[2:]), axis=1)], axis=1)


@pytest.mark.parametrize("seed", range(4))
def test_mass_matrix_and_forces_equal_the_derivatives_of_the_points(seed):
    weights, masses, q, qd = _random_chain(np.random.default_rng(seed))
    gravity = jnp.asarray([0.3, -1.0])

    @jax.jit
    def both(weights, masses, q, qd):
        pts = _from_points(weights)
        return (pts(q), chain.points(weights, q),
                mechanics.mass_matrix_and_forces(pts, masses, gravity, q, qd),
                chain.mass_matrix_and_forces(weights, masses, gravity, q, qd),
                chain.mass_matrix(weights, masses, q))

    p_auto, p_chain, (m_auto, f_auto), (m_chain, f_chain), m_only = both(weights, masses, q, qd)
    np.testing.assert_allclose(p_chain, p_auto, rtol=0, atol=TOL)
    np.testing.assert_allclose(m_chain, m_auto, rtol=0, atol=TOL)
    np.testing.assert_allclose(f_chain, f_auto, rtol=0, atol=TOL)
    np.testing.assert_array_equal(m_only, m_chain)
    assert float(jnp.max(jnp.abs(f_auto))) > 0.5  # velocity products and gravity both present


@pytest.mark.parametrize("seed", range(4))
def test_point_and_distance_terms_equal_automatic_derivatives(seed):
    rng = np.random.default_rng(10 + seed)
    weights, _, q, qd = _random_chain(rng, n_points=1)
    row, anchor = weights[0], jnp.asarray(rng.normal(size=2))

    @jax.jit
    def both(q, qd):
        point = lambda q_: _from_points(row[None])(q_)[0]
        distance = lambda q_: jnp.sqrt(jnp.sum((point(q_) - anchor) ** 2))
        auto = (point(q), jax.jvp(point, (q,), (qd,))[1], jax.jacfwd(point)(q),
                mechanics.second_derivative_along(point, q, qd),
                distance(q), jax.grad(distance)(q), mechanics.second_derivative_along(distance, q, qd))
        position, velocity, jac, convective = chain.point_terms(row, q, qd)
        closed = (position, velocity, jac, convective) + chain.distance_terms(position - anchor, velocity, jac, convective)
        return auto, closed

    for auto, closed in zip(*both(q, qd)):
        np.testing.assert_allclose(closed, auto, rtol=0, atol=TOL)


# ----------------------------------------------------------------- the models
CHAINS = [name for name in sorted(MODELS) if MODELS[name].chain_weights(MODELS[name].default_params()) is not None]
HAND_WRITTEN = [name for name in sorted(MODELS) if overrides(MODELS[name], "constraint_terms")]


#: Moved from the defaults where a model has them: lengths scaled, inertias set.
SCALED = {"l_t": 0.9, "l_s": 1.1, "c_t": 0.8, "c_s": 1.2}
SET = {"rho_t": 0.3, "rho_s": 0.25}


def _other_params(model):
    """The defaults with the lengths and inertias of :data:`SCALED` and :data:`SET` moved."""
    params = dict(model.default_params())
    params.update({k: params[k] * v for k, v in SCALED.items() if k in params})
    params.update({k: jnp.asarray(v) for k, v in SET.items() if k in params})
    return params


def _states(model, params, n=4, seed=0):
    y, _, ctx = jax.jit(model.section_to_state)(model.initial_guess(params), params)
    rng = np.random.default_rng(seed)
    q0 = y[: model.n_q]
    return [(q0 + 0.2 * jnp.asarray(rng.normal(size=model.n_q)), jnp.asarray(rng.normal(size=model.n_q)), ctx)
            for _ in range(n)]


def automatic_twin(model: Walker) -> Walker:
    """``model`` with its mass matrix, forces and constraint terms from automatic
    derivatives (the engine's default path): what its closed forms replace."""

    class Automatic(type(model)):
        def chain_weights(self, params):
            return None

        def constraint_terms(self, q, qd, params, ctx):
            return Walker.constraint_terms(self, q, qd, params, ctx)

    Automatic.__name__ = f"Automatic{type(model).__name__}"
    return Automatic()


def test_the_flat_foot_walkers_are_chains_with_hand_written_constraint_terms():
    assert {"flatfoot", "flatfoot_heel_rise"} <= set(CHAINS) & set(HAND_WRITTEN)


@pytest.mark.parametrize("name", CHAINS)
@pytest.mark.parametrize("which", ["defaults", "other"])
def test_a_chain_models_points_and_dynamics_equal_the_automatic_ones(name, which):
    model = MODELS[name]
    params = model.default_params() if which == "defaults" else _other_params(model)

    @jax.jit
    def both(q, qd, params):
        pts = lambda q_: model.points(q_, params)
        weights, masses = model.chain_weights(params), model.masses(params)
        gravity = model.gravity(params)
        return ((pts(q), mechanics.mass_matrix_and_forces(pts, masses, gravity, q, qd)),
                (chain.points(weights, q), chain.mass_matrix_and_forces(weights, masses, gravity, q, qd)))

    for q, qd, _ in _states(model, params):
        (p_auto, (m_auto, f_auto)), (p_chain, (m_chain, f_chain)) = both(q, qd, params)
        np.testing.assert_allclose(p_chain, p_auto, rtol=0, atol=TOL)
        np.testing.assert_allclose(m_chain, m_auto, rtol=0, atol=TOL)
        np.testing.assert_allclose(f_chain, f_auto, rtol=0, atol=TOL)


@pytest.mark.parametrize("name", HAND_WRITTEN)
def test_hand_written_constraint_terms_equal_the_automatic_ones(name):
    model = MODELS[name]
    params = _other_params(model)
    both = jax.jit(lambda q, qd, ctx: (Walker.constraint_terms(model, q, qd, params, ctx),
                                       model.constraint_terms(q, qd, params, ctx)))
    for q, qd, ctx in _states(model, params, seed=1):
        (sigma_auto, psi_auto), (sigma, psi) = both(q, qd, ctx)
        np.testing.assert_allclose(sigma, sigma_auto, rtol=0, atol=TOL)
        np.testing.assert_allclose(psi, psi_auto, rtol=0, atol=TOL * max(1.0, float(jnp.max(jnp.abs(psi_auto)))))


@pytest.mark.parametrize("name", sorted(set(CHAINS) | set(HAND_WRITTEN)))
def test_dynamics_impacts_and_their_parameter_derivatives_equal_the_automatic_twins(name):
    """The closed forms as the engine uses them: ``Walker.dynamics`` and
    ``Walker.apply_impact`` in every phase (traced, as in a step), and the
    accelerations' forward derivative in the parameters, against the model's
    :func:`automatic_twin`."""
    model = MODELS[name]
    twin = automatic_twin(model)
    params = _other_params(model)

    def terms(walker, params, y, phase, ctx):
        qdd, lam = walker.dynamics(y, params, phase, ctx)
        y_plus, impulses = walker.apply_impact(y, params, ctx, walker.constraint_mask(phase, params))
        return qdd, lam, y_plus, impulses

    def both(params, y, phase, ctx):
        d_qdd = lambda walker: jax.jacfwd(lambda p: walker.dynamics(y, p, phase, ctx)[0])(params)  # noqa: E731
        return (terms(model, params, y, phase, ctx), d_qdd(model)), (terms(twin, params, y, phase, ctx), d_qdd(twin))

    both = jax.jit(both)
    for (q, qd, ctx), phase in zip(_states(model, params, n=len(model.phases), seed=2), range(len(model.phases))):
        closed, automatic = both(params, jnp.concatenate([q, qd]), jnp.int32(phase), ctx)
        for a, b in zip(jax.tree_util.tree_leaves(closed), jax.tree_util.tree_leaves(automatic)):
            np.testing.assert_allclose(a, b, rtol=0, atol=TOL * (1.0 + float(jnp.max(jnp.abs(b)))))
