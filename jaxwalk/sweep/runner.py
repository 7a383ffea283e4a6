"""Run a sweep: config in, the analysis over its grid, dataset out.

The analysis is :func:`jaxwalk.grid.analyse_grid` (imported only when a sweep
runs, so configs can be checked without it). Any function with its signature
may be passed instead as ``analyse=``::

    analyse(model, fixed, grid, continuation_axis, options, progress=None) -> dict[str, np.ndarray]

with ``fixed`` every non-swept parameter (``{name: float}``), ``grid`` the swept
axes in grid order (``{name: (n_i,) float64}``), ``continuation_axis`` a key of
``grid`` or ``None``, ``options`` a :class:`jaxwalk.grid.AnalysisOptions` made
from ``[analysis]`` (:func:`analysis_options`), and ``progress`` a callable
taking the number of grid points just finished. For grid shape ``S`` it returns
the outputs every active analysis declares (:mod:`jaxwalk.analyses`): the
gait's always (``status``, ``lambda_max``, ``eigenvalues``, ``fixed_point``,
``period``, ``step_length``, ``speed``, ``work``, ``cost_of_transport``,
``newton_iterations``: :mod:`jaxwalk.analyses.gait`), and those of each
analysis ``options`` asks for (``[analysis] h_max``: ``h_max``,
``step_down_status``, ``h_failed``, :mod:`jaxwalk.analyses.step_down`; ...),
each with the grid's shape ``S`` plus its declared trailing axes; other keys
are ignored.

With ``[analysis] seed_axis`` the runner first runs the seed lines
(:func:`jaxwalk.seedline.seed_lines`, the engine's own, whatever ``analyse``
is) and calls ``analyse(..., starts=...)`` with each block's start points
(:func:`jaxwalk.grid.analyse_chunk`); the seed lines are recorded in the
dataset's attributes (``seed_line_*``).

The runner calls it once per block of the grid (``grid`` is then the block's
sub-grid, ``jaxwalk.grid.sub_grid``; blocks hold whole continuation lines), in
this process or as a Dask task (:mod:`jaxwalk.sweep.chunks`), and writes each
block as it finishes (:mod:`jaxwalk.sweep.store`); within a block the analysis
owns batching and devices. :func:`jaxwalk.analyses.check_block` holds each block to this contract.
"""

from __future__ import annotations

import dataclasses
import os
import shlex
import sys
import time
import warnings
from pathlib import Path
from typing import Callable, Mapping

import numpy as np

from jaxwalk import analyses
from jaxwalk.analyses import gait, step_down
from jaxwalk.analyses.step_down import ANALYSIS as step_down_analysis
from jaxwalk.configs import NEWTON_FIELDS, SOLVER_FIELDS
from jaxwalk.errors import ConfigError
from jaxwalk.files import check_output as check_output  # the output directory and dataset check
from jaxwalk.models import get_model
from jaxwalk.sweep.config import DEFAULT_MAX_POINTS, SweepConfig, load_config

Analyse = Callable[..., Mapping[str, np.ndarray]]

#: The gait's result arrays, with whether they carry a section-sized trailing axis
#: (declared in :mod:`jaxwalk.analyses.gait`).
RESULT_KEYS = {o.name: bool(o.trailing) for o in gait.OUTPUTS}
#: Result arrays of the step-down test (``[analysis] h_max``, :mod:`jaxwalk.analyses.step_down`), all of the grid's shape.
STEP_DOWN_KEYS = tuple(o.name for o in step_down.OUTPUTS)


