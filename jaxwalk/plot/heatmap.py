"""Heatmaps of a sweep variable over two grid axes, failures masked by status.

Each panel draws, bottom to top:

* the variable where a gait was found (status 0), on one viridis scale shared by all panels
  (logarithmic for a variable that asks for it, :mod:`jaxwalk.plot.scale`);
* every failure region (status != 0) as a categorical overlay, one fixed colour
  per status (:mod:`jaxwalk.plot.statuses`), named in the legend with its count;
* unstable gaits (status 0, ``lambda_max >= 1``) hatched, so a value map of
  speed or h_max still shows which gaits would not persist;
* the ``lambda_max = 1`` contour, where ``lambda_max`` crosses 1;
* with a bifurcation table (``[analysis] bifurcations``), the folds, flips and
  lost-gait edges located on the continuation lines, joined into curves
  (:mod:`jaxwalk.plot.loci`).

Cells are centred on the grid values (``shading="nearest"``), so a cell's
colour is exactly the value computed there; nothing is interpolated.
"""

from __future__ import annotations

import math

import numpy as np
import xarray as xr

from jaxwalk.plot import loci
from jaxwalk.plot.labels import (
    STABILITY_LIMIT, UNSTABLE, axis_label, figure_title, legend_columns, value_text, variable_label,
)
from jaxwalk.plot.layout import Layout, panel_views
from jaxwalk.plot.scale import use_log_scale
from jaxwalk.plot.statuses import failure_causes, failure_codes, legend_label, status_color, status_names
from jaxwalk.status import Status

#: Hatch of unstable gaits; its lines are drawn in :data:`HATCH_COLOR`.
HATCH = "////"
HATCH_COLOR = "0.1"
#: Smallest share of a panel a failure region needs to carry its name as well as its colour.
MIN_LABELLED_FRACTION = 0.03
#: Group id of the lambda_max = 1 contour (tests and callers find it by this).
CONTOUR_GID = "lambda_max=1"
#: Share (percent) of a heatmap's gaits at each end that may lie beyond a
#: linear colour scale's ends (:func:`linear_limits`).
OUTLIER_PERCENT = 1.0


def cell_edges(centres: np.ndarray) -> np.ndarray:
    """``(n + 1,)`` cell edges around ascending ``(n,)`` centres: midpoints, ends mirrored."""
    c = np.asarray(centres, np.float64)
    mid = 0.5 * (c[1:] + c[:-1])
    return np.concatenate([[c[0] - (mid[0] - c[0])], mid, [c[-1] + (c[-1] - mid[-1])]])


