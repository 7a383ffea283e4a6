"""A change of the gaits' event sequence is located as a border collision, and a
stability test function that changes sign by a jump there is not called a fold
(jaxwalk.bifurcation.locate with ``sequences``; jaxwalk.border_collision).

A synthetic re-solve stands in for Newton: on the line ``gamma`` the gait's
step takes sequence ``A`` below ``C`` and ``B`` from ``C`` on; its real
multiplier is 0.5 below ``C`` and jumps to ``0.5 + SLOPE (gamma - C) + JUMP``
above, so with ``JUMP`` past 0.5 the fold test changes sign at ``C`` by a jump,
and with a smaller jump it crosses +1 continuously at ``D`` beyond ``C``.
"""

from __future__ import annotations

import numpy as np
import pytest

from jaxwalk import bifurcation
from jaxwalk.bifurcation import BifurcationOptions, Kind, locate
from jaxwalk.border_collision import MAX_PASSES
from jaxwalk.models import get_model
from jaxwalk.status import Status
from tests.test_edge_location import _Bar

C, SLOPE = 0.43, 2.0
A, B = 6 * 2**52 + 0x012345, 7 * 2**52 + 0x0123E45  # two sequence codes (B: one more event)


def _fake(jump, fail_far_from=None):
    """A re-solve; ``fail_far_from``: Newton fails from a start farther than this from its target."""

    def evaluate(model, k, solver, newton, params, v0):
        x = np.asarray(params["gamma"], np.float64)
        mu = np.where(x < C, 0.5, 0.5 + jump + SLOPE * (x - C))
        status = np.full(len(x), Status.OK, np.int8)
        if fail_far_from is not None:
            status[np.abs(np.asarray(v0)[:, 0] - x) > fail_far_from] = Status.NO_CONVERGENCE
        v = np.stack([x, np.zeros_like(x)], axis=1)
        return status, v, np.stack([mu, np.full_like(mu, 0.1)], axis=1).astype(np.complex128), \
            np.where(x < C, A, B)[:, None].astype(np.int64)

    return evaluate


def _grid(x_points, jump):
    x = np.array([x_points], np.float64)
    status = np.zeros(x.shape, np.int8)
    _, v, mu, seq = _fake(jump)(None, 1, None, None, {"gamma": x[0]}, np.zeros((x.shape[1], 2)))
    return x, status, v[None], mu[None], seq[None, :, 0]


def test_a_multiplier_that_jumps_across_one_is_a_border_collision_not_a_fold(monkeypatch):
    monkeypatch.setattr(bifurcation, "_evaluate", _fake(jump=0.8))
    x, status, v, mu, seq = _grid([0.0, 1.0], 0.8)
    found = locate(get_model("simplest"), {"gamma": x}, "gamma", status, v, mu, sequences=seq,
                   options=BifurcationOptions(tol=1e-7))
    assert found.kind.tolist() == [Kind.BORDER_COLLISION] and found.status.tolist() == [Status.OK]
    assert abs(found.parameter[0] - C) <= 1e-7
    assert found.sequence.tolist() == [A] and found.sequence_beyond.tolist() == [B]
    assert found.jumps.tolist() == [1]  # the fold test's sign, by the jump
    assert found.multipliers[0, 0].real == pytest.approx(0.5) and found.multipliers_beyond[0, 0].real > 1.29


def test_without_sequences_the_same_jump_is_a_jump_not_a_fold(monkeypatch):
    """Without the sequences the regula falsi closes on the jump, and the
    located point has no multiplier near +1: a ``jump`` row, not a fold."""
    monkeypatch.setattr(bifurcation, "_evaluate", _fake(jump=0.8))
    x, status, v, mu, _ = _grid([0.0, 1.0], 0.8)
    found = locate(get_model("simplest"), {"gamma": x}, "gamma", status, v, mu, options=BifurcationOptions(tol=1e-7))
    assert found.kind.tolist() == [Kind.JUMP] and abs(found.parameter[0] - C) < 1e-6
    assert abs(found.multipliers[0, 0] - 1.0) > 0.2  # no multiplier near +1 there


@pytest.mark.parametrize("jump, kinds", [(-2.7, [Kind.JUMP]), (0.8, [Kind.JUMP]), (0.2, [Kind.FOLD])],
                         ids=["through_minus_one", "through_plus_one", "continuous"])
