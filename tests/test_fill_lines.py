"""A line's failed points beside found ones are solved again from the found
gait (jaxwalk.lines.fill_from_neighbours): a walk that reached them from the
other side or from afar does not decide that they hold no gait."""

from __future__ import annotations

import jax
import numpy as np

from jaxwalk.gait import NewtonOptions
from jaxwalk.lines import fill_from_neighbours, run_lines, segment_program
from jaxwalk.models import get_model
from jaxwalk.status import Status
from jaxwalk.step import SolverOptions

SIMPLEST = get_model("simplest")
SOLVER, NEWTON = SolverOptions(), NewtonOptions()


def _line():
    return {"gamma": np.linspace(0.004, 0.012, 9)[None]}


def test_points_marked_failed_beside_a_gait_are_found_again_as_the_walk_finds_them():
    """The walk's gaits with three points past the seed marked failed (as a walk
    that came from a failed start would leave them) are restored, one round per
    point, to exactly what the walk from the found side computes."""
    lines = _line()
    walked = run_lines(SIMPLEST, lines, lines["gamma"][0], 0, SOLVER, NEWTON, 256)
    assert (np.asarray(walked.status) == Status.OK).all()
    damaged = jax.tree_util.tree_map(np.array, walked)
    damaged.status[0, 6:] = Status.FELL
    damaged.v[0, 6:] = np.nan
    damaged.lambda_max[0, 6:] = np.nan
    filled = fill_from_neighbours(SIMPLEST, lines, lines["gamma"][0], damaged, segment_program(SIMPLEST, SOLVER, NEWTON), 256)
    for a, b in zip(jax.tree_util.tree_leaves(filled), jax.tree_util.tree_leaves(walked)):
        np.testing.assert_array_equal(np.asarray(a), np.asarray(b))


def test_a_point_that_holds_no_gait_stays_failed():
    """The simplest walker has no gait on a level floor: marked failed beside a
    found gait, it is tried again and stays failed, and nothing else moves."""
    lines = {"gamma": np.array([[0.0, 0.004, 0.005]])}
    walked = run_lines(SIMPLEST, lines, lines["gamma"][0], 2, SOLVER, NEWTON, 256)
    status = np.asarray(walked.status)
    assert status[0, 0] != Status.OK and (status[0, 1:] == Status.OK).all()
    again = fill_from_neighbours(SIMPLEST, lines, lines["gamma"][0], walked, segment_program(SIMPLEST, SOLVER, NEWTON), 256)
    for a, b in zip(jax.tree_util.tree_leaves(again), jax.tree_util.tree_leaves(walked)):
        np.testing.assert_array_equal(np.asarray(a), np.asarray(b))