def heatmap_figure(ds: xr.Dataset, name: str, layout: Layout):
    """A :class:`matplotlib.figure.Figure` of ``ds[name]`` over ``layout.x`` (horizontal)
    and ``layout.y`` (vertical), one panel per ``layout.panels`` value.

    Args:
        ds: a sweep dataset (:func:`jaxwalk.plot.source.check_sweep`).
        name: a variable over the grid axes.
        layout: from :func:`jaxwalk.plot.layout.choose_layout` with ``kind="heatmap"``.
    """
    from matplotlib.colors import LogNorm, Normalize, TwoSlopeNorm
    from matplotlib.figure import Figure  # no pyplot: no global backend or state

    views = panel_views(ds, layout)
    ncols = min(len(views), 4)
    nrows = math.ceil(len(views) / ncols)
    single = len(views) == 1
    fig = Figure(figsize=(8.0, 5.6) if single else (2.9 * ncols + 1.8, 2.5 * nrows + 1.8), layout="constrained")
    axes = fig.subplots(nrows, ncols, sharex=True, sharey=True, squeeze=False).ravel()
    for ax in axes[len(views):]:
        ax.set_visible(False)

    finite = np.concatenate([v[name].where(v["status"] == Status.OK).values.ravel() for _, v in views])
    finite = finite[np.isfinite(finite)]
    low, high, extend = linear_limits(finite) if finite.size else (0.0, 1.0, "neither")
    norm = Normalize(low, high)
    if finite.size and norm.vmin == norm.vmax:  # one value everywhere: still a readable scale
        norm = Normalize(norm.vmin - 0.5 * (abs(norm.vmin) or 1.0), norm.vmax + 0.5 * (abs(norm.vmax) or 1.0))
    bar_label = variable_label(ds, name) + _beyond_text(finite, low, high, extend)
    if name == "lambda_max" and finite.size and finite.min() < 1.0 < finite.max():
        # Stable gaits get half the colours whatever the largest unstable value
        # (one lambda_max of 3.4 made every stable cell the same dark purple).
        norm = TwoSlopeNorm(vcenter=1.0, vmin=float(finite.min()), vmax=float(finite.max()))
        bar_label = variable_label(ds, name) + "\n(linear below 1 and above 1, 1 at mid-scale)"
    elif use_log_scale(ds, name, finite):
        norm = LogNorm(vmin=float(finite.min()), vmax=float(finite.max()))
        bar_label = variable_label(ds, name) + " (log scale)"
    if isinstance(norm, (TwoSlopeNorm, LogNorm)):
        extend = "neither"  # these scales span every value

    counts: dict[int, int] = {}
    drew_contour = drew_unstable = drew_unlocated = False
    kinds: set[str] = set()
    mesh = None
    beyond = {"above": 0, "below": 0}
    for ax, (index, view) in zip(axes, views):
        mesh, c, u = _panel(ax, view, name, layout, norm, counts)
        _mark_beyond(ax, view, name, layout, low if extend in ("min", "both") else -np.inf,
                     high if extend in ("max", "both") else np.inf, beyond)
        drew_contour |= c
        drew_unstable |= u
        k, unlocated = loci.draw(ax, ds, view, layout.x, layout.y)
        kinds |= k
        drew_unlocated |= unlocated
        if index is not None:
            ax.set_title(value_text(ds, layout.panels, index), fontsize="medium")
    for i, ax in enumerate(axes[: len(views)]):
        if i + ncols >= len(views):  # no panel below this one
            ax.set_xlabel(axis_label(ds, layout.x, long=single))
        if ax.get_subplotspec().is_first_col():
            ax.set_ylabel(axis_label(ds, layout.y, long=single))
    if finite.size:
        bar = fig.colorbar(mesh, ax=axes[: len(views)].tolist(), label=bar_label, shrink=0.9 if single else 0.7,
                           extend=extend)
        if isinstance(norm, TwoSlopeNorm):
            bar.set_ticks(_two_slope_ticks(norm.vmin, norm.vmax))
    fig.suptitle(figure_title(ds, name, layout.fixed), fontsize="medium")
    handles = _legend_handles(ds, counts, drew_contour, drew_unstable) + loci.legend_handles(kinds, drew_unlocated)
    handles += [_beyond_handle(side, n) for side, n in beyond.items() if n]
    if not finite.size:
        handles.insert(0, _patch("white", "no gait found anywhere on this view", edge="none"))
    if handles:
        fig.legend(handles=handles, loc="outside lower center", ncols=legend_columns(handles), fontsize="small", frameon=False)
    return fig


def linear_limits(values: np.ndarray) -> tuple[float, float, str]:
    """``(low, high, extend)``: a linear colour scale's ends for the drawn ``values``
    and the colour bar's ``extend`` (``"neither"``, ``"min"``, ``"max"``, ``"both"``).

    The ends are the extreme values, except at an end where the few most
    extreme cells (:data:`OUTLIER_PERCENT` of them) span more of the range
    than all the cells between the two percentiles: there the scale ends at
    the percentile, the cells beyond take the end colour, and the bar's arrow
    (and its label, :func:`_beyond_text`) says so. The gait sensitivity norm
    of the shoe walker's foot plane is 14.8-24.2 at 90 % of its gaits and up
    to 232 next to a flip; on a scale to 232 the whole plane was one colour.
    """
    low, high = float(values.min()), float(values.max())
    # Drawn values, not interpolated between them: on a small grid the
    # interpolated percentile lies between the outlier and the next value.
    p_low = float(np.percentile(values, OUTLIER_PERCENT, method="higher"))
    p_high = float(np.percentile(values, 100.0 - OUTLIER_PERCENT, method="lower"))
    central = p_high - p_low
    # A stepped or nearly constant variable (h_max, Newton iterations) has no
    # central range to keep: clipping there would leave one colour.
    clip_high = central > 0.0 and high - p_high > central
    clip_low = central > 0.0 and p_low - low > central
    extend = {(False, False): "neither", (True, False): "min", (False, True): "max", (True, True): "both"}
    return (p_low if clip_low else low), (p_high if clip_high else high), extend[clip_low, clip_high]


