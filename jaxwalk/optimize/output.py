"""``jaxwalk optimize``: run a checked config, write the path dataset and its figure.

Outputs, in ``--out DIR``:

* ``<name>.zarr``: the path, dimensions ``iteration x start`` (and ``parameter``
  for gradients): each optimised parameter, the objective, ``lambda_max``,
  speed, step length, period, cost of transport, the status of every
  evaluation (CF flags), whether it was accepted, the final point and status of
  each start; with the resolved config, units and package versions in its
  attributes; plus the background grid's ``heatmap_lambda_max`` and
  ``heatmap_status`` on their own dimensions when one was computed.
* ``<name>.png``: the paths drawn over the ``lambda_max`` heatmap (two axes) or
  curve (one axis).
"""

from __future__ import annotations

import dataclasses
import threading
import warnings
from pathlib import Path as FilePath

import numpy as np
import xarray as xr

from jaxwalk import analyses, outputs
from jaxwalk.optimize.config import OptimizeConfig
from jaxwalk.optimize.engine import QUANTITIES, Path, optimise
from jaxwalk.configs import NEWTON_FIELDS, SOLVER_FIELDS
from jaxwalk.errors import ConfigError
from jaxwalk.files import check_output as check_dataset_output
from jaxwalk.files import provenance, write_zarr
from jaxwalk.status import Status, flag_attributes
from jaxwalk.sweep.dataset import output_units, units_note



def solver_options(config: OptimizeConfig):
    """``(SolverOptions, NewtonOptions)`` from the defaults and ``[analysis]``."""
    from jaxwalk.gait import NewtonOptions
    from jaxwalk.step import SolverOptions

    solver = dataclasses.replace(SolverOptions(), **{SOLVER_FIELDS[k]: v for k, v in config.solver.items() if k in SOLVER_FIELDS})
    newton = dataclasses.replace(NewtonOptions(), **{NEWTON_FIELDS[k]: v for k, v in config.solver.items() if k in NEWTON_FIELDS})
    return solver, newton


def check_output(out_dir, name: str, overwrite: bool) -> tuple[FilePath, FilePath]:
    """``(dataset, figure)`` paths if they can be written (nothing created). Raises ConfigError."""
    figure = FilePath(out_dir) / f"{name}.png"
    return check_dataset_output(out_dir, name, overwrite=overwrite, others=[figure]), figure


def load_heatmap(path, names) -> xr.Dataset:
    """A sweep dataset's ``lambda_max`` and ``status`` as the background. Raises ConfigError."""
    try:
        ds = xr.open_dataset(path, engine="zarr")
    except Exception as err:  # a missing or unreadable store: one line
        raise ConfigError(f"--heatmap '{path}': cannot open as a zarr dataset ({' '.join(str(err).split())[:200]})") from None
    dims = [d for d in ds["lambda_max"].dims] if "lambda_max" in ds else []
    if not dims or len(dims) > 2 or "status" not in ds:
        raise ConfigError(f"--heatmap '{path}': needs lambda_max and status over one or two swept parameters")
    if not set(dims) & set(names):
        raise ConfigError(f"--heatmap '{path}': its axes ({', '.join(dims)}) include none of the optimised parameters ({', '.join(names)})")
    return xr.Dataset({"heatmap_lambda_max": ds["lambda_max"], "heatmap_status": ds["status"]}).rename(
        {d: f"heatmap_{d}" for d in dims}
    ).load()


class _Stopped(Exception):
    """The background grid was cancelled (:meth:`_Background.cancel`)."""


def compute_heatmap(config: OptimizeConfig, model, solver, newton, stop: threading.Event | None = None) -> xr.Dataset | None:
    """The ``[heatmap]`` grid by :func:`jaxwalk.grid.analyse_grid` (``None`` without axes);
    with ``stop``, ended (``_Stopped``) after the first chunk done once it is set."""
    if not config.heatmap:
        return None
    from jaxwalk.grid import AnalysisOptions, analyse_grid

    grid = {a.name: np.asarray(a.values) for a in config.heatmap}
    first = {k: float(v[0]) for k, v in config.fixed_per_start().items()}
    first.update({n: float(config.starts[0, i]) for i, n in enumerate(config.problem.names)})
    fixed = {k: v for k, v in first.items() if k not in grid}
    # The sweep's default chunks, on every worker thread (docs/optimize.md).
    options = AnalysisOptions(solver=solver, newton=newton)

    def check(_done: int) -> None:
        if stop is not None and stop.is_set():
            raise _Stopped

    out = analyse_grid(model, fixed, grid, config.heatmap_continuation, options, check)
    dims = [f"heatmap_{a}" for a in grid]
    coords = {f"heatmap_{a}": (f"heatmap_{a}", v, {"long_name": model.param_specs[a].description, "units": model.param_specs[a].units}) for a, v in grid.items()}
    return xr.Dataset(
        {"heatmap_lambda_max": (dims, out["lambda_max"]), "heatmap_status": (dims, out["status"])}, coords=coords
    )


