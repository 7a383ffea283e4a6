"""The best foot ratio by five stability measures at the same points of the shoe
walker's foot plane (issue 15, item 4; results/README.md). Reads the sweep of
``sweeps/flatfoot_human_mfpt_map.toml`` (lambda_max, the gait sensitivity norm,
h_max and the MFPT on random terrain at 5 foot lengths x 8 ratios) and, where
it exists, that of ``sweeps/flatfoot_human_basin_map.toml`` (the basin on the
section; its grid holds every point of the MFPT map), and per foot length:

* the best grid ratio by each measure (least lambda_max and norm; largest h_max,
  MFPT, basin fraction), the human ratio's MFPT against the best;
* Spearman rank correlations of each measure with the MFPT over the line's
  gaits (each oriented so that larger is more stable);

prints the table and draws ``results/human/flatfoot_human_mfpt_map_optima.png``.
The grid is coarse (r in steps of 0.116), so a best ratio here is a grid point,
not a located optimum: the dense lines in results/README.md locate them.

    jaxwalk sweep sweeps/flatfoot_human_mfpt_map.toml --out results/human --overwrite
    python results/human/mfpt_map_optima.py
"""

from __future__ import annotations

import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.colors as mcolors  # noqa: E402
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from scipy.stats import spearmanr  # noqa: E402

import jaxwalk  # noqa: E402

HERE = Path(__file__).resolve().parent
#: (variable, +1 where larger is more stable else -1, label, colour, marker)
MEASURES = (("lambda_max", -1, r"$\lambda_{max}$", "C0", "o"),
            ("gait_sensitivity_norm", -1, "gait sensitivity norm", "C3", "s"),
            ("h_max", +1, r"$h_{max}$", "C2", "^"),
            ("basin_fraction", +1, "basin fraction", "C1", "D"),
            ("mfpt", +1, "MFPT", "k", "*"))
HUMAN_RATIO = 0.39
#: Lines with fewer gaits than this get no rank correlation.
MIN_GAITS = 4


def oriented(ds, basin, name: str, sign: int) -> np.ndarray:
    """``(l_f, r)`` the measure with larger = more stable, NaN where no gait or not measured."""
    source = basin if name.startswith("basin") else ds
    if source is None:
        return np.full((ds.sizes["l_f"], ds.sizes["r"]), np.nan)
    if source is basin:  # the basin map's points at the MFPT map's (l_f, r)
        source = basin.sel(l_f=ds.l_f.values, r=ds.r.values, method="nearest")
    v = source[name].transpose("l_f", "r").values.astype(float)
    walking = ds.status.transpose("l_f", "r").values == 0
    return np.where(walking, sign * v, np.nan)


def best_ratio(r: np.ndarray, good: np.ndarray) -> float:
    """The grid ratio where ``good`` is largest (NaN-free entries only); NaN if none."""
    ok = ~np.isnan(good)
    return float(r[ok][np.argmax(good[ok])]) if ok.any() else np.nan


def table(ds, basin) -> tuple[dict, dict]:
    """Per foot length: each measure's best grid ratio, and its Spearman correlation with the MFPT."""
    r = ds.r.values
    good = {m[0]: oriented(ds, basin, m[0], m[1]) for m in MEASURES}
    stars, rho = {m: [] for m in good}, {m: [] for m in good if m != "mfpt"}
    for i in range(ds.sizes["l_f"]):
        for m, v in good.items():
            stars[m].append(best_ratio(r, v[i]))
        mfpt = good["mfpt"][i]
        for m in rho:
            ok = ~np.isnan(good[m][i]) & ~np.isnan(mfpt)
            enough = ok.sum() >= MIN_GAITS and np.ptp(good[m][i][ok]) > 0
            rho[m].append(spearmanr(good[m][i][ok], mfpt[ok]).statistic if enough else np.nan)
    return {m: np.asarray(v) for m, v in stars.items()}, {m: np.asarray(v) for m, v in rho.items()}


