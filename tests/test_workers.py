"""Worker threads (``grid._run_on_devices``): a chunk's rows split over one thread
per CPU device, all threads running one compiled program."""

from __future__ import annotations

import jax
import numpy as np
import pytest

from jaxwalk import grid as G
from tests.test_lockstep import _newton_sqrt  # a while loop with row-dependent trip counts

pytestmark = pytest.mark.skipif(jax.device_count() < 2, reason="needs two CPU devices (XLA_FLAGS, as .ci/run sets)")


def test_threads_share_one_compile_and_equal_one_call():
    n_dev = jax.device_count()
    rows = 32 * n_dev
    block = {"a": np.geomspace(1e-6, 1e12, rows)}
    program = jax.jit(jax.vmap(_newton_sqrt))
    whole = jax.tree_util.tree_map(np.asarray, program(block))

    split = G._run_on_devices(program, block, min_rows_per_device=32)
    for a, b in zip(whole, split):
        np.testing.assert_array_equal(a, b)  # every row where it was, the same numbers
    assert len(set(whole[1].tolist())) > 3  # rows took different trip counts

    # One executable, for one thread's share: not one per device.
    compiled = [key for key in G._executables if key[0] is program]
    assert len(compiled) == 1 and G.compiled_count(program) == 1
    assert compiled[0][2] == (((rows // n_dev,), np.dtype(np.float64)),)
    G._run_on_devices(program, block, min_rows_per_device=32)
    assert G.compiled_count(program) == 1  # the second chunk reuses it


def test_small_chunks_stay_on_one_thread_and_share_its_compile():
    program = jax.jit(jax.vmap(_newton_sqrt))
    block = {"a": np.linspace(1.0, 2.0, 8)}
    out = G._run_on_devices(program, block, min_rows_per_device=32)
    assert out[0].shape == (8,)
    assert [key[2] for key in G._executables if key[0] is program] == [(((8,), np.dtype(np.float64)),)]
    # A chunk of 8 rows per thread, split over the threads, runs the 8-row executable again.
    G._run_on_devices(program, {"a": np.linspace(1.0, 2.0, 8 * jax.device_count())}, min_rows_per_device=8)
    assert G.compiled_count(program) == 1
