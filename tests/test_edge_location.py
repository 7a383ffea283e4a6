"""Where a line's gait is lost, the edge is located where the gait ends, not
where Newton first failed to reach it (jaxwalk.bifurcation._shrink_edges).

A synthetic re-solve stands in for Newton: the cycle exists below ``EDGE`` and
is found only from a start within ``REACH`` of the target (the start's
parameter is carried in its first coordinate). A bisection that takes a
failure from a far start for the gait's end stops short of ``EDGE``; following
the cycle there in steps does not.
"""

from __future__ import annotations

import numpy as np
import pytest

from jaxwalk import bifurcation
from jaxwalk.bifurcation import BifurcationOptions, Kind, locate
from jaxwalk.models import get_model
from jaxwalk.status import Status

EDGE, REACH = 0.7, 0.2


def _fake_evaluate(model, k, solver, newton, params, v0):
    x, start = np.asarray(params["gamma"], np.float64), np.asarray(v0)[:, 0]
    found = (x < EDGE) & (np.abs(x - start) <= REACH)
    # Beyond the edge a step fails (a grazing edge); short of it, far starts do not converge.
    status = np.where(found, Status.OK, np.where(x >= EDGE, Status.SCUFFING, Status.NO_CONVERGENCE)).astype(np.int8)
    v = np.stack([x, np.zeros_like(x)], axis=1)
    return status, v, np.tile(np.array([0.5, 0.1], np.complex128), (len(x), 1)), np.zeros((len(x), k), np.int64)


class _Bar:
    def __init__(self):
        self.total, self.n = 0, 0

    def update(self, k):
        self.n += k

    def refresh(self):
        pass


@pytest.mark.parametrize("found_end", [0, 1])
def test_a_lost_gait_is_followed_to_its_edge(monkeypatch, found_end):
    monkeypatch.setattr(bifurcation, "_evaluate", _fake_evaluate)
    x = np.array([[0.0, 1.0]]) if found_end == 0 else np.array([[1.0, 0.0]])
    status = np.full((1, 2), Status.SCUFFING, np.int8)
    status[0, found_end] = Status.OK
    v = np.full((1, 2, 2), np.nan)
    v[0, found_end] = [x[0, found_end], 0.0]
    mu = np.full((1, 2, 2), np.nan, np.complex128)
    bar = _Bar()
    found = locate(get_model("simplest"), {"gamma": x}, "gamma", status, v, mu, options=BifurcationOptions(tol=1e-6), progress=bar)
    assert found.kind.tolist() == [Kind.GRAZING] and found.beyond.tolist() == [Status.SCUFFING]
    assert abs(found.parameter[0] - EDGE) <= 1e-6
    assert found.v[0, 0] < EDGE and EDGE - found.v[0, 0] <= 2e-6  # the found side's cycle
    assert bar.n == bar.total  # the bar ends full when the brackets shrink faster than planned


def test_a_grid_point_the_line_lost_from_afar_moves_the_edge_on(monkeypatch):
    """The line's own continuation marked r = 0.5 failed (it came from the far
    side), but the cycle is found there from its neighbour: the edge is located
    in the next interval, at the cycle's real end."""
    monkeypatch.setattr(bifurcation, "_evaluate", _fake_evaluate)
    x = np.array([[0.0, 0.5, 1.0]])
    status = np.array([[Status.OK, Status.RUNNING, Status.SCUFFING]], np.int8)
    v = np.full((1, 3, 2), np.nan)
    v[0, 0] = [0.0, 0.0]
    mu = np.full((1, 3, 2), np.nan, np.complex128)
    bar = _Bar()
    found = locate(get_model("simplest"), {"gamma": x}, "gamma", status, v, mu, progress=bar)
    assert found.kind.tolist() == [Kind.GRAZING] and found.beyond.tolist() == [Status.SCUFFING]
    assert abs(found.parameter[0] - EDGE) <= 1e-6
    assert bar.n == bar.total