def test_a_jump_with_the_same_event_order_names_no_bifurcation(monkeypatch, jump, kinds):
    """The multipliers jump at ``C`` with one event sequence on both sides (a
    step map not smooth without an order change): past -1 the flip test, past
    +1 the fold test changes sign there, and neither is named; a jump that
    stays inside the circle and a continuous crossing of +1 after it is a fold."""
    def same(*args):
        status, v, mu, seq = _fake(jump)(*args)
        return status, v, mu, np.full_like(seq, A)

    monkeypatch.setattr(bifurcation, "_evaluate", same)
    x, status, v, mu, _ = _grid([0.0, 1.0], jump)
    seq = np.full(x.shape, A, np.int64)
    found = locate(get_model("simplest"), {"gamma": x}, "gamma", status, v, mu, sequences=seq,
                   options=BifurcationOptions(tol=1e-8))
    assert found.kind.tolist() == kinds
    if kinds == [Kind.JUMP]:
        assert abs(found.parameter[0] - C) <= 1e-8 and found.status.tolist() == [Status.OK]
    else:
        assert abs(found.parameter[0] - (C + (0.5 - jump) / SLOPE)) <= 1e-8


def test_a_continuous_crossing_beyond_the_collision_is_located_on_its_own_side(monkeypatch):
    jump = 0.2  # from 0.7 at C, through +1 at D
    d = C + (0.5 - jump) / SLOPE
    monkeypatch.setattr(bifurcation, "_evaluate", _fake(jump))
    x, status, v, mu, seq = _grid([0.0, 1.0], jump)
    found = locate(get_model("simplest"), {"gamma": x}, "gamma", status, v, mu, sequences=seq,
                   options=BifurcationOptions(tol=1e-8))
    assert found.kind.tolist() == [Kind.BORDER_COLLISION, Kind.FOLD]
    assert abs(found.parameter[0] - C) <= 1e-8 and found.jumps[0] == 0
    assert abs(found.parameter[1] - d) <= 1e-8 and found.sequence[1] == B
    assert abs(found.multipliers[1, 0] - 1.0) < 1e-6


def test_a_failed_midpoint_solve_is_retried_from_the_ends_gaits(monkeypatch):
    """Newton fails from the interpolated start (farther than 0.6 from the
    midpoint, as when the bracket's ends are far apart) and succeeds from the
    lower end's gait: the collision is still located, nothing reported lost."""
    monkeypatch.setattr(bifurcation, "_evaluate", _fake(jump=0.8, fail_far_from=0.6))
    x = np.array([[0.0, 1.0]])
    v = np.array([[[0.0, 0.0], [5.0, 0.0]]])  # the upper gait's point far from the line's (a stand-in)
    mu = np.array([[[0.5, 0.1], [1.3, 0.1]]], np.complex128)
    found = locate(get_model("simplest"), {"gamma": x}, "gamma", np.zeros((1, 2), np.int8), v, mu,
                   sequences=np.array([[A, B]]), options=BifurcationOptions(tol=1e-6))
    assert found.kind.tolist() == [Kind.BORDER_COLLISION] and found.status.tolist() == [Status.OK]
    assert abs(found.parameter[0] - C) <= 1e-6


def test_the_same_sequence_everywhere_changes_nothing(monkeypatch):
    """With one sequence on the line the table is the one located without sequences."""
    def same(model, k, solver, newton, params, v0):
        x = np.asarray(params["gamma"], np.float64)
        mu = 0.5 + x  # through +1 at 0.5
        return (np.zeros(len(x), np.int8), np.stack([x, x], 1), np.stack([mu, 0.1 + 0 * x], 1).astype(np.complex128),
                np.full((len(x), 1), A, np.int64))

    monkeypatch.setattr(bifurcation, "_evaluate", same)
    x = np.array([[0.0, 0.4, 0.8]])
    _, v, mu, seq = same(None, 1, None, None, {"gamma": x[0]}, None)
    args = (get_model("simplest"), {"gamma": x}, "gamma", np.zeros((1, 3), np.int8), v[None], mu[None])
    with_seq = locate(*args, sequences=seq[None, :, 0])
    without = locate(*args)
    assert with_seq.kind.tolist() == without.kind.tolist() == [Kind.FOLD]
    assert with_seq.parameter[0] == without.parameter[0] and abs(with_seq.parameter[0] - 0.5) <= 1e-6


