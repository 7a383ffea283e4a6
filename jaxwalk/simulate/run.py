"""Run a simulation: find the start, walk, write the dataset and figures."""

from __future__ import annotations

import sys

import os
from pathlib import Path

import numpy as np

from jaxwalk.models import get_model
from jaxwalk.simulate.config import SimulateConfig
from jaxwalk.simulate.dataset import build_trajectory_dataset
from jaxwalk.files import write_atomically
from jaxwalk.simulate.output import check_drawable, check_outputs
from jaxwalk.simulate.recorder import Trajectory, record_walk
from jaxwalk.simulate.start import GaitNotFound, check_start, find_start_gait, initial_state
from jaxwalk.status import STATUS_MEANINGS, Status, describe
from jaxwalk.walker import as_params


def run_simulation(
    config: SimulateConfig,
    out_dir: str | os.PathLike,
    *,
    plot: bool = True,
    gif: bool = True,
    overwrite: bool = False,
    command: str | None = None,
    solver=None,
    progress: bool = False,
) -> tuple[dict[str, Path], Trajectory]:
    """Find the start, walk, write the dataset and figures; return their paths and the walk.

    Everything that can be checked is checked before computing (the outputs, the
    model's drawing methods); no gait from the initial guess is a
    :class:`GaitNotFound` before anything is written. ``progress``: a bar over the
    steps, with the time left, and a line before each long stage (stderr).
    """
    from jaxwalk.step import SolverOptions

    model = get_model(config.model)
    paths = check_outputs(out_dir, config.name, plot=plot, gif=gif, overwrite=overwrite)
    if plot or gif:
        check_drawable(model)
    solver = solver or SolverOptions()
    params = as_params(config.fixed)
    gait = None
    if config.v0 is None:
        if progress:
            print(f"finding the {model.name} model's periodic gait", file=sys.stderr, flush=True)
        gait = find_start_gait(model, params, solver)
        if int(gait.status) != Status.OK:
            code = int(gait.status)
            meaning = STATUS_MEANINGS.get(Status(code), "") if code in set(map(int, Status)) else ""
            raise GaitNotFound(
                f"{config.source}: no periodic gait found from the {model.name} model's initial guess: "
                f"status {describe(code)} ({meaning}); give [simulate] v0 = [...] to start from a state of your own"
            )
        v = gait.v
    else:
        v = np.asarray(config.v0)
        check_start(model, params, v, f"{config.source}: [simulate]")
    y0, phase0, ctx0 = initial_state(model, params, v, config.drop)
    from tqdm.auto import tqdm

    desc = f"{config.name} (the first run of a model compiles; cached afterwards)"
    with tqdm(total=config.steps, unit="step", desc=desc, disable=not progress, file=sys.stderr) as bar:
        traj = record_walk(model, params, y0, phase0, ctx0, config.steps, config.dt, solver, progress=lambda: bar.update(1))

    from jaxwalk.files import write_zarr

    ds = build_trajectory_dataset(config, model, traj, gait=gait, command=command, solver=solver)
    write_zarr(ds, paths["dataset"], overwrite=overwrite)
    if plot or gif:
        from jaxwalk.figures import save_animation, save_stick_diagram, save_time_series, walk_geometry

        if progress:
            print(f"drawing {' and '.join(k for k, on in (('the figures', plot), ('the GIF', gif)) if on)}", file=sys.stderr, flush=True)

        geo = walk_geometry(ds, model)
        if plot:
            write_atomically(paths["stick"], lambda p: save_stick_diagram(ds, model, p, geometry=geo))
            write_atomically(paths["timeseries"], lambda p: save_time_series(ds, model, p, geometry=geo))
        if gif:
            write_atomically(paths["gif"], lambda p: save_animation(ds, model, p, geometry=geo))
    return paths, traj