def test_a_cycle_followed_past_the_line_end_has_no_edge(monkeypatch):
    monkeypatch.setattr(bifurcation, "_evaluate", _fake_evaluate)
    x = np.array([[0.0, 0.3, 0.6]])  # all below EDGE: the marked failures are the line's, not the cycle's
    status = np.array([[Status.OK, Status.RUNNING, Status.RUNNING]], np.int8)
    v = np.full((1, 3, 2), np.nan)
    v[0, 0] = [0.0, 0.0]
    bar = _Bar()
    found = locate(get_model("simplest"), {"gamma": x}, "gamma", status, v, np.full((1, 3, 2), np.nan, np.complex128), progress=bar)
    assert len(found.kind) == 0 and bar.n == bar.total


#: A second gait beside the line's: it exists on [OTHER_LO, OTHER_HI], which runs past the
#: line's EDGE, and Newton lands on it from starts farther than NEAR from the target
#: (with ``beyond = "other"``, from any start beyond EDGE).
OTHER_LO, OTHER_HI, NEAR = 0.45, 0.85, 0.02


def _two_gaits(beyond: str):
    def evaluate(model, k, solver, newton, params, v0):
        x, start = np.asarray(params["gamma"], np.float64), np.asarray(v0)
        gap = np.abs(x - start[:, 0])
        on_other = (x >= OTHER_LO) & (x <= OTHER_HI) & (gap <= REACH)
        # Newton stays on the gait it starts from, and lands on the other from a far start
        # (with beyond = "other", from any start past EDGE).
        other = on_other & ((start[:, 1] > 0.25) | (gap > NEAR) | ((beyond == "other") & (x >= EDGE)))
        line = ~other & (x < EDGE) & (gap <= REACH)
        status = np.where(line | other, Status.OK, np.where(x >= EDGE, Status.SCUFFING, Status.NO_CONVERGENCE))
        v = np.stack([x, np.where(other, 0.5, 0.0)], axis=1)
        mu = np.where(other[:, None], np.array([1.3, 0.1]), np.array([0.5, 0.1])).astype(np.complex128)
        return status.astype(np.int8), v, mu, np.zeros((len(x), k), np.int64)

    return evaluate


@pytest.mark.parametrize("beyond", ["scuff", "other"])
def test_an_edge_is_the_lines_own_gaits_not_a_gait_newton_jumped_to(monkeypatch, beyond):
    """Bisecting from the line's last gait, Newton's far starts land on a second gait
    that lives on past the line's edge (the heel-rise walker's stable twin and its
    unstable one, 0.08 apart). Taken for the line's, it would move the edge to the
    other gait's end (0.85) with its multiplier 1.3. A cycle that moved farther
    than the line's slope allows is not followed: the edge is the line's (0.7),
    its gait and multipliers the line's. Its kind names only what was seen beyond:
    grazing where the line's own cycle scuffs there; where every start beyond
    lands on the other gait, the cause is not known (``lost``, ``not_located``)."""
    monkeypatch.setattr(bifurcation, "_evaluate", _two_gaits(beyond))
    x = np.array([[0.4, 0.5, 1.0]])
    status = np.array([[Status.OK, Status.OK, Status.SCUFFING]], np.int8)
    v = np.array([[[0.4, 0.0], [0.5, 0.0], [np.nan, np.nan]]])
    mu = np.tile(np.array([0.5, 0.1], np.complex128), (1, 3, 1))
    found = locate(get_model("simplest"), {"gamma": x}, "gamma", status, v, mu, options=BifurcationOptions(tol=1e-6), progress=_Bar())
    expected = (Kind.GRAZING, Status.SCUFFING) if beyond == "scuff" else (Kind.LOST, Status.NOT_LOCATED)
    assert found.kind.tolist() == [expected[0]] and found.beyond.tolist() == [expected[1]]
    assert abs(found.parameter[0] - EDGE) <= 1e-6
    assert found.v[0, 1] == 0.0 and found.multipliers[0, 0].real == 0.5


