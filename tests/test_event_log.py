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


def test_the_event_sequence_output_is_on_by_default_only_where_the_model_logs_events():
    from types import SimpleNamespace

    from jaxwalk.analyses.event_sequence import ANALYSIS
    from jaxwalk.sweep import loads_config
    from jaxwalk.sweep.runner import analysis_options
    from tests.conftest import COMPASS_2D
    from tests.test_clearance import FLATFOOT_1

    assert ("event_sequence", True) in analysis_options(loads_config(FLATFOOT_1)).more
    assert "event_sequence" not in loads_config(FLATFOOT_1).to_dict()["analysis"]  # the default is not written
    off = loads_config(FLATFOOT_1.replace("min_clearance = true", "event_sequence = false"))
    assert "event_sequence" not in dict(analysis_options(off).more)
    assert off.to_dict()["analysis"]["event_sequence"] is False
    assert "event_sequence" not in dict(analysis_options(loads_config(COMPASS_2D)).more)  # the compass logs none

    # Read from each gait's end context; 0 where the search failed.
    ctx = np.stack([np.asarray(_ctx([0, 1, 2, 3, 4, 5])), np.asarray(_ctx([0, 1, 7]))])
    block = SimpleNamespace(model=FLAT, gaits=SimpleNamespace(context=ctx), shape=(2,))
    out = ANALYSIS.compute(block)
    final = ANALYSIS.finalise(out, np.array([0, 7], np.int8))
    assert final["event_sequence"].dtype == np.int64 and final["event_sequence"][1] == 0
    assert event_log.decode(final["event_sequence"][0], FLAT.guards)[-1] == "toe_strike"
    variables = ANALYSIS.variables(("gamma",), final, True, {"length": "1", "time": "1"}, FLAT)
    assert variables["event_sequence"][2]["event_names"].split() == list(FLAT.guards)
