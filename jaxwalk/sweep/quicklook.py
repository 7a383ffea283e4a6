"""A quick-look figure of a sweep dataset, written next to it.

``lambda_max`` (or ``speed`` when stability was not computed) over the first
one or two grid axes: a curve with failures marked by status for one axis, a
heatmap with the ``lambda_max = 1`` contour for two. Further axes are shown at
their first value. Publication figures belong to the plotting module; this
one only shows at a glance what a sweep found.
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

import numpy as np
import xarray as xr

from jaxwalk.status import Status, describe


def save_quicklook(ds: xr.Dataset, path: str | Path) -> Path:
    """Draw the quick-look figure of ``ds`` to ``path`` (PNG), atomically."""
    from matplotlib.figure import Figure  # no pyplot: no global backend or state

    dims = ds.attrs["swept_parameters"].split()
    rest = {d: 0 for d in dims[2:]}
    view = ds.isel(rest) if rest else ds
    name = "lambda_max" if ds.attrs.get("stability", 1) and np.isfinite(ds["lambda_max"].values).any() else "speed"
    var = view[name]

    fig = Figure(figsize=(7, 4.5), layout="constrained")
    ax = fig.add_subplot()
    title = f"{ds.attrs['name']}: {ds.attrs['model']}"
    if rest:
        title += " at " + ", ".join(f"{d} = {ds[d].values[0]:.4g}" for d in rest)
    ax.set_title(title)
    if len(dims) == 1:
        _curve(ax, view, dims[0], var)
    else:
        _heatmap(fig, ax, view, dims[0], dims[1], var)

    path = Path(path)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    os.close(fd)
    try:
        fig.savefig(tmp, format="png", dpi=120)
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.remove(tmp)
    return path


def _label(da: xr.DataArray, long: bool = True) -> str:
    """``name: long name [units]`` for grid axes; variables' long names are too long for an axis."""
    units = da.attrs.get("units")
    text = f"{da.name}: {da.attrs['long_name']}" if long and "long_name" in da.attrs else str(da.name)
    return text + (f" [{units}]" if units and units != "1" else "")


def _curve(ax, ds: xr.Dataset, x: str, var: xr.DataArray) -> None:
    xs = ds[x].values
    ys = var.values
    status = ds["status"].values
    ok = status == Status.OK
    ax.plot(xs[ok], ys[ok], ".-", color="C0", label=f"{var.name} (status ok)")
    if var.name == "lambda_max":
        ax.axhline(1.0, color="k", lw=0.8, ls="--", label="stability limit")
    bottom = np.nanmin(ys[ok]) if ok.any() else 0.0
    for i, code in enumerate(c for c in np.unique(status) if c != Status.OK):
        sel = status == code
        ax.plot(xs[sel], np.full(sel.sum(), bottom), "x", color=f"C{i + 1}", label=f"{describe(code)} ({sel.sum()})")
    ax.set_xlabel(_label(ds[x]))
    ax.set_ylabel(_label(var, long=False))
    ax.legend(fontsize="small")


def _heatmap(fig, ax, ds: xr.Dataset, x: str, y: str, var: xr.DataArray) -> None:
    values = var.transpose(y, x).values
    ax.set_facecolor("0.85")  # failed points are NaN: they show the background
    mesh = ax.pcolormesh(ds[x].values, ds[y].values, values, shading="nearest")
    fig.colorbar(mesh, ax=ax, label=_label(var, long=False))
    if var.name == "lambda_max" and min(values.shape) > 1 and np.nanmin(values, initial=np.inf) < 1.0 < np.nanmax(values, initial=-np.inf):
        ax.contour(ds[x].values, ds[y].values, values, levels=[1.0], colors="k", linewidths=1.0)
    ax.set_xlabel(_label(ds[x]))
    ax.set_ylabel(_label(ds[y]))
    n_failed = int((ds["status"].values != Status.OK).sum())
    ax.text(0.01, 0.01, f"grey: no gait ({n_failed} points)", transform=ax.transAxes, fontsize="small")