def _fold(x_fold: float):
    """One gait, ``v = (x, sqrt(x_fold - x))``, multiplier ``1 - sqrt(x_fold - x)``: it
    turns back at ``x_fold`` (no fixed point beyond), moving ever faster towards it."""
    def evaluate(model, k, solver, newton, params, v0):
        x = np.asarray(params["gamma"], np.float64)
        found = (x < x_fold) & (np.abs(x - np.asarray(v0)[:, 0]) <= REACH)
        root = np.sqrt(np.clip(x_fold - x, 0.0, None))
        v = np.stack([x, root], axis=1)
        mu = np.stack([1.0 - root, np.full_like(x, 0.1)], axis=1).astype(np.complex128)
        return np.where(found, Status.OK, Status.NO_CONVERGENCE).astype(np.int8), v, mu, np.zeros((len(x), k), np.int64)

    return evaluate


@pytest.mark.parametrize("gap", [3e-3, 1e-3])
def test_a_fold_just_past_a_grid_point_is_followed_to_the_fold(monkeypatch, gap):
    """Near a fold the gait moves like sqrt(distance), far faster than the grid's
    slope: a move beyond the slope bound that solves back to the same gait is the
    line's own, so the edge is the fold, located to tolerance (a review's case)."""
    x_fold = 0.5 + gap
    monkeypatch.setattr(bifurcation, "_evaluate", _fold(x_fold))
    x = np.array([[0.4, 0.5, 0.6]])
    status = np.array([[Status.OK, Status.OK, Status.NO_CONVERGENCE]], np.int8)
    v = np.array([[[0.4, np.sqrt(x_fold - 0.4)], [0.5, np.sqrt(gap)], [np.nan, np.nan]]])
    mu = np.array([[[1 - np.sqrt(x_fold - 0.4), 0.1], [1 - np.sqrt(gap), 0.1], [np.nan, np.nan]]], np.complex128)
    found = locate(get_model("simplest"), {"gamma": x}, "gamma", status, v, mu, options=BifurcationOptions(tol=1e-6), progress=_Bar())
    assert found.kind.tolist() == [Kind.FOLD] and found.beyond.tolist() == [Status.NO_CONVERGENCE]
    assert abs(found.parameter[0] - x_fold) <= 2e-6


def test_an_edge_without_a_grid_neighbour_checks_every_move(monkeypatch):
    """A line with one found grid point gives no slope: every move is solved back,
    and the jump to the second gait is still refused."""
    monkeypatch.setattr(bifurcation, "_evaluate", _two_gaits("scuff"))
    x = np.array([[0.4, 0.5, 1.0]])
    status = np.array([[Status.NO_CONVERGENCE, Status.OK, Status.SCUFFING]], np.int8)
    v = np.array([[[np.nan, np.nan], [0.5, 0.0], [np.nan, np.nan]]])
    mu = np.tile(np.array([0.5, 0.1], np.complex128), (1, 3, 1))
    found = locate(get_model("simplest"), {"gamma": x}, "gamma", status, v, mu, options=BifurcationOptions(tol=1e-6), progress=_Bar())
    grazing = found.kind == Kind.GRAZING
    assert grazing.sum() == 1 and abs(found.parameter[grazing][0] - EDGE) <= 1e-6
    assert found.v[grazing][0, 1] == 0.0


def test_a_guard_failing_beyond_outranks_a_multiplier_near_one(monkeypatch):
    """At the edge the last cycle's multiplier is 0.97 (within the fold window) but the
    step beyond scuffs: the cause seen is the guard, so the edge is grazing (the
    heel-rise trailing-reset line's edge at k 0.28134, whose multipliers jump there)."""
    def near_one(model, k, solver, newton, params, v0):
        status, v, mu, seq = _fake_evaluate(model, k, solver, newton, params, v0)
        return status, v, np.tile(np.array([0.97, 0.1], np.complex128), (len(status), 1)), seq

    monkeypatch.setattr(bifurcation, "_evaluate", near_one)
    x = np.array([[0.0, 0.5, 1.0]])
    status = np.array([[Status.OK, Status.OK, Status.SCUFFING]], np.int8)
    v = np.array([[[0.0, 0.0], [0.5, 0.0], [np.nan, np.nan]]])
    mu = np.tile(np.array([0.97, 0.1], np.complex128), (1, 3, 1))
    found = locate(get_model("simplest"), {"gamma": x}, "gamma", status, v, mu, options=BifurcationOptions(tol=1e-6), progress=_Bar())
    assert found.kind.tolist() == [Kind.GRAZING] and found.beyond.tolist() == [Status.SCUFFING]