def run_sweep(
    config: SweepConfig | str | os.PathLike,
    out_dir: str | os.PathLike,
    progress: bool = True,
    *,
    analyse: Analyse | None = None,
    overwrite: bool = False,
    plot: bool = True,
    command: str | None = None,
    max_points: int = DEFAULT_MAX_POINTS,
    chunk_size: int | None = None,
    dask: str | None = None,
) -> Path:
    """Run the sweep ``config`` and write ``out_dir/<name>.zarr``; return that path.

    The grid is computed block by block (``chunk_size`` points, whole
    continuation lines), each block written to ``out_dir/.<name>.zarr.partial``
    as soon as it is done; the finished store is renamed into place. A run
    that was killed or failed is continued by the same call (same config,
    options and ``chunk_size``): see :mod:`jaxwalk.sweep.store`.

    Args:
        config: a :class:`SweepConfig` or the path of a TOML config.
        out_dir: output directory (created if needed).
        progress: show a progress bar (on stderr).
        analyse: the analysis function (default :func:`jaxwalk.grid.analyse_grid`),
            called once per block with the block's sub-grid.
        overwrite: replace an existing dataset of the same name (and discard
            an unfinished run of a different sweep instead of refusing).
        plot: also write its figures, ``out_dir/<name>_<variable>_<kind>.png`` (:mod:`jaxwalk.plot`).
        command: command line recorded in the dataset (default: ``sys.argv``).
        max_points: grid size limit when ``config`` is a path.
        chunk_size: points per block (default ``AnalysisOptions.chunk_size``).
        dask: compute the blocks on a Dask cluster: a scheduler address, or
            ``"local"`` for a LocalCluster on this machine (:mod:`jaxwalk.sweep.chunks`).

    Raises:
        ConfigError: bad config or output directory, an unfinished run of a
            different sweep there, or too little disk space, before anything is
            computed or written.
    """
    config, model, target, options = _prepare(config, out_dir, max_points=max_points, overwrite=overwrite, chunk_size=chunk_size)
    if analyse is None:
        from jaxwalk import grid

        analyse = grid.analyse_grid
    if command is None:
        command = " ".join(shlex.quote(a) for a in sys.argv)
    store = _plan_store(config, model, target, options, command=command, overwrite=overwrite)  # checks; writes nothing
    seeds = None
    if config.seed_axis is not None:  # once for the whole grid, before its blocks (jaxwalk.seedline)
        from jaxwalk.seedline import seed_lines

        seeds = seed_lines(model, config.fixed, config.grid, config.continuation, config.seed_axis, options)
    starts = None if seeds is None else seeds.starts
    _compute_blocks(config, analyse, options, store, starts, progress=progress, dask=dask, command=command)
    _finish(config, model, store, options, seeds, progress)
    if plot:
        try:
            from jaxwalk.plot import plot_dataset

            plot_dataset(target, target.parent)  # read back: the figures show what was written
        except Exception as err:  # a figure is a convenience; the dataset is written
            warnings.warn(f"figures not written: {' '.join(str(err).split())}", stacklevel=2)
    return target


def _prepare(config, out_dir, *, max_points: int, overwrite: bool, chunk_size: int | None):
    """``(config, model, target, options)``: the config read and checked, the output path
    checked, the analysis options with ``chunk_size``. Raises ConfigError."""
    if not isinstance(config, SweepConfig):
        config = load_config(config, max_points=max_points)
    model = get_model(config.model)
    target = check_output(out_dir, config.name, overwrite=overwrite)
    options = analysis_options(config)
    if chunk_size is not None:
        options = dataclasses.replace(options, chunk_size=chunk_size)
    return config, model, target, options


def _plan_store(config, model, target, options, *, command: str = "", overwrite: bool = False):
    from jaxwalk.sweep.store import ChunkStore

    return ChunkStore.plan(config, model, target, chunk_size=options.chunk_size, options=_as_attribute(options, model),
                           command=command, overwrite=overwrite)


def _finish(config, model, store, options, seeds, progress: bool = True) -> None:
    """After every block: the seed lines' attributes, the analyses of the whole grid
    (:attr:`~jaxwalk.analyses.base.Analysis.whole_grid`), then the store renamed into place."""
    if seeds is not None:
        from jaxwalk.seedline import dataset_attributes

        store.set_attributes(dataset_attributes(seeds))
    whole = [(a, resolved) for a, resolved in analyses.active(config) if a.whole_grid]
    if whole:  # from the whole lines written
        from jaxwalk.grid import parameter_grid

        params = parameter_grid(model, config.fixed, config.grid)
        for analysis, _ in whole:
            analysis.finish(config, model, store.store, options, params, progress=progress)
    store.finish()