def test_between_the_last_grid_gait_and_a_lost_gaits_edge_both_are_located(monkeypatch):
    """The gait is lost at ``EDGE`` (a step fails beyond); between the last grid
    point that has it and the edge its sequence changes at ``C`` and, beyond
    that, a multiplier passes through -1: the edge, the collision and
    the flip are all located, though no two grid points bracket the last two."""
    edge, flip = 0.6, C + 0.1

    def evaluate(model, k, solver, newton, params, v0):
        x = np.asarray(params["gamma"], np.float64)
        mu = np.where(x < C, 0.5, -0.8 - 2.0 * (x - C))  # through -1 at C + 0.1
        status = np.where(x < edge, Status.OK, Status.SCUFFING).astype(np.int8)
        v = np.stack([x, np.zeros_like(x)], axis=1)
        return status, v, np.stack([mu, np.full_like(mu, 0.1)], 1).astype(np.complex128), np.where(x < C, A, B)[:, None]

    monkeypatch.setattr(bifurcation, "_evaluate", evaluate)
    x = np.array([[0.0, 0.4, 0.8]])
    status = np.array([[Status.OK, Status.OK, Status.SCUFFING]], np.int8)
    _, v, mu, seq = evaluate(None, 1, None, None, {"gamma": x[0]}, None)
    bar = _Bar()
    found = locate(get_model("simplest"), {"gamma": x}, "gamma", status, v[None], mu[None], sequences=seq[None, :, 0],
                   options=BifurcationOptions(tol=1e-7), progress=bar)
    assert found.kind.tolist() == [Kind.BORDER_COLLISION, Kind.FLIP, Kind.GRAZING]
    assert np.allclose(found.parameter, [C, flip, edge], rtol=0, atol=1e-7)
    assert found.jumps[0] == 0  # the flip test keeps its sign across the collision (0.5 -> -0.8)
    assert found.sequence.tolist() == [A, B, B] and found.beyond[2] == Status.SCUFFING
    assert bar.n == bar.total


def _edge_fake(status_at, seq_at, mu_at, reach=None):
    """A re-solve from rules of ``x``: status, sequence code, first multiplier
    (``reach``: Newton fails from a start farther than this from its target)."""

    def evaluate(model, k, solver, newton, params, v0):
        x = np.asarray(params["gamma"], np.float64)
        status = status_at(x).astype(np.int8)
        if reach is not None and v0 is not None:
            status[(status == Status.OK) & (np.abs(np.asarray(v0)[:, 0] - x) > reach)] = Status.NO_CONVERGENCE
        mu = np.stack([mu_at(x), np.full_like(x, 0.1)], 1).astype(np.complex128)
        return status, np.stack([x, np.zeros_like(x)], 1), mu, seq_at(x).astype(np.int64)[:, None]

    return evaluate


def _run(monkeypatch, evaluate, x, status=None, sequences=True, tol=1e-7):
    monkeypatch.setattr(bifurcation, "_evaluate", evaluate)
    x = np.asarray(x, np.float64)[None]
    st, v, mu, seq = evaluate(None, 1, None, None, {"gamma": x[0]}, None)
    status = st[None] if status is None else np.asarray(status, np.int8)[None]
    bar = _Bar()
    found = locate(get_model("simplest"), {"gamma": x}, "gamma", status, v[None], mu[None],
                   sequences=seq[None, :, 0] if sequences else None, options=BifurcationOptions(tol=tol), progress=bar)
    assert bar.n == bar.total
    return found


def test_withheld_sequences_find_no_collision_even_where_the_solver_logs_them(monkeypatch):
    evaluate = _edge_fake(lambda x: np.where(x < 0.6, Status.OK, Status.SCUFFING), lambda x: np.where(x < C, A, B),
                          lambda x: np.where(x < C, 0.5, -0.8 - 2.0 * (x - C)))
    found = _run(monkeypatch, evaluate, [0.0, 0.4, 0.8], sequences=False)
    assert found.kind.tolist() == [Kind.FLIP, Kind.GRAZING] and found.sequence.tolist() == [0, 0]


def test_a_line_given_in_decreasing_order_is_located_the_same(monkeypatch):
    evaluate = _fake(jump=0.8)
    up, down = _run(monkeypatch, evaluate, [0.0, 1.0]), _run(monkeypatch, evaluate, [1.0, 0.0])
    assert up.kind.tolist() == down.kind.tolist() == [Kind.BORDER_COLLISION]
    assert abs(down.parameter[0] - C) <= 1e-7 and down.sequence.tolist() == [A] and down.sequence_beyond.tolist() == [B]


