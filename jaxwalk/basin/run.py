"""Run a :class:`~jaxwalk.basin.config.BasinConfig`: find the gait, walk a grid of
starts about it (all at once, :func:`jaxwalk.global_stability.basin.fate` under vmap,
in chunks on every worker thread), write one self-describing dataset and the image.

Dataset (dims ``y``, ``x``; coordinates ``x``, ``y``: the varied section
coordinates' values, their names and units in the attributes):

* ``outcome`` int8, CF flag attributes: ``ok`` returned to within ``tol`` of
  the gait, the failing step's status (``fell``, ``scuffing``, ``stalled``, ...),
  ``not_returned`` (walked ``steps`` steps without either), ``not_a_state``
  (the start is not a state of the walker: :meth:`Walker.into_section` moves
  it; its ``steps`` and ``distance`` are those of a walk that means nothing);
* ``steps`` int32: steps walked (to the return, to the failure, or ``steps``);
* ``distance``: scaled distance to the fixed point at the end.
"""

from __future__ import annotations

import functools
import sys
from pathlib import Path
from typing import NamedTuple

import numpy as np
import xarray as xr

from jaxwalk import compiling
from jaxwalk.basin.config import BasinConfig
from jaxwalk.models import get_model
from jaxwalk.simulate.start import GaitNotFound, find_start_gait
from jaxwalk.status import STATUS_MEANINGS, Status, describe, flag_attributes


def output_paths(out_dir, name: str) -> dict[str, Path]:
    """``dataset`` ``DIR/<name>_basin.zarr`` and ``image`` ``DIR/<name>_basin.png``."""
    return {"dataset": Path(out_dir) / f"{name}_basin.zarr", "image": Path(out_dir) / f"{name}_basin.png"}


def check_outputs(out_dir, name: str, overwrite: bool) -> dict[str, Path]:
    """:func:`output_paths` if they can be written; creates nothing. Raises :class:`ConfigError`."""
    from jaxwalk.files import check_output

    paths = output_paths(out_dir, name)
    check_output(out_dir, f"{name}_basin", overwrite=overwrite, others=[paths["image"]])
    return paths


