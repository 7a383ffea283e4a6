"""Running a per-configuration program over many rows: ``lax.map`` sub-batches
inside one program, and fixed-shape chunks split over the worker threads.

Shared by every analysis of a grid (:mod:`jaxwalk.grid`, :mod:`jaxwalk.attractor`),
so that each pads, chunks and compiles alike.
"""

from __future__ import annotations

from typing import Any, Callable, NamedTuple

import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Bool

from jaxwalk import program_cache
from jaxwalk.workers import run_on_threads, thread_count

#: A call of independent configurations is split over the worker threads only
#: when each gets at least this many (a split call runs a program of its share's
#: shape). Continuation lines are heavier: two per thread (jaxwalk.lines).
MIN_ROWS_PER_THREAD = 32


#: Configurations (or lines) one worker thread advances together on the flat
#: step engine, every model alike: there a batch's cost is set by its average
#: lane, not by the slowest at every phase boundary (jaxwalk.flatstep).
FLAT_SUB_BATCH = 64


@program_cache.serializable
class Rows(NamedTuple):
    """One program call's configurations, one per row (the leading axis of every leaf).

    Attributes:
        params: the model's parameters, each ``(n,)``.
        inputs: what the program needs beside them, a NamedTuple of ``(n, ...)``
            arrays declared by the program (a fixed point, a start, a line's
            carry); ``()`` when it needs nothing more.
        valid: ``(n,)`` bool, False at rows that only pad a call to its fixed
            shape (:func:`run_chunks` sets it; ``None``: every row is real). The
            padding follows the real rows, in a call and in every worker
            thread's share of it (every n-th row), which programs that hand rows
            out in order rely on (:func:`jaxwalk.global_stability.walks.pooled_walks`).
    """

    params: dict[str, Array]
    inputs: Any = ()
    valid: Bool[Array, " n"] | None = None


def sub_batch_size(model, solver) -> int:
    """``lax.map`` sub-batch size: :data:`FLAT_SUB_BATCH` on the flat engine,
    else the model's ``lockstep_batch`` (the nested engine's per-model setting)."""
    return FLAT_SUB_BATCH if solver.engine == "flat" else model.lockstep_batch


def in_sub_batches(fn, rows, sub_batch: int, valid: Bool[Array, " n"] | None = None):
    """``vmap(fn)(rows)`` over the leading axis of every leaf of the pytree
    ``rows``, computed as ``lax.map`` over sub-batches of ``sub_batch`` rows
    (the last one padded with copies of the last row). A sub-batch of one row
    (``sub_batch`` 1, as the flat-foot walker's ``lockstep_batch`` and the basin's
    walks ask, or a call of one row) calls ``fn`` on the row without ``vmap``
    (:func:`_one_row`): the same values, rounded as an unbatched program rounds.

    Where ``valid`` is given (``(n,)`` bool, :attr:`Rows.valid`), a sub-batch
    without a valid row is skipped (a real branch: its outputs are zeros), so
    padding a call to a fixed shape costs at most one sub-batch's worth of copies."""
    n = jax.tree_util.tree_leaves(rows)[0].shape[0]
    sub = max(1, min(sub_batch, n))
    n_sub = -(-n // sub)
    pad = n_sub * sub - n

    def split(x):
        if pad:
            x = jnp.concatenate([x, jnp.repeat(x[-1:], pad, axis=0)], axis=0)
        return x.reshape((n_sub, sub) + x.shape[1:])

    batched = jax.jit(_one_row(fn) if sub == 1 else jax.vmap(fn))  # one trace for the output's shape and the branch
    if valid is None:
        out = jax.lax.map(batched, jax.tree_util.tree_map(split, rows))
    else:
        shapes = jax.eval_shape(batched, jax.tree_util.tree_map(lambda x: split(x)[0], rows))
        zeros = lambda _: jax.tree_util.tree_map(lambda s: jnp.zeros(s.shape, s.dtype), shapes)
        any_valid = split(jnp.asarray(valid, bool)).any(axis=1)
        out = jax.lax.map(lambda xs: jax.lax.cond(xs[1], batched, zeros, xs[0]), (jax.tree_util.tree_map(split, rows), any_valid))
    return jax.tree_util.tree_map(lambda x: x.reshape((n_sub * sub,) + x.shape[2:])[:n], out)


def _one_row(fn):
    """``vmap(fn)`` over a leading axis of length 1, without ``vmap``.

    Under ``vmap`` every ``lax.cond`` with a batched predicate becomes a
    ``select`` that computes both branches (and a ``while_loop``'s body masks
    its carry), even for one row. Calling ``fn`` on the row itself keeps the
    program's branches real (diffrax's and equinox's too)."""

    def one(rows):
        out = fn(jax.tree_util.tree_map(lambda x: x[0], rows))
        return jax.tree_util.tree_map(lambda x: jnp.expand_dims(jnp.asarray(x), 0), out)

    return one


def over_rows(one: Callable, sub_batch: int):
    """A function of :class:`Rows` (for ``jit``) giving ``one(params, inputs)`` of
    every row, ``sub_batch`` rows advancing together (:func:`in_sub_batches`),
    padding sub-batches skipped."""

    def program(rows: Rows):
        return in_sub_batches(lambda r: one(*r), (rows.params, rows.inputs), sub_batch, rows.valid)

    return program


def run_chunks(
    program,
    rows: Rows,
    chunk: int,
    progress: Callable[[int], None] | None,
    min_rows_per_thread: int = MIN_ROWS_PER_THREAD,
):
    """Apply ``program`` (a jitted function of :class:`Rows`) to ``rows``,
    ``chunk`` rows per call.

    Every call has one shape, ``chunk`` rows (rounded up to a multiple of the
    worker threads) whatever the number of rows: the last call is padded with
    copies of the last row, marked in :attr:`Rows.valid` (which
    :func:`in_sub_batches` skips), so grids of every size share one compiled
    program. ``progress`` is called with the rows finished after each call.
    """
    rows = rows._replace(valid=None)
    n_rows = jax.tree_util.tree_leaves(rows)[0].shape[0]
    n_threads = thread_count()
    chunk = max(n_threads, -(-chunk // n_threads) * n_threads)
    pieces = []
    for start in range(0, n_rows, chunk):
        stop = min(start + chunk, n_rows)
        pad = chunk - (stop - start)
        block = jax.tree_util.tree_map(lambda v: _padded(np.asarray(v)[start:stop], pad), rows)
        block = block._replace(valid=np.arange(chunk) < stop - start)
        out = run_on_threads(program, block, min_rows_per_thread)
        out = jax.tree_util.tree_map(lambda x: x[: stop - start], out)
        pieces.append(out)
        if progress is not None:
            progress(stop - start)
    return jax.tree_util.tree_map(lambda *xs: np.concatenate(xs), *pieces)


def _padded(x: np.ndarray, pad: int) -> np.ndarray:
    """``x`` with ``pad`` copies of its last row appended."""
    return np.concatenate([x, np.repeat(x[-1:], pad, axis=0)]) if pad else x