def test_three_sequences_between_two_grid_points_give_two_collisions(monkeypatch):
    third = 9 * 2**52 + 1
    evaluate = _edge_fake(lambda x: np.full(len(x), Status.OK), lambda x: np.select([x < C, x < 0.7], [A, B], third),
                          lambda x: 0.5 + 0 * x)
    found = _run(monkeypatch, evaluate, [0.0, 1.0])
    assert found.kind.tolist() == [Kind.BORDER_COLLISION] * 2
    assert np.allclose(found.parameter, [C, 0.7], rtol=0, atol=1e-7)
    assert found.sequence.tolist() == [A, B] and found.sequence_beyond.tolist() == [B, third]


def test_a_sign_bracket_that_meets_another_sequence_inside_is_not_located(monkeypatch):
    """Both grid ends take sequence A, the fold test changes sign between them
    (a linear one: the secant's first trial is its root, 0.5), and the gaits
    just below 0.5 take B: the bracket ends not_located, not a located fold."""
    evaluate = _edge_fake(lambda x: np.full(len(x), Status.OK), lambda x: np.where((x > 0.45) & (x <= 0.5), B, A),
                          lambda x: 0.5 + x)
    found = _run(monkeypatch, evaluate, [0.0, 1.0])
    assert found.kind.tolist() == [Kind.FOLD] and found.status.tolist() == [Status.NOT_LOCATED]


def test_edges_followed_through_grid_points_report_each_point_once(monkeypatch):
    """The line marked 0.3 failed (reached from afar); followed from 0, from
    0.6 downwards and from 0.6 upwards, three edges walk through the same
    stretches. The flip at 0.7 and the gait's end at 0.8 are reported once."""
    evaluate = _edge_fake(lambda x: np.where(x < 0.8, Status.OK, Status.SCUFFING), lambda x: np.full(len(x), A),
                          lambda x: 0.5 - 15.0 * np.maximum(x - 0.6, 0.0), reach=0.35)
    found = _run(monkeypatch, evaluate, [0.0, 0.3, 0.6, 1.0], status=[Status.OK, Status.RUNNING, Status.OK, Status.SCUFFING])
    assert found.kind.tolist() == [Kind.FLIP, Kind.GRAZING]
    assert np.allclose(found.parameter, [0.7, 0.8], rtol=0, atol=1e-7)


def test_beside_a_fold_edge_the_fold_is_not_sought_again_across_a_collision(monkeypatch):
    """The gait is lost at a fold edge (0.8, a multiplier within the fold window
    of +1); its order changes at 0.5 on the way. The fold test's sign change
    beside the edge is the edge itself: one fold, the edge's."""
    evaluate = _edge_fake(lambda x: np.where(x < 0.8, Status.OK, Status.NO_CONVERGENCE), lambda x: np.where(x < 0.5, A, B),
                          lambda x: np.where(x < 0.5, 0.5, 1.0 + (x - 0.79)))
    found = _run(monkeypatch, evaluate, [0.0, 0.4, 1.0])
    assert found.kind.tolist() == [Kind.BORDER_COLLISION, Kind.FOLD]
    assert np.allclose(found.parameter, [0.5, 0.8], rtol=0, atol=1e-7)


def test_two_flips_closer_than_the_tolerance_on_either_side_of_a_grid_point_are_both_reported(monkeypatch):
    """A multiplier passes -1 and comes back within 1.2e-6 around the grid
    point 0.5 (tol 1e-6): two stability changes, both located."""
    evaluate = _edge_fake(lambda x: np.full(len(x), Status.OK), lambda x: np.full(len(x), A),
                          lambda x: -1.0 + ((x - 0.5) ** 2 - (0.6e-6) ** 2))
    found = _run(monkeypatch, evaluate, [0.0, 0.5, 1.0], tol=1e-6)
    assert found.kind.tolist() == [Kind.FLIP, Kind.FLIP] and found.status.tolist() == [Status.OK] * 2
    assert np.allclose(found.parameter, [0.5 - 0.6e-6, 0.5 + 0.6e-6], rtol=0, atol=1e-6)


