"""Stability over a Cartesian grid of parameters, in chunks, on every CPU device.

``analyse_grid`` is what ``jaxwalk sweep`` runs: it lays the grid out as one
batch of configurations (or, with continuation, as lines along one axis),
cuts it into chunks, runs each chunk as one jitted ``vmap`` program sharded
over the available devices (``XLA_FLAGS=--xla_force_host_platform_device_count``
gives one CPU device per core), and returns NumPy arrays shaped like the grid.
"""

from __future__ import annotations

import dataclasses
import functools
from typing import Callable, Mapping

import jax
import jax.numpy as jnp
import numpy as np

from jaxwalk.continuation import continue_along, gaits_independent, seed_index, visiting_order
from jaxwalk.gait import Gait, NewtonOptions
from jaxwalk.step import SolverOptions
from jaxwalk.stepdown import StepDownOptions, h_max
from jaxwalk.walker import Walker


@dataclasses.dataclass(frozen=True)
class AnalysisOptions:
    """Settings of a grid analysis.

    Attributes:
        solver, newton: integration and fixed-point settings.
        chunk_size: configurations (or continuation lines) per jitted call;
            rounded up to a multiple of the device count.
        step_down: settings of the global-stability test (the paper's h_m);
            ``None`` skips it.
    """

    solver: SolverOptions = SolverOptions()
    newton: NewtonOptions = NewtonOptions()
    chunk_size: int = 256
    step_down: StepDownOptions | None = None