def build_dataset(config: OptimizeConfig, model, path: Path, heatmap: xr.Dataset | None, command: str | None) -> xr.Dataset:
    """The path (and background) as a self-describing xarray dataset."""
    p = config.problem
    units = output_units(model)
    q_units = {q: outputs.units_text(analyses.output(q), units) for q in QUANTITIES}
    dims = ("iteration", "start")
    data = {}
    for i, n in enumerate(p.names):
        spec = model.param_specs[n]
        data[n] = (dims, path.params[:, :, i], {"long_name": spec.description, "units": spec.units})
        data[f"final_{n}"] = (("start",), path.final_params[:, i], {"long_name": f"last accepted {n}", "units": spec.units})
        data[f"best_{n}"] = (("start",), path.best_params[:, i], {"long_name": f"{n} at the accepted iterate of least merit", "units": spec.units})
    sign = "-" if p.sign < 0 else ""
    data["objective"] = (dims, path.objective, {"long_name": f"objective: {sign}{p.objective} (minimised)", "units": q_units[p.objective]})
    for q in (q for q in QUANTITIES if q in path.metrics):  # the gait sensitivity norm only when asked for
        data[q] = (dims, path.metrics[q], {"long_name": q.replace("_", " "), "units": q_units[q]})
    data["gradient"] = (dims + ("parameter",), path.gradient, {"long_name": "d objective / d parameter", "units": "objective units per parameter unit"})
    flags = flag_attributes()
    data["status"] = (dims, path.status, {"long_name": "status of the gait search at this iterate", **flags})
    data["accepted"] = (dims, path.accepted, {"long_name": "iterate kept (false: failed, undone)"})
    data["final_status"] = (("start",), path.final_status, {"long_name": "ok, or the status the start ended with", **flags})
    data["ended_at"] = (("start",), path.ended_at, {"long_name": "iteration at which the start ended"})
    data["best_iteration"] = (("start",), path.best_row, {"long_name": "iteration of least merit (objective + penalty/2 sum c^2), -1: none accepted"})
    for name, values in config.start_fixed.items():
        spec = model.param_specs[name]
        data[name] = (("start",), values, {"long_name": spec.description, "units": spec.units})
    if p.hold:
        data["multiplier"] = (dims + ("held",), path.multipliers, {"long_name": "augmented Lagrangian multiplier"})
    coords = {
        "iteration": ("iteration", np.arange(path.status.shape[0])),
        "start": ("start", np.arange(path.status.shape[1])),
        # Variable-length strings (object): zarr's fixed-width UTF-32 type is "unstable" (it warns).
        "parameter": ("parameter", np.array(p.names, dtype=object), {"long_name": "optimised parameter"}),
    }
    if p.hold:
        coords["held"] = ("held", np.array(list(p.hold), dtype=object), {"long_name": "held quantity"})
    ds = xr.Dataset(data, coords=coords)
    if heatmap is not None:
        ds = ds.merge(describe_heatmap(heatmap))
    ds.attrs.update(
        {
            "title": f"jaxwalk optimisation '{config.name}' of the {config.model} model",
            "Conventions": "CF-1.10",
            "name": config.name,
            "model": config.model,
            "units_note": units_note(model),
            "method": "projected Adam (optax) in parameters scaled to their bounds; gradients by the implicit "
            "function theorem at each fixed point; held quantities by an augmented Lagrangian",
            "config": config.to_json(),
            **provenance(command, "jaxwalk.optimize.run_optimize", extra_versions=("optax",)),
        }
    )
    return ds


def describe_heatmap(heatmap: xr.Dataset) -> xr.Dataset:
    """The background grid with the attributes a sweep's variables have: units,
    short long_names, CF status flags (whether computed or read from a store)."""
    heatmap = heatmap.copy()
    heatmap["heatmap_lambda_max"].attrs = {
        "long_name": "largest eigenvalue modulus", "units": "1",
        "description": "lambda_max of the background grid: largest eigenvalue modulus of the step-to-step Jacobian (stable below 1)",
    }
    heatmap["heatmap_status"].attrs = {"long_name": "status", "description": "outcome at this background grid point", **flag_attributes()}
    return heatmap