def test_a_grid_point_the_line_lost_costs_one_interval_not_the_rest_of_the_line(monkeypatch):
    """One spurious failure in the middle of 21 points, no bifurcation: the
    edges followed from both sides stop at the next grid gaits (16 rounds of
    solves at tol 1e-6, where walking on to the line's end took 176)."""
    x = np.linspace(0.0, 1.0, 21)
    status = np.zeros(21, np.int8)
    status[10] = Status.RUNNING
    evaluate = _edge_fake(lambda x: np.full(len(x), Status.OK), lambda x: np.full(len(x), A), lambda x: 0.5 + 0 * x)
    monkeypatch.setattr(bifurcation, "_evaluate", evaluate)
    _, v, mu, seq = evaluate(None, 1, None, None, {"gamma": x}, None)
    bar = _Bar()
    found = locate(get_model("simplest"), {"gamma": x[None]}, "gamma", status[None], v[None], mu[None],
                   sequences=seq[None, :, 0], options=BifurcationOptions(tol=1e-6), progress=bar)
    assert len(found.kind) == 0 and bar.n == bar.total <= 20


def test_more_order_changes_in_one_interval_than_the_passes_leave_one_unlocated(monkeypatch):
    codes = lambda x: (1000 + np.floor(x * 10)).astype(np.int64) + 2**52  # a new order every 0.1
    evaluate = _edge_fake(lambda x: np.full(len(x), Status.OK), codes, lambda x: 0.5 + 0 * x)
    found = _run(monkeypatch, evaluate, [0.0, 0.999], tol=1e-7)
    located = found.kind[found.status == Status.OK]
    assert located.tolist() == [Kind.BORDER_COLLISION] * MAX_PASSES
    assert found.kind[-1] == Kind.BORDER_COLLISION and found.status[-1] == Status.NOT_LOCATED


def test_sequence_codes_that_cannot_be_compared_are_refused():
    from jaxwalk.errors import ConfigError

    x, status, v, mu, seq = _grid([0.0, 1.0], 0.8)
    with pytest.raises(ConfigError, match="integers"):
        locate(get_model("simplest"), {"gamma": x}, "gamma", status, v, mu, sequences=seq.astype(float))
    with pytest.raises(ConfigError, match="period-1"):
        locate(get_model("simplest"), {"gamma": x}, "gamma", status, v, mu, period=2, sequences=seq)


class _FailingCall:
    """A re-solve whose gaits have multipliers ``pair(x)`` (a complex pair, or one
    real multiplier beside 0.1) and whose call number ``fail_at`` fails (``STALLED``)."""

    def __init__(self, first, complex_pair, fail_at=0):
        self.first, self.complex_pair, self.fail_at, self.calls = first, complex_pair, fail_at, 0

    def __call__(self, model, k, solver, newton, params, v0):
        x = np.asarray(params["gamma"], np.float64)
        z = self.first(x)
        mu = np.stack([z, np.conj(z) if self.complex_pair else np.full_like(z, 0.1)], 1).astype(np.complex128)
        self.calls += 1
        status = np.full(len(x), Status.STALLED if self.calls == self.fail_at else Status.OK, np.int8)
        return status, np.stack([x, 0 * x], 1), mu, np.full((len(x), 1), A, np.int64)


@pytest.mark.parametrize("first, complex_pair, kind", [
    (lambda x: 0.5 + x + 0j, False, Kind.FOLD),  # the fold test through zero at 0.5
    (lambda x: (0.5 + x) * np.exp(0.3j), True, Kind.NEIMARK_SACKER),  # a pair through the unit circle at 0.5
], ids=["fold", "neimark_sacker"])
def test_a_sign_change_whose_last_solve_fails_is_kept_unlocated_with_no_multipliers(monkeypatch, first, complex_pair, kind):
    """The bracket closes but the midpoint's own solve, the run's last call, fails:
    the row stays, with that failure as its status and NaN for its point and
    multipliers (not a solver's stand-in)."""
    clean = _FailingCall(first, complex_pair)
    assert _run(monkeypatch, clean, [0.0, 1.0], tol=1e-6).kind.tolist() == [kind]
    found = _run(monkeypatch, _FailingCall(first, complex_pair, fail_at=clean.calls), [0.0, 1.0], tol=1e-6)
    assert found.kind.tolist() == [kind] and found.status.tolist() == [Status.STALLED]
    assert np.isnan(found.multipliers).all() and np.isnan(found.v).all()


