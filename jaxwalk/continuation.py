"""Gait searches over parameter grids, with natural-parameter continuation.

From one fixed initial guess Newton's method loses a gait far from where the
guess was made (for the simplest walker, above a slope of about 0.0135). Along
the *continuation axis* we instead start each grid point from its converged
neighbour: the sweep begins at the grid point nearest the model's default
value of that parameter (where the model's initial guess is valid), walks up
the axis, then walks down from the same seed. A point whose search fails starts
the next one from the last converged gait (or from the model's guess if there
is none yet). All other axes are batched with ``vmap``.
"""

from __future__ import annotations

from typing import Mapping

import jax
import jax.numpy as jnp
import numpy as np

from jaxwalk.gait import Gait, NewtonOptions, find_gait
from jaxwalk.status import Status
from jaxwalk.step import SolverOptions
from jaxwalk.walker import Walker

Array = jax.Array


def seed_index(values: np.ndarray, default: float) -> int:
    """Index of the grid value nearest ``default`` (where continuation starts)."""
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
    """Gaits along one line of the continuation axis (one config per entry).

    Args:
        params_line: dict of ``(n,)`` parameter arrays along the axis.
        order, restart: from :func:`visiting_order`; NumPy or traced arrays (a
            jitted caller passes them as inputs, so one program serves every
            seed position of a line length).
        v_start: ``(n_v,)`` start of the seed point (the first visited) in
            place of the model's initial guess, used where ``have_start``
            (e.g. a converged gait of a seed line, :mod:`jaxwalk.seedline`). It
            plays the guess's part throughout: where the seed point fails, the
            walk down restarts from it too.

    Returns:
        A :class:`Gait` whose leaves have leading dimension ``n``, in grid order.
    """
    guess_fn = model.initial_guess
    some = next(iter(params_line.values()))
    n_v = len(model.section_names)

    def visit(carry, xs):
        v_prev, have_prev, v_seed, have_seed = carry
        index, from_seed = xs
        p = {k: val[index] for k, val in params_line.items()}
        start_v = jnp.where(from_seed, v_seed, v_prev)
        start_ok = jnp.where(from_seed, have_seed, have_prev)
        v0 = jnp.where(start_ok, start_v, guess_fn(p))
        gait = find_gait(model, p, v0, solver, newton)
        ok = gait.status == Status.OK
        first = index == order[0]
        v_seed = jnp.where(first & ok, gait.v, v_seed)
        have_seed = have_seed | (first & ok)
        v_prev = jnp.where(ok, gait.v, start_v)
        have_prev = ok | start_ok
        return (v_prev, have_prev, v_seed, have_seed), gait

    order, restart = jnp.asarray(order), jnp.asarray(restart)
    have = jnp.asarray(have_start, bool)
    v0 = jnp.zeros(n_v, some.dtype) if v_start is None else jnp.where(have, jnp.asarray(v_start, some.dtype), 0.0)
    carry0 = (v0, have, v0, have)
    _, gaits = jax.lax.scan(visit, carry0, (order, restart))
    inverse = jnp.argsort(order)
    return jax.tree_util.tree_map(lambda x: x[inverse], gaits)

