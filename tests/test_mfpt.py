"""The mean first-passage time on random terrain (jaxwalk.global_stability.mfpt) against
direct Monte Carlo walks (jaxwalk.global_stability.walks), and the sweep hook.

Truth: 2000 walks from the gait on i.i.d. N(0, sigma^2) ground height changes,
each until its first failed step; the chain's expected steps from the gait must
agree with their mean within three standard errors plus the chain's own
discretisation error estimate (a coarser mesh's difference), and that estimate
must be under half the answer (else agreement would say little).

Measured (2026-12-01, shared machine): simplest, sigma 1.5e-4: chain 20.21
(error 4.77, escaped 1.6%), Monte Carlo 22.42 +- 0.46 (all falls are scuffs).
Compass, sigma 3e-3 m (2026-12-03): chain 23.19 (error 9.66 at mesh 13, escaped
5.7%; the 3-D chain is coarse: a finer mesh costs mesh^3 steps), Monte Carlo
22.60 +- 0.46 over 2000 walks (every one ended by a scuff, none censored):
0.59 apart, 11.05 allowed. That check took 7:29 on the two cores then, beside
a benchmark on a loaded machine, and was opt-in; measured again on 2026-12-06
(pinned to one core, an MFPT sweep on the other, jaxwalk reporting that it
compiled both the compass walker's programs) it took 65 s, the simplest
walker's 54 s, and it runs in the suite.
"""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxwalk.gait import find_gait
from jaxwalk.global_stability.mfpt import MFPTOptions, mesh_states, mfpt, plan
from jaxwalk.global_stability.walks import WalkEnd, monte_carlo, pooled_walks, walk_until
from jaxwalk.models import get_model
from jaxwalk.status import Status

#: sigma where the MFPT is 20-500 steps (model length units: leg lengths; metres), and the chain's mesh.
CASES = {"simplest": (1.5e-4, MFPTOptions(sigma=1.5e-4, mesh=21, samples=64, span=5.0)), "compass": (3e-3, MFPTOptions(sigma=3e-3, mesh=13, samples=48, span=5.0))}


def _gait(name):
    model = get_model(name)
    params = {s.name: jnp.asarray(s.default, jnp.float64) for s in model.parameters}
    g = find_gait(model, params, model.initial_guess(params))
    assert int(g.status) == 0
    return model, params, np.asarray(g.v)


@pytest.mark.slow
@pytest.mark.parametrize("name", list(CASES))
def test_mfpt_agrees_with_monte_carlo(name):
    model, params, v = _gait(name)
    sigma, options = CASES[name]
    chain = mfpt(model, params, v, options)
    mc = monte_carlo(model, params, v, sigma, n_walks=2000, max_steps=int(30 * chain.mfpt))
    assert 20 <= mc.mean <= 500
    assert mc.censored == 0
    assert chain.error < 0.5 * chain.mfpt
    assert abs(chain.mfpt - mc.mean) <= 3 * mc.standard_error + chain.error


def test_pooled_walks_are_each_walk_alone_whatever_lane_runs_it():
    """The Monte Carlo walks and the basin's returns run on a few lanes, each lane taking
    the next walk when its own ends (``pooled_walks``): every walk ends (steps, status,
    stop, state) exactly as ``walk_until`` alone ends it. 40 starts near the simplest
    walker's gait on random terrain, 8 lanes, step limits 5-59 (and one 0): some walks scuff, some
    come back near the gait (the stop rule), most reach their limit; rows past a
    ``valid`` prefix are not walked, also where fewer than the lanes are real."""
    model, params, v = _gait("simplest")
    n, sigma = 40, 1e-4
    keys = jax.vmap(lambda i: jax.random.fold_in(jax.random.PRNGKey(1), i))(jnp.arange(n))
    rng = np.random.default_rng(0)
    starts = jnp.asarray(v + 4e-4 * rng.standard_normal((n, len(v))))
    limits = jnp.asarray(rng.integers(5, 60, n), jnp.int32).at[1].set(0)  # a limit of 0: not a step
    each = {k: jnp.full(n, x) for k, x in params.items()}

    def drop(key, k):
        return sigma * jax.random.normal(jax.random.fold_in(key, k), dtype=starts.dtype)

    def near(v_):
        return jnp.max(jnp.abs(v_ - v)) < 1.5e-4

    alone = jax.jit(jax.vmap(lambda key, s, m: walk_until(model, params, s, m, drop=lambda k: drop(key, k), stop=near)))(
        keys, starts, limits)
    pooled = jax.jit(lambda valid: pooled_walks(model, each, starts, limits, 8, drop=lambda i, k: drop(keys[i], k),
                                                stop=lambda _, v_: near(v_), valid=valid))
    for rows in (n, 30, 3):  # all rows; a call's padding after 30; fewer real rows than lanes
        got = pooled(jnp.arange(n) < rows)
        for field in WalkEnd._fields:
            np.testing.assert_array_equal(np.asarray(getattr(got, field))[:rows], np.asarray(getattr(alone, field))[:rows])
        assert not np.asarray(got.steps)[rows:].any()
    status, stopped = np.asarray(alone.status), np.asarray(alone.stopped)
    assert (status != Status.OK).any() and stopped.any() and ((status == Status.OK) & ~stopped).any()