def test_an_unlocated_fold_keeps_its_kind(monkeypatch):
    """A smooth crossing of +1 at 0.25 whose first regula falsi trial (there)
    fails: the bracket never closes, its row stays an unlocated fold, not a
    jump (the midpoint of an open bracket need not be near +1)."""
    def failing_first_trial(model, k, solver, newton, params, v0):
        x = np.asarray(params["gamma"], np.float64)
        mu = 0.5 + 2.0 * x
        status = np.where(np.abs(x - 0.25) < 1e-3, np.int8(Status.NO_CONVERGENCE), np.int8(Status.OK))
        return (status, np.stack([x, x], 1), np.stack([mu, 0.1 + 0 * x], 1).astype(np.complex128),
                np.full((len(x), 1), A, np.int64))

    monkeypatch.setattr(bifurcation, "_evaluate", failing_first_trial)
    x = np.array([[0.0, 1.0]])
    _, v, mu, seq = failing_first_trial(None, 1, None, None, {"gamma": x[0]}, None)
    found = locate(get_model("simplest"), {"gamma": x}, "gamma", np.zeros((1, 2), np.int8), v[None], mu[None],
                   sequences=seq[None, :, 0])
    assert found.kind.tolist() == [Kind.FOLD] and found.status.tolist() == [Status.NO_CONVERGENCE]


def test_a_complex_pair_that_jumps_across_the_circle_is_a_jump():
    """The Neimark-Sacker test changes sign by a pair jumping from modulus 0.8 to
    1.3: no pair's product is near 1 where it is located."""
    mu = 0.8 * np.exp(1j * np.array([0.7, -0.7]))
    assert bifurcation._crosses(Kind.NEIMARK_SACKER, mu / 0.8, BifurcationOptions())
    assert not bifurcation._crosses(Kind.NEIMARK_SACKER, 1.3 * mu / 0.8, BifurcationOptions())
    # Two multipliers meeting at +1 are complex on one side of the fold: still a fold.
    assert bifurcation._crosses(Kind.FOLD, np.array([1 + 5e-4j, 1 - 5e-4j]), BifurcationOptions())


def _stepped(mu_below, mu_above):
    """A re-solve (one event sequence) whose multipliers step from ``mu_below`` to
    ``mu_above`` at ``C``, constant on either side."""

    def evaluate(model, k, solver, newton, params, v0):
        x = np.asarray(params["gamma"], np.float64)
        mu = np.where((x < C)[:, None], np.asarray(mu_below, np.complex128), np.asarray(mu_above, np.complex128))
        return (np.zeros(len(x), np.int8), np.stack([x, np.zeros_like(x)], 1), mu,
                np.full((len(x), 1), A, np.int64))

    return evaluate


@pytest.mark.parametrize("below, above", [([0.97, 0.1], [1.5, 0.1]), ([1.5, 0.1], [0.97, 0.1]),
                                          ([-0.97, 0.1], [-1.5, 0.1]), ([-1.5, 0.1], [-0.97, 0.1])],
                         ids=["fold_up", "fold_down", "flip_out", "flip_in"])
def test_a_jump_with_one_side_near_the_crossing_is_still_a_jump(monkeypatch, below, above):
    """The multiplier jumps from 0.03 inside the window around the crossing to
    0.5 outside it: whichever side the bracket's midpoint falls on, the row is
    a jump (both ends are read), carrying the lower side's multipliers and the
    upper side's as ``multipliers_beyond``."""
    monkeypatch.setattr(bifurcation, "_evaluate", _stepped(below, above))
    x = np.array([[0.0, 1.0]])
    _, v, mu, seq = _stepped(below, above)(None, 1, None, None, {"gamma": x[0]}, None)
    found = locate(get_model("simplest"), {"gamma": x}, "gamma", np.zeros((1, 2), np.int8), v[None], mu[None],
                   sequences=seq[None, :, 0], options=BifurcationOptions(tol=1e-8))
    assert found.kind.tolist() == [Kind.JUMP] and found.status.tolist() == [Status.OK]
    assert abs(found.parameter[0] - C) <= 1e-8
    np.testing.assert_array_equal(found.multipliers[0], np.asarray(below, np.complex128))
    np.testing.assert_array_equal(found.multipliers_beyond[0], np.asarray(above, np.complex128))
    assert found.jumps.tolist() == [1 if below[0] > 0 else 2]


