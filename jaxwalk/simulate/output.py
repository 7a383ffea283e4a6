"""The files a simulation writes: their paths and the checks before computing
(both by :mod:`jaxwalk.files`, which also writes them atomically)."""

from __future__ import annotations

import os
from pathlib import Path

from jaxwalk.errors import ConfigError
from jaxwalk.files import check_output
from jaxwalk.files import write_atomically as write_atomically  # where callers have found it
from jaxwalk.walker import Walker, missing


def output_paths(out_dir: str | os.PathLike, name: str, *, plot: bool = True, gif: bool = True) -> dict[str, Path]:
    """The files a simulation writes: ``dataset``, and ``stick``/``timeseries`` (PNG), ``gif``."""
    out = Path(out_dir)
    paths = {"dataset": out / f"{name}_trajectory.zarr"}
    if plot:
        paths["stick"] = out / f"{name}_stick.png"
        paths["timeseries"] = out / f"{name}_timeseries.png"
    if gif:
        paths["gif"] = out / f"{name}_walk.gif"
    return paths


def check_outputs(out_dir, name: str, *, plot: bool = True, gif: bool = True, overwrite: bool = False) -> dict[str, Path]:
    """:func:`output_paths` if they can be written; creates nothing. Raises :class:`ConfigError`."""
    paths = output_paths(out_dir, name, plot=plot, gif=gif)
    check_output(out_dir, f"{name}_trajectory", overwrite=overwrite, others=paths.values())
    return paths


def check_drawable(model: Walker) -> None:
    """Raise :class:`ConfigError` if ``model`` lacks what the figures need (the drawing capability)."""
    reason = missing(model, "drawing")
    if reason:
        raise ConfigError(f"model '{model.name}' {reason} (pass --no-plot --no-gif for the dataset alone)")
