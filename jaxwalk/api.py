"""The notebook API: ``jaxwalk.sweep``, ``jaxwalk.simulate``, ``jaxwalk.optimize``.

Each takes a config as a path, TOML text or a dict (the parsed TOML), runs
what the command of the same name runs, and returns the dataset as an
``xarray.Dataset`` in memory, equal to the store the command writes. Files
are written to ``out`` only when it is given; without it the store is built
in a temporary directory that is removed before the function returns.

Bad input of any kind raises :class:`ConfigError` (``jaxwalk.ConfigError``)
with the command line's one-line message; nothing is written then.
See docs/python.md.
"""

from __future__ import annotations

import operator
import os
import tempfile
from pathlib import Path
from typing import Any, Callable, Mapping

import xarray as xr

from jaxwalk.errors import ConfigError
from jaxwalk.sweep.config import DEFAULT_MAX_POINTS

Config = "str | os.PathLike | Mapping[str, Any]"


def _read(config, *, load: Callable, loads: Callable, parse: Callable, checked: type, kind: str, **extra):
    """A checked config from a path, TOML text (a string with a newline) or a dict."""
    if isinstance(config, Mapping):
        bad = [k for k in config if not isinstance(k, str)]
        if bad:
            raise ConfigError(f"config: keys must be strings (as in TOML), got {bad[0]!r}")
        return parse(dict(config), source=f"<{kind} dict>", **extra)
    if isinstance(config, str) and "\n" in config:
        return loads(config, source=f"<{kind} text>", **extra)
    if isinstance(config, (str, os.PathLike)):
        return load(config, **extra)
    if isinstance(config, checked):  # already a checked config
        return config
    raise ConfigError(f"config: expected a path, TOML text or a dict, got {type(config).__name__}")


def _count(name: str, value, *, optional: bool = False):
    """``value`` if it is a positive integer (or ``None`` where ``optional``), else a ConfigError."""
    if value is None and optional:
        return value
    try:
        number = None if isinstance(value, bool) else operator.index(value)  # ints, NumPy's too
    except TypeError:
        number = None
    if number is None or number < 1:
        raise ConfigError(f"{name} must be a positive integer{' or None' if optional else ''}, got {value!r}")
    return number


def _loaded(path: Path) -> xr.Dataset:
    with xr.open_dataset(path, engine="zarr") as ds:
        return ds.load()


def sweep(
    config,
    out: str | os.PathLike | None = None,
    *,
    overwrite: bool = False,
    plot: bool = False,
    progress: bool = True,
    chunk_size: int | None = None,
    max_points: int = DEFAULT_MAX_POINTS,
    partial: bool = False,
    analyse: Callable | None = None,
) -> xr.Dataset:
    """Run a sweep (``jaxwalk sweep``) and return its dataset (docs/sweeps.md).

    Args:
        config: path of a TOML config, TOML text, or the config as a dict.
        out: directory to write ``<name>.zarr`` (and, with ``plot``, its figures) into;
            ``None``: nothing is written. A run interrupted there is continued by the same call.
        overwrite, chunk_size, max_points: as the command's options.
        plot: also write the figures (needs ``out``).
        progress: a progress bar with the time left (stderr).
        partial: reopen an incomplete ``out`` store's computed points instead of refusing
            (:func:`jaxwalk.sweep.integrity.check_complete`); an ordinary run is always complete.
        analyse: the analysis function (default :func:`jaxwalk.grid.analyse_grid`; tests pass a stand-in).

    Raises:
        ConfigError: bad config or output directory, before anything is computed.
    """
    from jaxwalk.sweep.config import SweepConfig, load_config, loads_config, parse_config
    from jaxwalk.sweep.integrity import check_complete
    from jaxwalk.sweep.runner import run_sweep

    chunk_size = _count("chunk_size", chunk_size, optional=True)  # a plain int: recorded and fingerprinted as one
    max_points = _count("max_points", max_points)
    cfg = _read(
        config, load=load_config, loads=loads_config, parse=parse_config, checked=SweepConfig, kind="sweep",
        max_points=max_points,
    )
    if plot and out is None:
        raise ConfigError("plot=True needs out: the directory to write the figures into")
    with tempfile.TemporaryDirectory(prefix="jaxwalk-sweep-") as tmp:
        path = run_sweep(
            cfg, tmp if out is None else out, progress=progress, analyse=analyse, overwrite=overwrite or out is None,
            plot=plot, command=f"jaxwalk.sweep({cfg.name!r})", chunk_size=chunk_size,
        )
        return check_complete(_loaded(path), path, partial=partial)