def parameter_grid(model: Walker, fixed: Mapping[str, float], grid: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
    """Every model parameter as a float64 array of the grid's shape ``S``.

    Swept names vary along their axis (axes in ``grid``'s order); fixed names
    and defaults are constant.
    """
    axes = list(grid)
    shape = tuple(len(np.atleast_1d(grid[a])) for a in axes)
    out = {}
    for spec in model.parameters:
        if spec.name in grid:
            k = axes.index(spec.name)
            line = np.asarray(grid[spec.name], np.float64)
            view = [1] * len(shape)
            view[k] = len(line)
            out[spec.name] = np.broadcast_to(line.reshape(view), shape).copy()
        else:
            value = float(fixed.get(spec.name, spec.default))
            out[spec.name] = np.full(shape, value)
    return out


def _shard_leading(tree, n_devices: int):
    """Place the leading axis of every leaf across the CPU devices."""
    if n_devices == 1:
        return tree
    mesh = jax.sharding.Mesh(np.array(jax.devices()[:n_devices]), ("batch",))
    sharding = jax.sharding.NamedSharding(mesh, jax.sharding.PartitionSpec("batch"))
    return jax.device_put(tree, sharding)


@functools.lru_cache(maxsize=None)
def _independent_program(model: Walker, solver: SolverOptions, newton: NewtonOptions):
    return jax.jit(lambda p: gaits_independent(model, p, solver, newton))


@functools.lru_cache(maxsize=None)
def _continuation_program(model: Walker, solver: SolverOptions, newton: NewtonOptions, order: tuple, restart: tuple):
    order_a, restart_a = np.array(order, np.int32), np.array(restart, bool)
    line = lambda p: continue_along(model, p, order_a, restart_a, solver, newton)
    return jax.jit(jax.vmap(line))


@functools.lru_cache(maxsize=None)
def _step_down_program(model: Walker, solver: SolverOptions, step_down: StepDownOptions):
    def one(p):
        v = p.pop("__v_star__")
        return h_max(model, p, v, step_down, solver)

    return jax.jit(jax.vmap(one))


def _run_chunks(program, params_rows: dict[str, np.ndarray], chunk: int, progress: Callable[[int], None] | None) -> Gait:
    """Apply ``program`` to ``params_rows`` (leading axis = rows) chunk by chunk."""
    n_rows = next(iter(params_rows.values())).shape[0]
    n_dev = jax.device_count()
    # Few distinct shapes, few compilations: small inputs pad to a power of two.
    rows = min(chunk, 1 << max(0, (n_rows - 1).bit_length()))
    chunk = max(n_dev, -(-rows // n_dev) * n_dev)
    pieces = []
    for start in range(0, n_rows, chunk):
        stop = min(start + chunk, n_rows)
        block = {k: v[start:stop] for k, v in params_rows.items()}
        pad = chunk - (stop - start)
        if pad:  # pad with copies of the last row so every chunk has one shape (one compile)
            block = {k: np.concatenate([v, np.repeat(v[-1:], pad, axis=0)]) for k, v in block.items()}
        out = program(_shard_leading(block, n_dev))
        out = jax.tree_util.tree_map(lambda x: np.asarray(x)[: stop - start], out)
        pieces.append(out)
        if progress is not None:
            progress(stop - start)
    return jax.tree_util.tree_map(lambda *xs: np.concatenate(xs), *pieces)


def analyse_grid(
    model: Walker,
    fixed: Mapping[str, float],
    grid: Mapping[str, np.ndarray],
    continuation_axis: str | None = None,
    options: AnalysisOptions = AnalysisOptions(),
    progress: Callable[[int], None] | None = None,
) -> dict[str, np.ndarray]:
    """Fixed point, Jacobian eigenvalues and step metrics over a parameter grid.

    Args:
        model: the walker.
        fixed: parameter values held fixed (others at their defaults).
        grid: swept axes, ``name -> 1-D values``; the grid is their product, in order.
        continuation_axis: a name in ``grid`` to continue along, or ``None``
            for independent searches from the model's initial guess.
        options: solver, Newton and chunking settings.
        progress: called with the number of configurations finished after each chunk.

    Returns:
        Arrays with the grid's shape ``S`` in front: ``status`` (int8),
        ``lambda_max``, ``eigenvalues`` (complex, ``S + (n_v,)``),
        ``fixed_point`` (``S + (n_v,)``), ``jacobian`` (``S + (n_v, n_v)``),
        ``period``, ``step_length``, ``speed``, ``work`` (actuator work per
        step), ``cost_of_transport``, ``newton_iterations``; with
        ``options.step_down`` also ``h_max`` (NaN where no gait was found),
        ``step_down_status`` (int8, the first failed drop's status, ``OK`` if none
        failed up to the limit; where no gait was found, the gait's status) and
        ``h_failed`` (that drop's height).
    """
    params = parameter_grid(model, fixed, grid)
    axes = list(grid)
    shape = tuple(len(np.atleast_1d(grid[a])) for a in axes)
    if continuation_axis is None:
        rows = {k: v.reshape(-1) for k, v in params.items()}
        program = _independent_program(model, options.solver, options.newton)
        gaits = _run_chunks(program, rows, options.chunk_size, progress)
        unflatten = lambda x: x.reshape(shape + x.shape[1:])
    else:
        k = axes.index(continuation_axis)
        values = np.asarray(grid[continuation_axis], np.float64)
        seed = seed_index(values, model.param_specs[continuation_axis].default)
        order, restart = visiting_order(len(values), seed)
        moved = {n: np.moveaxis(v, k, -1) for n, v in params.items()}
        moved_shape = next(iter(moved.values())).shape
        rows = {n: v.reshape(-1, len(values)) for n, v in moved.items()}
        program = _continuation_program(model, options.solver, options.newton, tuple(order), tuple(restart))
        line_progress = None if progress is None else (lambda n: progress(n * len(values)))
        gaits = _run_chunks(program, rows, max(1, options.chunk_size // len(values)), line_progress)

        def unflatten(x):
            x = x.reshape(moved_shape + x.shape[2:])
            return np.moveaxis(x, len(shape) - 1, k)

    gaits = jax.tree_util.tree_map(unflatten, gaits)
    out = {
        "status": gaits.status.astype(np.int8),
        "lambda_max": gaits.lambda_max,
        "eigenvalues": gaits.eigenvalues,
        "fixed_point": gaits.v,
        "jacobian": gaits.jacobian,
        "period": gaits.period,
        "step_length": gaits.step_length,
        "speed": gaits.speed,
        "work": gaits.work,
        "cost_of_transport": gaits.cost_of_transport,
        "newton_iterations": gaits.iterations.astype(np.int32),
    }
    if options.step_down is not None:
        rows = {k: v.reshape(-1) for k, v in params.items()}
        rows["__v_star__"] = gaits.v.reshape(-1, gaits.v.shape[-1])
        program = _step_down_program(model, options.solver, options.step_down)
        drops = _run_chunks(program, rows, options.chunk_size, None)
        out["h_max"] = drops.h_max.reshape(shape)
        no_gait = out["status"] != 0  # no h_max without a gait: carry the gait's status
        out["step_down_status"] = np.where(no_gait, out["status"], drops.first_failure.astype(np.int8).reshape(shape))
        out["h_failed"] = drops.failed_at.reshape(shape)
    return out