def test_one_jump_that_changes_two_tests_is_one_row_with_both_bits(monkeypatch):
    """A multiplier jumps from 0.5 to 1.5 and another from 0.2 to -1.6 at ``C``:
    the fold and the flip tests both change sign there, by one jump."""
    monkeypatch.setattr(bifurcation, "_evaluate", _stepped([0.5, 0.2], [1.5, -1.6]))
    x = np.array([[0.0, 1.0]])
    _, v, mu, seq = _stepped([0.5, 0.2], [1.5, -1.6])(None, 1, None, None, {"gamma": x[0]}, None)
    found = locate(get_model("simplest"), {"gamma": x}, "gamma", np.zeros((1, 2), np.int8), v[None], mu[None],
                   sequences=seq[None, :, 0], options=BifurcationOptions(tol=1e-8))
    assert found.kind.tolist() == [Kind.JUMP] and found.jumps.tolist() == [3]


def test_a_continuous_crossing_has_no_jump_columns(monkeypatch):
    """A smooth fold row keeps NaN ``multipliers_beyond`` and ``jumps`` 0."""
    monkeypatch.setattr(bifurcation, "_evaluate", _fake(jump=0.2))
    x, status, v, mu, seq = _grid([0.0, 1.0], 0.2)
    found = locate(get_model("simplest"), {"gamma": x}, "gamma", status, v, mu,
                   options=BifurcationOptions(tol=1e-8))
    fold = found.kind == Kind.FOLD
    assert fold.sum() == 1 and found.jumps[fold][0] == 0 and np.isnan(found.multipliers_beyond[fold]).all()


def test_a_jump_of_the_neimark_sacker_test_is_in_the_rows_bits(monkeypatch):
    """A real multiplier jumps from 0.2 to 3.0 beside one at 0.5: the fold test and the
    Neimark-Sacker test (a real pair's product through 1) change sign by the one jump:
    one jump row with both bits, not a row dropped as a neutral saddle."""
    monkeypatch.setattr(bifurcation, "_evaluate", _stepped([0.5, 0.2], [0.5, 3.0]))
    x = np.array([[0.0, 1.0]])
    _, v, mu, seq = _stepped([0.5, 0.2], [0.5, 3.0])(None, 1, None, None, {"gamma": x[0]}, None)
    found = locate(get_model("simplest"), {"gamma": x}, "gamma", np.zeros((1, 2), np.int8), v[None], mu[None],
                   sequences=seq[None, :, 0], options=BifurcationOptions(tol=1e-8))
    assert found.kind.tolist() == [Kind.JUMP] and found.jumps.tolist() == [1 | 4]


def test_a_bracket_closed_by_the_last_allowed_trial_is_located(monkeypatch):
    """With ``max_iter`` just the trials the regula falsi needs, the row is
    located (``OK``), not left ``no_convergence``."""
    calls = []

    def counted(*args):
        calls.append(len(args[4]["gamma"]))
        return _stepped([0.97, 0.1], [1.5, 0.1])(*args)

    monkeypatch.setattr(bifurcation, "_evaluate", counted)
    x = np.array([[0.0, 1.0]])
    _, v, mu, seq = _stepped([0.97, 0.1], [1.5, 0.1])(None, 1, None, None, {"gamma": x[0]}, None)
    run = lambda max_iter: locate(get_model("simplest"), {"gamma": x}, "gamma", np.zeros((1, 2), np.int8), v[None],
                                  mu[None], sequences=seq[None, :, 0],
                                  options=BifurcationOptions(tol=1e-8, max_iter=max_iter))
    assert run(80).status.tolist() == [Status.OK]
    trials = len(calls) - 1  # the last call: the midpoint's solve
    assert run(trials).status.tolist() == [Status.OK]
    assert run(trials - 1).status.tolist() == [Status.NOT_LOCATED]


