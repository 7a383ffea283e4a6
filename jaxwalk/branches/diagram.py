"""Bifurcation diagrams of a ``jaxwalk continue`` dataset: a quantity against
the continuation parameter, stable parts solid and unstable dashed, one colour
per period, labelled points marked and named."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import xarray as xr

from jaxwalk.bifurcation import Kind

MARKERS = {Kind.FOLD: "s", Kind.FLIP: "o", Kind.NEIMARK_SACKER: "D", Kind.BRANCH_POINT: "^"}
QUANTITIES = ("lambda_max", "v0", "v1", "v2")


def quantity(ds: xr.Dataset, name: str) -> tuple[np.ndarray, str]:
    """``(branch, point)`` values of ``name`` (``lambda_max`` or ``v<i>``, a section coordinate) and its label."""
    if name == "lambda_max":
        return ds["lambda_max"].values, "lambda_max (largest multiplier modulus of the k-step map)"
    if name.startswith("v") and name[1:].isdigit() and int(name[1:]) < ds.sizes["section"]:
        i = int(name[1:])
        return ds["v"].values[..., i], f"{ds.attrs['section_names'].split()[i]} (fixed point)"
    raise ValueError(f"unknown quantity '{name}' (known: lambda_max, v0 ... v{ds.sizes['section'] - 1})")


def plot_branches(path: str | Path, out: str | Path | None = None, y: str = "lambda_max", fmt: str = "png") -> Path:
    """Draw ``path``'s branches; writes ``out/<name>_bifurcation_<y>.<fmt>`` and returns its path."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    ds = xr.open_zarr(path)
    values, ylabel = quantity(ds, y)
    p = ds["parameter"].values
    stable = ds["stable"].values
    period = ds["period"].values
    colours = {k: f"C{i}" for i, k in enumerate(sorted(set(period.tolist())))}
    fig, ax = plt.subplots(figsize=(7, 4.5))
    for b in range(p.shape[0]):
        n = int(ds["n_points"].values[b])
        for part, style in ((stable[b, :n], "-"), (~stable[b, :n], "--")):
            # Each part joined to its neighbours so the line is unbroken where stability changes.
            show = part | np.roll(part, 1) & (np.arange(n) > 0)
            ax.plot(np.where(show, p[b, :n], np.nan), np.where(show, values[b, :n], np.nan), style, color=colours[int(period[b])],
                    label=f"period {int(period[b])}" if b == int(np.argmax(period == period[b])) and style == "-" else None)
    _labels(ax, ds, y)
    ax.set_xlabel(f"{ds.attrs['continuation_parameter']} ({ds.attrs['continuation_units']})")
    ax.set_ylabel(ylabel)
    ax.set_title(f"{ds.attrs['model']}: stable solid, unstable dashed")
    ax.legend(fontsize=8)
    target = Path(out or Path(path).parent) / f"{ds.attrs['name']}_bifurcation_{y}.{fmt}"
    from jaxwalk.files import write_atomically

    write_atomically(target, lambda p: fig.savefig(p, dpi=130, bbox_inches="tight"))  # never half a figure
    plt.close(fig)
    return target


def _labels(ax, ds: xr.Dataset, y: str) -> None:
    """Mark and name each located point."""
    kinds = ds["label_kind"].values
    for r, kind in enumerate(kinds):
        x = float(ds["label_parameter"].values[r])
        if y == "lambda_max":
            mu = ds["label_multipliers_real"].values[r] + 1j * ds["label_multipliers_imag"].values[r]
            yy = float(np.max(np.abs(mu)))
        else:
            yy = float(ds["label_v"].values[r, int(y[1:])])
        name = Kind(int(kind)).name.lower()
        ax.plot([x], [yy], MARKERS.get(Kind(int(kind)), "x"), color="k", ms=6)
        ax.annotate(f"{name} {x:.7g}", (x, yy), textcoords="offset points", xytext=(4, 4), fontsize=7)