def simulate(
    config, out: str | os.PathLike | None = None, *, steps: int | None = None, drop: float | None = None,
    plot: bool = False, gif: bool = False, overwrite: bool = False, progress: bool = True,
) -> xr.Dataset:
    """Walk ``steps`` steps from the periodic gait (``jaxwalk simulate``) and return the
    trajectory dataset (docs/simulate.md); figures and the GIF only with ``out``.

    Raises:
        ConfigError: bad config or output directory, or no gait to start from.
    """
    from jaxwalk.simulate.config import SimulateConfig, load_simulate_config, loads_simulate_config, parse_simulate_config
    from jaxwalk.simulate.run import run_simulation

    cfg = _read(
        config, load=load_simulate_config, loads=loads_simulate_config, parse=parse_simulate_config, checked=SimulateConfig, kind="simulate",
        steps=steps, drop=drop,
    )
    if (plot or gif) and out is None:
        raise ConfigError("plot=True or gif=True needs out: the directory to write them into")
    with tempfile.TemporaryDirectory(prefix="jaxwalk-simulate-") as tmp:
        paths, _ = run_simulation(
            cfg, tmp if out is None else out, plot=plot, gif=gif, overwrite=overwrite or out is None,
            command=f"jaxwalk.simulate({cfg.name!r})", progress=progress,
        )
        return _loaded(paths["dataset"])


def optimize(
    config, out: str | os.PathLike | None = None, *, heatmap: bool | str | os.PathLike = True, plot: bool = False,
    overwrite: bool = False, progress: bool = True,
) -> xr.Dataset:
    """Minimise the config's objective by gradients (``jaxwalk optimize``) and return the
    path dataset (docs/optimize.md). ``heatmap``: compute the config's ``[heatmap]``
    background (``True``), none (``False``), or a sweep store's path to take it from.

    Raises:
        ConfigError: bad config, heatmap store or output directory.
    """
    from jaxwalk.optimize.config import OptimizeConfig, load_optimize_config, parse_optimize_config
    from jaxwalk.optimize.output import run_optimize
    from jaxwalk.sweep.config import parse_toml

    def loads(text, source):
        return parse_optimize_config(parse_toml(text, source=source), source=source, text=text)

    cfg = _read(config, load=load_optimize_config, loads=loads, parse=parse_optimize_config, checked=OptimizeConfig, kind="optimize")
    if plot and out is None:
        raise ConfigError("plot=True needs out: the directory to write the figure into")
    heatmap_path = None if isinstance(heatmap, bool) else heatmap
    with tempfile.TemporaryDirectory(prefix="jaxwalk-optimize-") as tmp:
        path, _ = run_optimize(
            cfg, tmp if out is None else out, heatmap_path=heatmap_path, heatmap=bool(heatmap), plot=plot,
            overwrite=overwrite or out is None, command=f"jaxwalk.optimize({cfg.name!r})", progress=progress,
        )
        return _loaded(path)


def open_dataset(path: str | os.PathLike, *, partial: bool = False) -> xr.Dataset:
    """A sweep store read into memory, refused (:class:`ConfigError`) if it is
    unfinished or damaged unless ``partial`` (docs/sweeps.md)."""
    from jaxwalk.plot.source import open_sweep

    return open_sweep(path, partial=partial)
