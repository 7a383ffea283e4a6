"""Worker threads (``jaxwalk.workers``): a chunk's rows split over one thread
per CPU device, all threads running one compiled program."""

from __future__ import annotations

import jax
import numpy as np
import pytest

from jaxwalk.workers import compiled_shapes, run_on_threads
from tests.test_lockstep import _newton_sqrt  # a while loop with row-dependent trip counts

pytestmark = pytest.mark.skipif(jax.device_count() < 2, reason="needs two CPU devices (XLA_FLAGS, as .ci/run sets)")


def test_threads_share_one_compile_and_equal_one_call():
    n_dev = jax.device_count()
    rows = 32 * n_dev
    block = {"a": np.geomspace(1e-6, 1e12, rows)}
    program = jax.jit(jax.vmap(_newton_sqrt))
    whole = jax.tree_util.tree_map(np.asarray, program(block))

    split = run_on_threads(program, block, min_rows_per_thread=32)
    for a, b in zip(whole, split):
        np.testing.assert_array_equal(a, b)  # every row where it was, the same numbers
    assert len(set(whole[1].tolist())) > 3  # rows took different trip counts

    # One executable, for one thread's share: not one per device.
    assert compiled_shapes(program) == [(((rows // n_dev,), np.dtype(np.float64)),)]
    run_on_threads(program, block, min_rows_per_thread=32)
    assert len(compiled_shapes(program)) == 1  # the second chunk reuses it


def test_small_chunks_stay_on_one_thread_and_share_its_compile():
    program = jax.jit(jax.vmap(_newton_sqrt))
    block = {"a": np.linspace(1.0, 2.0, 8)}
    out = run_on_threads(program, block, min_rows_per_thread=32)
    assert out[0].shape == (8,)
    assert compiled_shapes(program) == [(((8,), np.dtype(np.float64)),)]
    # A chunk of 8 rows per thread, split over the threads, runs the 8-row executable again.
    run_on_threads(program, {"a": np.linspace(1.0, 2.0, 8 * jax.device_count())}, min_rows_per_thread=8)
    assert len(compiled_shapes(program)) == 1