def starts_grid(config: BasinConfig, v_star: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(xs, ys, starts)``: the axes' values and the ``(ny * nx, n_v)`` starts (C order, y slowest)."""
    (nx, ny), (sx, sy) = config.points, config.span
    xs = v_star[config.x] + np.linspace(-sx, sx, nx)
    ys = v_star[config.y] + np.linspace(-sy, sy, ny)
    starts = np.repeat(v_star[None], nx * ny, axis=0)
    gy, gx = np.meshgrid(ys, xs, indexing="ij")
    starts[:, config.x], starts[:, config.y] = gx.reshape(-1), gy.reshape(-1)
    return xs, ys, starts


class FateStart(NamedTuple):
    """The input of the fate program beside the parameters, one start per row."""

    v: np.ndarray  # (n, n_v) the start on the section
    target: np.ndarray  # (n, n_v) the gait returned to
    scale: np.ndarray  # (n, n_v) the section's scale of distance


#: Starts per call of the fate program: one compiled shape for every image size
#: (the last call padded, its padding skipped: :func:`jaxwalk.batching.run_chunks`),
#: and the progress bar's step. 4096 left a flat-foot image of 61 x 61 starts (7
#: minutes) at 0% until it ended; 512 still fills every worker thread's sub-batches.
CALL_STARTS = 512


@functools.lru_cache(maxsize=None)
def _fate_program(model, options, solver):
    import jax
    import jax.numpy as jnp

    from jaxwalk import program_cache
    from jaxwalk.batching import Rows
    from jaxwalk.global_stability.basin import cycle_distance, fate_of
    from jaxwalk.walker import is_state
    from jaxwalk.global_stability.walks import pooled_walks

    # Starts near the basin's edge walk many steps, most return in a few: each
    # lane takes the next start when its own walk ends.
    def program(rows: Rows):
        start: FateStart = rows.inputs
        n = start.v.shape[0]
        end = pooled_walks(model, rows.params, start.v, jnp.full(n, options.steps, jnp.int32), model.lockstep_batch,
                           stop=lambda i, v: cycle_distance(v, start.target[i][None], start.scale[i]) < options.tol,
                           valid=rows.valid, solver=solver)
        fates = jax.vmap(lambda e, target, scale: fate_of(e, target[None], scale))(end, start.target, start.scale)
        state = jax.vmap(lambda v, p: is_state(model, v, p))(start.v, rows.params)
        return fates._replace(status=jnp.where(state, fates.status, jnp.int8(Status.NOT_A_STATE)))

    program = compiling.jit(program, model)
    program_cache.register(program, "basin_fate", model, options, solver)
    return program


def walk_starts(config: BasinConfig, model, params, v_star: np.ndarray, starts: np.ndarray, solver, progress=None):
    """:class:`~jaxwalk.global_stability.basin.Fate` of every start (NumPy leaves);
    ``progress(n)`` after each call of ``n`` starts."""
    from jaxwalk.batching import Rows, run_chunks
    from jaxwalk.global_stability.basin import BasinOptions

    options = BasinOptions(steps=config.steps, tol=config.tol)
    program = _fate_program(model, options, solver)
    n = len(starts)
    start = FateStart(starts, np.repeat(v_star[None], n, 0), np.repeat(np.asarray(config.scale)[None], n, 0))
    rows = Rows({k: np.full(n, float(v)) for k, v in params.items()}, start)
    return run_chunks(program, rows, CALL_STARTS, progress)


def find_gait_or_fail(config: BasinConfig, model, params, solver):
    """The stable period-1 gait from the model's initial guess; :class:`GaitNotFound` otherwise."""
    gait = find_start_gait(model, params, solver)
    code = int(gait.status)
    if code != Status.OK:
        raise GaitNotFound(f"{config.source}: no periodic gait found from the {model.name} model's initial guess: "
                           f"status {describe(code)} ({STATUS_MEANINGS.get(Status(code), '')})")
    if not float(gait.lambda_max) < 1.0:
        raise GaitNotFound(f"{config.source}: the {model.name} model's gait here is unstable (lambda_max = "
                           f"{float(gait.lambda_max):.4g}): it has no basin of its own")
    return gait


def build_dataset(config: BasinConfig, model, gait, xs, ys, fates, command: str | None = None) -> xr.Dataset:
    """The image's data as one dataset (module docstring), attributes self-describing."""
    from jaxwalk.files import provenance
    from jaxwalk.sweep.dataset import output_units

    shape = (len(ys), len(xs))
    names = tuple(model.section_names)
    xn, yn = names[config.x], names[config.y]
    data = {
        "outcome": (("y", "x"), np.asarray(fates.status, np.int8).reshape(shape),
                    {"long_name": "fate of the start (ok: returned to the gait)", **flag_attributes()}),
        "steps": (("y", "x"), np.asarray(fates.steps, np.int32).reshape(shape),
                  {"long_name": "steps walked: to the return (ok), to the failed step, or the limit", "units": "steps"}),
        "distance": (("y", "x"), np.asarray(fates.distance).reshape(shape),
                     {"long_name": "scaled distance to the fixed point after the last completed step", "units": "1"}),
    }
    # Section coordinates carry no declared units (as a sweep's fixed_point): the model's own.
    coords = {"x": ("x", xs, {"long_name": f"section coordinate {xn} (the model's units)"}),
              "y": ("y", ys, {"long_name": f"section coordinate {yn} (the model's units)"})}
    attrs = {
        "title": f"basin of attraction of the {config.model} gait on the section ({xn}, {yn})",
        "kind": "basin", "name": config.name, "model": config.model,
        "fixed_parameters": " ".join(f"{k}={v!r}" for k, v in config.fixed.items()),
        "parameter_units": " ".join(f"{k}={spec.units}" for k, spec in model.param_specs.items()),
        "model_units": " ".join(f"{k}={v}" for k, v in output_units(model).items()),
        "section_names": " ".join(names), "fixed_point": [float(v) for v in gait.v],
        "lambda_max": float(gait.lambda_max), "x_coordinate": xn, "y_coordinate": yn, "span": list(config.span),
        "held": "every other section coordinate at the fixed point", "steps_limit": config.steps, "tol": config.tol,
        "scale": list(config.scale),
        "norm": "sqrt(sum_i ((v_i - v*_i) / scale_i)^2) over the section coordinates (jaxwalk.global_stability.basin)",
        "returned": "ok: after some completed step (1..steps_limit) within tol of the fixed point",
        # As a sweep's: the resolved config as JSON (itself a valid config), and the file as written.
        "config": config.to_json(), "config_toml": config.text or "", "config_source": config.source,
        **provenance(command, "jaxwalk.basin.run_basin"),
    }
    return xr.Dataset(data, coords=coords, attrs=attrs)


def run_basin(config: BasinConfig, out, *, overwrite: bool = False, command: str | None = None, solver=None,
              progress: bool = False):
    """Check the outputs, find the gait, walk the starts, write the dataset and the image;
    returns ``(paths, dataset)``. ``progress``: a bar over the starts (on stderr)."""
    from tqdm.auto import tqdm

    from jaxwalk.basin.figure import save_basin
    from jaxwalk.files import write_atomically, write_zarr
    from jaxwalk.step import SolverOptions
    from jaxwalk.walker import as_params

    model = get_model(config.model)
    paths = check_outputs(out, config.name, overwrite)
    solver = solver or SolverOptions()
    params = as_params(config.fixed)
    gait = find_gait_or_fail(config, model, params, solver)
    v_star = np.asarray(gait.v, np.float64)
    xs, ys, starts = starts_grid(config, v_star)
    with tqdm(total=len(starts), unit="start", desc=f"{config.name} basin", disable=not progress, file=sys.stderr) as bar:
        fates = walk_starts(config, model, config.fixed, v_star, starts, solver, bar.update)
    ds = build_dataset(config, model, gait, xs, ys, fates, command)
    write_zarr(ds, paths["dataset"], overwrite=overwrite)
    write_atomically(paths["image"], lambda p: save_basin(ds, p))
    return paths, ds
