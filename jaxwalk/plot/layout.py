"""Which grid axis goes where in a figure.

A figure shows a variable over one grid axis (``x``; a curve) or two (``x``
and ``y``; a heatmap, or for line plots one curve per ``y`` value, as the
paper's Figs. 5 and 6 draw one line per foot length). A third axis becomes
small multiples (one panel per value, ``panels``); every other axis is held
at one index (``fixed``: chosen with ``--at AXIS=INDEX``, else its first value).
Axes with a single value are always fixed: there is nothing to draw along them.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import xarray as xr

from jaxwalk.plot.source import PlotError, grid_axes

#: Most panels in one figure; a longer panel axis is shown at this many evenly spaced values.
MAX_PANELS = 12


@dataclasses.dataclass(frozen=True)
class Layout:
    """Where each grid axis goes.

    Attributes:
        x: the horizontal axis.
        y: the heatmap's vertical axis, or the line plot's one-curve-per-value axis;
            ``None``: a single curve.
        panels: the small-multiples axis (``None``: one panel).
        panel_indices: the indices of ``panels`` drawn, ascending.
        fixed: every other grid axis, at this index.
    """

    x: str
    y: str | None
    panels: str | None
    panel_indices: tuple[int, ...]
    fixed: dict[str, int]


def parse_at(items: list[str] | None) -> dict[str, int]:
    """``["a=2", "m=0"]`` (from ``--at``) as ``{"a": 2, "m": 0}``.

    Raises:
        PlotError: an item is not ``AXIS=INDEX`` with an integer index.
    """
    out: dict[str, int] = {}
    for item in items or []:
        axis, sep, index = item.partition("=")
        try:
            if not sep or not axis:
                raise ValueError
            out[axis.strip()] = int(index)
        except ValueError:
            raise PlotError(f"--at: expected AXIS=INDEX (an integer index into the axis), got '{item}'") from None
    return out


def choose_layout(
    ds: xr.Dataset,
    kind: str,
    *,
    x: str | None = None,
    y: str | None = None,
    at: dict[str, int] | None = None,
    max_panels: int = MAX_PANELS,
) -> Layout:
    """The layout of a ``kind`` (``"heatmap"`` or ``"lines"``) figure of ``ds``.

    Unchosen ``x`` and ``y`` are the axes with the most values (the first in grid
    order on ties), so a (3 foot lengths x 64 ratios) grid plots against the
    ratio, one line per foot length.

    Raises:
        PlotError: an unknown axis, an axis both drawn and fixed, an index out of
            range, or a heatmap without two axes of more than one value.
    """
    dims = grid_axes(ds)
    size = {d: ds.sizes[d] for d in dims}
    at = dict(at or {})
    for axis, index in at.items():
        if axis not in size:
            raise PlotError(f"--at: '{axis}' is not a grid axis (axes: {', '.join(dims)})")
        if not -size[axis] <= index < size[axis]:
            raise PlotError(f"--at: index {index} out of range for '{axis}' ({size[axis]} values: 0 to {size[axis] - 1})")
        at[axis] = index % size[axis]
    for flag, axis in (("--x", x), ("--y", y)):
        if axis is None:
            continue
        if axis not in size:
            raise PlotError(f"{flag}: '{axis}' is not a grid axis (axes: {', '.join(dims)})")
        if axis in at:
            raise PlotError(f"{flag}: '{axis}' is also fixed by --at")
        if size[axis] < 2:
            raise PlotError(f"{flag}: '{axis}' has a single value; there is nothing to draw along it")
    if x is not None and x == y:
        raise PlotError(f"--x and --y are both '{x}'")

    # Free axes, longest first (stable sort: grid order on ties).
    free = sorted((d for d in dims if size[d] > 1 and d not in at and d not in (x, y)), key=lambda d: -size[d])
    if x is None:
        if not free:
            raise PlotError("no grid axis with more than one value is left to draw along")
        x = free.pop(0)
    if y is None and free:
        y = free.pop(0)
    if kind == "heatmap" and y is None:
        described = ", ".join(f"{d} ({size[d]})" for d in dims)
        raise PlotError(f"a heatmap needs two grid axes with more than one value each; this dataset has {described}")
    panels = free.pop(0) if free else None
    panel_indices: tuple[int, ...] = ()
    if panels is not None:
        n = size[panels]
        # Panels in ascending order of value (a values = [...] axis may be in any order).
        by_value = np.argsort(ds[panels].values, kind="stable")
        shown = range(n) if n <= max_panels else np.unique(np.linspace(0, n - 1, max_panels).round().astype(int))
        panel_indices = tuple(int(by_value[k]) for k in shown)
    fixed = {d: at.get(d, 0) for d in dims if d not in (x, y, panels)}
    return Layout(x=x, y=y, panels=panels, panel_indices=panel_indices, fixed=fixed)


def panel_views(ds: xr.Dataset, layout: Layout) -> list[tuple[int | None, xr.Dataset]]:
    """``[(panel index or None, the data of that panel)]``: fixed axes selected,
    drawn axes sorted ascending (a ``values = [...]`` axis may be in any order)."""
    view = ds.isel(layout.fixed) if layout.fixed else ds
    drawn = [a for a in (layout.x, layout.y) if a is not None]
    view = view.sortby(drawn)
    if layout.panels is None:
        return [(None, view)]
    return [(i, view.isel({layout.panels: i})) for i in layout.panel_indices]
