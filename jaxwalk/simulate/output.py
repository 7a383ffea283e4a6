"""The files a simulation writes: their paths, the checks before computing,
and writing each one atomically."""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

from jaxwalk.errors import ConfigError
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
    from jaxwalk.sweep.runner import check_output

    check_output(out_dir, f"{name}_trajectory", overwrite=overwrite)  # the directory, and the dataset
    paths = output_paths(out_dir, name, plot=plot, gif=gif)
    for path in paths.values():
        if (path.exists() or path.is_symlink()) and not overwrite:
            raise ConfigError(f"'{path}' already exists (pass --overwrite to replace it)")
    return paths


def check_drawable(model: Walker) -> None:
    """Raise :class:`ConfigError` if ``model`` lacks what the figures need (the drawing capability)."""
    reason = missing(model, "drawing")
    if reason:
        raise ConfigError(f"model '{model.name}' {reason} (pass --no-plot --no-gif for the dataset alone)")


def write_atomically(target: Path, write) -> None:
    """``write(path)`` into a hidden directory beside ``target``, then rename it into place."""
    import shutil

    target.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{target.name}.", suffix=".tmp", dir=target.parent))
    try:
        path = tmp / target.name
        write(path)
        os.replace(path, target)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
