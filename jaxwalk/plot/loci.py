"""Two-parameter loci: the bifurcations located on continuation lines, joined
into curves on a heatmap (``[analysis] bifurcations``, issue 16 item 4).

A sweep with a continuation axis ``c`` and another grid axis ``a`` has one
line along ``c`` per value of ``a``; :mod:`jaxwalk.analyses.bifurcations`
locates each fold, flip, Neimark-Sacker point and lost-gait edge on every
line to 1e-6 in ``c``. Drawn on a heatmap over ``(c, a)``, the points of one
kind on neighbouring lines are joined, so the edges of a stable band are
curves through located points, not the grid's cell boundaries.

Joining rule: lines are taken in the order of ``a``'s grid values. Between
two neighbouring lines, points of the same kind are paired nearest first
(each point at most once), and a pair is joined only when its ``c`` values
differ by at most :data:`MAX_JUMP` of the ``c`` axis's range; a line with no
point of that kind, or only a far one, breaks the curve there. Points whose
location did not reach its tolerance (``bifurcation_status != 0``) are drawn
hollow and never joined: a curve passes through located points only.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import xarray as xr


#: Largest change of the continuation parameter between two joined points on
#: neighbouring lines, as a fraction of that axis's range. A band edge of the
#: flat-foot (l_f, r) map moves by about 0.02 in r (2% of the axis) between
#: neighbouring l_f lines; a tenth of the range joins such curves and still
#: keeps two separate branches of one kind apart.
MAX_JUMP = 0.1

#: How each kind is drawn: (line style, marker, label). Black with a white
#: halo reads on viridis and on every failure colour alike; the lambda_max = 1
#: contour is the solid black line, so no locus is solid black.
#: Keyed by the kind's name in the dataset's ``flag_meanings`` (the file is the
#: record of what its codes meant, as for statuses).
STYLES: dict[str, tuple[object, str, str]] = {
    "fold": ("-", "o", "fold (multiplier +1)"),
    "flip": ("--", "s", "flip (multiplier -1)"),
    "neimark_sacker": ("-.", "D", "Neimark-Sacker (|complex pair| = 1)"),
    "grazing": (":", "^", "grazing (a step starts to fail)"),
    "lost": (":", "x", "gait lost (cause unknown: no guard failed)"),
    "branch_point": ("", "P", "branch point (multiplier +1)"),
    "border_collision": ((0, (4, 1, 1, 1, 1, 1)), "v", "border collision (event order changes)"),  # dash-dot-dot
    "jump": ("", "*", "multipliers jump (no bifurcation)"),
    "switch": ("", "H", "switch between coexisting gaits (no bifurcation)"),
}
#: Style of a kind this version does not know.
OTHER_STYLE = (":", "o", "")
#: The fold's line is white on a black halo, the others black on a white one.
FOLD_COLOR = "white"
#: Group id of the drawn curves (tests and callers find them by this).
LOCUS_GID = "bifurcation-locus"


@dataclasses.dataclass(frozen=True)
class Locus:
    """One curve of one kind: ``(n,)`` continuation values and line-axis values, in line order."""

    kind: str
    continuation: np.ndarray
    line_value: np.ndarray


def continuation_axis(ds: xr.Dataset) -> str | None:
    """The grid axis the bifurcation table's lines run along (``None`` without a table)."""
    if "bifurcation_kind" not in ds:
        return None
    grid = [d for d in ds["status"].dims]
    along = [d for d in grid if f"bifurcation_{d}" not in ds]
    return along[0] if len(along) == 1 else None


def points_in_view(ds: xr.Dataset, view: xr.Dataset, line_axis: str) -> xr.Dataset:
    """The table's rows on the lines ``view`` shows: every grid axis that ``view``
    holds at one value (fixed, or the panel's) other than ``line_axis`` must match."""
    table = ds[[v for v in ds.data_vars if ds[v].dims[:1] == ("bifurcation",)]]
    keep = np.ones(table.sizes["bifurcation"], bool)
    for d in ds["status"].dims:
        if d == line_axis or f"bifurcation_{d}" not in ds or view[d].ndim != 0:
            continue
        keep &= np.isclose(table[f"bifurcation_{d}"].values, float(view[d].values), rtol=1e-12, atol=0.0)
    return table.isel(bifurcation=np.flatnonzero(keep))


def kind_names(ds: xr.Dataset) -> dict[int, str]:
    """``{code: name}`` of ``bifurcation_kind`` from its CF flag attributes."""
    attrs = ds["bifurcation_kind"].attrs
    values, meanings = attrs.get("flag_values", []), str(attrs.get("flag_meanings", "")).split()
    return {int(v): m for v, m in zip(np.atleast_1d(values), meanings)}


