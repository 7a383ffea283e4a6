"""Chord iterations from a neighbour's Jacobian (``find_gait``'s ``jacobian_guess``,
the flat-foot walker's continuation lines): primal steps updated with the guess
while they contract, full Newton after, a probe with tangents once a chord
update is small, and the tangents always at the reported point."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxwalk.gait import CHORD_EXPECTED_THETA, CHORD_MAX_THETA, NewtonOptions, _Newton, _newton_iteration, find_gait
from jaxwalk.lines import chord_steps
from jaxwalk.models import get_model
from jaxwalk.status import Status
from jaxwalk.step import SolverOptions
from tests.step_stand_in import StepStandIn

#: A linear step map f(v) = M v + c: its fixed point and Jacobian are known exactly.
M = jnp.asarray([[0.8, 0.1], [-0.2, 0.3]])
C = jnp.asarray([0.005, -0.002])  # a fixed point 0.02 from the start: no update is cut to max_update
FIXED_POINT = np.linalg.solve(np.eye(2) - np.asarray(M), np.asarray(C))


def _search(guess, falls_beyond: float = np.inf, start=(0.0, 0.0), falls_below=-np.inf) -> list[tuple[bool, _Newton]]:
    """Run the loop's body by hand from ``start`` with ``guess`` as the chord's
    Jacobian: ``[(a chord step, carry after), ...]`` until the search ends (an
    evaluation with tangents, a probe's too, is not a chord step). The step
    fails (``FELL``) from any ``v`` with a component beyond ``falls_beyond``,
    or with its first below ``falls_below``."""
    start = jnp.asarray(start)
    zero, i0, nan = jnp.zeros(()), jnp.zeros((), jnp.int32), jnp.full((), jnp.nan)

    def residual(v):
        fell = (jnp.max(jnp.abs(v)) > falls_beyond) | (v[0] < falls_below)
        status = jnp.where(fell, jnp.int8(Status.FELL), jnp.int8(Status.OK))
        return M @ v + C - v, StepStandIn(status, zero, zero, zero, i0, i0, i0, i0, jnp.zeros(2), jnp.zeros(1))

    body = jax.jit(_newton_iteration(residual, NewtonOptions(), jnp.eye(2), lambda v: v, jnp.asarray(guess), start))
    carry = _Newton(start, i0, jnp.int8(Status.IN_PROGRESS), jnp.asarray(False), jnp.full((2, 2), nan), nan, nan,
                    nan, i0, i0, i0 - 1, i0 - 1, jnp.zeros(2), jnp.zeros(1), jnp.asarray(False), i0, jnp.full((), jnp.inf),
                    jnp.asarray(True), jnp.asarray(True))
    trail = []
    while int(carry.status) == Status.IN_PROGRESS and len(trail) < 30:
        probe = float(carry.last_update) * CHORD_EXPECTED_THETA < NewtonOptions().tol
        chord_step = bool(carry.chord) and not bool(carry.converged) and not probe
        carry = body(carry)
        trail.append((chord_step, carry))
    return trail


def test_a_close_guess_takes_chord_steps_to_the_fixed_point_and_reports_its_own_jacobian():
    trail = _search(M + 1e-3 * jnp.asarray([[1.0, -1.0], [0.5, 2.0]]))  # a chord contracting by about 0.005
    chord = [c for c, _ in trail]
    end = trail[-1][1]
    assert int(end.status) == Status.OK
    assert all(chord[:-1]) and not chord[-1], chord  # chord steps only, then one evaluation with tangents
    assert len(trail) >= 3  # a chord converges linearly: at least two updates before the fixed point's evaluation
    # No tangents were evaluated before the last step: the reported Jacobian stayed unknown until it.
    assert all(np.isnan(np.asarray(c.jac)).all() for _, c in trail[:-1])
    # Within what the rate test estimates: a linear contraction leaves about tol (Newton's leaves ~0 here).
    np.testing.assert_allclose(end.v, FIXED_POINT, rtol=0, atol=2 * NewtonOptions().tol)
    np.testing.assert_allclose(end.jac, M, rtol=0, atol=1e-15)  # the gait's own Jacobian, not the guess


def test_a_guess_that_does_not_contract_hands_over_to_newton():
    """Guess 0: the chord step is the plain iteration ``v <- f(v)``, contracting by
    M's spectral radius (0.76), more than :data:`CHORD_MAX_THETA`: after the second
    chord update measures it, full Newton goes on from there."""
    assert max(abs(np.linalg.eigvals(np.asarray(M)))) > CHORD_MAX_THETA
    trail = _search(jnp.zeros((2, 2)))
    chord = [c for c, _ in trail]
    assert chord[:2] == [True, True] and not any(chord[2:]), chord
    assert not bool(trail[1][1].chord)
    end = trail[-1][1]
    assert int(end.status) == Status.OK
    np.testing.assert_allclose(end.v, FIXED_POINT, rtol=0, atol=1e-10)


def test_a_chord_step_that_fails_or_diverges_starts_the_search_again_with_newton():
    """A guess whose chord diverges (``0.6 I + 0.4 M``: each chord step multiplies the
    error by -1.5) walks toward where the step fails; the failed chord step is not the search's end: it
    starts again from its start with full Newton, which finds the fixed point,
    and the chord's iterations count in ``spent``. The same with the step never
    failing: the diverging chord (``theta >= 1``) also hands over."""
    for falls_beyond in (0.03, np.inf):
        trail = _search(0.6 * jnp.eye(2) + 0.4 * M, falls_beyond)
        chord = [c for c, _ in trail]
        end = trail[-1][1]
        assert chord[0] and not any(chord[3:]), chord
        restart = next(i for i, (_, c) in enumerate(trail) if int(c.spent) > 0)
        np.testing.assert_array_equal(trail[restart][1].v, [0.0, 0.0])  # back at its start
        assert int(end.status) == Status.OK, falls_beyond
        np.testing.assert_allclose(end.v, FIXED_POINT, rtol=0, atol=1e-10)


def test_a_small_chord_update_is_followed_by_a_probe_that_ends_the_search_where_it_is():
    """From 5e-7 of the fixed point with a guess contracting by about 0.005: one
    chord update of about 5e-7, then a probe (the tangents) whose Newton update
    (about 2.5e-9) is below tol: the search ends at the chord's iterate, within
    tol of the fixed point, with the map's own Jacobian; two evaluations where
    chord steps and the rate test take three."""
    start = FIXED_POINT + np.asarray([5e-7, -3e-7])
    trail = _search(M + 1e-3 * jnp.asarray([[1.0, -1.0], [0.5, 2.0]]), start=start)
    assert [c for c, _ in trail] == [True, False]
    first, end = trail[0][1], trail[1][1]
    assert float(first.last_update) * CHORD_EXPECTED_THETA < NewtonOptions().tol < float(first.last_update)
    assert int(end.status) == Status.OK and int(end.k) == 2
    np.testing.assert_array_equal(end.v, first.v)  # ended where the probe was, not one update further
    assert 1e-10 < np.abs(np.asarray(end.v) - FIXED_POINT).max() < NewtonOptions().tol
    np.testing.assert_allclose(end.jac, M, rtol=0, atol=1e-15)


@pytest.mark.parametrize("factor", [-0.25, 0.6])
def test_a_probe_whose_update_is_not_small_goes_on_with_newton(factor):
    """A guess whose chord step multiplies the error by ``factor`` (an overshoot
    shrinking it 4x; a slow chord keeping 60 % of it), from 5e-7 of the fixed
    point: the first chord update (1.25 and 0.4 times 5e-7) is small enough for
    a probe, which finds an update above tol and takes it (Newton's own, even
    where it is larger than the chord's), and the next evaluation with
    tangents, whose update is rounding, ends the search there: one chord step
    and two with tangents, no start again."""
    guess = jnp.eye(2) + (M - jnp.eye(2)) / (1 - factor)  # chord error (G - I)^-1 (G - M) e = factor e
    start = FIXED_POINT + np.asarray([5e-7, -3e-7])
    trail = _search(guess, start=start)
    assert [c for c, _ in trail] == [True, False, False]
    probe, end = trail[1][1], trail[2][1]
    assert int(probe.status) == Status.IN_PROGRESS and float(probe.last_update) > NewtonOptions().tol
    assert int(end.status) == Status.OK and int(end.spent) == 0
    np.testing.assert_allclose(end.v, FIXED_POINT, rtol=0, atol=1e-15)  # a linear map: Newton's update is exact
    np.testing.assert_allclose(end.jac, M, rtol=0, atol=1e-15)


def test_a_probe_whose_step_fails_starts_the_search_again_with_newton():
    """The chord's iterate lies where the step fails (its first component 1.25e-7
    below the fixed point's): the probe fails, the search starts again from its
    start with full Newton, and, begun again, ends as Newton's does: one update
    past its last evaluation's, evaluated there (the fixed point itself here)."""
    start = FIXED_POINT + np.asarray([5e-7, -3e-7])
    guess = jnp.eye(2) + (M - jnp.eye(2)) / 1.25  # the chord overshoots: error factor -0.25
    trail = _search(guess, start=start, falls_below=FIXED_POINT[0] - 1e-8)
    assert [c for c, _ in trail][:2] == [True, False] and not any(c for c, _ in trail[1:])
    restart = trail[1][1]
    np.testing.assert_array_equal(restart.v, start)
    assert int(restart.spent) == 2 and int(restart.k) == 0 and not bool(restart.chorded)
    end = trail[-1][1]
    assert int(end.status) == Status.OK and len(trail) == 5  # two Newton updates, then the evaluation at the end
    np.testing.assert_allclose(end.v, FIXED_POINT, rtol=0, atol=1e-15)


def test_the_compass_gait_from_its_neighbours_jacobian_is_the_gait_newton_finds():
    """On the compass walker, from the gait at a slope 0.002 lower: with that gait's
    Jacobian the search finds the gait full Newton finds, to ``tol`` (it may end
    at a probe within ``tol`` of the gait, where Newton goes one update
    further), with its own Jacobian; a NaN guess is full Newton, the same gait."""
    model = get_model("compass")
    params = model.default_params()
    lower = {**params, "gamma": params["gamma"] - 0.002}
    neighbour = find_gait(model, lower, model.initial_guess(lower))
    assert int(neighbour.status) == Status.OK
    full = find_gait(model, params, neighbour.v)
    chord = find_gait(model, params, neighbour.v, jacobian_guess=neighbour.jacobian)
    unknown = find_gait(model, params, neighbour.v, jacobian_guess=jnp.full_like(neighbour.jacobian, jnp.nan))
    for gait, bound in ((chord, NewtonOptions().tol), (unknown, 1e-12)):
        assert int(gait.status) == Status.OK
        np.testing.assert_allclose(gait.v, full.v, rtol=0, atol=bound)
        np.testing.assert_allclose(gait.jacobian, full.jacobian, rtol=0, atol=1e-6)
        assert abs(float(gait.lambda_max) - float(full.lambda_max)) < 1e-6  # the shoe map: 5.6e-7
    assert not np.allclose(neighbour.jacobian, full.jacobian, rtol=0, atol=1e-6)  # the guess is not the answer


def test_which_walkers_lines_take_chord_steps():
    """The flat-foot walker's lines run one at a time: chord steps. The heel-rise
    variant's section moves iterates into it: full Newton. The batched walkers
    (and any walker on the flat engine, 64 lanes a sub-batch): full Newton."""
    nested, flat = SolverOptions(), SolverOptions(engine="flat")
    assert chord_steps(get_model("flatfoot"), nested)
    assert not chord_steps(get_model("flatfoot_heel_rise"), nested)
    assert not chord_steps(get_model("flatfoot"), flat)
    for name in ("simplest", "compass", "kneed"):
        assert not chord_steps(get_model(name), nested), name
