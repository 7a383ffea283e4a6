"""Stability over a Cartesian grid of parameters, in chunks, on every CPU core.

``analyse_grid`` cuts the grid into blocks (``chunk_shape``: at most
``chunk_size`` points, whole continuation lines) and runs ``analyse_chunk`` on
each; ``jaxwalk sweep`` runs the same blocks one by one (or on a Dask cluster)
and streams each to disk. ``analyse_chunk`` lays its block out as one
batch of configurations (or, with continuation, as lines along one axis),
cuts it into chunks, runs each chunk as one jitted ``vmap`` program split
over one worker thread per CPU device (``XLA_FLAGS=
--xla_force_host_platform_device_count`` gives one per core; the threads share
one compiled program), and returns NumPy arrays shaped like the grid.
"""

from __future__ import annotations

import dataclasses
import functools
from typing import Callable, Mapping

import jax
import numpy as np

from jaxwalk import compiling, program_cache
from jaxwalk.analyses.gait import OUTPUTS as GAIT_OUTPUTS
from jaxwalk.attractor import AttractorOptions
from jaxwalk.batching import sub_batch_size
from jaxwalk.batching import Rows, over_rows, run_chunks as _run_chunks
from jaxwalk.continuation import checked_guess, fill_starts, seed_index, start_value
from jaxwalk.errors import ConfigError
from jaxwalk.gait import Gait, NewtonOptions, find_gait
from jaxwalk.lines import run_lines
from jaxwalk.parameters import parameter_grid as parameter_grid
from jaxwalk.step import SolverOptions
from jaxwalk.stepdown import StepDownOptions
from jaxwalk.walker import Walker


@dataclasses.dataclass(frozen=True)
class AnalysisOptions:
    """Settings of a grid analysis.

    Attributes:
        solver, newton: integration and fixed-point settings.
        chunk_size: grid points per chunk (a block of the grid, the unit of
            work, of resuming and of the dataset's zarr chunks; with
            continuation, ``chunk_size // line length`` whole lines, at least
            one); also the rows per jitted call, rounded up to a multiple of
            the worker threads (``jaxwalk.workers``).
        step_down: settings of the global-stability test (the paper's h_m);
            ``None`` skips it.
        attractors: settings of the attractor search (:mod:`jaxwalk.attractor`);
            ``None`` skips it.
        global_stability: the gait sensitivity norm and the MFPT
            (:class:`jaxwalk.global_stability.options.GlobalOptions`); ``None`` skips them.
        more: ``(name, options)`` of the other analyses to run (:mod:`jaxwalk.analyses`
            plug-ins without a field here), in any order; by default the one
            that is on by default in a config too, ``failure_cause``
            (:mod:`jaxwalk.analyses.failure`).
        gait_guess: with continuation, Newton's first start at every line's seed
            point (``(n_v,)`` section coordinates) in place of the model's
            :meth:`~jaxwalk.walker.Walker.initial_guess`, where the line has no
            start of its own (a seed line's gait); ``None``: the model's.
        gait_guess_at: ``((name, value), ...)``: where the guessed gait is; a
            line along (or a seed line along) a named axis starts at its grid
            value nearest there (:func:`jaxwalk.continuation.start_value`).
    """

    solver: SolverOptions = SolverOptions()
    newton: NewtonOptions = NewtonOptions()
    chunk_size: int = 256
    step_down: StepDownOptions | None = None
    attractors: AttractorOptions | None = None
    global_stability: object | None = None
    more: tuple[tuple[str, object], ...] = (("failure_cause", True),)
    gait_guess: tuple[float, ...] | None = None
    gait_guess_at: tuple[tuple[str, float], ...] = ()


@functools.lru_cache(maxsize=None)
def _independent_program(model: Walker, solver: SolverOptions, newton: NewtonOptions):
    """Gait searches from the model's guess, :func:`sub_batch_size` configurations
    at a time: a vmapped while loop runs until its slowest element is done, so
    each sub-batch of neighbouring grid points (similar iteration and step
    counts) stops on its own."""

    def one(p, _):
        return find_gait(model, p, model.initial_guess(p), solver, newton)

    program = compiling.jit(over_rows(one, sub_batch_size(model, solver)), model)
    program_cache.register(program, "independent", model, solver, newton)
    return program


