"""``Gait.context``: the end context of the step from the gait's own fixed point,
from the search's last evaluation (what ``[analysis] min_clearance`` reads
instead of walking that step again, jaxwalk.analyses.clearance).

The shipped simple walkers clear their context at every step's end, so a
simplest walker whose context also keeps the heel-strike time and the stance
angle there stands in for one that keeps something (the flat-foot walker's
event times and ``min_clearance``; its sweep is checked in test_clearance.py,
opt-in: its grid program takes minutes to compile).
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np

from jaxwalk.gait import Fallback, find_gait
from jaxwalk.models.simplest import SimplestWalker
from jaxwalk.status import Status
from jaxwalk.step import step_map


class KeepingWalker(SimplestWalker):
    """The simplest walker whose context keeps, at the step's end, its time and
    the stance angle just before heel-strike (both functions of the start)."""

    name = "simplest_keeping"
    context = ("x_stance", "ground_next", "t_strike", "alpha_strike")

    def on_event(self, guard, t, y, params, phase, ctx):
        out = super().on_event(guard, t, y, params, phase, ctx)
        kept = out.ctx.at[2].set(t).at[3].set(y[2])
        return out._replace(ctx=jnp.where(out.step_done, kept, out.ctx))


MODEL = KeepingWalker()


def _search(gamma, v0=None, fallback=None):
    """``(params, Gait)`` from ``v0`` (the guess made at 0.009), with ``fallback``
    (none by default: a Fallback not used, so every search here is one program)."""
    p = {"gamma": jnp.asarray(gamma)}
    v0 = MODEL.initial_guess({"gamma": jnp.asarray(0.009)}) if v0 is None else v0
    return p, find_gait(MODEL, p, v0, fallback=Fallback(v0, jnp.asarray(False)) if fallback is None else fallback)


@jax.jit
def _steps(params, starts):
    """The plain step map's results from each of ``starts`` ``(2, n_v)``."""
    return jax.vmap(lambda v: step_map(MODEL, v, params)[1])(starts)


def test_the_context_is_the_end_context_of_the_step_from_the_fixed_point():
    params, gait = _search(0.009)
    assert int(gait.status) == Status.OK and int(gait.iterations) >= 2  # a search, not its start
    # The step from the fixed point, and from a point about as far from it as
    # the iterate before the last update (updates 3.3e-5, 1.9e-7: test_newton_stop.py).
    res = _steps(params, jnp.stack([gait.v, gait.v.at[0].add(1.9e-7)]))
    np.testing.assert_allclose(gait.context, res.ctx[0], rtol=0, atol=1e-12)
    assert abs(float(gait.context[2]) - float(gait.period)) < 1e-12  # the step's end, as the period's
    # ... which ends its step apart from the converged one's: the context is not an earlier iterate's.
    assert np.max(np.abs(np.asarray(res.ctx[1] - res.ctx[0]))) > 1e-9


def test_after_a_fallback_the_context_is_the_second_searchs():
    """A first search that falls (started walking backwards) restarts from the
    fallback in the same loop; the context is that search's converged step's."""
    guess = MODEL.initial_guess({"gamma": jnp.asarray(0.009)})
    assert int(_search(0.009, -guess)[1].status) != Status.OK  # alone, the first search fails
    params, gait = _search(0.009, -guess, Fallback(guess, jnp.asarray(True)))
    assert int(gait.status) == Status.OK
    res = _steps(params, jnp.stack([gait.v, gait.v]))
    np.testing.assert_allclose(gait.context, res.ctx[0], rtol=0, atol=1e-12)


def test_a_failed_search_has_no_context():
    _, gait = _search(-0.05)  # uphill without power: no gait
    assert int(gait.status) != Status.OK
    assert np.isnan(np.asarray(gait.context)).all() and gait.context.shape == (4,)
