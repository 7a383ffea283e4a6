"""Worker threads: one jitted program over a batch's rows, on every CPU core.

A chunk of a grid analysis (``jaxwalk.grid``) is one batch: its rows are dealt
to one worker thread per CPU device (``XLA_FLAGS=
--xla_force_host_platform_device_count``, which ``import jaxwalk`` sets to the
core count), and every thread runs the same compiled program on its share.
The program is compiled once per process and shape (:func:`executable`),
whichever thread, or the caller alone, runs it.
"""

from __future__ import annotations

import functools
import threading
from concurrent.futures import ThreadPoolExecutor

import jax
import numpy as np

from jaxwalk import program_cache


def thread_count() -> int:
    """Worker threads a batch is split over: one per CPU device."""
    return jax.device_count()


@functools.lru_cache(maxsize=1)
def _threads(n: int) -> ThreadPoolExecutor:
    return ThreadPoolExecutor(n, thread_name_prefix="jaxwalk-worker")


_executables: dict = {}
_executables_lock = threading.Lock()


def executable(program, args):
    """``program`` compiled for the shapes and dtypes of ``args``, once per process.

    Every worker thread runs this one executable, on the default CPU device.
    One copy per device (each thread's input committed to its own device) ran
    as fast, but compiled the program once per device, side by side: the
    flat-foot map's cold run peaked at 6.05 GB against 3.27 GB for one copy
    (the persistent cache's key includes the device, so the second copy is a
    second compile, not a load). On the CPU a device is a label: executions
    from several threads on one device run in parallel on the same thread pool
    (measured: a second core's speed-up is the same either way,
    benchmarks/README.md). A chunk run on one thread takes the same path, so
    a shape compiled for one is not compiled again for the other. A program
    registered with :mod:`jaxwalk.program_cache` is loaded from disk, not
    traced, when a run before traced it.
    """
    leaves, tree = jax.tree_util.tree_flatten(args)
    key = (program, tree, tuple((np.shape(x), np.result_type(x)) for x in leaves))
    with _executables_lock:
        if key not in _executables:
            _executables[key] = program_cache.lower(program, args).compile()
        return _executables[key]


def compiled_shapes(program) -> list[tuple]:
    """The input shapes ``program`` has been compiled for in this process
    (:func:`executable`): one ``((shape, dtype), ...)`` per compile, over the
    input's leaves."""
    with _executables_lock:
        return [key[2] for key in _executables if key[0] is program]


def run_on_threads(program, block, min_rows_per_thread: int):
    """``program(block)`` as NumPy arrays, the rows (the leading axis of every
    leaf of the pytree ``block``) split over one worker thread per CPU device.

    The threads share one compiled program (:func:`executable`) and each runs
    it on every n-th row, so the CPU device count (``XLA_FLAGS=
    --xla_force_host_platform_device_count``, which ``import jaxwalk`` sets to
    the core count) is the number of cores a sweep keeps busy. Launched one
    after the other from one thread, the calls did not overlap (measured: no
    faster than one thread). One SPMD program sharded over the devices does run
    them together, but then every iteration of every batched while loop waits
    for both devices (the loop condition is an all-reduce): 0.65 against
    0.45 ms per configuration this way (simplest walker, 2048 configurations,
    two cores; see benchmarks/README.md).
    """
    n_rows = jax.tree_util.tree_leaves(block)[0].shape[0]
    n_threads = thread_count()
    if n_threads == 1 or n_rows % n_threads or n_rows // n_threads < min_rows_per_thread:
        return jax.tree_util.tree_map(np.asarray, executable(program, block)(block))

    # Every n_threads-th row: neighbouring grid points cost about the same, so the
    # threads get equal work (contiguous halves of a slope sweep differ by ~15%
    # in steps and Newton iterations).
    parts = [jax.tree_util.tree_map(lambda v, i=i: v[i::n_threads], block) for i in range(n_threads)]
    compiled = executable(program, parts[0])
    outs = list(_threads(n_threads).map(lambda part: jax.tree_util.tree_map(np.asarray, compiled(part)), parts))
    # Interleave back: row j came from thread j % n_threads.
    return jax.tree_util.tree_map(lambda *xs: np.stack(xs, axis=1).reshape((n_rows,) + xs[0].shape[1:]), *outs)