def _coexisting(lower_mu, upper_mu, fail_from_q=False, q_sequence=A):
    """Two gaits of one event sequence: ``P`` (``v = (x, 0)``, multiplier ``lower_mu``) for
    ``x < 0.6``, ``Q`` (``v = (x, 1)``, multiplier ``upper_mu``) for ``x > 0.4``; Newton finds the one
    nearer its start (``v0[1]`` below 1/2: ``P`` where it exists), else the one that exists."""

    def evaluate(model, k, solver, newton, params, v0):
        x = np.asarray(params["gamma"], np.float64)
        toward_q = np.full(len(x), True) if v0 is None else np.asarray(v0)[:, 1] >= 0.5
        q = np.where(x <= 0.4, False, np.where(x >= 0.6, True, toward_q))
        if v0 is None:  # the grid itself: P below 0.5, Q above
            q = x > 0.5
        v = np.stack([x, np.where(q, 1.0, 0.0)], 1)
        mu = np.stack([np.where(q, upper_mu, lower_mu), np.full_like(x, 0.1)], 1).astype(np.complex128)
        status = np.zeros(len(x), np.int8)
        if fail_from_q and v0 is not None:  # Newton started on Q's own point fails below 0.6
            status[(np.asarray(v0)[:, 1] == 1.0) & (x < 0.6)] = Status.NO_CONVERGENCE
        return status, v, mu, np.where(q, q_sequence, A)[:, None].astype(np.int64)

    return evaluate


@pytest.mark.parametrize("lower_mu, upper_mu", [(0.5, 1.5), (0.97, 1.03)], ids=["far_from_one", "near_one"])
def test_a_sign_change_between_two_coexisting_gaits_is_a_switch(monkeypatch, lower_mu, upper_mu):
    """The line's grid gaits are ``P`` at 0.0 and ``Q`` at 1.0; both exist over 0.4-0.6 and
    the fold test differs between them. The regula falsi closes somewhere there on Newton's
    choice of gait, not on a crossing: re-solved at the located point from each end, the
    bracket gives two gaits, a ``switch`` row; the code before named it a jump (0.5, 1.5:
    nothing near +1) or a fold (0.97, 1.03: both within the window)."""
    found = _run(monkeypatch, _coexisting(lower_mu, upper_mu), [0.0, 1.0], sequences=False)
    assert found.kind.tolist() == [Kind.SWITCH] and found.status.tolist() == [Status.OK]
    assert 0.4 <= found.parameter[0] <= 0.6 and found.jumps.tolist() == [1]
    assert found.v[0, 1] == 0.0 and found.multipliers[0, 0].real == lower_mu  # the lower end's gait, P
    assert found.multipliers_beyond[0, 0].real == upper_mu


def test_one_gait_on_both_ends_stays_a_jump(monkeypatch):
    """The same jump of the multipliers with one fixed point (the re-solves from both ends
    agree): a ``jump``, as before."""
    monkeypatch.setattr(bifurcation, "_evaluate", _fake(jump=0.8))
    x, status, v, mu, _ = _grid([0.0, 1.0], 0.8)
    found = locate(get_model("simplest"), {"gamma": x}, "gamma", status, v, mu, options=BifurcationOptions(tol=1e-7))
    assert found.kind.tolist() == [Kind.JUMP]


@pytest.mark.parametrize("lower_mu, upper_mu, kind", [(0.5, 1.5, Kind.FOLD), (0.97, 1.03, Kind.FOLD)])
def test_a_bracket_whose_re_solve_from_one_end_fails_is_not_located(monkeypatch, lower_mu, upper_mu, kind):
    """The two coexisting gaits again, but Newton from the upper end's gait fails at the
    located point: one gait or two is not known there, so the row is neither a jump nor a
    fold of one gait (as it was when that re-solve's failure was read as "one gait"): the
    test's kind, not located, with the failure as its status."""
    found = _run(monkeypatch, _coexisting(lower_mu, upper_mu, fail_from_q=True), [0.0, 1.0], sequences=False)
    assert found.kind.tolist() == [kind] and found.status.tolist() == [Status.NO_CONVERGENCE]


def test_a_sequence_change_between_two_coexisting_gaits_is_a_switch(monkeypatch):
    """The two coexisting gaits with different event sequences (``Q`` takes ``B``): the
    bisection on the sequence closes between them, but re-solved there from each side's
    gait the two sides are two gaits, not one gait through a border collision: a
    ``switch`` row that keeps both sequences."""
    found = _run(monkeypatch, _coexisting(0.5, 0.7, q_sequence=B), [0.0, 1.0])
    assert found.kind.tolist() == [Kind.SWITCH] and found.status.tolist() == [Status.OK]
    assert 0.4 <= found.parameter[0] <= 0.6
    assert found.sequence.tolist() == [A] and found.sequence_beyond.tolist() == [B]
    assert found.multipliers[0, 0].real == 0.5 and found.multipliers_beyond[0, 0].real == 0.7