def join(kind: str, c: np.ndarray, a: np.ndarray, line_values: np.ndarray, max_jump: float) -> list[Locus]:
    """Curves of one kind from its located points ``(c, a)``; ``line_values``: the
    line axis's grid values in order (neighbours are consecutive entries)."""
    order = {float(v): i for i, v in enumerate(np.sort(line_values))}
    rank = np.array([order.get(float(x), -1) for x in a])
    by_line = {r: list(np.flatnonzero(rank == r)) for r in np.unique(rank[rank >= 0])}
    nxt: dict[int, int] = {}
    for r, here in by_line.items():
        there = by_line.get(r + 1, [])
        pairs = sorted((abs(c[i] - c[j]), i, j) for i in here for j in there)
        used_i, used_j = set(), set()
        for gap, i, j in pairs:
            if gap <= max_jump and i not in used_i and j not in used_j:
                nxt[i] = j
                used_i.add(i)
                used_j.add(j)
    starts = [i for r in sorted(by_line) for i in by_line[r] if i not in nxt.values()]
    curves = []
    for i in starts:
        chain = [i]
        while chain[-1] in nxt:
            chain.append(nxt[chain[-1]])
        curves.append(Locus(kind, c[chain], a[chain]))
    return curves


def loci(ds: xr.Dataset, view: xr.Dataset, x: str, y: str) -> tuple[list[Locus], list[tuple[str, float, float]]]:
    """``(curves, unlocated)`` for a heatmap of ``view`` over ``(x, y)``: the located
    points joined per kind, and ``[(kind, c, a)]`` of the points not located to
    tolerance. Empty when the table is absent or neither drawn axis is the
    continuation axis."""
    axis = continuation_axis(ds)
    if axis is None or axis not in (x, y):
        return [], []
    line_axis = y if axis == x else x
    table = points_in_view(ds, view, line_axis)
    names = kind_names(ds)
    kind = np.array([names.get(int(k), f"kind {int(k)}") for k in table["bifurcation_kind"].values], dtype=object)
    c = table["bifurcation_parameter"].values.astype(float)
    a = table[f"bifurcation_{line_axis}"].values.astype(float)
    located = (table["bifurcation_status"].values == 0) & np.isfinite(c)
    span = float(np.ptp(ds[axis].values)) or 1.0
    curves = []
    for k in sorted(set(kind[located])):
        sel = located & (kind == k)
        curves += join(k, c[sel], a[sel], ds[line_axis].values, MAX_JUMP * span)
    bad = np.flatnonzero(~located & np.isfinite(c))
    return curves, [(kind[i], float(c[i]), float(a[i])) for i in bad]


def _colors(kind: str) -> tuple[str, str]:
    """(line colour, halo colour) of a kind."""
    return (FOLD_COLOR, "black") if kind == "fold" else ("black", "white")


def draw(ax, ds: xr.Dataset, view: xr.Dataset, x: str, y: str) -> tuple[set[str], bool]:
    """Draw the loci of ``view``'s panel on ``ax``; return the kinds drawn and
    whether a point not located to tolerance was drawn (hollow)."""
    from matplotlib import patheffects

    curves, unlocated = loci(ds, view, x, y)
    axis = continuation_axis(ds)
    xy = (lambda c, a: (c, a)) if axis == x else (lambda c, a: (a, c))
    kinds = set()
    for curve in curves:
        style, marker, _ = STYLES.get(curve.kind, OTHER_STYLE)
        color, halo = _colors(curve.kind)
        px, py = xy(curve.continuation, curve.line_value)
        (line,) = ax.plot(px, py, linestyle=style or "none", marker=marker, markersize=3.5, color=color,
                          markeredgecolor=halo, markeredgewidth=0.6, linewidth=1.4)
        line.set(path_effects=[patheffects.withStroke(linewidth=3.0, foreground=halo)], gid=LOCUS_GID)
        kinds.add(curve.kind)
    for k, c, a in unlocated:
        px, py = xy(c, a)
        ax.plot([px], [py], linestyle="none", marker=STYLES.get(k, OTHER_STYLE)[1], markersize=4,
                markerfacecolor="none", markeredgecolor="black", gid="bifurcation-unlocated")
    return kinds, bool(unlocated)