def _beyond_text(values: np.ndarray, low: float, high: float, extend: str) -> str:
    """The colour bar label's note on the cells beyond a clipped scale ("" if none)."""
    notes = []
    if extend in ("max", "both"):
        notes.append(f"{int((values > high).sum())} above, up to {values.max():.4g}")
    if extend in ("min", "both"):
        notes.append(f"{int((values < low).sum())} below, down to {values.min():.4g}")
    return "\n(scale clipped at the outliers: " + "; ".join(notes) + ")" if notes else ""


#: Markers on the cells whose value lies beyond a clipped colour scale: those
#: cells take the scale's end colour, which alone would not tell them apart.
BEYOND_MARKERS = {"above": "^", "below": "v"}


def _mark_beyond(ax, view: xr.Dataset, name: str, layout: Layout, low: float, high: float, beyond: dict[str, int]) -> None:
    """Mark the gaits whose ``name`` lies above ``high`` or below ``low`` (the clipped
    scale's ends; infinite where that end is not clipped); add their counts to ``beyond``."""
    ok = view["status"].transpose(layout.y, layout.x).values == Status.OK
    values = np.where(ok, view[name].transpose(layout.y, layout.x).values, np.nan)
    values[~np.isfinite(values)] = np.nan  # an infinite value is drawn blank, not at the scale's end
    xx, yy = np.meshgrid(view[layout.x].values, view[layout.y].values)
    size = min(16.0, (300.0 / max(xx.shape)) ** 2)  # points^2: no larger than a cell of a fine grid
    for side, cells in (("above", values > high), ("below", values < low)):
        if cells.any():
            ax.scatter(xx[cells], yy[cells], marker=BEYOND_MARKERS[side], s=size, facecolors="white",
                       edgecolors="k", linewidths=0.5, zorder=3, gid=f"beyond-scale-{side}")
            beyond[side] += int(cells.sum())


def _beyond_handle(side: str, count: int):
    from matplotlib.lines import Line2D

    return Line2D([], [], marker=BEYOND_MARKERS[side], linestyle="none", markerfacecolor="white", markeredgecolor="k",
                  label=f"{side} the colour scale ({count} point{'s' if count != 1 else ''})")


def _two_slope_ticks(vmin: float, vmax: float) -> list[float]:
    """Four ticks on each side of 1, rounded to 3 decimals and kept inside
    ``[vmin, vmax]``: a tick past either end (1.722 on a scale ending at
    1.72195) sent every tick of the two-slope colour bar to its foot."""
    ticks = {round(float(t), 3) for t in np.linspace(vmin, 1.0, 4)} | {round(float(t), 3) for t in np.linspace(1.0, vmax, 4)}
    return sorted(t for t in ticks if vmin <= t <= vmax)


def _panel(ax, view: xr.Dataset, name: str, layout: Layout, norm, counts: dict[int, int]):
    """Draw one panel; add its failure counts to ``counts``; return
    ``(value mesh, whether the contour was drawn, whether unstable gaits were hatched)``."""
    from matplotlib import patheffects
    from matplotlib.colors import ListedColormap

    x, y = view[layout.x].values, view[layout.y].values
    status = view["status"].transpose(layout.y, layout.x).values
    ok = status == Status.OK
    values = np.where(ok, view[name].transpose(layout.y, layout.x).values, np.nan)
    # Points with a gait but no value (a variable NaN there) show the axes' face colour.
    ax.set_facecolor("white")
    mesh = ax.pcolormesh(x, y, np.ma.masked_invalid(values), shading="nearest", norm=norm, cmap="viridis")

    codes = failure_codes(status)
    if codes:
        category = np.full(status.shape, -1)
        for i, code in enumerate(codes):
            category[status == code] = i
            counts[code] = counts.get(code, 0) + int((status == code).sum())
        cmap = ListedColormap([status_color(c) for c in codes])
        ax.pcolormesh(
            x, y, np.ma.masked_less(category, 0), shading="nearest", cmap=cmap, vmin=-0.5, vmax=len(codes) - 0.5
        )
        names = status_names(view["status"])
        for code in codes:
            _name_region(ax, x, y, status == code, names.get(code, str(code)))

    contour = unstable_drawn = False
    if "lambda_max" in view and np.isfinite(view["lambda_max"].values).any():
        lam = np.where(ok, view["lambda_max"].transpose(layout.y, layout.x).values, np.nan)
        unstable = ok & (lam >= 1.0)
        if unstable.any():
            _hatch_cells(ax, cell_edges(x), cell_edges(y), unstable)
            unstable_drawn = True
        if unstable.any() and (lam < 1.0).any() and min(lam.shape) > 1:
            cs = ax.contour(x, y, np.ma.masked_invalid(lam), levels=[1.0], colors="k", linewidths=1.6)
            cs.set_gid(CONTOUR_GID)
            cs.set(path_effects=[patheffects.withStroke(linewidth=3.2, foreground="white")])
            contour = any(len(seg) for seg in cs.allsegs[0])
    return mesh, contour, unstable_drawn


