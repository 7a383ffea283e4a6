"""Running a per-configuration program over many rows: ``lax.map`` sub-batches
inside one program, and fixed-shape chunks split over the worker threads.

Shared by every analysis of a grid (:mod:`jaxwalk.grid`, :mod:`jaxwalk.attractor`),
so that each pads, chunks and compiles alike.
"""

from __future__ import annotations

from typing import Callable

import jax
import jax.numpy as jnp
import numpy as np

from jaxwalk.workers import run_on_threads, thread_count

#: A call of independent configurations is split over the worker threads only
#: when each gets at least this many (a split call runs a program of its share's
#: shape). Continuation lines are heavier: two per thread (jaxwalk.lines).
MIN_ROWS_PER_THREAD = 32


#: Configurations (or lines) one worker thread advances together on the flat
#: step engine, every model alike: there a batch's cost is set by its average
#: lane, not by the slowest at every phase boundary (jaxwalk.flatstep).
FLAT_SUB_BATCH = 64
#: The key :func:`run_chunks` adds to a call's rows: False at padding rows.
ROW_VALID = "__row_valid__"


def sub_batch_size(model, solver) -> int:
    """``lax.map`` sub-batch size: :data:`FLAT_SUB_BATCH` on the flat engine,
    else the model's ``lockstep_batch`` (the nested engine's per-model setting)."""
    return FLAT_SUB_BATCH if solver.engine == "flat" else model.lockstep_batch


def in_sub_batches(fn, params, sub_batch: int):
    """``vmap(fn)(params)`` over the leading axis, computed as ``lax.map`` over
    sub-batches of ``sub_batch`` rows (the last one padded with copies of the last row).

    Where ``params`` holds :data:`ROW_VALID` (``(n,)`` bool, as :func:`run_chunks`
    passes it), a sub-batch without a valid row is skipped (a real branch: its
    outputs are zeros), so padding a call to a fixed shape costs at most one
    sub-batch's worth of copies."""
    params = dict(params)
    valid = params.pop(ROW_VALID, None)
    n = jax.tree_util.tree_leaves(params)[0].shape[0]
    sub = max(1, min(sub_batch, n))
    n_sub = -(-n // sub)
    pad = n_sub * sub - n

    def split(x):
        if pad:
            x = jnp.concatenate([x, jnp.repeat(x[-1:], pad, axis=0)], axis=0)
        return x.reshape((n_sub, sub) + x.shape[1:])

    batched = jax.jit(jax.vmap(fn))  # one trace for the output's shape and the branch
    if valid is None:
        out = jax.lax.map(batched, jax.tree_util.tree_map(split, params))
    else:
        shapes = jax.eval_shape(batched, jax.tree_util.tree_map(lambda x: split(x)[0], params))
        zeros = lambda _: jax.tree_util.tree_map(lambda s: jnp.zeros(s.shape, s.dtype), shapes)
        any_valid = split(jnp.asarray(valid, bool)).any(axis=1)
        out = jax.lax.map(lambda xs: jax.lax.cond(xs[1], batched, zeros, xs[0]), (jax.tree_util.tree_map(split, params), any_valid))
    return jax.tree_util.tree_map(lambda x: x.reshape((n_sub * sub,) + x.shape[2:])[:n], out)


def run_chunks(
    program,
    params_rows: dict[str, np.ndarray],
    chunk: int,
    progress: Callable[[int], None] | None,
    min_rows_per_thread: int = MIN_ROWS_PER_THREAD,
):
    """Apply ``program`` to ``params_rows`` (leading axis = rows) ``chunk`` rows per call.

    Every call has one shape, ``chunk`` rows (rounded up to a multiple of the
    worker threads) whatever the number of rows: the last call is padded with
    copies of the last row, marked invalid in :data:`ROW_VALID` (which
    :func:`in_sub_batches` skips), so grids of every size share one compiled
    program. ``progress`` is called with the rows finished after each call.
    """
    n_rows = next(iter(params_rows.values())).shape[0]
    n_threads = thread_count()
    chunk = max(n_threads, -(-chunk // n_threads) * n_threads)
    pieces = []
    for start in range(0, n_rows, chunk):
        stop = min(start + chunk, n_rows)
        block = {k: v[start:stop] for k, v in params_rows.items()}
        pad = chunk - (stop - start)
        if pad:
            block = {k: np.concatenate([v, np.repeat(v[-1:], pad, axis=0)]) for k, v in block.items()}
        block[ROW_VALID] = np.arange(chunk) < stop - start
        out = run_on_threads(program, block, min_rows_per_thread)
        out = jax.tree_util.tree_map(lambda x: x[: stop - start], out)
        pieces.append(out)
        if progress is not None:
            progress(stop - start)
    return jax.tree_util.tree_map(lambda *xs: np.concatenate(xs), *pieces)
