"""The dataset a plot reads: opened, checked to be a jaxwalk sweep, its variables chosen.

A jaxwalk sweep dataset (``docs/sweeps.md``) has the global attribute
``swept_parameters`` (its grid axes, in grid order) and an integer ``status``
over those axes. Anything else is refused with a one-line :class:`PlotError`
before a figure is drawn or a file written.
"""

from __future__ import annotations

import difflib
import os
import warnings
from pathlib import Path

import numpy as np
import xarray as xr

from jaxwalk import analyses
from jaxwalk.status import Status
from jaxwalk.errors import ConfigError
from jaxwalk.sweep.integrity import check_complete

#: The variables drawn by default, in this order, when the dataset has them with values:
#: those whose declaration ranks them (:attr:`jaxwalk.outputs.Output.plot`; stability
#: measures first); those of the analyses beside the gait only where they ran.
DEFAULT_VARIABLES = analyses.plotted()


class PlotError(ConfigError):
    """Unusable plot input (a missing or foreign dataset, an unknown variable or axis).

    A :class:`~jaxwalk.errors.ConfigError`, so the command line reports it as
    one line with exit status 2.
    """


def open_sweep(path: str | os.PathLike, *, partial: bool = False) -> xr.Dataset:
    """The sweep dataset at ``path`` (a zarr store), loaded into memory and checked.

    A store with points not computed (an unfinished run) or damaged (a lost chunk
    file) is refused, or with ``partial`` read with those points ``NOT_COMPUTED``
    (:func:`jaxwalk.sweep.integrity.check_complete`).

    Raises:
        PlotError: ``path`` does not exist, is not a zarr store, or is not a jaxwalk sweep dataset.
        IncompleteStore: points are missing (a ``ConfigError`` as ``PlotError``), without ``partial``.
    """
    path = Path(path)
    if not path.exists():
        raise PlotError(f"dataset '{path}' not found")
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # zarr's consolidated-metadata and format chatter
            with xr.open_dataset(path, engine="zarr") as ds:
                ds = ds.load()
    except Exception as err:  # zarr and xarray raise many types for "not a store"
        reason = " ".join(str(err).split())
        reason = reason if len(reason) <= 100 else reason[:97] + "..."
        raise PlotError(f"'{path}' is not a zarr store xarray can open ({reason})") from None
    check_sweep(ds, str(path))
    return check_complete(ds, path, partial=partial)


def check_sweep(ds: xr.Dataset, where: str = "dataset") -> xr.Dataset:
    """``ds`` if it is a jaxwalk sweep dataset (grid axes named, ``status`` over them).

    Raises:
        PlotError: it is not.
    """
    dims = ds.attrs.get("swept_parameters")
    if not isinstance(dims, str) or not dims.split():
        raise PlotError(f"'{where}' is not a jaxwalk sweep dataset (no 'swept_parameters' attribute)")
    missing = [d for d in dims.split() if d not in ds.dims]
    if missing:
        raise PlotError(f"'{where}' is not a jaxwalk sweep dataset: grid axes {', '.join(missing)} missing")
    if "status" not in ds or tuple(ds["status"].dims) != tuple(dims.split()):
        raise PlotError(f"'{where}' is not a jaxwalk sweep dataset (no 'status' over its grid axes)")
    if not np.issubdtype(ds["status"].dtype, np.integer):
        raise PlotError(f"'{where}': 'status' is not an integer status code")
    return ds


def grid_axes(ds: xr.Dataset) -> tuple[str, ...]:
    """The grid axes of a sweep dataset, in grid order."""
    return tuple(ds.attrs["swept_parameters"].split())


def plottable_variables(ds: xr.Dataset) -> tuple[str, ...]:
    """Every numeric variable over exactly the grid axes, ``status`` excepted."""
    dims = set(grid_axes(ds))
    return tuple(
        name
        for name, da in ds.data_vars.items()
        if name != "status" and set(da.dims) == dims and np.issubdtype(da.dtype, np.number)
        and not np.issubdtype(da.dtype, np.complexfloating) and "flag_values" not in da.attrs
    )


def has_values(ds: xr.Dataset, name: str) -> bool:
    """Whether ``name`` was computed: finite somewhere, or no gait was found at all
    (then every number is NaN, and its figure still maps the failures)."""
    values = ds[name].values
    return bool(np.isfinite(values).any() or not (ds["status"].values == Status.OK).any())


def identically_zero(ds: xr.Dataset, name: str) -> bool:
    """Whether every finite value of ``name`` is exactly 0 (and there is one): a
    passive walker's work and cost of transport, nothing worth a figure."""
    values = ds[name].values
    finite = values[np.isfinite(values)]
    return bool(finite.size and not finite.any())


def choose_variables(ds: xr.Dataset, requested: list[str] | tuple[str, ...] | None = None) -> list[str]:
    """The variables to draw: ``requested`` after checking, else the defaults the dataset has.

    Defaults are :data:`DEFAULT_VARIABLES` present with values (:func:`has_values`)
    that are not all zero (:func:`identically_zero`); ``lambda_max`` without
    stability, ``h_max`` without ``[analysis] h_max``, or the cost of transport of
    a passive walker is left out (asked for by name, it is drawn).

    Raises:
        PlotError: a requested name is not a plottable variable of ``ds``, or has no
            value where a gait was found (not computed), or nothing is left to draw.
    """
    known = plottable_variables(ds)
    if requested is None:
        chosen = [v for v in DEFAULT_VARIABLES if v in known and has_values(ds, v) and not identically_zero(ds, v)]
        if not chosen:
            raise PlotError(f"dataset '{ds.attrs.get('name', '?')}' has none of {', '.join(DEFAULT_VARIABLES)} with values")
        return chosen
    chosen = []
    for name in requested:
        if name not in known:
            close = difflib.get_close_matches(name, known, n=1)
            hint = f" (did you mean '{close[0]}'?)" if close else ""
            raise PlotError(f"--vars: unknown variable '{name}'{hint} (this dataset has: {', '.join(known)})")
        if not has_values(ds, name):
            raise PlotError(f"--vars: '{name}' has no values in this dataset (not computed: all NaN where a gait was found)")
        if name not in chosen:
            chosen.append(name)
    return chosen