def _name_region(ax, x: np.ndarray, y: np.ndarray, mask: np.ndarray, name: str) -> None:
    """Write ``name`` on a failure region (``mask``, ``(ny, nx)``) large enough to hold it,
    at its cell nearest the region's centroid (inside the region even when it is not convex)."""
    if mask.sum() < max(4, MIN_LABELLED_FRACTION * mask.size):
        return
    iy, ix = np.nonzero(mask)
    # Centroid in index space: axes may be unevenly spaced, the cells are what is seen.
    k = np.argmin((iy - iy.mean()) ** 2 + (ix - ix.mean()) ** 2)
    ax.text(
        x[ix[k]], y[iy[k]], name, ha="center", va="center", fontsize="small", gid="status-label",
        bbox={"boxstyle": "round,pad=0.2", "facecolor": "white", "alpha": 0.75, "linewidth": 0},
    )


def _hatch_cells(ax, x_edges: np.ndarray, y_edges: np.ndarray, mask: np.ndarray) -> None:
    """Hatch the cells where ``mask`` (``(ny, nx)``) is true, following the grid exactly:
    one rectangle per run of consecutive cells in a row (the hatch pattern is aligned
    across rectangles; runs, not cells, keep a 1000 x 1000 map fast to draw)."""
    from matplotlib.collections import PolyCollection

    padded = np.pad(mask, ((0, 0), (1, 1))).astype(np.int8)
    iy, start = np.nonzero(np.diff(padded, axis=1) == 1)  # a run starts at cell `start`
    _, stop = np.nonzero(np.diff(padded, axis=1) == -1)  # ... and ends before cell `stop`
    x0, x1, y0, y1 = x_edges[start], x_edges[stop], y_edges[iy], y_edges[iy + 1]
    verts = np.stack([np.stack([x0, y0], -1), np.stack([x1, y0], -1), np.stack([x1, y1], -1), np.stack([x0, y1], -1)], 1)
    cells = PolyCollection(verts, facecolors="none", edgecolors=HATCH_COLOR, linewidths=0.0, hatch=HATCH)
    cells.set_gid("unstable")
    ax.add_collection(cells, autolim=False)


def _patch(color: str, label: str, *, edge: str = "0.3", hatch: str | None = None):
    from matplotlib.patches import Patch

    return Patch(facecolor=color, edgecolor=edge, hatch=hatch, linewidth=0.6, label=label)


def _legend_handles(ds: xr.Dataset, counts: dict[int, int], contour: bool, unstable: bool) -> list:
    from matplotlib.lines import Line2D

    handles = []
    if contour:
        handles.append(Line2D([], [], color="k", linewidth=1.6, label=STABILITY_LIMIT))
    if unstable:
        handles.append(_patch("white", UNSTABLE, edge=HATCH_COLOR, hatch=HATCH))
    names, causes = status_names(ds["status"]), failure_causes(ds)
    for code in sorted(counts):
        label = legend_label(names.get(code, str(code)), counts[code], cause=causes.get(code))
        handles.append(_patch(status_color(code), label))
    return handles
