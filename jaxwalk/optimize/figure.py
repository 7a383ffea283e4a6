"""The optimisation paths over the ``lambda_max`` background (one PNG)."""

from __future__ import annotations

import numpy as np
import xarray as xr


def _start_coordinate(ds: xr.Dataset, name: str) -> np.ndarray:
    """``(K, S)`` values of parameter ``name`` along the paths (optimised or fixed per start)."""
    if name in ds and ds[name].dims == ("iteration", "start"):
        return ds[name].values
    if name in ds and ds[name].dims == ("start",):
        return np.broadcast_to(ds[name].values, ds["status"].shape)
    fixed = ds.attrs.get("config")
    import json

    value = json.loads(fixed)["params"].get(name, np.nan) if fixed else np.nan
    return np.full(ds["status"].shape, float(value))


def _start_labels(ds: xr.Dataset, names: list[str], n_start: int) -> list[str]:
    """``start i`` and the fixed parameters that vary per start (e.g. ``k = 0.29``)."""
    import json

    starts = json.loads(ds.attrs["config"]).get("starts", {}) if "config" in ds.attrs else {}
    varying = [k for k, v in starts.items()
               if k not in names and isinstance(v, list) and len(v) == n_start and len(set(map(str, v))) > 1]
    return [", ".join([f"start {s}"] + [f"{k} = {starts[k][s]:g}" for k in varying
                                        if isinstance(starts[k][s], (int, float))]) for s in range(n_start)]


def draw_paths(ds: xr.Dataset, target) -> None:
    """Draw every start's path (accepted iterates joined, failed ones as crosses,
    the best iterate as a dot) over ``heatmap_lambda_max`` (stable < 1; NaN where no gait);
    with several parameters and no background, ``lambda_max`` along the iterations
    (a lost gait's iteration as a cross on the axis)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = [str(n) for n in ds["parameter"].values]
    axes = [str(d)[len("heatmap_"):] for d in ds["heatmap_lambda_max"].dims] if "heatmap_lambda_max" in ds else []
    fig, ax = plt.subplots(figsize=(6.4, 4.8), constrained_layout=True)
    accepted = ds["accepted"].values
    if len(axes) == 2:
        x_name, y_name = axes
        lam = ds["heatmap_lambda_max"].where(ds["heatmap_status"] == 0).transpose(f"heatmap_{y_name}", f"heatmap_{x_name}")
        mesh = ax.pcolormesh(ds[f"heatmap_{x_name}"].values, ds[f"heatmap_{y_name}"].values, lam.values,
                             shading="nearest", cmap="viridis", vmin=0.0, vmax=max(1.2, float(np.nanmax(lam.values)) if np.isfinite(lam.values).any() else 1.2))
        fig.colorbar(mesh, ax=ax, label="lambda_max (grey: no gait)")
        ax.set_facecolor("0.85")
        if np.isfinite(lam.values).any() and np.nanmin(lam.values) < 1 < np.nanmax(lam.values):
            ax.contour(ds[f"heatmap_{x_name}"].values, ds[f"heatmap_{y_name}"].values, lam.values, levels=[1.0], colors="w", linewidths=1)
        xs, ys = _start_coordinate(ds, x_name), _start_coordinate(ds, y_name)
        ax.set_xlabel(x_name), ax.set_ylabel(y_name)
    elif axes or len(names) == 1:
        x_name = axes[0] if axes else names[0]
        if axes:
            lam = ds["heatmap_lambda_max"].where(ds["heatmap_status"] == 0)
            ax.plot(ds[f"heatmap_{x_name}"].values, lam.values, "-", color="0.5", label="grid")
        xs, ys = _start_coordinate(ds, x_name), ds["lambda_max"].values
        ax.set_xlabel(x_name), ax.set_ylabel("lambda_max")
    else:  # several parameters and no background: lambda_max along the iterations
        xs = np.broadcast_to(np.arange(ds.sizes["iteration"], dtype=float)[:, None], ds["status"].shape)
        ys = ds["lambda_max"].values
        ax.axhline(1.0, color="0.5", ls="--", lw=1)
        ax.set_xlabel("iteration"), ax.set_ylabel("lambda_max")
    along_iterations = ax.get_xlabel() == "iteration"
    labels = _start_labels(ds, names, accepted.shape[1])
    for s in range(accepted.shape[1]):
        ok = accepted[:, s]
        line, = ax.plot(xs[ok, s], ys[ok, s], ".-", ms=3, lw=1, label=labels[s])
        failed = ~ok & np.isfinite(xs[:, s]) & np.isfinite(ys[:, s])
        ax.plot(xs[failed, s], ys[failed, s], "x", color=line.get_color(), ms=5)
        if along_iterations:  # a lost gait has no lambda_max: its iteration marked on the axis
            lost = ~ok & (np.arange(len(ok)) <= int(ds["ended_at"].values[s])) & ~np.isfinite(ys[:, s])
            ax.plot(xs[lost, s], np.zeros(int(lost.sum())), "x", color=line.get_color(), ms=5, clip_on=False,
                    transform=ax.get_xaxis_transform())
        best = int(ds["best_iteration"].values[s]) if "best_iteration" in ds else -1
        if best >= 0:
            ax.plot(xs[best, s], ys[best, s], "o", color=line.get_color(), mec="k", ms=6)
    if accepted.shape[1] > 1:
        ax.legend(fontsize=8, title="start (best iterate: dot)", title_fontsize=8)
    ax.set_title(ds.attrs.get("title", "optimisation"), fontsize=9)
    from jaxwalk.files import write_atomically

    write_atomically(target, lambda path: fig.savefig(path, dpi=120))  # never half a figure
    plt.close(fig)
