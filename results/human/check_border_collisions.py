"""The heel-rise walker's border collisions checked apart from the locator
(docs/model.md, "The heel-rise walker"; results/README.md).

For every ``border_collision`` row of the push-off and stance-reset sweeps'
bifurcation tables, Newton (``jaxwalk.gait.find_gait``, not the locator's
re-solve) solves the gait ``DK`` below and above the located parameter from the
row's fixed point, and prints whether each side's step takes the event order the
table names for it, and how far the two ``lambda_max`` are apart.

    jaxwalk sweep sweeps/flatfoot_heel_rise_push_k.toml --out results/human --overwrite
    jaxwalk sweep sweeps/flatfoot_heel_rise_stance_reset_k.toml --out results/human --overwrite
    python results/human/check_border_collisions.py

Measured 2026-12-07: all nine collisions, both orders as named, ``lambda_max``
3.3e-7 to 2.6e-5 apart (the lines' own slope over 2e-6); again (session 53,
Newton's iterates kept in the section) all ten, the tenth on the stance-reset
line ``mu`` 1e6, ``ankle_rest`` 0.2 at ``k`` 0.058421, 3.6e-7 to 2.6e-5 apart.
"""

from __future__ import annotations

import json
from pathlib import Path

import jaxwalk  # noqa: F401  (before jax: float64, the caches)
import jax
import numpy as np
import xarray as xr

from jaxwalk.event_log import codes, describe
from jaxwalk.gait import find_gait
from jaxwalk.models import get_model

HERE = Path(__file__).parent
#: The sweeps (each dataset records every parameter it held fixed).
SWEEPS = ("flatfoot_heel_rise_push_k", "flatfoot_heel_rise_stance_reset_k")
#: Distance from the located parameter: the location's tolerance.
DK = 1e-6


def main() -> int:
    model = get_model("flatfoot_heel_rise")
    solve = jax.jit(lambda p, v: find_gait(model, p, v))
    failures = 0
    for name in SWEEPS:
        ds = xr.open_zarr(HERE / f"{name}.zarr", consolidated=False)
        axis, fixed = ds.attrs["continuation_axis"], json.loads(ds.attrs["fixed_parameters"])
        for j in np.flatnonzero(ds["bifurcation_kind"].values == 7):
            row = ds.isel(bifurcation=int(j))
            params = {**model.default_params(), **fixed}
            line = {d: float(row[f"bifurcation_{d}"]) for d in ds["status"].dims if f"bifurcation_{d}" in row}
            params.update(line)
            at = float(row["bifurcation_parameter"])
            sides = []
            for dk, expected in ((-DK, row["bifurcation_sequence"]), (DK, row["bifurcation_sequence_beyond"])):
                p = {k: np.float64(v) for k, v in {**params, axis: at + dk}.items()}
                gait = solve(p, row["bifurcation_point"].values)
                code = int(codes(model, np.asarray(gait.context)))
                sides.append((int(gait.status) == 0 and code == int(expected), float(gait.lambda_max)))
            ok = all(s[0] for s in sides)
            failures += not ok
            print(f"{name} {line} {axis} {at:.6f}: {'both orders as named' if ok else 'MISMATCH'}, "
                  f"lambda_max {abs(sides[0][1] - sides[1][1]):.1e} apart; "
                  f"{describe(int(row['bifurcation_sequence_beyond']), model.guards)}")
    return 1 if failures else 0


if __name__ == "__main__":
    raise SystemExit(main())
