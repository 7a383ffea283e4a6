"""Lockstep sub-batches (``Walker.lockstep_batch``, ``batching.in_sub_batches``):
how many configurations a worker thread advances together must not change what each
one computes."""

from __future__ import annotations

from typing import NamedTuple

import jax
import jax.extend.core
import jax.numpy as jnp
import numpy as np
import pytest

from jaxwalk import grid as G
from jaxwalk.batching import Rows, in_sub_batches, over_rows, run_chunks
from jaxwalk.gait import NewtonOptions
from jaxwalk.models import get_model
from jaxwalk.models.compass import CompassWalker


def _newton_sqrt(p):
    """A while loop whose trip count depends on the row (as Newton's and the ODE
    solver's do): sqrt(a) by Newton from 1 to 1e-14, and the iterations taken."""

    def cond(c):
        x, k = c
        return (jnp.abs(x * x - p["a"]) > 1e-14 * p["a"]) & (k < 100)

    def body(c):
        x, k = c
        return 0.5 * (x + p["a"] / x), k + 1

    return jax.lax.while_loop(cond, body, (jnp.ones(()), jnp.zeros((), jnp.int32)))


@pytest.mark.parametrize("sub_batch", [1, 2, 3, 64])
def test_sub_batches_equal_one_vmap(sub_batch):
    # 7 rows: every sub-batch size but 1 and 64 leaves a padded last sub-batch.
    params = {"a": jnp.asarray([2.0, 1e6, 0.5, 3.0, 1e-6, 7.0, 1e12])}
    whole = jax.jit(jax.vmap(_newton_sqrt))(params)
    parts = jax.jit(lambda p: in_sub_batches(_newton_sqrt, p, sub_batch))(params)
    for a, b in zip(whole, parts):
        np.testing.assert_array_equal(np.asarray(a), np.asarray(b))
    assert len(set(np.asarray(whole[1]).tolist())) > 3  # the rows did take different trip counts


def _primitives(jaxpr) -> set[str]:
    """Names of every primitive in ``jaxpr`` and its sub-jaxprs (loop bodies, branches)."""
    names = set()
    for eqn in jaxpr.eqns:
        names.add(eqn.primitive.name)
        for sub in jax.extend.core.jaxprs_in_params(eqn.params):
            names |= _primitives(sub)
    return names


def test_one_row_at_a_time_keeps_its_branches_real():
    """With sub-batches of one row (the flat-foot walker's ``lockstep_batch``) the
    row's program is not vmapped: a ``lax.cond`` stays a branch that runs one
    side, where a vmap, even of one row, turns it into a ``select`` of both sides
    (diffrax's and equinox's branches inside a step too); and it computes what
    the vmap does, a constant output broadcast to every row as ``vmap`` does."""

    def one(p):
        root, its = _newton_sqrt(p)
        return jax.lax.cond(its > 5, lambda r: r * 2.0, lambda r: r - 1.0, root), its, 1.0  # and a Python float

    params = {"a": jnp.asarray([2.0, 1e6, 0.5])}
    for sub_batch, has_cond in ((1, True), (2, False)):
        jaxpr = jax.make_jaxpr(lambda p: in_sub_batches(one, p, sub_batch))(params).jaxpr
        assert ("cond" in _primitives(jaxpr)) == has_cond, sub_batch
        got = jax.jit(lambda p: in_sub_batches(one, p, sub_batch))(params)
        for a, b in zip(jax.jit(jax.vmap(one))(params), got):
            np.testing.assert_array_equal(np.asarray(a), np.asarray(b))


class _CompassOneAtATime(CompassWalker):
    """The compass walker run one configuration per sub-batch (the flat-foot walker's setting)."""

    lockstep_batch = 1


def test_continuation_one_line_at_a_time_equals_lines_together():
    """The flat-foot walker's path (lines one at a time) against the default (64 lines
    together), on the compass walker where both compile in seconds: the same
    statuses, and the same gaits to what the one-at-a-time search guarantees.
    Its lines take chord steps and end a search at an evaluation whose Newton
    update is below ``tol`` (jaxwalk.gait._newton_iteration), so its gait lies
    within ``tol`` (1e-8) of the fixed point, where full Newton's is far closer;
    the two programs also round differently (one row is not vmapped at all):
    2.5e-9 apart when both ran to Newton's end (measured 2026-12-07). The bound
    is ``tol`` plus that noise for each program: 1.5e-8 (measured 2026-12-08:
    8.9e-9)."""
    grid = {"gamma": np.array([0.03, 0.05, 0.07]), "m_h": np.array([8.0, 10.0, 12.0, 14.0])}
    together = G.analyse_grid(get_model("compass"), {}, grid, "m_h")
    alone = G.analyse_grid(_CompassOneAtATime(), {}, grid, "m_h")
    np.testing.assert_array_equal(alone["status"], together["status"])
    assert (together["status"] == 0).sum() >= 6
    ok = together["status"] == 0
    bound = NewtonOptions().tol + 2 * 2.5e-9
    np.testing.assert_allclose(alone["fixed_point"][ok], together["fixed_point"][ok], rtol=0, atol=bound)
    np.testing.assert_allclose(alone["lambda_max"][ok], together["lambda_max"][ok], rtol=0, atol=1e-6)


class _Scale(NamedTuple):
    """A program's typed input beside the parameters (as the analyses declare theirs)."""

    factor: jax.Array  # (n,) multiplies the parameter
    offset: jax.Array  # (n, 2) added to both outputs' first


def test_typed_inputs_travel_with_their_rows_through_chunks_padding_and_threads():
    """``Rows(params, inputs)`` over :func:`run_chunks`: 11 rows in calls of 4 (the
    last padded, then split over the worker threads) give every row its own
    parameters and inputs, as one ``vmap`` over all rows does."""
    n = 11
    a = np.geomspace(1e-3, 1e9, n)
    inputs = _Scale(np.linspace(0.5, 2.0, n), np.arange(2.0 * n).reshape(n, 2))

    def one(p, s):
        root, its = _newton_sqrt({"a": p["a"] * s.factor})
        return root + s.offset[0], its

    program = jax.jit(over_rows(one, 2))
    root, its = run_chunks(program, Rows({"a": a}, inputs), 4, None)
    expect_root, expect_its = jax.vmap(one)({"a": jnp.asarray(a)}, jax.tree_util.tree_map(jnp.asarray, inputs))
    np.testing.assert_array_equal(root, np.asarray(expect_root))
    np.testing.assert_array_equal(its, np.asarray(expect_its))
    np.testing.assert_allclose(root - inputs.offset[:, 0], np.sqrt(a * inputs.factor), rtol=1e-13)
