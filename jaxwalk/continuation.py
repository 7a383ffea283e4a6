"""Gait searches over parameter grids, with natural-parameter continuation.

From one fixed initial guess Newton's method loses a gait far from where the
guess was made (for the simplest walker, above a slope of about 0.0135). Along
the *continuation axis* we instead start each grid point from its converged
neighbour: the sweep begins at the grid point nearest the value of that parameter at
which the model's initial guess was made (its default, or that of the
documented gait the guess is: :meth:`jaxwalk.walker.Walker.seed_value`), walks up
the axis, then walks down from the same seed. A point whose search fails starts
the next one from the last converged gait (or from the model's guess if there
is none yet). All other axes are batched with ``vmap``.
"""

from __future__ import annotations

from typing import Mapping, NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from jaxwalk.gait import Gait, NewtonOptions, find_gait
from jaxwalk.status import Status
from jaxwalk.step import SolverOptions
from jaxwalk.walker import Walker

Array = jax.Array


def seed_index(values: np.ndarray, default: float) -> int:
    """Index of the grid value nearest ``default`` (where continuation starts: :meth:`jaxwalk.walker.Walker.seed_value`)."""
    return int(np.argmin(np.abs(np.asarray(values) - default)))


def visiting_order(n: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Order in which a continuation axis of length ``n`` is visited from ``seed``.

    Returns ``order`` (every index once: seed, up to the end, then down from
    ``seed - 1``) and ``restart`` (True where the walk restarts from the seed's
    gait instead of the previous point's).
    """
    order = np.concatenate([np.arange(seed, n), np.arange(seed - 1, -1, -1)]).astype(np.int32)
    restart = np.zeros(n, bool)
    if seed > 0:
        restart[n - seed] = True
    return order, restart


class LineCarry(NamedTuple):
    """What a continuation line hands from one visit to the next (one line; vmap it).

    Attributes:
        v_prev, have_prev: ``(n_v,)`` start for the next visit (the last
            converged gait, or the last start where a search failed) and whether it holds one.
        v_seed, have_seed: ``(n_v,)`` the seed point's gait (or the line's given
            start before the seed is visited), where the walk down restarts.
    """

    v_prev: Array
    have_prev: Array
    v_seed: Array
    have_seed: Array


def line_start(n_v: int, dtype, v_start: Array | None = None, have_start: Array | bool = False) -> LineCarry:
    """The carry before a line's first visit: ``v_start`` where ``have_start``
    (it then plays the model's initial guess's part throughout), else none."""
    have = jnp.asarray(have_start, bool)
    v0 = jnp.zeros(n_v, dtype) if v_start is None else jnp.where(have, jnp.asarray(v_start, dtype), 0.0)
    return LineCarry(v0, have, v0, have)


def continue_segment(
    model: Walker,
    visits: Mapping[str, Array],
    restart: Array,
    first: Array,
    valid: Array,
    carry: LineCarry,
    solver: SolverOptions,
    newton: NewtonOptions,
) -> tuple[LineCarry, Gait]:
    """Gaits at ``L`` consecutive visits of one continuation line, in visiting order.

    Args:
        visits: dict of ``(L,)`` parameter arrays, one entry per visit.
        restart: ``(L,)`` True where the visit starts from the seed's gait
            instead of the previous visit's (:func:`visiting_order`).
        first: ``(L,)`` True at the line's seed point (its first visit).
        valid: ``(L,)`` False at padding visits: skipped (a real branch, not
            a masked one, as long as ``valid`` is not batched: every line of a
            call shares it), their gaits zeros and the carry unchanged.
        carry: from the visit before (:func:`line_start` before the first).

    Returns:
        The carry after the last visit, and a :class:`Gait` of ``(L,)`` leaves.
    """
    guess_fn = model.initial_guess

    def search(carry: LineCarry, p, from_seed, is_first):
        start_v = jnp.where(from_seed, carry.v_seed, carry.v_prev)
        start_ok = jnp.where(from_seed, carry.have_seed, carry.have_prev)
        v0 = jnp.where(start_ok, start_v, guess_fn(p))
        gait = find_gait(model, p, v0, solver, newton)
        ok = gait.status == Status.OK
        seeded = is_first & ok
        after = LineCarry(
            v_prev=jnp.where(ok, gait.v, start_v),
            have_prev=ok | start_ok,
            v_seed=jnp.where(seeded, gait.v, carry.v_seed),
            have_seed=carry.have_seed | seeded,
        )
        return after, gait

    # One trace serves both the shape of a skipped visit's output and the branch
    # that runs (jit caches the trace of one function object at one signature).
    search = jax.jit(search)

    def visit(carry, xs):
        p, from_seed, is_first, real = xs
        shapes = jax.eval_shape(search, carry, p, from_seed, is_first)
        skipped = lambda c, *_: (c, jax.tree_util.tree_map(lambda s: jnp.zeros(s.shape, s.dtype), shapes[1]))
        return jax.lax.cond(real, search, skipped, carry, p, from_seed, is_first)

    return jax.lax.scan(visit, carry, (dict(visits), restart, first, valid))


def continue_along(
    model: Walker,
    params_line: Mapping[str, Array],
    order: np.ndarray,
    restart: np.ndarray,
    solver: SolverOptions,
    newton: NewtonOptions,
    v_start: Array | None = None,
    have_start: Array | bool = False,
) -> Gait:
    """Gaits along one whole line of the continuation axis (one config per
    entry): :func:`continue_segment` over every visit at once.

    Args:
        params_line: dict of ``(n,)`` parameter arrays along the axis.
        order, restart: from :func:`visiting_order` (NumPy arrays).
        v_start: ``(n_v,)`` start of the seed point (the first visited) in
            place of the model's initial guess, used where ``have_start``
            (e.g. a converged gait of a seed line, :mod:`jaxwalk.seedline`). It
            plays the guess's part throughout: where the seed point fails, the
            walk down restarts from it too.

    Returns:
        A :class:`Gait` whose leaves have leading dimension ``n``, in grid order.
    """
    order = np.asarray(order)
    some = next(iter(params_line.values()))
    n = len(order)
    visits = {k: jnp.asarray(val)[order] for k, val in params_line.items()}
    first = np.arange(n) == 0
    carry = line_start(len(model.section_names), some.dtype, v_start, have_start)
    _, gaits = continue_segment(model, visits, jnp.asarray(restart), first, np.ones(n, bool), carry, solver, newton)
    inverse = np.argsort(order)
    return jax.tree_util.tree_map(lambda x: x[inverse], gaits)

