"""Continuation lines start Newton on the secant through the two gaits before
(jaxwalk.continuation), falling back to the gait before where that search
fails (jaxwalk.gait.find_gait's second start)."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np

from jaxwalk import configs
from jaxwalk.continuation import after_visit, fresh_carry, parabola_start, secant_start
from jaxwalk.gait import PREDICTORS, Fallback, Gait, NewtonOptions, find_gait
from jaxwalk.lines import SEGMENT_LENGTH, _neighbour_carry, run_lines, segment_inputs
from jaxwalk.models import get_model
from jaxwalk.status import Status
from jaxwalk.step import SolverOptions

SIMPLEST = get_model("simplest")
SOLVER = SolverOptions()


def _walk(v_of_s, positions, from_seed=None, carry=None):
    """The carry after visiting ``positions`` in order (after ``carry``'s visits,
    if given), each converging to ``v_of_s(s)``."""
    carry = fresh_carry(jnp.zeros(2), jnp.asarray(False)) if carry is None else carry
    from_seed = from_seed or [False] * len(positions)
    for k, (s, seed) in enumerate(zip(positions, from_seed)):
        carry = after_visit(carry, v_of_s(s), jnp.asarray(True), jnp.asarray(s), jnp.asarray(seed), jnp.asarray(k == 0),
                            carry.v_prev, carry.have_prev, s * jnp.eye(2))  # a Jacobian that names its visit
    return carry


def test_the_secant_is_exact_on_a_straight_branch_and_waits_for_two_gaits():
    line = lambda s: jnp.array([1.0 + 2.0 * s, -3.0 * s])
    one = _walk(line, [0.1])
    assert not bool(secant_start(one, jnp.asarray(0.2), jnp.asarray(False))[1])
    two = _walk(line, [0.1, 0.25])
    v, usable, _ = secant_start(two, jnp.asarray(0.5), jnp.asarray(False))  # a step 5/3 of the last
    assert bool(usable)
    np.testing.assert_allclose(v, line(0.5), rtol=1e-14)
    # A restart from the seed starts from the seed's gait, not from the secant;
    # so does a step back against the walk or more than twice the last one.
    assert not bool(secant_start(two, jnp.asarray(0.0), jnp.asarray(True))[1])
    assert not bool(secant_start(two, jnp.asarray(0.2), jnp.asarray(False))[1])
    assert not bool(secant_start(two, jnp.asarray(0.56), jnp.asarray(False))[1])
    # The gait found may lie the prediction's move plus the last step's from it.
    np.testing.assert_allclose(secant_start(two, jnp.asarray(0.5), jnp.asarray(False))[2], (1 + 5 / 3) * 3.0 * 0.15, rtol=1e-14)


def test_the_walk_down_extrapolates_from_the_seed():
    """After the restart, the seed (0.3) and the first point down (0.2) make the secant for 0.1."""
    line = lambda s: jnp.array([s**2, 1.0 - s])
    carry = _walk(line, [0.3, 0.4, 0.5, 0.2], from_seed=[False, False, False, True])
    v, usable, _ = secant_start(carry, jnp.asarray(0.1), jnp.asarray(False))
    assert bool(usable)
    np.testing.assert_allclose(v, line(0.2) + (line(0.2) - line(0.3)), rtol=1e-14)


def test_the_parabola_is_exact_on_a_quadratic_branch_and_waits_for_three_gaits():
    """Uneven steps; not across the restart from the seed, where the walk down has
    two gaits (the seed's and its first) until its second point down."""
    branch = lambda s: jnp.array([1.0 + 2.0 * s - 4.0 * s**2, 3.0 * s**2])
    two = _walk(branch, [0.1, 0.25])
    assert bool(secant_start(two, jnp.asarray(0.4), jnp.asarray(False))[1])
    assert not bool(parabola_start(two, jnp.asarray(0.4), jnp.asarray(False))[1])
    three = _walk(branch, [0.1, 0.25, 0.3])
    v, usable = parabola_start(three, jnp.asarray(0.38), jnp.asarray(False))
    assert bool(usable)
    np.testing.assert_allclose(v, branch(0.38), rtol=1e-13)
    assert not bool(parabola_start(three, jnp.asarray(0.35), jnp.asarray(True))[1])  # a restart from the seed
    assert not bool(parabola_start(three, jnp.asarray(0.2), jnp.asarray(False))[1])  # back against the walk
    down = _walk(branch, [0.3, 0.4, 0.5, 0.2], from_seed=[False, False, False, True])
    assert bool(secant_start(down, jnp.asarray(0.1), jnp.asarray(False))[1])
    assert not bool(parabola_start(down, jnp.asarray(0.1), jnp.asarray(False))[1])
    down = _walk(branch, [0.3, 0.4, 0.5, 0.2, 0.1], from_seed=[False, False, False, True, False])
    v, usable = parabola_start(down, jnp.asarray(0.0), jnp.asarray(False))
    assert bool(usable)
    np.testing.assert_allclose(v, branch(0.0), rtol=1e-13, atol=1e-14)
    # After a failed visit the parabola waits for three more gaits, the secant for two.
    failed = after_visit(three, jnp.full(2, jnp.nan), jnp.asarray(False), jnp.asarray(0.4), jnp.asarray(False),
                         jnp.asarray(False), three.v_prev, three.have_prev, jnp.full((2, 2), jnp.nan))
    again = _walk(branch, [0.5, 0.6], carry=failed)
    assert bool(secant_start(again, jnp.asarray(0.7), jnp.asarray(False))[1])
    assert not bool(parabola_start(again, jnp.asarray(0.7), jnp.asarray(False))[1])
    again = _walk(branch, [0.7], carry=again)
    v, usable = parabola_start(again, jnp.asarray(0.8), jnp.asarray(False))
    assert bool(usable)
    np.testing.assert_allclose(v, branch(0.8), rtol=1e-13)
    # A last step far longer than the one before would weigh the gaits by about
    # the square of the ratio: more than MAX_STEP_RATIO (2) and the secant starts.
    uneven = _walk(branch, [0.1, 0.1001, 0.3])
    assert bool(secant_start(uneven, jnp.asarray(0.35), jnp.asarray(False))[1])
    assert not bool(parabola_start(uneven, jnp.asarray(0.35), jnp.asarray(False))[1])
    assert bool(parabola_start(_walk(branch, [0.1, 0.2, 0.39]), jnp.asarray(0.45), jnp.asarray(False))[1])


def test_a_failed_visit_breaks_the_secant():
    line = lambda s: jnp.array([s, s])
    carry = _walk(line, [0.1, 0.2])
    np.testing.assert_array_equal(carry.jac_prev, 0.2 * np.eye(2))  # the chord's matrix: the last gait's Jacobian
    np.testing.assert_array_equal(carry.jac_seed, 0.1 * np.eye(2))
    failed = after_visit(carry, jnp.full(2, jnp.nan), jnp.asarray(False), jnp.asarray(0.3), jnp.asarray(False),
                         jnp.asarray(False), carry.v_prev, carry.have_prev, jnp.full((2, 2), jnp.nan))
    assert not bool(secant_start(failed, jnp.asarray(0.4), jnp.asarray(False))[1])
    np.testing.assert_array_equal(failed.v_prev, line(0.2))  # the next start: the last gait found
    # ... but not its Jacobian: the next search starts with full Newton.
    assert np.isnan(failed.jac_prev).all() and not np.isnan(failed.jac_seed).any()


def test_a_search_that_fails_stalls_or_jumps_starts_again_from_its_fallback():
    """From a start far off the gait the search fails; with the guess as the
    fallback the same call finds the gait the guess finds and counts both
    searches' iterations. A first search cut off after one iteration (stalled)
    or whose gait lies beyond ``max_jump`` from its start (jumped) falls back
    too; one that converges within both limits keeps its own result; where
    both searches fail the second's failure is reported."""
    p = {"gamma": jnp.asarray(0.009)}
    guess = SIMPLEST.initial_guess(p)
    bad = guess.at[0].add(0.5).at[1].add(-0.5)
    search = jax.jit(lambda v0, fb: find_gait(SIMPLEST, p, v0, SOLVER, NewtonOptions(), fb))
    fallback = lambda v, use, **kw: Fallback(v, jnp.asarray(use), jnp.asarray(kw.get("max_iter", 99)),
                                               jnp.asarray(kw.get("max_jump", jnp.inf)))
    direct, alone = search(guess, fallback(guess, False)), search(bad, fallback(guess, False))
    assert int(alone.status) != Status.OK and int(direct.status) == Status.OK
    rescued = search(bad, fallback(guess, True))
    np.testing.assert_array_equal(rescued.v, direct.v)
    assert int(rescued.iterations) == int(direct.iterations) + int(alone.iterations)
    kept = search(guess, fallback(bad, True, max_iter=20, max_jump=1.0))
    np.testing.assert_array_equal(kept.v, direct.v)
    assert int(kept.iterations) == int(direct.iterations)
    stalled = search(guess, fallback(guess, True, max_iter=1))
    assert int(stalled.status) == Status.OK and int(stalled.iterations) == int(direct.iterations) + 1
    jumped = search(guess, fallback(guess, True, max_jump=0.0))
    assert int(jumped.status) == Status.OK and int(jumped.iterations) == 2 * int(direct.iterations)
    both = search(bad, fallback(bad, True))
    assert int(both.status) == int(alone.status) and int(both.iterations) == 2 * int(alone.iterations)
    for name in ("events", "failure_phase", "failure_guard", "failure_limit"):
        assert int(getattr(both.stats, name)) == int(getattr(alone.stats, name)), name
    assert int(both.stats.failure_phase) >= 0


def test_the_secant_saves_iterations_and_finds_the_same_gaits():
    """The simplest walker along its slopes (Garcia's range) on a grid whose
    spacing grows by 4 % a point: every gait found by both predictors, the same to
    Newton's tolerance, and where the secant applies (from the third visit of
    each direction on) in at most 3 iterations, fewer than from the
    neighbour's gait alone."""
    steps = 1.04 ** np.arange(26)
    gamma = 0.002 + 0.013 * np.concatenate([[0.0], np.cumsum(steps)]) / steps.sum()
    seed = 6
    out = {}
    for predictor in PREDICTORS:
        out[predictor] = run_lines(SIMPLEST, {"gamma": gamma[None]}, gamma, seed, SOLVER, NewtonOptions(predictor=predictor), 256)
    prev, sec = out["previous"], out["secant"]
    assert (np.asarray(prev.status) == Status.OK).all() and (np.asarray(sec.status) == Status.OK).all()
    np.testing.assert_allclose(sec.v, prev.v, atol=1e-8)
    # The walk up visits seed + 2.. with a secant; the walk down seed - 2.. (the seed is its first point).
    secant_visits = np.r_[0 : seed - 1, seed + 2 : gamma.size]
    it_sec, it_prev = np.asarray(sec.iterations)[0, secant_visits], np.asarray(prev.iterations)[0, secant_visits]
    assert it_sec.max() <= 3 and it_sec.mean() < it_prev.mean() - 0.8, (it_sec, it_prev)


def test_segments_carry_each_visit_s_parameter_value():
    """A line longer than a segment: every segment's positions are the
    parameter's values in visiting order (seed, up, then down)."""
    values = np.linspace(0.0, 1.0, SEGMENT_LENGTH + 9)
    segments, order = segment_inputs(SIMPLEST, {"gamma": values[None]}, values, 5)
    position = np.concatenate([np.asarray(rows.inputs.position)[0] for rows in segments])[: values.size]
    np.testing.assert_array_equal(position, values[order])
    np.testing.assert_array_equal(order[:3], [5, 6, 7])


def test_the_fill_starts_from_the_secant_through_its_neighbours():
    """``_neighbour_carry``: from the left the neighbour is point - 1 and the
    secant's second point point - 2 (the parabola's third point - 3), from the
    right point + 1 and point + 2 (point + 3);
    at a line's end, or where the point beyond failed, there is no secant; the
    search's chord iterations use the neighbour's Jacobian."""
    status = np.full((1, 6), Status.OK, np.int8)
    status[0, 4] = Status.FELL
    v = np.arange(12.0).reshape(1, 6, 2)
    jac = np.arange(24.0).reshape(1, 6, 2, 2)
    gaits = Gait(v, jac, *([None] * 5), status, *([None] * 5))
    s = np.array([0.0, 0.1, 0.3, 0.6, 1.0, 1.5])
    point, side = np.array([2, 1, 2, 3, 1, 4]), np.array([-1, -1, 1, -1, 1, 1])
    carry = _neighbour_carry(gaits, s, np.zeros(6, int), point, side)
    np.testing.assert_array_equal(carry.v_prev, v[0, point + side])
    np.testing.assert_array_equal(carry.s_prev, s[point + side])
    # Off the line's start (1 from the left) or end (4 from the right); beyond a failed point (2 from the right).
    np.testing.assert_array_equal(carry.have_prev2, [True, False, False, True, True, False])
    np.testing.assert_array_equal(carry.s_prev2[[0, 3, 4]], s[[0, 1, 3]])
    np.testing.assert_array_equal(carry.v_prev2[[0, 3, 4]], v[0, [0, 1, 3]])
    np.testing.assert_array_equal(carry.jac_prev, jac[0, point + side])  # the chord's matrix: the neighbour's Jacobian
    # The parabola's third point: point - 3 from the left (only 3 has it), point + 3 from the right (1 has 4, failed).
    np.testing.assert_array_equal(carry.have_prev3, [False, False, False, True, False, False])
    np.testing.assert_array_equal(carry.v_prev3[3], v[0, 0])
    assert carry.s_prev3[3] == s[0]


def test_the_config_and_the_options_offer_the_same_predictors():
    assert configs.PREDICTORS == PREDICTORS
    assert NewtonOptions().predictor == "secant"
