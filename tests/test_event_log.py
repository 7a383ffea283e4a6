"""Sequence codes (jaxwalk.event_log): a step's logged events, one integer, decoded back."""

from __future__ import annotations

import jax.numpy as jnp
import numpy as np

from jaxwalk import event_log
from jaxwalk.models import get_model

FLAT = get_model("flatfoot")


def _ctx(guards):
    """A flat-foot context that logged ``guards`` in order, as its resets do."""
    ctx = jnp.zeros(len(FLAT.context))
    history, count = (FLAT.ctx_index(name) for name in FLAT.event_log)
    for g in guards:
        ctx = ctx.at[history].set(event_log.append(ctx[history], g)).at[count].add(1.0)
    return ctx


def test_a_logged_sequence_decodes_to_its_events_a_leading_guard_zero_included():
    names = FLAT.guards
    steps = [[0, 1, 2, 3, 4, 5], [1, 2, 3, 4, 5], [0, 0, 5], [2]]  # unlock is guard 0: no digit of its own
    codes = [int(event_log.sequence_code(FLAT, _ctx(s))) for s in steps]
    assert len(set(codes)) == len(codes)
    for s, code in zip(steps, codes):
        assert event_log.decode(code, names) == tuple(names[g] for g in s)
    assert event_log.describe(codes[0], names) == "unlock > knee_flex > toe_off > knee_strike > heel_strike > toe_strike"


def test_codes_of_a_batch_and_of_the_models_that_log_nothing():
    batch = jnp.stack([_ctx([0, 5]), _ctx([1, 5])])
    codes = event_log.codes(FLAT, np.asarray(batch))
    assert codes.shape == (2,) and codes.dtype == np.int64 and codes[0] != codes[1]
    simplest = get_model("simplest")
    assert simplest.event_log is None
    assert int(event_log.sequence_code(simplest, jnp.zeros((len(simplest.context) or 1,)))) == event_log.NONE
    assert event_log.decode(event_log.NONE, FLAT.guards) == () and event_log.describe(0, FLAT.guards) == "none"


def test_a_step_longer_than_the_history_keeps_its_last_events():
    guards = [1, 2] * 8  # 16 events, 13 kept
    names = event_log.decode(int(event_log.sequence_code(FLAT, _ctx(guards))), FLAT.guards)
    assert names[0] == "..." and names[1:] == tuple(FLAT.guards[g] for g in guards[-event_log.DEPTH:])