def _compute_blocks(config, analyse, options, store, starts, *, progress: bool, dask, command: str) -> None:
    """Compute and write every block ``store`` still needs, with a progress bar; say
    first when an unfinished run is continued, and on Ctrl-C what was kept and how
    to continue (:class:`SweepInterrupted`); record this machine's speed (:mod:`timings`)."""
    from tqdm.auto import tqdm

    from jaxwalk.progress import shown as stage_bars
    from jaxwalk.sweep.chunks import chunk_results

    act = analyses.active(config)
    n_v = len(get_model(config.model).section_names)
    keys = [o.name for o in analyses.outputs(act)]
    started, traced_before, points_before = time.perf_counter(), program_cache_traces(), store.points_done
    if store.done:
        print(
            f"continuing the unfinished run in '{store.partial}': {len(store.done)} of {store.n_chunks} chunks "
            f"({store.points_done} of {config.n_points} points) were done", file=sys.stderr,
        )
    try:
        with chunk_results(analyse, config, options, store, keys, dask=dask, starts=starts) as finished:  # connects first
            bar = tqdm(total=config.n_points, initial=store.points_done, unit="pt", desc=config.name, disable=not progress)
            with bar, stage_bars(progress):  # the heavy analyses' own bars, under this one
                for index, results in finished:  # each block checked and on disk as soon as it is done
                    shape = tuple(r.stop - r.start for r in store.region(index))
                    store.write(index, analyses.check_block(results, shape, n_v, act))
                    bar.update(store.points_in(index))
    except KeyboardInterrupt:
        raise SweepInterrupted(interrupted_message(store, config.n_points, command)) from None
    if getattr(analyse, "__module__", None) == "jaxwalk.grid" and dask is None:  # this machine's speed, for --dry-run
        from jaxwalk.sweep import timings

        points = config.n_points - points_before
        timings.record(config, time.perf_counter() - started, points, program_cache_traces() > traced_before)


def program_cache_traces() -> int:
    """Grid programs traced so far in this process (0 if the analysis never loaded)."""
    module = sys.modules.get("jaxwalk.program_cache")
    return module.counts["traced"] if module is not None else 0


def dry_run(config: SweepConfig, out_dir, *, chunk_size: int | None = None, overwrite: bool = False) -> str:
    """What ``run_sweep`` would do, computing nothing: points, chunks, store size, time when known.

    Raises:
        ConfigError: as ``run_sweep`` would, before computing.
    """
    from jaxwalk.sweep import timings
    from jaxwalk.configs import human_bytes

    config, model, target, options = _prepare(config, out_dir, max_points=DEFAULT_MAX_POINTS, overwrite=overwrite,
                                              chunk_size=chunk_size)
    store = _plan_store(config, model, target, options, overwrite=overwrite)
    shape = " x ".join(map(str, config.shape))
    todo = config.n_points - store.points_done
    lines = [
        f"{config.name}: {config.n_points:,} points ({shape}, {config.model} model) in {store.n_chunks:,} chunk"
        f"{'s' * (store.n_chunks != 1)} of {' x '.join(map(str, store.chunks))}",
        f"store: {target}, up to {human_bytes(store.estimated_bytes())} on disk",
    ]
    if store.done:
        lines.append(f"continues an unfinished run: {len(store.done)} of {store.n_chunks} chunks done, {todo:,} points to go")
    guess = timings.estimate(config, todo)
    lines.append(f"time: {guess}" if guess else f"time: unknown (no earlier {config.model} run of this kind on this machine)")
    return "\n".join(lines)


class SweepInterrupted(KeyboardInterrupt):
    """Ctrl-C during a sweep; its message says what was kept and the command that continues."""


