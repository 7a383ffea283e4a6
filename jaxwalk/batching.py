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

#: A chunk of independent configurations is split over the worker threads only
#: when each gets at least this many (a split chunk runs a program of half its
#: shape: small grids, such as the tests', keep one shape and one compile).
#: Continuation lines are heavier: two per thread.
MIN_ROWS_PER_THREAD = 32


def in_sub_batches(fn, params, sub_batch: int):
    """``vmap(fn)(params)`` over the leading axis, computed as ``lax.map`` over
    sub-batches of ``sub_batch`` rows (the last one padded with copies of the last row)."""
    n = jax.tree_util.tree_leaves(params)[0].shape[0]
    sub = max(1, min(sub_batch, n))
    n_sub = -(-n // sub)
    pad = n_sub * sub - n

    def split(x):
        if pad:
            x = jnp.concatenate([x, jnp.repeat(x[-1:], pad, axis=0)], axis=0)
        return x.reshape((n_sub, sub) + x.shape[1:])

    out = jax.lax.map(jax.vmap(fn), jax.tree_util.tree_map(split, params))
    return jax.tree_util.tree_map(lambda x: x.reshape((n_sub * sub,) + x.shape[2:])[:n], out)


def run_chunks(
    program,
    params_rows: dict[str, np.ndarray],
    chunk: int,
    progress: Callable[[int], None] | None,
    min_rows_per_thread: int = MIN_ROWS_PER_THREAD,
    rows: int | None = None,
):
    """Apply ``program`` to ``params_rows`` (leading axis = rows) chunk by chunk
    (``rows`` per call if given, to share another call's compiled shape)."""
    n_rows = next(iter(params_rows.values())).shape[0]
    n_threads = thread_count()
    # Few distinct shapes, few compilations: small inputs pad to a power of two.
    rows = rows or min(chunk, 1 << max(0, (n_rows - 1).bit_length()))
    chunk = max(n_threads, -(-rows // n_threads) * n_threads)
    pieces = []
    for start in range(0, n_rows, chunk):
        stop = min(start + chunk, n_rows)
        block = {k: v[start:stop] for k, v in params_rows.items()}
        pad = chunk - (stop - start)
        if pad:  # pad with copies of the last row so every chunk has one shape (one compile)
            block = {k: np.concatenate([v, np.repeat(v[-1:], pad, axis=0)]) for k, v in block.items()}
        out = run_on_threads(program, block, min_rows_per_thread)
        out = jax.tree_util.tree_map(lambda x: x[: stop - start], out)
        pieces.append(out)
        if progress is not None:
            progress(stop - start)
    return jax.tree_util.tree_map(lambda *xs: np.concatenate(xs), *pieces)
