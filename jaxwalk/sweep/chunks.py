"""Where a sweep's chunks are computed: in this process, or on a Dask cluster.

Both yield ``(index, results)`` for the blocks a :class:`~jaxwalk.sweep.store.ChunkStore`
still needs, as they finish; the runner checks and writes each one in this
process (one writer: no two processes touch the store). A block is computed by
the analysis function on the block's own sub-grid (:func:`jaxwalk.grid.sub_grid`),
which gives the numbers the whole grid has there, bit for bit, on any machine
with the same package versions.

``--dask ADDRESS`` sends each block to a Dask distributed scheduler as one task
(``--dask local`` starts a :class:`distributed.LocalCluster` of one single-core
worker per CPU core); at most a few tasks per worker thread are in flight, so
memory stays flat on both sides however large the grid. The workers need
jaxwalk installed; each compiles the analysis once (the program caches,
:mod:`jaxwalk.cache`; ``--dask local`` workers inherit ``JAXWALK_CACHE_DIR``). See docs/sweeps.md.
"""

from __future__ import annotations

import contextlib
import os
import re
from itertools import islice
from typing import Callable, Iterable, Iterator, Mapping

import numpy as np

from jaxwalk.errors import ConfigError

#: Tasks in flight per worker thread: enough to keep every worker busy while the
#: client writes, few enough that waiting results stay small.
TASKS_PER_THREAD = 2
#: How long to wait for a scheduler before giving up (a Dask time string).
CONNECT_TIMEOUT = "20s"
_DEVICE_FLAG = re.compile(r"--xla_force_host_platform_device_count=\d+")


def compute_chunk(analyse: Callable, model_name: str, fixed: Mapping, grid: Mapping, continuation: str | None,
                  options, region: tuple[slice, ...], keys: Iterable[str],
                  starts: np.ndarray | None = None) -> dict[str, np.ndarray]:
    """The analysis of one block (a Dask task; also what the local loop runs).

    Returns the ``keys`` of ``analyse``'s output for the grid block ``region``
    (arrays of the block's shape, NumPy), ready for ``runner.check_results``.
    ``starts``: the block's lines' start points (``[analysis] seed_axis``),
    passed on as ``analyse(..., starts=starts)``.
    """
    from jaxwalk.grid import sub_grid
    from jaxwalk.models import get_model

    extra = {} if starts is None else {"starts": starts}
    out = analyse(get_model(model_name), dict(fixed), sub_grid(grid, region), continuation, options, **extra)
    return {k: np.asarray(out[k]) for k in keys if k in out}


@contextlib.contextmanager
def chunk_results(analyse: Callable, config, options, store, keys: Iterable[str],
                  dask: str | None = None, starts: np.ndarray | None = None,
                  ) -> Iterator[Iterator[tuple[int, dict[str, np.ndarray]]]]:
    """``(index, results)`` of every block ``store`` still needs, as they finish.

    Args:
        analyse: the analysis (``jaxwalk.grid.analyse_grid``'s signature).
        config: the sweep (model name, fixed values, axes, continuation).
        options: its ``AnalysisOptions``.
        store: the :class:`~jaxwalk.sweep.store.ChunkStore` (its ``pending`` blocks and regions).
        keys: the result keys to return.
        dask: ``None`` (this process, blocks in order), ``"local"`` (a
            LocalCluster on this machine) or a scheduler address (``tcp://host:8786``).
        starts: with ``[analysis] seed_axis``, the start points of every
            continuation line (``jaxwalk.seedline.SeedLines.starts``, the grid's
            shape without the continuation axis, plus ``(n_v,)``), computed once
            for the whole grid; each block gets its own lines' slice.

    Raises:
        ConfigError: ``dask`` is given but ``distributed`` is not installed or the
            scheduler cannot be reached (before anything is computed).
    """
    keys = tuple(keys)
    args = (analyse, config.model, dict(config.fixed), config.grid, config.continuation, options)
    along = None if config.continuation is None else config.dims.index(config.continuation)

    def block_starts(i: int) -> np.ndarray | None:
        if starts is None:
            return None
        region = store.region(i)
        return np.ascontiguousarray(starts[region[:along] + region[along + 1 :]])

    if dask is None:
        yield ((i, compute_chunk(*args, store.region(i), keys, block_starts(i))) for i in store.pending())
        return
    with dask_client(dask) as client:
        yield _on_dask(client, args, store, keys, block_starts)


def _on_dask(client, args, store, keys, block_starts) -> Iterator[tuple[int, dict[str, np.ndarray]]]:
    from distributed import as_completed

    window = max(2, TASKS_PER_THREAD * sum(client.nthreads().values()))
    pending = store.pending()
    tag = store.fingerprint["config"][:12]
    index_of = {}
    futures = as_completed()

    def submit(i: int) -> None:
        future = client.submit(compute_chunk, *args, store.region(i), keys, block_starts(i),
                               key=f"jaxwalk-chunk-{tag}-{i}", pure=False)
        index_of[future.key] = i
        futures.add(future)

    for i in islice(pending, window):
        submit(i)
    for future in futures:
        results = future.result()  # a task's exception is raised here; the store keeps what was done
        i = index_of.pop(future.key)
        future.release()
        nxt = next(pending, None)
        if nxt is not None:
            submit(nxt)
        yield i, results


def local_worker_env() -> dict[str, str]:
    """Environment of a ``--dask local`` worker: one XLA CPU device (one core) each,
    as there is one worker per core; other settings (``JAXWALK_CACHE_DIR``,
    ``EQX_ON_ERROR``) are inherited."""
    flags = _DEVICE_FLAG.sub("", os.environ.get("XLA_FLAGS", "")).strip()
    return {"XLA_FLAGS": f"{flags} --xla_force_host_platform_device_count=1".strip()}


@contextlib.contextmanager
def dask_client(address: str):
    """A ``distributed.Client`` of the scheduler at ``address``, or of a new
    LocalCluster (one single-threaded worker process per CPU core) for ``"local"``."""
    try:
        from distributed import Client, LocalCluster
    except ImportError:
        raise ConfigError("--dask needs the 'distributed' package: pip install 'jaxwalk[dask]'") from None
    if address == "local":
        n = os.cpu_count() or 1
        with LocalCluster(n_workers=n, threads_per_worker=1, processes=True, dashboard_address=None,
                          env=local_worker_env()) as cluster, Client(cluster) as client:
            yield client
        return
    try:
        client = Client(address, timeout=CONNECT_TIMEOUT)
    except (OSError, TimeoutError, ValueError) as err:
        raise ConfigError(f"--dask {address}: cannot reach the scheduler ({' '.join(str(err).split())})") from None
    with client:
        yield client
