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
``status`` (int, ``S``), ``lambda_max``, ``period``, ``step_length``, ``speed``,
``work`` (actuator work per step), ``cost_of_transport``,
``newton_iterations`` (``S``), ``eigenvalues`` (complex, ``S + (n_v,)``) and
``fixed_point`` (``S + (n_v,)``); when ``options.step_down`` is set (``[analysis]
h_max``) also ``h_max`` (float, ``S``; NaN where no gait), ``step_down_status``
(int, ``S``; the first failed drop's status, ``OK`` if none failed up to the
limit, the gait's status where there is no gait) and ``h_failed`` (float, ``S``;
the first failed drop's height, NaN if none); other keys are ignored.

With ``[analysis] seed_axis`` the runner first runs the seed lines
(:func:`jaxwalk.seedline.seed_lines`, the engine's own, whatever ``analyse``
is) and calls ``analyse(..., starts=...)`` with each block's start points
(:func:`jaxwalk.grid.analyse_chunk`); the seed lines are recorded in the
dataset's attributes (``seed_line_*``).

The runner calls it once per block of the grid (``grid`` is then the block's
sub-grid, ``jaxwalk.grid.sub_grid``; blocks hold whole continuation lines), in
this process or as a Dask task (:mod:`jaxwalk.sweep.chunks`), and writes each
block as it finishes (:mod:`jaxwalk.sweep.store`); within a block the analysis
owns batching and devices. :func:`check_results` holds each block to this contract.
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

from jaxwalk.models import get_model
from jaxwalk.status import RESULT_STATUSES, Status
from jaxwalk.sweep import attractors
from jaxwalk.sweep.config import DEFAULT_MAX_POINTS, ConfigError, SweepConfig, load_config

Analyse = Callable[..., Mapping[str, np.ndarray]]

#: Result arrays, with whether they carry a section-sized trailing axis.
RESULT_KEYS = {
    "status": False,
    "lambda_max": False,
    "eigenvalues": True,
    "fixed_point": True,
    "period": False,
    "step_length": False,
    "speed": False,
    "work": False,
    "cost_of_transport": False,
    "newton_iterations": False,
}
_FLOATS = ("lambda_max", "eigenvalues", "fixed_point", "period", "step_length", "speed", "work", "cost_of_transport")
#: Result arrays of the step-down test (``[analysis] h_max``), all of the grid's shape.
STEP_DOWN_KEYS = ("h_max", "step_down_status", "h_failed")
_VALID_CODES = np.array([int(s) for s in RESULT_STATUSES])
#: ``[analysis]`` keys and the ``NewtonOptions`` / ``SolverOptions`` fields they set.
_NEWTON_FIELDS = {"newton_tol": "tol", "max_newton_iter": "max_iter"}
_SOLVER_FIELDS = {"rtol": "rtol", "atol": "atol"}


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
    if not isinstance(config, SweepConfig):
        config = load_config(config, max_points=max_points)
    model = get_model(config.model)
    target = check_output(out_dir, config.name, overwrite=overwrite)
    options = analysis_options(config)
    if analyse is None:
        from jaxwalk import grid

        analyse = grid.analyse_grid
    if command is None:
        command = " ".join(shlex.quote(a) for a in sys.argv)

    if chunk_size is not None:
        options = dataclasses.replace(options, chunk_size=chunk_size)

    from jaxwalk.sweep.store import ChunkStore

    step_down = config.h_max is not None
    keys = {**RESULT_KEYS, **({k: False for k in STEP_DOWN_KEYS} if step_down else {}), **_global_keys(config)}
    n_v = len(model.section_names)
    attractor_keys = None if config.attractors is None else attractors.result_keys(config.attractors, n_v)
    keys.update(attractor_keys or {})
    store = ChunkStore.plan(  # checks a partial run and the disk space; writes nothing
        config, model, target, chunk_size=options.chunk_size, options=_as_attribute(options), result_keys=keys,
        command=command, overwrite=overwrite,
    )
    seeds = None
    if config.seed_axis is not None:  # once for the whole grid, before its blocks (jaxwalk.seedline)
        from jaxwalk.seedline import seed_lines

        seeds = seed_lines(model, config.fixed, config.grid, config.continuation, config.seed_axis, options)
    starts = None if seeds is None else seeds.starts
    _compute_blocks(config, analyse, options, store, keys, n_v, starts, progress=progress, dask=dask, command=command)
    if seeds is not None:
        from jaxwalk.seedline import dataset_attributes

        store.set_attributes(dataset_attributes(seeds))
    if config.bifurcations:  # from the whole lines written (jaxwalk.sweep.bifurcations)
        from jaxwalk.sweep.bifurcations import write_table

        write_table(config, model, store.store, options)
    store.finish()
    if plot:
        try:
            from jaxwalk.plot import plot_dataset

            plot_dataset(target, target.parent)  # read back: the figures show what was written
        except Exception as err:  # a figure is a convenience; the dataset is written
            warnings.warn(f"figures not written: {' '.join(str(err).split())}", stacklevel=2)
    return target


def _compute_blocks(config, analyse, options, store, keys, n_v: int, starts, *, progress: bool, dask, command: str) -> None:
    """Compute and write every block ``store`` still needs, with a progress bar; say
    first when an unfinished run is continued, and on Ctrl-C what was kept and how
    to continue (:class:`SweepInterrupted`); record this machine's speed (:mod:`timings`)."""
    from tqdm.auto import tqdm

    from jaxwalk.sweep.chunks import chunk_results

    step_down = config.h_max is not None
    attractor_keys = None if config.attractors is None else attractors.result_keys(config.attractors, n_v)
    started, traced_before, points_before = time.perf_counter(), program_cache_traces(), store.points_done
    if store.done:
        print(
            f"continuing the unfinished run in '{store.partial}': {len(store.done)} of {store.n_chunks} chunks "
            f"({store.points_done} of {config.n_points} points) were done", file=sys.stderr,
        )
    try:
        with chunk_results(analyse, config, options, store, keys, dask=dask, starts=starts) as finished:  # connects first
            bar = tqdm(total=config.n_points, initial=store.points_done, unit="pt", desc=config.name, disable=not progress)
            with bar:
                for index, results in finished:  # each block checked and on disk as soon as it is done
                    shape = tuple(r.stop - r.start for r in store.region(index))
                    checked = check_results(results, shape, n_v, stability=config.stability, step_down=step_down)
                    if attractor_keys is not None:
                        checked.update(attractors.check(results, checked["status"], attractor_keys))
                    store.write(index, {**checked, **_global_check(results, checked["status"], config)})
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
    from jaxwalk.sweep.config import _human_bytes
    from jaxwalk.sweep.store import ChunkStore

    model = get_model(config.model)
    target = check_output(out_dir, config.name, overwrite=overwrite)
    options = analysis_options(config)
    if chunk_size is not None:
        options = dataclasses.replace(options, chunk_size=chunk_size)
    keys = {**RESULT_KEYS, **({k: False for k in STEP_DOWN_KEYS} if config.h_max is not None else {})}
    store = ChunkStore.plan(
        config, model, target, chunk_size=options.chunk_size, options=_as_attribute(options), result_keys=keys,
        overwrite=overwrite,
    )
    shape = " x ".join(map(str, config.shape))
    todo = config.n_points - store.points_done
    lines = [
        f"{config.name}: {config.n_points:,} points ({shape}, {config.model} model) in {store.n_chunks:,} chunk"
        f"{'s' * (store.n_chunks != 1)} of {' x '.join(map(str, store.chunks))}",
        f"store: {target}, up to {_human_bytes(store.estimated_bytes())} on disk",
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
    by the solver settings ``[analysis]`` gives, with ``step_down`` set from
    ``[analysis] h_max`` when it is on."""
    from jaxwalk.grid import AnalysisOptions

    base = AnalysisOptions()
    solver = dataclasses.replace(base.solver, **{_SOLVER_FIELDS[k]: v for k, v in config.solver.items() if k in _SOLVER_FIELDS})
    newton = dataclasses.replace(base.newton, **{_NEWTON_FIELDS[k]: v for k, v in config.solver.items() if k in _NEWTON_FIELDS})
    step_down = None
    if config.h_max is not None:
        from jaxwalk.stepdown import StepDownOptions

        step_down = StepDownOptions(dh=config.h_max["step"], count=config.h_max["count"], n_steps=config.h_max["steps"])
    options = dataclasses.replace(base, solver=solver, newton=newton, step_down=step_down,
                                  attractors=attractors.options(config.attractors))
    if config.global_stability:  # [analysis] gait_sensitivity / mfpt (jaxwalk.global_stability)
        from jaxwalk.global_stability.options import global_options

        options = dataclasses.replace(options, global_stability=global_options(config.global_stability))
    return options


def _global_keys(config: SweepConfig) -> dict[str, bool]:
    if not config.global_stability:
        return {}
    from jaxwalk.global_stability.sweep import result_keys

    return result_keys(config.global_stability)


def _global_check(results, status, config: SweepConfig) -> dict[str, np.ndarray]:
    if not config.global_stability:
        return {}
    from jaxwalk.global_stability.sweep import check

    return check(results, status, config.global_stability)


def _as_attribute(options) -> dict:
    return dataclasses.asdict(options) if dataclasses.is_dataclass(options) else dict(options)


def check_output(out_dir: str | os.PathLike, name: str, *, overwrite: bool = False) -> Path:
    """``out_dir/<name>.zarr`` if it can be written; creates nothing.

    Raises:
        ConfigError: ``out_dir`` is not a directory or not writable, or the dataset
            exists and ``overwrite`` is false.
    """
    out = Path(out_dir)
    target = out / f"{name}.zarr"
    if out.exists() and not out.is_dir():
        raise ConfigError(f"--out '{out}' exists and is not a directory")
    existing = out
    while not existing.exists():
        if existing.parent == existing:
            break
        existing = existing.parent
    if not existing.is_dir():
        raise ConfigError(f"--out '{out}': '{existing}' is not a directory")
    if not os.access(existing, os.W_OK | os.X_OK):
        raise ConfigError(f"--out '{out}': '{existing}' is not writable")
    if (target.exists() or target.is_symlink()) and not overwrite:
        raise ConfigError(f"'{target}' already exists (pass --overwrite to replace it)")
    return target


def check_results(
    results: Mapping[str, np.ndarray],
    shape: tuple[int, ...],
    n_v: int,
    *,
    stability: bool = True,
    step_down: bool = False,
) -> dict[str, np.ndarray]:
    """Check the analysis output against the contract and make its failures explicit.

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
    keys = list(RESULT_KEYS) + (list(STEP_DOWN_KEYS) if step_down else [])
    missing = [k for k in keys if k not in results]
    if missing:
        raise ValueError(f"the analysis returned no {', '.join(missing)}")
    out = {}
    for key in keys:
        value = np.asarray(results[key])
        expected = shape + ((n_v,) if RESULT_KEYS.get(key, False) else ())
        if value.shape != expected:
            raise ValueError(f"the analysis returned '{key}' of shape {value.shape}, expected {expected}")
        out[key] = value
    for key in ("status", "step_down_status") if step_down else ("status",):
        codes = out[key]
        if not np.issubdtype(codes.dtype, np.integer):
            raise ValueError(f"the analysis returned '{key}' of dtype {codes.dtype}, expected an integer type")
        bad = ~np.isin(codes, _VALID_CODES)
        if bad.any():
            raise ValueError(f"the analysis returned {key} codes {sorted(set(codes[bad].tolist()))}, not dataset statuses")
    status = out["status"].astype(np.int8)
    if step_down:
        for key in ("h_max", "h_failed"):
            out[key] = out[key].astype(np.float64)
        if (out["h_max"] < 0).any():
            raise ValueError("the analysis returned a negative 'h_max'")
    out["eigenvalues"] = out["eigenvalues"].astype(np.complex128)
    for key in ("lambda_max", "fixed_point", "period", "step_length", "speed", "work", "cost_of_transport"):
        out[key] = out[key].astype(np.float64)
    out["newton_iterations"] = out["newton_iterations"].astype(np.int32)

    required = ["fixed_point", "period", "step_length", "speed", "work", "cost_of_transport"] + (["lambda_max", "eigenvalues"] if stability else [])
    required += ["h_max"] if step_down else []
    finite = np.ones(shape, bool)
    for key in required:
        ok = np.isfinite(out[key])
        finite &= ok.all(axis=-1) if RESULT_KEYS.get(key, False) else ok
    status = np.where((status == Status.OK) & ~finite, np.int8(Status.NONFINITE), status).astype(np.int8)
    if not stability:  # not asked for: absent, whatever the analysis computed
        out["lambda_max"] = np.full(shape, np.nan)
        out["eigenvalues"] = np.full(shape + (n_v,), complex(np.nan, np.nan))
    failed = status != Status.OK
    for key in _FLOATS:
        mask = failed[..., None] if RESULT_KEYS[key] else failed
        nan = complex(np.nan, np.nan) if key == "eigenvalues" else np.nan
        out[key] = np.where(mask, nan, out[key])
    out["status"] = status
    if step_down:  # no gait, no step-down: its status is the gait's
        out["h_max"] = np.where(failed, np.nan, out["h_max"])
        drop_status = np.where(failed, status, out["step_down_status"]).astype(np.int8)
        out["step_down_status"] = drop_status
        out["h_failed"] = np.where(failed | (drop_status == Status.OK), np.nan, out["h_failed"])
    return out