def interrupted_message(store, n_points: int, command: str) -> str:
    """``"interrupted: kept 3 of 12 chunks (768 of 3072 points) in '...'; continue with: ..."``."""
    if not store.done or not store.partial.exists():
        return "interrupted before the first chunk was done: nothing kept"
    return (
        f"interrupted: kept {len(store.done)} of {store.n_chunks} chunks ({store.points_done} of {n_points} points) "
        f"in '{store.partial}'; continue with: {command}"
    )


def analysis_options(config: SweepConfig):
    """The :class:`jaxwalk.grid.AnalysisOptions` of ``config``: its defaults, updated
    by the solver settings ``[analysis]`` gives, with the grid options of every
    analysis that is on (:meth:`jaxwalk.analyses.base.Analysis.grid_options`: its
    own field, or ``more``)."""
    from jaxwalk.grid import AnalysisOptions

    base = AnalysisOptions()
    solver = dataclasses.replace(base.solver, **{SOLVER_FIELDS[k]: v for k, v in config.solver.items() if k in SOLVER_FIELDS})
    newton = dataclasses.replace(base.newton, **{NEWTON_FIELDS[k]: v for k, v in config.solver.items() if k in NEWTON_FIELDS})
    fields, more = {}, []
    for analysis, resolved in analyses.active(config):
        grid_options = analysis.grid_options(resolved) if analysis.name != "gait" else None
        if grid_options is None:
            continue
        if analysis.options_field is not None:
            fields[analysis.options_field] = grid_options
        else:
            more.append((analysis.name, grid_options))
    guess = {} if config.gait_guess is None else {
        "gait_guess": tuple(config.gait_guess), "gait_guess_at": tuple(sorted(config.gait_guess_at.items()))}
    return dataclasses.replace(base, solver=solver, newton=newton, **fields, more=tuple(more), **guess)


def _as_attribute(options, model) -> dict:
    """The options as recorded in a dataset (and in a partial run's fingerprint):
    every field (the controller's safety as ``model`` resolves it), the analyses
    of ``more`` under their names, and only when on (so adding an analysis
    changes no earlier sweep's record)."""
    if not dataclasses.is_dataclass(options):
        return dict(options)
    record = dataclasses.asdict(options)
    if hasattr(options, "solver"):  # a solver object by name, not by its fields
        record["solver"] = options.solver.as_record(model)
    record.update(dict(record.pop("more", ())))
    for key in ("gait_guess", "gait_guess_at"):  # only when given, so earlier sweeps' records stand
        if not record.get(key):
            record.pop(key, None)
    return record


def check_results(
    results: Mapping[str, np.ndarray],
    shape: tuple[int, ...],
    n_v: int,
    *,
    stability: bool = True,
    step_down: bool = False,
) -> dict[str, np.ndarray]:
    """Check the gait's (and with ``step_down`` the step-down test's) output against
    the contract and make its failures explicit (:func:`jaxwalk.analyses.check_block`).

    Shapes and status codes must match (``ValueError`` otherwise). Then: where
    ``status != 0`` every float is set to NaN; where ``status == 0`` but a number
    that should exist is not finite, the status becomes ``NONFINITE`` and the
    floats NaN. Without ``stability``, ``lambda_max`` and the eigenvalues are
    not required and are written as NaN.

    With ``step_down`` (``[analysis] h_max``) the :data:`STEP_DOWN_KEYS` are
    required too (a negative ``h_max`` is a ``ValueError``): ``h_max`` is one
    of the numbers that must exist where the gait's ``status`` is 0 (a NaN there
    makes the point ``NONFINITE``) and is NaN exactly where ``status != 0``;
    there ``step_down_status`` is the gait's status and ``h_failed`` NaN, as it
    is wherever ``step_down_status`` is 0 (no drop failed). Without
    ``step_down`` those keys are ignored.

    Returns:
        New arrays: status int8, newton_iterations int32, eigenvalues complex128,
        the rest float64; with ``step_down`` also step_down_status int8, h_max
        and h_failed float64.
    """
    settings = {"gait": stability, **({step_down_analysis.name: {}} if step_down else {})}
    return analyses.check_block(results, shape, n_v, analyses.active_settings(settings))
