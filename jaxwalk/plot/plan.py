"""Plot a sweep dataset: which figures, drawn, then written.

:func:`make_figures` checks every choice (variables, axes, kinds, format) and
draws every figure in memory; :func:`plot_dataset` then writes them. Bad input
is a :class:`~jaxwalk.plot.source.PlotError` raised before any file is written.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Sequence

import xarray as xr

from jaxwalk.plot.attractors import view_for
from jaxwalk.plot.heatmap import heatmap_figure
from jaxwalk.plot.layout import MAX_PANELS, choose_layout, parse_at
from jaxwalk.plot.lines import lines_figure
from jaxwalk.plot.output import FORMATS, figure_path, save_figure
from jaxwalk.plot.source import PlotError, check_sweep, choose_variables, open_sweep

#: Figure kinds, in the order they are drawn.
KINDS = ("heatmap", "lines")


def make_figures(
    ds: xr.Dataset,
    *,
    variables: Sequence[str] | None = None,
    kinds: Sequence[str] | None = None,
    x: str | None = None,
    y: str | None = None,
    at: dict[str, int] | Sequence[str] | None = None,
    max_panels: int = MAX_PANELS,
) -> dict[tuple[str, str], object]:
    """``{(variable, kind): Figure}`` for a sweep dataset, nothing written.

    Args:
        ds: a sweep dataset (in memory; :func:`jaxwalk.plot.source.open_sweep` reads one).
        variables: names to draw (default: :data:`jaxwalk.plot.source.DEFAULT_VARIABLES`,
            those the dataset has with values; attractor variables on the
            attractor's statuses, :mod:`jaxwalk.plot.attractors`).
        kinds: among :data:`KINDS`; default: line plots, and heatmaps when the grid
            has two axes of more than one value. A heatmap asked for on a grid
            without them is an error.
        x, y, at, max_panels: the layout (:func:`jaxwalk.plot.layout.choose_layout`);
            ``at`` as ``{axis: index}`` or ``["axis=index", ...]``.

    Raises:
        PlotError: an unknown variable, kind or axis, or an impossible layout.
    """
    check_sweep(ds, ds.attrs.get("name", "dataset"))
    names = choose_variables(ds, variables)
    at = parse_at(list(at)) if at is not None and not isinstance(at, dict) else dict(at or {})
    if kinds is None:
        try:
            layouts = {"heatmap": choose_layout(ds, "heatmap", x=x, y=y, at=at, max_panels=max_panels)}
        except PlotError:
            layouts = {}  # a 1-D grid (or one axis left): line plots only
        layouts["lines"] = choose_layout(ds, "lines", x=x, y=y, at=at, max_panels=max_panels)
    else:
        unknown = [k for k in kinds if k not in KINDS]
        if unknown:
            raise PlotError(f"--kind: unknown kind '{unknown[0]}' (kinds: {', '.join(KINDS)})")
        layouts = {k: choose_layout(ds, k, x=x, y=y, at=at, max_panels=max_panels) for k in KINDS if k in kinds}
    draw = {"heatmap": heatmap_figure, "lines": lines_figure}
    return {(name, kind): draw[kind](view_for(ds, name), name, layout) for name in names for kind, layout in layouts.items()}


def plot_dataset(
    dataset: xr.Dataset | str | os.PathLike,
    out_dir: str | os.PathLike | None = None,
    *,
    fmt: str = "png",
    partial: bool = False,
    **choices,
) -> list[Path]:
    """Draw the figures of a sweep dataset and write one file per figure; return their paths.

    Files are ``out_dir/<name>_<variable>_<kind>.<fmt>`` (:mod:`jaxwalk.plot.output`),
    each written atomically, only after every figure has been drawn.

    Args:
        dataset: the dataset, or the path of its zarr store.
        out_dir: where to write (created if needed); default: the store's directory.
        fmt: ``"png"``, ``"pdf"`` or ``"svg"``.
        partial: draw an unfinished or damaged store's computed points (the rest
            shown as "not computed", the title saying how much), instead of refusing it.
        **choices: ``variables``, ``kinds``, ``x``, ``y``, ``at``, ``max_panels`` of :func:`make_figures`.

    Raises:
        PlotError: bad input (see :func:`make_figures`, :func:`jaxwalk.plot.source.open_sweep`),
            an unknown format, or an ``out_dir`` that cannot be written; nothing is written then.
    """
    if fmt not in FORMATS:
        raise PlotError(f"--format: unknown format '{fmt}' (formats: {', '.join(FORMATS)})")
    if isinstance(dataset, xr.Dataset):
        ds = dataset
        if out_dir is None:
            raise PlotError("out_dir is required when plotting a dataset that is not read from a file")
    else:
        ds = open_sweep(dataset, partial=partial)
        out_dir = Path(dataset).parent if out_dir is None else out_dir
    out = check_out_dir(out_dir)
    figures = make_figures(ds, **choices)
    out.mkdir(parents=True, exist_ok=True)
    name = ds.attrs.get("name") or "sweep"
    return [save_figure(fig, figure_path(out, name, var, kind, fmt), fmt) for (var, kind), fig in figures.items()]


def check_out_dir(out_dir: str | os.PathLike) -> Path:
    """``out_dir`` as a path if it is, or can be made, a writable directory; creates nothing.

    Raises:
        PlotError: it is a file, or its nearest existing ancestor is not a writable directory.
    """
    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise PlotError(f"--out '{out}' exists and is not a directory")
    existing = out
    while not existing.exists() and existing.parent != existing:
        existing = existing.parent
    if not existing.is_dir() or not os.access(existing, os.W_OK | os.X_OK):
        raise PlotError(f"--out '{out}': '{existing}' is not a writable directory")
    return out
