"""Line plots in the style of the paper's Figs. 5 and 6: a variable against one
grid axis, one curve per value of another (lambda_m against foot ratio r, one
line per foot length l_f).

Gaits found are joined by lines (a failed point breaks the line); stable gaits
are filled markers, unstable ones (``lambda_max >= 1``) open markers. Failed
points have no value, so they are marked on a thin strip under each panel,
one row per curve in the curve's colour, with one marker shape per status,
named in the legend. ``lambda_max`` figures draw the stability limit
``lambda_max = 1`` and, with a bifurcation table, mark the points located on
each curve (folds, flips, border collisions, edges: at their parameter and
largest multiplier modulus, :func:`jaxwalk.plot.loci.draw_on_curve`); a variable that asks for it is drawn on a logarithmic value
axis (:mod:`jaxwalk.plot.scale`); a variable with an error estimate beside it
(``<name>_error``: the MFPT's, the basin fraction's) gets error bars.
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
from jaxwalk.plot.statuses import failure_causes, failure_codes, legend_label, status_marker, status_names
from jaxwalk.status import Status

#: Most curves in one panel; a longer curve axis is shown at this many evenly spaced values.
MAX_CURVES = 8
#: Group id of the stability-limit line (tests and callers find it by this).
LIMIT_GID = "lambda_max=1"
#: Rows of the key below the panels that the figure's own height leaves room
#: for, and the height (inches) added for each row beyond them.
LEGEND_ROWS_FREE, LEGEND_ROW_INCHES = 6, 0.24


def curve_indices(n: int, max_curves: int = MAX_CURVES) -> list[int]:
    """All of ``range(n)``, or ``max_curves`` evenly spaced indices including both ends."""
    if n <= max_curves:
        return list(range(n))
    return np.unique(np.linspace(0, n - 1, max_curves).round().astype(int)).tolist()


def lines_figure(ds: xr.Dataset, name: str, layout: Layout):
    """A :class:`matplotlib.figure.Figure` of ``ds[name]`` against ``layout.x``, one
    curve per ``layout.y`` value (a single curve when ``layout.y`` is ``None``),
    one panel per ``layout.panels`` value.

    Args:
        ds: a sweep dataset (:func:`jaxwalk.plot.source.check_sweep`).
        name: a variable over the grid axes.
        layout: from :func:`jaxwalk.plot.layout.choose_layout` with ``kind="lines"``.
    """
    from matplotlib import colormaps
    from matplotlib.figure import Figure  # no pyplot: no global backend or state

    views = panel_views(ds, layout)
    ncols = min(len(views), 3)
    nrows = math.ceil(len(views) / ncols)
    single = len(views) == 1
    n_y = ds.sizes[layout.y] if layout.y else 1
    picked = curve_indices(n_y)
    # A sequential map keeps the curves' order readable (short foot to long foot).
    # Its light end stops at coral, 3:1 contrast on white (WCAG's for graphics): yellow vanishes.
    colors = ["C0"] if layout.y is None else [colormaps["plasma"](f) for f in np.linspace(0.0, 0.6, len(picked))]
    lam_known = "lambda_max" in ds and np.isfinite(ds["lambda_max"].values).any()
    drawn_values = np.concatenate([v[name].where(v["status"] == Status.OK).values.ravel() for _, v in views])
    log_scale = use_log_scale(ds, name, drawn_values)
    any_failed = any((v["status"].values != Status.OK).any() for _, v in views)

    fig = Figure(figsize=(8.0, 5.2) if single else (3.6 * ncols + 2.4, 3.0 * nrows + 1.4), layout="constrained")
    # Each panel is a value axes over a thin strip axes for the failed points (which have no value).
    step = 2 if any_failed else 1
    ratios = [1.0, 0.08 + 0.03 * len(picked)] if any_failed else [1.0]
    grid = fig.add_gridspec(step * nrows, ncols, height_ratios=ratios * nrows)
    axes, strips = [], []
    for k in range(len(views)):
        r, c = divmod(k, ncols)
        ax = fig.add_subplot(grid[step * r, c], sharey=axes[0] if axes else None)
        strip = fig.add_subplot(grid[step * r + 1, c], sharex=ax) if any_failed else None
        axes.append(ax)
        strips.append(strip)

    counts: dict[int, int] = {}
    unstable_any = False
    curve_handles: list = []
    located, unlocated = set(), False
    for i, (ax, strip, (index, view)) in enumerate(zip(axes, strips, views)):
        drawn = _panel(ax, strip, view, name, layout, picked, colors, lam_known, counts)
        unstable_any |= drawn["unstable"]
        located |= drawn["located"]
        unlocated |= drawn["unlocated"]
        curve_handles = drawn["handles"]
        if name == "lambda_max":
            ax.axhline(1.0, color="k", linewidth=0.9, linestyle="--", gid=LIMIT_GID)
        if index is not None:
            ax.set_title(value_text(ds, layout.panels, index), fontsize="medium")
        ax.grid(True, linewidth=0.4, alpha=0.5)
        bottom = strip if strip is not None else ax
        if strip is not None:
            ax.tick_params(labelbottom=False)
            labels = [f"{float(ds[layout.y].values[j]):.3g}" for j in picked] if layout.y else [""]
            _style_strip(strip, labels, first_col=i % ncols == 0)
        if i + ncols >= len(views):  # no panel below this one
            bottom.set_xlabel(axis_label(ds, layout.x, long=single))
        if log_scale:
            ax.set_yscale("log")
        if i % ncols == 0:
            ax.set_ylabel(variable_label(ds, name) + (" (log scale)" if log_scale else ""))
        else:
            ax.tick_params(labelleft=False)
    fig.suptitle(figure_title(ds, name, layout.fixed), fontsize="medium")

    if layout.y is not None:
        title = axis_label(ds, layout.y, long=False)
        if len(picked) < n_y:
            title += f"\n({len(picked)} of {n_y} values)"
        fig.legend(handles=curve_handles, loc="outside right center", fontsize="small", title=title, title_fontsize="small")
    keys = _key_handles(ds, name, counts, unstable_any, lam_known, subset=len(picked) < n_y)
    keys += loci.legend_markers(located, unlocated)
    if keys:
        _bottom_key(fig, keys)
    return fig


def _bottom_key(fig, keys: list) -> None:
    """The key of markers and statuses under the panels, the figure made taller
    for each of its rows beyond :data:`LEGEND_ROWS_FREE`: the panels' height is
    fixed, and constrained layout gives the key its rows first, so a long key
    would squeeze them flat."""
    columns = legend_columns(keys)
    fig.legend(handles=keys, loc="outside lower center", ncols=columns, fontsize="small", frameon=False)
    rows = math.ceil(len(keys) / columns)
    width, height = fig.get_size_inches()
    fig.set_size_inches(width, height + LEGEND_ROW_INCHES * max(0, rows - LEGEND_ROWS_FREE))


def _panel(ax, strip, view: xr.Dataset, name: str, layout: Layout, picked, colors, lam_known: bool, counts: dict[int, int]) -> dict:
    """Draw one panel's curves on ``ax`` and its failed points on ``strip`` (one row
    per curve, top row the first curve); add failure counts to ``counts``."""
    x = view[layout.x].values
    handles = []
    unstable_any = False
    located, unlocated = set(), False  # bifurcation kinds marked on the curves
    for row, (j, color) in enumerate(zip(picked, colors)):
        curve = view.isel({layout.y: j}) if layout.y else view
        status = curve["status"].transpose(layout.x).values
        ok = status == Status.OK
        y = np.where(ok, curve[name].transpose(layout.x).values, np.nan)
        label = f"{float(view[layout.y].values[j]):.4g}" if layout.y else name
        (line,) = ax.plot(x, y, "-", color=color, linewidth=1.5, label=label)
        stable = ok.copy()
        if lam_known:
            lam = curve["lambda_max"].transpose(layout.x).values
            unstable = ok & (lam >= 1.0)
            stable &= ~unstable
            if unstable.any():
                unstable_any = True
                ax.plot(x[unstable], y[unstable], "o", markersize=4, markerfacecolor="white", markeredgecolor=color, linestyle="none")
        ax.plot(x[stable], y[stable], "o", markersize=3, color=color, linestyle="none")
        _error_bars(ax, curve, name, layout, ok, y, color)
        if name == "lambda_max" and "bifurcation_kind" in curve:
            k, u = loci.draw_on_curve(ax, curve, layout.x, color)
            located |= k
            unlocated |= u
        handles.append(line)
        for code in failure_codes(status):
            sel = status == code
            counts[code] = counts.get(code, 0) + int(sel.sum())
            strip.plot(
                x[sel], np.full(sel.sum(), -row), status_marker(code), color=color, markersize=5,
                linestyle="none", gid=f"failed:{code}",
            )
    return {"handles": handles, "unstable": unstable_any, "located": located, "unlocated": unlocated}


def error_name(ds: xr.Dataset, name: str) -> str | None:
    """The variable holding ``name``'s error estimate (``mfpt_error``,
    ``basin_fraction_error``), if the dataset has one."""
    return f"{name}_error" if f"{name}_error" in ds else None


def _error_bars(ax, curve: xr.Dataset, name: str, layout: Layout, ok: np.ndarray, y: np.ndarray, color) -> None:
    """``+-`` the variable's own error estimate at each gait: an MFPT's is often
    half its value, and a curve drawn without it claims an order it may not have.
    On a log axis a bar whose lower end is not positive runs off the bottom."""
    err_name = error_name(curve, name)
    if err_name is None:
        return
    err = np.where(ok, curve[err_name].transpose(layout.x).values, np.nan)
    shown = np.isfinite(y) & np.isfinite(err)
    if shown.any():
        bars = ax.errorbar(curve[layout.x].values[shown], y[shown], yerr=err[shown], fmt="none", ecolor=color,
                           elinewidth=1.0, capsize=2.5)
        for part in bars.lines[2]:
            part.set_gid("error-bar")


def _style_strip(strip, labels: list[str], *, first_col: bool) -> None:
    """The failure strip: rows ``0, -1, ..., -(rows - 1)``, each named by its curve's
    value (on the first column), the strip labelled "failed"."""
    rows = len(labels)
    strip.set_ylim(-rows + 0.4, 0.6)
    strip.set_facecolor("0.96")
    strip.set_yticks(-np.arange(rows), labels if first_col and any(labels) else [""] * rows, fontsize="x-small")
    strip.tick_params(axis="y", length=0)
    if first_col:
        strip.set_ylabel("failed", rotation=0, ha="right", va="center", fontsize="small", labelpad=4)


def _key_handles(ds: xr.Dataset, name: str, counts: dict[int, int], unstable: bool, lam_known: bool, subset: bool) -> list:
    from matplotlib.lines import Line2D

    handles = []
    if name == "lambda_max":
        handles.append(Line2D([], [], color="k", linewidth=0.9, linestyle="--", label=STABILITY_LIMIT))
    if lam_known:
        handles.append(Line2D([], [], marker="o", markersize=3, color="0.3", linestyle="none", label=r"stable gait ($\lambda_{\max} < 1$)"))
    if unstable:
        handles.append(Line2D([], [], marker="o", markersize=4, markerfacecolor="white", markeredgecolor="0.3", linestyle="none", label=UNSTABLE))
    err_name = error_name(ds, name)
    if err_name is not None:
        handles.append(Line2D([], [], marker="|", markersize=9, color="0.3", linestyle="none", label=f"error bars: \u00b1 {err_name}"))
    names, causes = status_names(ds["status"]), failure_causes(ds)
    for code in sorted(counts):
        label = legend_label(names.get(code, str(code)), counts[code], shown=subset, cause=causes.get(code))
        handles.append(Line2D([], [], marker=status_marker(code), color="0.2", linestyle="none", label=label))
    return handles