class _Background:
    """``fn(*args)`` (:func:`compute_heatmap`) on a thread of its own, beside the optimisation.

    The background grid is independent of the path, so a cold run compiles both
    programs at once: XLA compiles the optimiser's second-order program on one
    core for minutes, and the grid's program compiles and runs on the other
    meanwhile; the optimiser waits for the grid before its first evaluation, so
    no two programs run at once (:func:`~jaxwalk.optimize.engine.optimise`'s
    ``before_running``; docs/optimize.md). The thread is a daemon, so an
    interrupted or failed optimisation ends the process without waiting for the
    grid; :meth:`cancel` also stops it at its next chunk where the process goes
    on (a notebook).
    """

    def __init__(self, fn, *args):
        self._stop = threading.Event()
        self._result, self._error = None, None
        self._thread = threading.Thread(target=self._run, args=(fn, args), name="jaxwalk-background", daemon=True)
        self._thread.start()

    def _run(self, fn, args) -> None:
        try:
            self._result = fn(*args, stop=self._stop)
        except BaseException as err:  # handed to the caller by result()
            self._error = err

    def done(self) -> bool:
        return not self._thread.is_alive()

    def cancel(self) -> None:
        self._stop.set()

    def result(self):
        """The grid, once computed; its exception, raised here, where it failed."""
        self._thread.join()
        if self._error is not None:
            raise self._error
        return self._result


def run_optimize(config: OptimizeConfig, out_dir, *, heatmap_path=None, heatmap: bool = True, plot: bool = True,
                 overwrite: bool = False, command: str | None = None, progress: bool = False) -> tuple[FilePath, xr.Dataset]:
    """Check the outputs, optimise, compute or load the background, write dataset and figure."""
    from jaxwalk.models import get_model

    target, figure = check_output(out_dir, config.name, overwrite)
    background = load_heatmap(heatmap_path, config.problem.names) if heatmap_path is not None else None
    model = get_model(config.model)
    solver, newton = solver_options(config)
    import sys

    from tqdm.auto import tqdm

    desc = f"{config.name} (the first run of a model compiles; cached afterwards)"
    beside = _Background(compute_heatmap, config, model, solver, newton) if background is None and heatmap and config.heatmap else None
    if beside is not None and progress:
        print(f"computing the background grid ({int(np.prod([len(a.values) for a in config.heatmap]))} points) while the optimiser compiles",
              file=sys.stderr, flush=True)

    def wait_for_background() -> None:  # the optimiser's programs are compiled; none of them has run
        if progress and not beside.done():
            tqdm.write("waiting for the background grid", file=sys.stderr)
        beside.result()

    try:
        with tqdm(total=config.problem.iterations + 1, unit="it", desc=desc, disable=not progress, file=sys.stderr) as bar:
            path = optimise(
                model, config.problem, config.fixed_per_start(), config.starts, solver, newton, progress=lambda k: bar.update(1),
                before_running=None if beside is None else wait_for_background, guesses=config.guesses,
            )
    except BaseException:
        if beside is not None:
            beside.cancel()
        raise
    if beside is not None:
        background = beside.result()
    ds = build_dataset(config, model, path, background, command)
    write_zarr(ds, target, overwrite=overwrite)
    if plot:
        try:
            from jaxwalk.optimize.figure import draw_paths

            draw_paths(ds, figure)
        except Exception as err:  # a figure is a convenience; the dataset is written
            warnings.warn(f"figure not written: {' '.join(str(err).split())}", stacklevel=2)
    return target, ds


def summary(ds: xr.Dataset) -> str:
    """One line per start: final point, objective and status."""
    from jaxwalk.status import describe

    names = [str(n) for n in ds["parameter"].values]
    lines = []
    for s in ds["start"].values:
        k = int(ds["ended_at"].sel(start=s))
        best = int(ds["best_iteration"].sel(start=s))
        point = ", ".join(f"{n} = {float(ds[f'best_{n}'].sel(start=s)):.5g}" for n in names)
        obj = f"objective {float(ds['objective'].sel(start=s, iteration=best)):.5g} (best, iteration {best})" if best >= 0 else "no gait"
        status = describe(int(ds["final_status"].sel(start=s)))
        lines.append(f"start {int(s)}: {point}, {obj}, {status} at iteration {k}")
    return "; ".join(lines)


__all__ = ["run_optimize", "build_dataset", "compute_heatmap", "load_heatmap", "summary", "Status"]
