"""Seed lines: where continuation lines start, found by continuation along another axis.

A sweep continued along axis A runs one line along A per point of the other
axes, each started at its seed point (the A value nearest the one the guess
was made at, :meth:`jaxwalk.walker.Walker.seed_value`; most often A's default)
from the model's initial guess. Far
from them along another axis B (the flat-foot walker's foot length, say) that
guess misses the gait and the whole line is lost. With ``[analysis] seed_axis
= "B"`` a *seed line* first runs along B at A's seed value, itself continued
from B's seed (the B value nearest its seed value; with ``[analysis]
gait_guess`` from that guess, at ``gait_guess_at`` where it names B) up then down, exactly as
:func:`jaxwalk.lines.run_lines` walks any line; every A-line then
starts its seed point from the seed line's gait at its B value (from the
model's guess, or the ``gait_guess``, where the seed line failed there). With more than two axes
there is one seed line per combination of the others.

The seed lines run once for the whole grid, before its blocks; each block is
handed the start points of its own lines (``starts`` of
:func:`jaxwalk.grid.analyse_chunk`), so a block gets the same starts whichever
process computes it and whether or not the run was resumed. They run the
A-lines' compiled program (lines of every length do: :mod:`jaxwalk.lines`).
"""

from __future__ import annotations

import json
from typing import Mapping, NamedTuple

import numpy as np

from jaxwalk.continuation import checked_guess, fill_starts, seed_index, start_value
from jaxwalk.lines import run_lines
from jaxwalk.parameters import parameter_grid
from jaxwalk.walker import Walker


class SeedLines(NamedTuple):
    """The seed lines of a grid, on the grid without its continuation axis A.

    Attributes:
        axis: the seed axis B.
        at: ``{A: A's seed value}``, where the seed lines run.
        dims: the grid's axes without A, in grid order (the shape ``O`` below).
        status: ``O`` int8 status of each seed-line point.
        v: ``O + (n_v,)`` its fixed point, NaN where ``status != 0``: also the
            start points of the A-lines (``starts``).
        newton_iterations: ``O`` int32.
    """

    axis: str
    at: dict[str, float]
    dims: tuple[str, ...]
    status: np.ndarray
    v: np.ndarray
    newton_iterations: np.ndarray

    @property
    def starts(self) -> np.ndarray:
        """Start points of the continuation lines (``starts`` of ``analyse_chunk``)."""
        return self.v


def check_axes(grid: Mapping[str, np.ndarray], continuation_axis: str | None, seed_axis: str) -> None:
    """``ValueError`` unless ``seed_axis`` is a grid axis other than the continuation axis."""
    if continuation_axis is None:
        raise ValueError(f"seed_axis = '{seed_axis}' needs a continuation axis")
    if seed_axis not in grid:
        raise ValueError(f"seed_axis = '{seed_axis}' is not a grid axis (axes: {', '.join(grid)})")
    if seed_axis == continuation_axis:
        raise ValueError(f"seed_axis = '{seed_axis}' is the continuation axis; name another grid axis")


def seed_lines(model: Walker, fixed: Mapping[str, float], grid: Mapping[str, np.ndarray],
               continuation_axis: str, seed_axis: str, options) -> SeedLines:
    """Run the seed lines along ``seed_axis`` at the continuation axis's seed value.

    Args:
        model, fixed, grid, options: as :func:`jaxwalk.grid.analyse_grid`.
        continuation_axis: A, the axis the grid's lines follow.
        seed_axis: B, another grid axis.
    """
    check_axes(grid, continuation_axis, seed_axis)
    axes = list(grid)
    a_values = np.asarray(grid[continuation_axis], np.float64)
    guess_at = dict(options.gait_guess_at)
    a_seed = float(a_values[seed_index(a_values, start_value(model, continuation_axis, fixed, a_values, guess_at))])
    sub = {name: (np.array([a_seed]) if name == continuation_axis else np.asarray(values, np.float64))
           for name, values in grid.items()}
    params = {n: np.squeeze(v, axes.index(continuation_axis)) for n, v in parameter_grid(model, fixed, sub).items()}
    dims = tuple(a for a in axes if a != continuation_axis)
    k = dims.index(seed_axis)
    b_values = np.asarray(grid[seed_axis], np.float64)
    moved = {n: np.moveaxis(v, k, -1) for n, v in params.items()}
    moved_shape = next(iter(moved.values())).shape
    rows = {n: v.reshape(-1, len(b_values)) for n, v in moved.items()}
    seed_b = seed_index(b_values, start_value(model, seed_axis, fixed, b_values, guess_at))
    starts = fill_starts(None, next(iter(rows.values())).shape[0], checked_guess(model, options))
    gaits = run_lines(model, rows, b_values, seed_b, options.solver, options.newton, options.chunk_size, starts)

    def back(x):
        x = np.asarray(x).reshape(moved_shape + x.shape[2:])
        return np.moveaxis(x, len(dims) - 1, k)

    status = back(gaits.status).astype(np.int8)
    v = np.where((status == 0)[..., None], back(gaits.v), np.nan)
    v = np.where(np.isfinite(v).all(axis=-1, keepdims=True), v, np.nan)
    return SeedLines(seed_axis, {continuation_axis: a_seed}, dims, status, v, back(gaits.iterations).astype(np.int32))


def dataset_attributes(seeds: SeedLines | None) -> dict[str, str]:
    """The seed lines as global attributes of a sweep's dataset (JSON strings;
    ``seed_line_fixed_point`` has ``null`` where the seed line failed)."""
    if seeds is None:
        return {}
    v = [[None if not np.isfinite(x) else float(x) for x in row] for row in seeds.v.reshape(-1, seeds.v.shape[-1])]
    return {
        "seed_line_at": json.dumps(seeds.at),
        "seed_line_dims": " ".join(seeds.dims),
        "seed_line_shape": json.dumps(list(seeds.status.shape)),
        "seed_line_status": json.dumps(seeds.status.reshape(-1).tolist()),
        "seed_line_newton_iterations": json.dumps(seeds.newton_iterations.reshape(-1).tolist()),
        "seed_line_fixed_point": json.dumps(v),
    }
