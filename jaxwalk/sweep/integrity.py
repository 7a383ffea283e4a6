"""Whether a sweep dataset holds every point it claims: unfinished and damaged stores.

A store's status variables have the fill value ``NOT_COMPUTED`` (13): a chunk
that was never written (an unfinished run's ``.<name>.zarr.partial``) or whose
status file was lost reads as "not computed", never as "ok". A lost file of a
number where ``status`` is ``OK`` reads as NaN, which a written point never is
(:func:`jaxwalk.sweep.runner.check_results`): that point is "damaged".
:func:`check_complete` refuses both with one line naming the chunks, unless
asked to let a partial dataset through (then its missing points are
``NOT_COMPUTED``, and the figures say so).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import xarray as xr

from jaxwalk import analyses
from jaxwalk.status import Status
from jaxwalk.errors import ConfigError


def required() -> tuple[str, ...]:
    """Numbers over the grid that a written point with ``status == OK`` always has:
    the outputs declared finite where the gait is (:mod:`jaxwalk.analyses`;
    ``lambda_max`` and ``h_max`` only when computed: somewhere finite)."""
    return tuple(
        o.name for a in analyses.registry() if a.status_of_outputs == "status" for o in a.outputs(a.fullest())
        if o.finite_where_ok and not o.trailing and not o.is_complex
    )


def statuses() -> tuple[str, ...]:
    """The status variables any analysis writes."""
    return tuple(o.name for o in analyses.declared() if o.flags)


class IncompleteStore(ConfigError):
    """A sweep dataset with points not computed or damaged (one line: which chunks)."""


def missing_points(ds: xr.Dataset) -> np.ndarray:
    """Boolean mask of the grid (``status``'s shape): points not computed or damaged."""
    status = ds["status"].values
    missing = status == Status.NOT_COMPUTED
    ok = status == Status.OK
    inf_is_a_value = {o.name for o in analyses.declared() if o.inf_is_a_value}  # unstable gait's GSN: inf
    for name in required():
        if name in ds and ds[name].dims == ds["status"].dims:
            values = ds[name].values
            nan = np.isnan(values) if name in inf_is_a_value else ~np.isfinite(values)
            if (ok & ~nan).any():  # computed in this sweep: NaN at an OK point is a lost file
                missing |= ok & nan
    return missing


def chunk_shape(ds: xr.Dataset) -> tuple[int, ...]:
    """The zarr chunk shape of the grid variables (the sweep's blocks); the whole grid if unknown."""
    chunks = ds["status"].encoding.get("chunks") or ds["status"].encoding.get("preferred_chunks")
    if isinstance(chunks, dict):
        chunks = tuple(chunks[d] for d in ds["status"].dims)
    return tuple(int(c) for c in chunks) if chunks else ds["status"].shape


def missing_chunks(ds: xr.Dataset) -> tuple[list[int], int]:
    """``(indices, count)``: the blocks (C order over the block grid, as the store's
    ``done/<i>``) holding a missing point, and how many blocks there are."""
    mask = missing_points(ds)
    chunks = chunk_shape(ds)
    grid = tuple(-(-n // c) for n, c in zip(mask.shape, chunks))
    pad = [(0, g * c - n) for g, c, n in zip(grid, chunks, mask.shape)]
    blocks = np.pad(mask, pad).reshape([x for g, c in zip(grid, chunks) for x in (g, c)])
    per_block = blocks.any(axis=tuple(range(1, 2 * len(grid), 2)))
    return [int(i) for i in np.flatnonzero(per_block)], int(np.prod(grid))


def ranges(indices: list[int]) -> str:
    """``"3, 5-7, 10"``."""
    out, start = [], None
    for i, j in zip(indices, indices[1:] + [None]):
        start = i if start is None else start
        if j != i + 1:
            out.append(str(i) if start == i else f"{start}-{i}")
            start = None
    return ", ".join(out)


def continue_command(path: str | Path) -> str | None:
    """The command that continues the unfinished run a store belongs to, if it is one
    (``DIR/.<name>.zarr.partial/<name>.zarr``: the partial directory's ``run.json``)."""
    try:
        return json.loads((Path(path).parent / "run.json").read_text()).get("command") or None
    except (OSError, ValueError, AttributeError):
        return None


def check_complete(ds: xr.Dataset, where: str | Path, *, partial: bool = False) -> xr.Dataset:
    """``ds`` if every point is there; with ``partial``, ``ds`` with its missing
    points set to ``NOT_COMPUTED`` (numbers NaN) and ``attrs["partial"]`` saying how
    much is there.

    Raises:
        IncompleteStore: points are missing and ``partial`` is false.
    """
    mask = missing_points(ds)
    if not mask.any():
        return ds
    indices, n_chunks = missing_chunks(ds)
    summary = f"{int(mask.sum())} of {mask.size} points in chunk{'s' * (len(indices) != 1)} {ranges(indices)} of {n_chunks}"
    if not partial:
        command = continue_command(where)
        how = f"continue it with: {command}" if command else "rerun the sweep that made it"
        raise IncompleteStore(
            f"'{where}' is incomplete: {summary} not computed or damaged; {how} (or --partial to draw what is done)"
        )
    ds = ds.copy()
    grid_dims = ds["status"].dims
    for name, var in ds.data_vars.items():
        if var.dims[: len(grid_dims)] != grid_dims:
            continue
        where_missing = xr.DataArray(mask, dims=grid_dims)
        if name in statuses():
            ds[name] = var.where(~where_missing, np.int8(Status.NOT_COMPUTED)).astype(var.dtype)
        elif np.issubdtype(var.dtype, np.inexact):
            ds[name] = var.where(~where_missing)
        ds[name].attrs = var.attrs
    ds.attrs["partial"] = f"partial: {mask.size - int(mask.sum())} of {mask.size} points computed"
    return ds
