"""Gradient descent on ``lambda_max`` of the heel-rise walker at a fixed stiff
ankle, over eight actuation and ankle options at once (docs/model.md, "The
heel-rise walker", the descent paragraph).

Starts from the unstable gait of ``sweeps/flatfoot_heel_rise_burst_k.toml``'s
``trailing_reset`` 0.5, ``swing_burst`` 0 line at the ``k`` asked for (a gait
reached there by continuation: the documented guesses are far from it, so
``jaxwalk optimize``, which starts from them, cannot). Each iteration finds the
gait by Newton from the last one's fixed point and its gradient
(``jaxwalk.sensitivity.gait_sensitivity``, forward mode), then takes a
normalised step of ``STEP`` in the box's unit coordinates; a step that loses
the gait is undone and halved, and the descent ends below ``STEP_MIN``.

    jaxwalk sweep sweeps/flatfoot_heel_rise_burst_k.toml --out results/human --no-plot --overwrite
    python results/human/descend_stiff_ankle.py 0.45 0.29

Writes ``stiff_ankle_descent_k<k>.json`` here: every iterate's parameters,
status, ``lambda_max``, speed (sqrt(gL)) and step length (L). The
second-order program compiles for about five minutes on one core.
"""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path

import jaxwalk  # noqa: F401  (before jax: float64, the caches)
import jax
import jax.numpy as jnp
import numpy as np
import xarray as xr

from jaxwalk.models import get_model
from jaxwalk.sensitivity import gait_sensitivity
from jaxwalk.status import Status

HERE = Path(__file__).parent
#: The options descended over and their boxes (within the parameters' bounds).
BOUNDS = {
    "P": (0.02, 0.08), "k_hip": (0.0, 0.3), "ankle_push": (0.0, 0.15), "trailing_reset": (0.0, 1.0),
    "hip_double_support": (0.0, 1.0), "heel_brake": (0.0, 0.05), "swing_dorsi": (0.0, 0.5), "ankle_rest": (0.0, 0.3),
}  # fmt: skip
STEP, STEP_MIN, ITERATIONS = 0.02, 1e-4, 60


def start(k):
    """``(params, v)``: the sweep's line parameters and its gait at the ``k`` nearest ``k``."""
    ds = xr.open_zarr(HERE / "flatfoot_heel_rise_burst_k.zarr")
    line = ds.sel(trailing_reset=0.5, swing_burst=0.0).sel(k=k, method="nearest")
    if int(line.status) != Status.OK:
        raise SystemExit(f"no gait at k = {float(line.k)} on the line")
    model = get_model("flatfoot_heel_rise")
    params = {**model.default_params(), **json.loads(ds.attrs["fixed_parameters"]), "trailing_reset": 0.5,
              "swing_burst": 0.0, "k": float(line.k)}  # fmt: skip
    return model, params, jnp.asarray(line.fixed_point.values)


def descend(k):
    model, params, v = start(k)
    names = tuple(BOUNDS)
    lo, hi = (np.array([b[i] for b in BOUNDS.values()]) for i in (0, 1))
    sensitivity = jax.jit(lambda p, v0: gait_sensitivity(model, p, v0, names))
    x, step, good, log, t0 = np.array([params[n] for n in names]), STEP, None, [], time.time()
    for it in range(ITERATIONS):
        p = {a: jnp.asarray(b, jnp.float64) for a, b in {**params, **dict(zip(names, x))}.items()}
        s = sensitivity(p, v)
        status, lam = Status(int(s.status)), float(s.metrics.lambda_max)
        log.append(dict(iteration=it, status=status.name, lambda_max=lam, speed=float(s.metrics.speed),
                        step_length=float(s.metrics.step_length), seconds=time.time() - t0, **dict(zip(names, map(float, x)))))
        print(json.dumps(log[-1]), flush=True)
        if status == Status.OK and np.isfinite(lam):
            good = (x.copy(), s.metrics.v, np.asarray(s.d_lambda_max) * (hi - lo))  # gradient per unit of the box
        elif good is None:
            break
        else:
            step /= 2.0
            if step < STEP_MIN:
                break
        x, v, grad = good
        unit = (x - lo) / (hi - lo) - step * grad / np.linalg.norm(grad)
        x = lo + np.clip(unit, 0.0, 1.0) * (hi - lo)
    (HERE / f"stiff_ankle_descent_k{float(params['k']):.2f}.json").write_text(json.dumps(log, indent=1) + "\n")


if __name__ == "__main__":
    for k in sys.argv[1:] or ["0.45"]:
        descend(float(k))