def chunk_shape(shape: tuple[int, ...], chunk_size: int, along: int | None = None) -> tuple[int, ...]:
    """Shape of the blocks a grid of ``shape`` is cut into: at most ``chunk_size``
    points each, filled from the last axis (so a block is contiguous in C order
    when it can be); with continuation along axis ``along``, every block holds
    whole lines along it (``chunk_size // shape[along]`` of them, at least one),
    so each line's warm starts run as in one uninterrupted pass."""
    chunks = [1] * len(shape)
    budget = max(1, chunk_size)
    if along is not None:
        chunks[along] = shape[along]
        budget = max(1, chunk_size // shape[along])
    for k in reversed(range(len(shape))):
        if k == along:
            continue
        chunks[k] = min(shape[k], budget)
        budget = budget // shape[k] if chunks[k] == shape[k] else 1
    return tuple(chunks)


def chunk_count(shape: tuple[int, ...], chunks: tuple[int, ...]) -> tuple[int, ...]:
    """Chunks along each axis (the last ones may be partial)."""
    return tuple(-(-n // c) for n, c in zip(shape, chunks))


def chunk_region(shape: tuple[int, ...], chunks: tuple[int, ...], index: int) -> tuple[slice, ...]:
    """The grid indices of chunk ``index`` (chunks numbered in C order of the chunk grid)."""
    where = np.unravel_index(index, chunk_count(shape, chunks))
    return tuple(slice(int(i) * c, min((int(i) + 1) * c, n)) for i, c, n in zip(where, chunks, shape))


def sub_grid(grid: Mapping[str, np.ndarray], region: tuple[slice, ...]) -> dict[str, np.ndarray]:
    """The axes of the block ``region`` of ``grid``: itself a grid (their product)."""
    return {name: np.asarray(values)[r] for (name, values), r in zip(grid.items(), region)}


def analyse_grid(
    model: Walker,
    fixed: Mapping[str, float],
    grid: Mapping[str, np.ndarray],
    continuation_axis: str | None = None,
    options: AnalysisOptions = AnalysisOptions(),
    progress: Callable[[int], None] | None = None,
    *,
    seed_axis: str | None = None,
    starts: np.ndarray | None = None,
) -> dict[str, np.ndarray]:
    """Fixed point, Jacobian eigenvalues and step metrics over a parameter grid.

    The grid is cut into blocks of :func:`chunk_shape` (``options.chunk_size``
    points, whole continuation lines) and each block is one call of
    :func:`analyse_chunk`; ``jaxwalk sweep`` makes the same calls and streams
    each block to disk instead of holding the grid (``jaxwalk.sweep.store``).
    Arguments and results as :func:`analyse_chunk`, for the whole grid.

    With ``seed_axis`` (a grid axis other than the continuation axis), seed
    lines along it run first (:func:`jaxwalk.seedline.seed_lines`) and every
    continuation line starts from their gait at its point; the result then
    also holds ``seed_line_status`` and ``seed_line_fixed_point`` (the grid's
    shape without the continuation axis). ``starts`` gives those start points
    directly instead (as :func:`analyse_chunk`).
    """
    shape = tuple(len(np.atleast_1d(grid[a])) for a in grid)
    along = None if continuation_axis is None else list(grid).index(continuation_axis)
    chunks = chunk_shape(shape, options.chunk_size, along)
    out: dict[str, np.ndarray] = {}
    if (seed_axis is not None or starts is not None) and continuation_axis is None:
        raise ValueError("seed lines and start points need a continuation axis")
    if seed_axis is not None:
        from jaxwalk.seedline import seed_lines

        seeds = seed_lines(model, fixed, grid, continuation_axis, seed_axis, options)
        starts = seeds.starts
        out["seed_line_status"], out["seed_line_fixed_point"] = seeds.status, seeds.v
    for index in range(int(np.prod(chunk_count(shape, chunks)))):
        region = chunk_region(shape, chunks, index)
        block_starts = None if starts is None else starts[region[:along] + region[along + 1 :]]
        part = analyse_chunk(model, fixed, sub_grid(grid, region), continuation_axis, options, starts=block_starts)
        for key, value in part.items():
            if key not in out:
                out[key] = np.empty(shape + value.shape[len(shape) :], value.dtype)
            out[key][region] = value
        if progress is not None:
            progress(int(np.prod([r.stop - r.start for r in region])))
    return out


def analyse_chunk(
    model: Walker,
    fixed: Mapping[str, float],
    grid: Mapping[str, np.ndarray],
    continuation_axis: str | None = None,
    options: AnalysisOptions = AnalysisOptions(),
    progress: Callable[[int], None] | None = None,
    *,
    starts: np.ndarray | None = None,
) -> dict[str, np.ndarray]:
    """Fixed point, Jacobian eigenvalues and step metrics over a grid held in memory at once.

    Called on a block of a larger grid (:func:`sub_grid`), it gives bit for bit
    the numbers the larger grid has there, as long as the block holds whole
    continuation lines: every configuration (or line) is computed on its own,
    whatever its batch neighbours, padding or thread (test_lockstep, test_workers). A
    block holding a line of the continuation axis in full starts it from the same seed.

    Args:
        model: the walker.
        fixed: parameter values held fixed (others at their defaults).
        grid: swept axes, ``name -> 1-D values``; the grid is their product, in order.
        continuation_axis: a name in ``grid`` to continue along, or ``None``
            for independent searches from the model's initial guess.
        options: solver, Newton, chunking and analysis settings.
        progress: called with the number of configurations finished after each chunk.
        starts: with continuation only: start points of the lines' seed points,
            shaped like the grid without the continuation axis, plus ``(n_v,)``;
            NaN where a line has none (it starts from ``options.gait_guess``, else
            from ``model.initial_guess``).
            ``jaxwalk.seedline`` makes them; a block's are the same slice of
            the whole grid's whoever computes it, so its lines run alike.

    Returns:
        Arrays with the grid's shape ``S`` in front: the gait's outputs
        (:mod:`jaxwalk.analyses.gait`, each cast to its declared dtype:
        ``status`` int8, ``lambda_max``, ``eigenvalues`` complex ``S + (n_v,)``,
        ``fixed_point`` ``S + (n_v,)``, ``period``, ``step_length``, ``speed``,
        ``work``, ``cost_of_transport``, ``newton_iterations`` int32), the
        step-to-step ``jacobian`` ``S + (n_v, n_v)`` (not written to a
        dataset); and the outputs of the analyses ``options`` asks for
        (:func:`_beyond_the_gait`; their declarations are :mod:`jaxwalk.analyses`).
    """
    params = parameter_grid(model, fixed, grid)
    axes = list(grid)
    shape = tuple(len(np.atleast_1d(grid[a])) for a in axes)
    if continuation_axis is None:
        if options.gait_guess is not None:  # independent points start from the model's guess: refuse, not ignore
            raise ConfigError("gait_guess needs a continuation axis (the lines start from it)")
        rows = Rows({k: v.reshape(-1) for k, v in params.items()})
        program = _independent_program(model, options.solver, options.newton)
        gaits = _run_chunks(program, rows, options.chunk_size, progress)
        unflatten = lambda x: x.reshape(shape + x.shape[1:])
    else:
        k = axes.index(continuation_axis)
        values = np.asarray(grid[continuation_axis], np.float64)
        seed = seed_index(values, start_value(model, continuation_axis, fixed, values, dict(options.gait_guess_at)))
        moved = {n: np.moveaxis(v, k, -1) for n, v in params.items()}
        moved_shape = next(iter(moved.values())).shape
        rows = {n: v.reshape(-1, len(values)) for n, v in moved.items()}
        if starts is not None:
            starts = np.asarray(starts, np.float64).reshape(-1, len(model.section_names))
        starts = fill_starts(starts, next(iter(rows.values())).shape[0], checked_guess(model, options))
        gaits = run_lines(model, rows, values, seed, options.solver, options.newton, options.chunk_size, starts, progress)

        def unflatten(x):
            x = x.reshape(moved_shape + x.shape[2:])
            return np.moveaxis(x, len(shape) - 1, k)

    gaits = jax.tree_util.tree_map(unflatten, gaits)
    out = {o.name: np.asarray(getattr(gaits, o.source)).astype(o.dtype) for o in GAIT_OUTPUTS}
    # Not a dataset variable: the attractor search starts from it (Block.results).
    out["jacobian"] = gaits.jacobian
    out.update(_beyond_the_gait(model, params, gaits, out, options))
    return out


def _beyond_the_gait(model: Walker, params, gaits: Gait, out, options: AnalysisOptions) -> dict[str, np.ndarray]:
    """The outputs of the analyses that start from a block's gaits (:mod:`jaxwalk.analyses`),
    each only when ``options`` asks for it, in the registry's order (a later one
    sees the earlier ones' outputs); arrays of the grid's shape."""
    from jaxwalk.analyses import Block, plugins

    results = dict(out)
    run = lambda program, rows: _run_chunks(program, rows, options.chunk_size, None)  # noqa: E731
    for analysis in plugins():
        if analysis.options_of(options) is not None:
            block = Block(model, params, gaits, results, options, sub_batch_size(model, options.solver), run)
            results.update(analysis.compute(block))
    return {k: v for k, v in results.items() if k not in out}
