"""The best foot ratio by three stability measures over the shoe walker's foot plane
(issue 15, item 4; results/README.md). Reads the sweep of
``sweeps/flatfoot_human_measures_map.toml`` and, per foot length:

* r* by lambda_max (least), the gait sensitivity norm (least) and h_max (largest),
  each with its kind (``jaxwalk.sweep.line_optima``: interior, band edge, plateau, ...);
* Spearman rank correlations between the three over the line's gaits (each
  oriented so that larger is better: -lambda_max, -GSN, h_max);

prints the table and draws ``results/human/flatfoot_human_measures_map_optima.png``.

    jaxwalk sweep sweeps/flatfoot_human_measures_map.toml --out results/human --overwrite
    python results/human/measures_optima.py
"""

from __future__ import annotations

import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from scipy.stats import spearmanr  # noqa: E402

import jaxwalk  # noqa: E402
from jaxwalk.sweep import line_optima  # noqa: E402
from jaxwalk.sweep.optimum import KINDS  # noqa: E402

HERE = Path(__file__).resolve().parent
MEASURES = (("lambda_max", "min", r"$\lambda_{max}$ (least)", "C0", "o"),
            ("gait_sensitivity_norm", "min", "gait sensitivity norm (least)", "C3", "s"),
            ("h_max", "max", r"$h_{max}$ (largest)", "C2", "^"))
#: Lines with fewer gaits than this get no rank correlation.
MIN_GAITS = 5


def oriented(ds, name: str) -> np.ndarray:
    """``(l_f, r)`` the measure with larger = more stable, NaN where no gait."""
    v = ds[name].transpose("l_f", "r").values.astype(float)
    v = np.where(ds.status.transpose("l_f", "r").values == 0, v, np.nan)
    return -v if name != "h_max" else v


def correlations(ds) -> dict[str, np.ndarray]:
    """Spearman rank correlation of each pair of measures along every foot length."""
    lam, gsn, h = (oriented(ds, m[0]) for m in MEASURES)
    out = {r"$\lambda_{max}$ ~ $h_{max}$": [], r"GSN ~ $h_{max}$": [], r"GSN ~ $\lambda_{max}$": []}
    for i in range(ds.sizes["l_f"]):
        ok = np.isfinite(lam[i]) & np.isfinite(gsn[i]) & np.isfinite(h[i])
        for key, (a, b) in zip(out, ((lam, h), (gsn, h), (gsn, lam))):
            enough = ok.sum() >= MIN_GAITS and np.ptp(a[i][ok]) > 0 and np.ptp(b[i][ok]) > 0
            out[key].append(spearmanr(a[i][ok], b[i][ok]).statistic if enough else np.nan)
    return {k: np.asarray(v) for k, v in out.items()}


def figure(ds, optima, rho, path: Path) -> None:
    lf, r = ds.l_f.values, ds.r.values
    fig, (ax, bx) = plt.subplots(1, 2, figsize=(11, 4.6), gridspec_kw={"width_ratios": [1.25, 1]}, constrained_layout=True)
    lam = np.where(ds.status.transpose("r", "l_f").values == 0, ds.lambda_max.transpose("r", "l_f").values, np.nan)
    ax.set_facecolor("0.88")
    mesh = ax.pcolormesh(lf, r, lam, shading="nearest", cmap="cividis", vmin=0.5, vmax=1.0)
    fig.colorbar(mesh, ax=ax, label=r"$\lambda_{max}$ (grey: no gait)", extend="max")
    for (name, _, label, colour, marker), opt in zip(MEASURES, optima):
        kind = opt.optimum_kind.values
        star = np.where(kind != KINDS.index("no_gait"), opt.star.values, np.nan)
        ax.plot(lf, star, "-", color=colour, lw=1.2, label=label)
        inner = kind == KINDS.index("interior")
        ax.plot(lf[~inner], star[~inner], marker, color=colour, mfc="none", ms=5, ls="none")
        ax.plot(lf[inner], star[inner], marker, color=colour, ms=5, ls="none")
    ax.axhline(0.39, color="k", ls=":", lw=1, label="human foot ratio 0.39")
    ax.set(xlabel=r"foot length $l_f$ (leg lengths)", ylabel="foot ratio r",
           title="best r per foot length, by each measure\n(filled: interior; open: band edge, plateau, grid edge)")
    ax.legend(fontsize=8, loc="upper left")
    for (key, values), colour in zip(rho.items(), ("C2", "C3", "C4")):
        bx.plot(lf, values, "o-", color=colour, ms=3, label=key)
    bx.axhline(0, color="k", lw=0.6)
    bx.set(xlabel=r"foot length $l_f$ (leg lengths)", ylabel="Spearman rank correlation along r", ylim=(-1.05, 1.05),
           title=f"rank agreement along r (larger = more stable;\nlines with >= {MIN_GAITS} gaits)")
    bx.legend(fontsize=8, loc="lower left")
    fig.savefig(path, dpi=150)


def main(path: str = str(HERE / "flatfoot_human_measures_map.zarr")) -> None:
    ds = jaxwalk.open_dataset(path)
    optima = [line_optima(ds, name, "r", sense) for name, sense, *_ in MEASURES]
    rho = correlations(ds)
    gaits = (ds.status == 0).sum("r").values
    print("| l_f | gaits | r* lambda_max | r* GSN | r* h_max | rho(lambda, h_max) | rho(GSN, h_max) | rho(GSN, lambda) |")
    print("|---|---|---|---|---|---|---|---|")
    for i, l_f in enumerate(ds.l_f.values):
        cells = []
        for opt in optima:
            kind = KINDS[int(opt.optimum_kind.values[i])]
            cells.append("-" if kind == "no_gait" else f"{float(opt.star.values[i]):.3f} ({kind.replace('_', ' ')})")
        corr = [f"{rho[k][i]:+.2f}" if np.isfinite(rho[k][i]) else "-" for k in rho]
        print(f"| {l_f:.4f} | {gaits[i]} | " + " | ".join(cells + corr) + " |")
    out = HERE / "flatfoot_human_measures_map_optima.png"
    figure(ds, optima, rho, out)
    print("wrote", out)


if __name__ == "__main__":
    main(*sys.argv[1:])