def test_flat_ground_never_falls():
    model, params, v = _gait("simplest")
    assert np.isinf(mfpt(model, params, v, MFPTOptions(sigma=0.0)).mfpt)
    mc = monte_carlo(model, params, v, 0.0, n_walks=8, max_steps=30)
    assert mc.censored == 8 and np.all(mc.steps == 30)


def test_terrain_too_gentle_to_fail_gives_inf_not_rounding_noise():
    """At sigma 1e-7 no sampled step of the simplest walker fails: Q is stochastic and
    I - Q singular, so the solve's t is noise (of either sign); the MFPT is inf."""
    model, params, v = _gait("simplest")
    result = mfpt(model, params, v, MFPTOptions(sigma=1e-7, mesh=9, samples=16, span=5.0))
    assert result.mfpt == np.inf and result.quasi_stationary == np.inf and result.error == 0.0


def test_mfpt_is_reproducible():
    """ARPACK starts from a fixed vector (its default is random): the same chain, the same numbers bit for bit."""
    model, params, v = _gait("simplest")
    options = MFPTOptions(sigma=1.5e-4, mesh=9, samples=16, span=5.0)
    first, second = mfpt(model, params, v, options), mfpt(model, params, v, options)
    assert tuple(first) == tuple(second)


def test_progress_counts_every_step_map_of_both_chains():
    """What a sweep's MFPT bar counts (jaxwalk.progress): every step map of the fine and
    the coarse chain, in one report per call, and reporting changes no number."""
    model, params, v = _gait("simplest")
    options = MFPTOptions(sigma=1.5e-4, mesh=9, samples=16, span=5.0)
    done = []
    reported = mfpt(model, params, v, options, progress=done.append)
    chains = plan(model, params, v, options)
    assert len(done) >= 2 and sum(done) == chains.steps
    fine, coarse = (len(mesh_states(m)) for m in (chains.fine, chains.coarse))
    assert chains.steps == fine * 16 + coarse * 8  # the coarse chain: half the samples
    assert tuple(reported) == tuple(mfpt(model, params, v, options))


@pytest.mark.parametrize("kwargs, words", [({"n_walks": 1}, "n_walks must be an integer >= 2"),
                                           ({"max_steps": 0}, "max_steps must be an integer"),
                                           ({"max_steps": 2**31}, "max_steps must be an integer")])
def test_monte_carlo_refuses_bad_counts_with_one_line(kwargs, words):
    from jaxwalk.errors import ConfigError

    model = get_model("simplest")
    with pytest.raises(ConfigError, match=words):
        monte_carlo(model, {"gamma": 0.009}, np.zeros(len(model.section_names)), 1e-4, **kwargs)


def test_a_chain_in_which_every_step_fails_has_dominant_eigenvalue_zero_not_a_crash():
    """Where every sampled step from every mesh state fails (met on the shoe
    walker's foot plane at sigma 0.005: the coarse chain of the unstable gait at
    l_f 0.2935, r 0.158, lambda_max 1.49, had no non-zero entry), the chain's
    matrix is zero: ARPACK stopped on it ("starting vector is zero"), which
    ended a 35-minute sweep. Its dominant eigenvalue is 0, its escape
    weights uniform; a non-zero matrix still gets its Perron pair."""
    import scipy.sparse

    from jaxwalk.global_stability.mfpt import _dominant_eigenvalue

    lam, pi = _dominant_eigenvalue(scipy.sparse.csr_matrix((6, 6)))
    assert lam == 0.0 and np.allclose(pi, 1.0 / 6)
    q = scipy.sparse.csr_matrix(np.array([[0.5, 0.2, 0.0], [0.1, 0.6, 0.1], [0.0, 0.3, 0.4]]))
    lam, pi = _dominant_eigenvalue(q)
    w, vl = np.linalg.eig(q.toarray().T)
    k = np.argmax(np.abs(w))
    assert abs(lam - abs(w[k])) < 1e-12 and np.allclose(pi, np.abs(vl[:, k]) / np.abs(vl[:, k]).sum(), atol=1e-10)