def draw_on_curve(ax, curve: xr.Dataset, x: str, color) -> tuple[set[str], bool]:
    """On a ``lambda_max`` line plot: the points located on the line ``curve`` shows
    (every other grid axis at one value), each at its parameter and its largest
    multiplier modulus there (a border collision's on its lower side; on the
    curve where the row has none), marked by kind in the curve's colour
    (hollow: not located to tolerance). ``curve``:
    the dataset at the curve's values of the other grid axes (its table
    kept). Nothing when ``x`` is not the table's continuation axis. Returns the kinds drawn
    and whether an unlocated point was drawn."""
    if "bifurcation_kind" not in curve or f"bifurcation_{x}" in curve:
        return set(), False  # no table, or x is not the continuation axis (the table has a column for the others)
    table = curve[[v for v in curve.data_vars if curve[v].dims[:1] == ("bifurcation",)]]
    keep = np.ones(table.sizes["bifurcation"], bool)
    for d in curve.coords:  # the curve's own line: every other grid axis at its value
        if d != x and f"bifurcation_{d}" in curve and curve[d].ndim == 0:
            keep &= np.isclose(table[f"bifurcation_{d}"].values, float(curve[d].values), rtol=1e-12, atol=0.0)
    table = table.isel(bifurcation=np.flatnonzero(keep))
    names = kind_names(curve)
    lam = np.max(np.hypot(table["bifurcation_multipliers_real"].values, table["bifurcation_multipliers_imag"].values),
                 axis=-1, initial=0.0)
    # A row whose last solve failed has no multipliers: it is marked on the curve itself.
    ok = (curve["status"].values == 0) & np.isfinite(curve["lambda_max"].values)
    xs, ys = curve[x].values[ok], curve["lambda_max"].values[ok]
    order = np.argsort(xs)
    on_curve = np.interp(table["bifurcation_parameter"].values, xs[order], ys[order]) if ok.any() else np.full(lam.shape, np.nan)
    lam = np.where(np.isfinite(lam), lam, on_curve)
    kinds, unlocated = set(), False
    for j in range(table.sizes["bifurcation"]):
        kind = names.get(int(table["bifurcation_kind"].values[j]), "")
        located = int(table["bifurcation_status"].values[j]) == 0
        c = float(table["bifurcation_parameter"].values[j])
        marker = STYLES.get(kind, OTHER_STYLE)[1]
        line_only = marker in ("x", "+")  # no face: its edge carries the curve's colour
        ax.plot([c], [lam[j]], linestyle="none", marker=marker, markersize=6,
                markerfacecolor=color if located else "none", markeredgewidth=1.4 if line_only else 0.8,
                markeredgecolor=color if line_only and located else "black",
                gid=LOCUS_GID if located else "bifurcation-unlocated", zorder=5)
        kinds |= {kind} if located else set()
        unlocated |= not located
    return kinds, unlocated


def legend_markers(kinds: set[str], unlocated: bool = False) -> list:
    """Legend entries for :func:`draw_on_curve`'s markers (in the order of :data:`STYLES`)."""
    from matplotlib.lines import Line2D

    handles = [Line2D([], [], linestyle="none", marker=STYLES.get(k, OTHER_STYLE)[1], markerfacecolor="0.6",
                      markeredgecolor="black", markersize=6, label=f"{STYLES.get(k, OTHER_STYLE)[2] or k}, located")
               for k in sorted(kinds, key=lambda k: list(STYLES).index(k) if k in STYLES else len(STYLES))]
    if unlocated:
        handles.append(Line2D([], [], linestyle="none", marker="o", markerfacecolor="none", markeredgecolor="black",
                              label="bifurcation, not located to tolerance"))
    return handles


def legend_handles(kinds: set[str], unlocated: bool = False) -> list:
    """One legend entry per kind drawn (in the order of :data:`STYLES`), and one
    for hollow markers when some point was not located to tolerance."""
    from matplotlib import patheffects
    from matplotlib.lines import Line2D

    handles = []
    for k in sorted(kinds, key=lambda k: list(STYLES).index(k) if k in STYLES else len(STYLES)):
        style, marker, label = STYLES.get(k, OTHER_STYLE)
        color, halo = _colors(k)
        line = Line2D([], [], linestyle=style or "none", marker=marker, color=color, markeredgecolor=halo,
                      markersize=4, linewidth=1.4, label=f"{label or k}, located")
        line.set(path_effects=[patheffects.withStroke(linewidth=3.0, foreground=halo)])
        handles.append(line)
    if unlocated:
        handles.append(Line2D([], [], linestyle="none", marker="o", markerfacecolor="none", markeredgecolor="black",
                              label="bifurcation, not located to tolerance"))
    return handles
