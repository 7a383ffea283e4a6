"""The best point of every line of a sweep: r*(l_f) and its kind.

The seed paper's claim is about an optimum: on each foot length, the foot
ratio ``r*`` where local (``lambda_max``, least) or global (``h_max``,
largest) stability is best. On a sweep dataset the lines run along one grid
axis (``along``), one per combination of the other axes. This module finds
each line's best walking point and says *what kind* of optimum it is, because
a best point at the edge of the walking band (the walker fails one grid step
further) is a boundary, not a stationary optimum, and the paper's reading
("an optimal r exists") holds only for the interior kind:

* ``interior``: the best grid point has walking neighbours on both sides,
  both worse (strictly); the optimum is refined by the parabola through the
  three, so it is not tied to the grid (its error is of order the grid step
  cubed where the variable is smooth).
* ``grid_edge``: the best point (or plateau) reaches the first or last grid
  value: the line ends there, so the true optimum may lie outside the grid.
* ``band_edge``: the next point along the line did not walk (its status is
  reported in ``beyond_status``): the optimum is pressed against a failure
  boundary and moves with that boundary.
* ``plateau``: two or more neighbouring points share the best value exactly
  (``h_max`` is a multiple of its resolution), inside the band.

For every kind but ``interior``, ``star`` is the middle of the run of grid
points that share the best value (one point, or a plateau) and
``star_lower``/``star_upper`` its ends.

Where no point of a line walks, ``kind`` is ``no_gait``.
"""

from __future__ import annotations

from typing import Literal

import numpy as np
import xarray as xr

from jaxwalk.errors import ConfigError
from jaxwalk.status import Status

#: The kinds of optimum, as stored in ``optimum_kind`` (codes in order).
KINDS = ("interior", "band_edge", "grid_edge", "plateau", "no_gait")
#: What the result's kinds mean, stored with it.
COMMENT = (
    "best walking point of each line: interior (both grid neighbours walk and are worse; refined by "
    "the parabola through the three), band_edge (a neighbour did not walk: beyond_status), grid_edge "
    "(the line's first or last grid value), plateau (neighbours share the best value: star is its "
    "middle), no_gait (no point of the line walks)"
)


def line_optima(
    ds: xr.Dataset,
    variable: str = "lambda_max",
    along: str = "r",
    sense: Literal["min", "max"] = "min",
) -> xr.Dataset:
    """The best walking point of every line of ``ds`` along the grid axis ``along``.

    Args:
        ds: a sweep dataset (``jaxwalk.open_dataset``) with ``status`` and
            ``variable`` over a grid that includes ``along``.
        variable: the quantity to optimise (``lambda_max``, ``h_max``, ...).
        along: the grid axis the lines run along.
        sense: ``"min"`` (``lambda_max``) or ``"max"`` (``h_max``).

    Returns:
        A dataset over the other grid axes with ``star`` (``along``'s value at
        the optimum), ``star_lower``, ``star_upper`` (the grid values that
        bracket it: the parabola's neighbours, or a plateau's ends),
        ``value`` (the variable there), ``optimum_kind`` (index into
        :data:`KINDS`, names in its ``flag_meanings``), ``beyond_status``
        (the status of the failing neighbour at a band edge, else -1), and
        ``band_lower``/``band_upper`` (the walking run of grid points that
        holds the optimum).

    Raises:
        ConfigError: an unknown variable or axis, a variable that is not one float per grid
            point (a status, a count, a fixed point), or a bad ``sense``.
    """
    if variable not in ds.data_vars:
        raise ConfigError(f"line_optima: no variable {variable!r} in the dataset (has: {', '.join(ds.data_vars)})")
    if along not in ds[variable].dims or along not in ds.coords:
        raise ConfigError(f"line_optima: {variable!r} has no grid axis {along!r} (axes: {', '.join(ds[variable].dims)})")
    grid = ds["status"].dims
    if set(ds[variable].dims) != set(grid):
        extra = [d for d in ds[variable].dims if d not in grid]
        raise ConfigError(f"line_optima: {variable!r} is not one number per grid point (it has the axes "
                          f"{', '.join(extra) or 'of another grid'} beyond the grid's {', '.join(grid)})")
    if "flag_values" in ds[variable].attrs or not np.issubdtype(ds[variable].dtype, np.floating):
        raise ConfigError(f"line_optima: {variable!r} is not a measure to optimise (a status or a count)")
    if sense not in ("min", "max"):
        raise ConfigError(f"line_optima: sense must be 'min' or 'max', not {sense!r}")
    values = ds[variable].transpose(..., along)
    status = ds["status"].transpose(..., along)
    others = [d for d in values.dims if d != along]
    x = np.asarray(ds[along].values, float)
    sign = 1.0 if sense == "min" else -1.0
    flat_v = np.asarray(values.values, float).reshape(-1, x.size)
    flat_s = np.asarray(status.values).reshape(-1, x.size)
    rows = [_one_line(x, sign * v, s) for v, s in zip(flat_v, flat_s)]
    shape = tuple(ds.sizes[d] for d in others)

    def field(i, dtype=float):
        return (others, np.asarray([row[i] for row in rows], dtype).reshape(shape))

    out = xr.Dataset(
        {
            "star": field(0),
            "star_lower": field(1),
            "star_upper": field(2),
            "value": (others, sign * np.asarray([row[3] for row in rows], float).reshape(shape)),
            "optimum_kind": field(4, np.int8),
            "beyond_status": field(5, np.int8),
            "band_lower": field(6),
            "band_upper": field(7),
        },
        coords={d: ds[d] for d in others},
    )
    out["optimum_kind"].attrs.update(flag_values=np.arange(len(KINDS), dtype=np.int8), flag_meanings=" ".join(KINDS))
    out.attrs.update(variable=variable, along=along, sense=sense, comment=COMMENT)
    return out


