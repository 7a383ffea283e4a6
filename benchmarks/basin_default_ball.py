"""Each model's default basin ball (``Walker.basin_radius``, ``Walker.basin_scale``),
measured at its default gait (docs/global_stability.md, "The default ball is the
model's"). Not a timing: the measurement behind a default, kept runnable.

For each model named (default: all four):

1. its default gait (``find_gait`` from ``initial_guess`` at the default parameters);
2. with ``--extent R`` (3-D sections only: the 2-D ones have their basin images),
   the basin's extent along each signed section axis, unscaled: the ray radii of
   the basin measure with ``scale`` 1, ``radius`` R, 16 scan points, 6 bisections;
3. the basin measure at the model's default ball and default settings.

    PYTHONPATH=. python benchmarks/basin_default_ball.py [MODEL ...] [--extent 3]

Writes ``benchmarks/results/basin_default_ball.json``.
"""

from __future__ import annotations

import argparse
import time

import jax
import jax.numpy as jnp
import numpy as np

from benchmarks._record import write_stamped
from jaxwalk.gait import find_gait
from jaxwalk.global_stability.basin import BasinOptions, basin
from jaxwalk.models import get_model


def measure(model, params, v_star, options: BasinOptions) -> dict:
    """The basin measure of the gait at ``v_star`` under ``options``, and its wall time."""
    start = time.perf_counter()
    b = jax.jit(lambda p, v: basin(model, p, v, v[None], options))(params, jnp.asarray(v_star))
    return {"fraction": float(b.fraction), "fraction_error": float(b.fraction_error), "radius": float(b.radius),
            "ray_radius": np.asarray(b.ray_radius).round(4).tolist(), "seconds": round(time.perf_counter() - start, 1)}


def one_model(name: str, extent: float | None) -> dict:
    model = get_model(name)
    params = model.default_params()
    gait = find_gait(model, params, model.initial_guess(params))
    assert int(gait.status) == 0, f"{name}: no gait at the defaults"
    v_star, n_v = np.asarray(gait.v), len(gait.v)
    out = {"params": {k: float(v) for k, v in params.items()}, "v_star": v_star.tolist(),
           "lambda_max": float(gait.lambda_max), "basin_radius": model.basin_radius,
           "basin_scale": model.basin_scale}
    if extent is not None and n_v >= 3:  # the 2 n_v rays are the signed axes: + of each, then - of each
        rays = measure(model, params, v_star, BasinOptions(radius=extent, samples=16, directions=2 * n_v, scan=16,
                                                           bisections=6, scale=(1.0,) * n_v))["ray_radius"]
        out["extent"] = {axis: [rays[i], rays[n_v + i]] for i, axis in enumerate(model.section_names)}
        out["extent_radius"] = extent
    out["default_ball"] = measure(model, params, v_star, BasinOptions())
    print(name, out, flush=True)
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("models", nargs="*", default=["simplest", "compass", "kneed", "flatfoot"])
    parser.add_argument("--extent", type=float, default=None, help="radius of the unscaled axis rays (3-D sections)")
    args = parser.parse_args()
    write_stamped("basin_default_ball", {name: one_model(name, args.extent) for name in args.models})


if __name__ == "__main__":
    main()
