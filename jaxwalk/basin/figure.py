"""The basin image: every start coloured by its fate, shaded by its steps, the fixed point marked.

Returned starts are drawn in a sequential colour map over their steps-to-return
(colour bar); each failure status in its fixed colour (:mod:`jaxwalk.plot.statuses`,
the same as in every heatmap), darker the sooner it failed; ``not returned`` in
its own colour. The fixed point is a white-edged black cross.
"""

from __future__ import annotations

import textwrap

import numpy as np
import xarray as xr

from jaxwalk.status import Status

#: Characters per line of the title (the figure is about 7.5 inches wide at the title's 9 pt).
TITLE_CHARS = 100


def rgb_image(outcome: np.ndarray, steps: np.ndarray, limit: int):
    """``(ny, nx, 3)`` colours and the returned starts' colour map and norm."""
    import matplotlib as mpl
    from matplotlib.colors import Normalize, to_rgb

    from jaxwalk.plot.statuses import status_color

    returned = outcome == Status.OK
    top = max(1, int(steps[returned].max())) if returned.any() else 1
    cmap, norm = mpl.colormaps["viridis_r"], Normalize(1, top)
    rgb = np.zeros(outcome.shape + (3,))
    rgb[returned] = cmap(norm(steps[returned]))[:, :3]
    for code in np.unique(outcome[~returned]):
        where = outcome == code
        # Shade: a failure in its first step is 55% as bright as one at the walk's limit.
        shade = 0.55 + 0.45 * np.clip(steps[where] / max(1, limit), 0.0, 1.0)
        rgb[where] = np.asarray(to_rgb(status_color(int(code))))[None] * shade[:, None]
    return rgb, cmap, norm


def save_basin(ds: xr.Dataset, path) -> None:
    """Draw a ``jaxwalk basin`` dataset (:mod:`jaxwalk.basin.run`) to ``path``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.cm import ScalarMappable
    from matplotlib.patches import Patch

    from jaxwalk.plot.statuses import status_color, status_names

    outcome, steps = ds["outcome"].values, ds["steps"].values
    x, y = ds["x"].values, ds["y"].values
    rgb, cmap, norm = rgb_image(outcome, steps, int(ds.attrs["steps_limit"]))
    fig, ax = plt.subplots(figsize=(7.5, 6.0), layout="constrained")
    dx, dy = (x[1] - x[0]) / 2, (y[1] - y[0]) / 2
    ax.imshow(rgb, origin="lower", extent=(x[0] - dx, x[-1] + dx, y[0] - dy, y[-1] + dy), aspect="auto",
              interpolation="nearest")
    v = ds.attrs["fixed_point"]
    names = ds.attrs["section_names"].split()
    vx, vy = v[names.index(ds.attrs["x_coordinate"])], v[names.index(ds.attrs["y_coordinate"])]
    ax.plot([vx], [vy], marker="+", color="k", markersize=14, markeredgewidth=2.5)
    ax.plot([vx], [vy], marker="+", color="w", markersize=10, markeredgewidth=1.0, label="fixed point")
    labels = status_names(ds["outcome"])
    share = {int(c): float((outcome == c).mean()) for c in np.unique(outcome)}
    handles = [Patch(color=status_color(c), label=f"{labels[c]} ({100 * share[c]:.1f}%)") for c in sorted(share) if c != Status.OK]
    returned = f"returned ({100 * share.get(int(Status.OK), 0.0):.1f}%)"
    ax.legend(handles=[Patch(color=cmap(0.3), label=returned), *handles], loc="upper left", fontsize=8, framealpha=0.85)
    bar = fig.colorbar(ScalarMappable(norm, cmap), ax=ax)
    bar.set_label("steps to return (within tol of the fixed point)")
    ax.set_xlabel(ds.attrs["x_coordinate"])
    ax.set_ylabel(ds.attrs["y_coordinate"])
    held = [n for n in names if n not in (ds.attrs["x_coordinate"], ds.attrs["y_coordinate"])]
    note = f"; {', '.join(held)} at the fixed point" if held else ""
    # A walker with many parameters (the flat-foot walker's twenty) needs several lines.
    head = textwrap.fill(f"{ds.attrs['model']} basin, {ds.attrs['fixed_parameters']}", TITLE_CHARS)
    ax.set_title(f"{head}\nat most {ds.attrs['steps_limit']} steps, tol {ds.attrs['tol']:g}{note}", fontsize=9)
    fig.savefig(path, dpi=130)
    plt.close(fig)
