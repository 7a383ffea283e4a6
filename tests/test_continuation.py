"""Continuation lines start Newton on the secant through the two gaits before
(jaxwalk.continuation), falling back to the gait before where that search
fails (jaxwalk.gait.find_gait's second start)."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np

from jaxwalk import configs
from jaxwalk.continuation import after_visit, fresh_carry, secant_start
from jaxwalk.gait import PREDICTORS, NewtonOptions, find_gait
from jaxwalk.lines import run_lines
from jaxwalk.models import get_model
from jaxwalk.status import Status
from jaxwalk.step import SolverOptions

SIMPLEST = get_model("simplest")
SOLVER = SolverOptions()


def _walk(v_of_s, positions, from_seed=None):
    """The carry after visiting ``positions`` in order, each converging to ``v_of_s(s)``."""
    carry = fresh_carry(jnp.zeros(2), jnp.asarray(False))
    from_seed = from_seed or [False] * len(positions)
    for k, (s, seed) in enumerate(zip(positions, from_seed)):
        carry = after_visit(carry, v_of_s(s), jnp.asarray(True), jnp.asarray(s), jnp.asarray(seed), jnp.asarray(k == 0),
                            carry.v_prev, carry.have_prev)
    return carry


def test_the_secant_is_exact_on_a_straight_branch_and_waits_for_two_gaits():
    line = lambda s: jnp.array([1.0 + 2.0 * s, -3.0 * s])
    one = _walk(line, [0.1])
    assert not bool(secant_start(one, jnp.asarray(0.2), jnp.asarray(False))[1])
    two = _walk(line, [0.1, 0.25])
    v, usable = secant_start(two, jnp.asarray(0.4), jnp.asarray(False))
    assert bool(usable)
    np.testing.assert_allclose(v, line(0.4), rtol=1e-14)
    # A restart from the seed starts from the seed's gait, not from the secant.
    assert not bool(secant_start(two, jnp.asarray(0.0), jnp.asarray(True))[1])


def test_the_walk_down_extrapolates_from_the_seed():
    """After the restart, the seed (0.3) and the first point down (0.2) make the secant for 0.1."""
    line = lambda s: jnp.array([s**2, 1.0 - s])
    carry = _walk(line, [0.3, 0.4, 0.5, 0.2], from_seed=[False, False, False, True])
    v, usable = secant_start(carry, jnp.asarray(0.1), jnp.asarray(False))
    assert bool(usable)
    np.testing.assert_allclose(v, line(0.2) + (line(0.2) - line(0.3)), rtol=1e-14)


def test_a_failed_visit_breaks_the_secant():
    line = lambda s: jnp.array([s, s])
    carry = _walk(line, [0.1, 0.2])
    failed = after_visit(carry, jnp.full(2, jnp.nan), jnp.asarray(False), jnp.asarray(0.3), jnp.asarray(False),
                         jnp.asarray(False), carry.v_prev, carry.have_prev)
    assert not bool(secant_start(failed, jnp.asarray(0.4), jnp.asarray(False))[1])
    np.testing.assert_array_equal(failed.v_prev, line(0.2))  # the next start: the last gait found


def test_a_failed_search_starts_again_from_its_fallback():
    """A start far off the gait fails; with the guess as fallback the same call
    finds the gait the guess finds, and counts the iterations of both searches."""
    p = {"gamma": jnp.asarray(0.009)}
    guess = SIMPLEST.initial_guess(p)
    bad = guess.at[0].add(0.5).at[1].add(-0.5)
    search = jax.jit(lambda v0, use: find_gait(SIMPLEST, p, v0, SOLVER, NewtonOptions(), v_fallback=guess, use_fallback=use))
    alone, rescued, direct = search(bad, False), search(bad, True), search(guess, False)
    assert int(alone.status) != Status.OK
    assert int(rescued.status) == Status.OK and int(direct.status) == Status.OK
    np.testing.assert_array_equal(rescued.v, direct.v)
    assert int(rescued.iterations) == int(direct.iterations) + int(alone.iterations)


def test_the_secant_saves_iterations_and_finds_the_same_gaits():
    """The simplest walker along its slopes (Garcia's range): every gait found
    by both predictors, the same to Newton's tolerance, in fewer iterations."""
    gamma = np.linspace(0.002, 0.015, 27)
    out = {}
    for predictor in PREDICTORS:
        out[predictor] = run_lines(SIMPLEST, {"gamma": gamma[None]}, gamma, 4, SOLVER, NewtonOptions(predictor=predictor), 256)
    prev, sec = out["previous"], out["secant"]
    assert (np.asarray(prev.status) == Status.OK).all() and (np.asarray(sec.status) == Status.OK).all()
    np.testing.assert_allclose(sec.v, prev.v, atol=1e-8)
    assert int(np.sum(sec.iterations)) < 0.8 * int(np.sum(prev.iterations))


def test_the_config_and_the_options_offer_the_same_predictors():
    assert configs.PREDICTORS == PREDICTORS
    assert NewtonOptions().predictor == "secant"