def figure(ds, stars, rho, path: Path) -> None:
    lf, r = ds.l_f.values, ds.r.values
    fig, (ax, bx) = plt.subplots(1, 2, figsize=(11, 4.6), gridspec_kw={"width_ratios": [1.25, 1]},
                                 constrained_layout=True)
    walking = ds.status.transpose("r", "l_f").values == 0
    mfpt = np.where(walking, ds.mfpt.transpose("r", "l_f").values, np.nan)
    ax.set_facecolor("0.88")
    finite = np.isfinite(mfpt)
    mesh = ax.pcolormesh(lf, r, np.where(finite, mfpt, np.nan), shading="nearest", cmap="viridis",
                         norm=mcolors.LogNorm(vmin=max(np.nanmin(mfpt[finite]), 1.0), vmax=np.nanmax(mfpt[finite])))
    fig.colorbar(mesh, ax=ax, label=r"MFPT at $\sigma$ = 0.005 (steps; grey: no gait)")
    spread = np.linspace(-0.3, 0.3, len(MEASURES)) * np.diff(lf).min() * 0.5
    for (name, _, label, colour, marker), dx in zip(MEASURES, spread):
        ax.plot(lf + dx, stars[name], marker, color=colour, mec="w" if colour == "k" else colour, ms=7,
                ls="-", lw=0.8, label=f"best r by {label}")
    ax.axhline(HUMAN_RATIO, color="w", ls=":", lw=1.2, label=f"human foot ratio {HUMAN_RATIO}")
    ax.set(xlabel=r"foot length $l_f$ (leg lengths)", ylabel="foot ratio r",
           title="MFPT on random terrain, and the best grid ratio\nper foot length by each measure")
    ax.legend(fontsize=7, loc="lower right", framealpha=0.85)
    for (name, _, label, colour, marker) in MEASURES[:-1]:
        bx.plot(lf, rho[name], marker + "-", color=colour, ms=5, label=label)
    bx.axhline(0, color="k", lw=0.6)
    bx.set(xlabel=r"foot length $l_f$ (leg lengths)", ylabel="Spearman rank correlation with the MFPT",
           ylim=(-1.05, 1.05), title=f"rank agreement with the MFPT along r\n(larger = more stable; lines with >= {MIN_GAITS} gaits)")
    bx.legend(fontsize=8, loc="lower left")
    fig.savefig(path, dpi=150)


def main(path: str = str(HERE / "flatfoot_human_mfpt_map.zarr"),
         basin_path: str = str(HERE / "flatfoot_human_basin_map.zarr")) -> None:
    ds = jaxwalk.open_dataset(path)
    basin = jaxwalk.open_dataset(basin_path) if Path(basin_path).exists() else None
    stars, rho = table(ds, basin)
    gaits = (ds.status == 0).sum("r").values
    human = int(np.argmin(np.abs(ds.r.values - HUMAN_RATIO)))
    names = [m[0] for m in MEASURES]
    print("| l_f | gaits | " + " | ".join(f"best r {n}" for n in names) + " | MFPT best / at r 0.39 | "
          + " | ".join(f"rho({n}, MFPT)" for n in names[:-1]) + " |")
    print("|---" * (2 + 2 * len(names)) + "|")
    for i, l_f in enumerate(ds.l_f.values):
        m = np.where(ds.status.values[i] == 0, ds.mfpt.values[i], np.nan)
        ratio = np.nanmax(m) / m[human] if np.isfinite(m[human]) else np.nan
        cells = [f"{stars[n][i]:.3f}" if np.isfinite(stars[n][i]) else "-" for n in names]
        cells.append(f"{np.nanmax(m):,.0f} / {m[human]:,.0f} ({ratio:.1f}x)" if gaits[i] else "-")
        cells += [f"{rho[n][i]:+.2f}" if np.isfinite(rho[n][i]) else "-" for n in names[:-1]]
        print(f"| {l_f:.4f} | {gaits[i]} | " + " | ".join(cells) + " |")
    out = HERE / "flatfoot_human_mfpt_map_optima.png"
    figure(ds, stars, rho, out)
    print("wrote", out)


if __name__ == "__main__":
    main(*sys.argv[1:])