def _one_line(x: np.ndarray, cost: np.ndarray, status: np.ndarray) -> tuple:
    """(star, lower, upper, cost, kind, beyond, band_lower, band_upper) of one line; ``cost`` is minimised."""
    walks = (status == Status.OK) & np.isfinite(cost)
    if not walks.any():
        return (np.nan, np.nan, np.nan, np.nan, KINDS.index("no_gait"), -1, np.nan, np.nan)
    i = int(np.argmin(np.where(walks, cost, np.inf)))
    lo, hi = _walking_run(walks, i)
    band = (x[lo], x[hi])
    first, last = _run_around([j for j in range(lo, hi + 1) if cost[j] == cost[i]], i)
    grid_points = (x[first] + x[last]) / 2, x[first], x[last], cost[i]
    if first == 0 or last == x.size - 1:
        return (*grid_points, KINDS.index("grid_edge"), -1, *band)
    if not (walks[first - 1] and walks[last + 1]):
        beyond = int(status[first - 1] if not walks[first - 1] else status[last + 1])
        return (*grid_points, KINDS.index("band_edge"), beyond, *band)
    if last > first:
        return (*grid_points, KINDS.index("plateau"), -1, *band)
    star, value = _parabola_vertex(x[i - 1 : i + 2], cost[i - 1 : i + 2])
    return (star, x[i - 1], x[i + 1], value, KINDS.index("interior"), -1, *band)


def _walking_run(walks: np.ndarray, i: int) -> tuple[int, int]:
    """First and last index of the run of walking points that holds ``i``."""
    lo = i
    while lo > 0 and walks[lo - 1]:
        lo -= 1
    hi = i
    while hi < walks.size - 1 and walks[hi + 1]:
        hi += 1
    return lo, hi


def _run_around(indices: list[int], i: int) -> tuple[int, int]:
    """The consecutive run of ``indices`` (sorted) that holds ``i``."""
    first = last = i
    while first - 1 in indices:
        first -= 1
    while last + 1 in indices:
        last += 1
    return first, last


def _parabola_vertex(x: np.ndarray, y: np.ndarray) -> tuple[float, float]:
    """Vertex of the parabola through three points whose middle one is lowest."""
    coeffs = np.polyfit(x - x[1], y, 2)
    if coeffs[0] <= 0:  # cannot happen for a strict interior minimum; keep the grid point
        return float(x[1]), float(y[1])
    shift = -coeffs[1] / (2 * coeffs[0])
    return float(x[1] + shift), float(np.polyval(coeffs, shift))
