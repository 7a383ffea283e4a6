"""What makes the heel-rise walker's stiff-ankle gaits unstable: the mode of
their largest real multiplier, measured (docs/model.md, "The heel-rise walker",
"Why the stiff gaits are unstable").

At gaits of the ``trailing_reset`` 0.5, ``swing_torque`` 0 line of
``sweeps/flatfoot_heel_rise_swing_torque_k.toml``, the step map's Jacobian by
forward mode, its eigenvector of the largest real multiplier (signed so that
``psi_dot`` grows more negative: a faster start), and the step's period ``T``
and actuator work ``W`` from one step at ``v* +- 1e-4`` along it (central
differences ``dT``, ``dW`` per unit of that eigenvector). Then a walk of up to
twelve steps from ``v* +- 2e-3`` along the mode at ``k`` 0.45, to the status
that ends it.

    jaxwalk sweep sweeps/flatfoot_heel_rise_swing_torque_k.toml --out results/human --no-plot --overwrite
    python results/human/speed_mode.py

Writes ``speed_mode.json`` here.
"""

from __future__ import annotations

import json
from pathlib import Path

import jaxwalk  # noqa: F401  (before jax: float64, the caches)
import jax
import jax.numpy as jnp
import numpy as np
import xarray as xr

from jaxwalk.gait import step_jacobian
from jaxwalk.models import get_model
from jaxwalk.status import Status
from jaxwalk.step import step_map

HERE = Path(__file__).parent
STIFFNESSES = (0.05, 0.09, 0.29, 0.40, 0.45, 0.49)
MODEL = get_model("flatfoot_heel_rise")
STEP = jax.jit(lambda v, p: step_map(MODEL, v, p))
JACOBIAN = jax.jit(lambda v, p: step_jacobian(MODEL, v, p))


def gait(line, k):
    """``(params, v*)`` of the line's gait at the grid ``k`` nearest ``k`` (None where it has none)."""
    point = line.sel(k=k, method="nearest")
    if int(point.status) != Status.OK:
        return None
    fixed = json.loads(line.attrs["fixed_parameters"])
    params = {**MODEL.default_params(), **fixed, "trailing_reset": 0.5, "swing_torque": 0.0, "k": float(point.k)}
    return {n: jnp.asarray(x, jnp.float64) for n, x in params.items()}, jnp.asarray(point.fixed_point.values)


def faster_mode(v, params):
    """``(multiplier, eigenvector)``: the largest real multiplier, its eigenvector signed toward a faster start."""
    values, vectors = np.linalg.eig(np.asarray(JACOBIAN(v, params)))
    real = np.abs(values.imag) < 1e-12
    if not real.any():
        raise SystemExit(f"no real multiplier at k = {float(params['k'])}: {values}")
    i = int(np.argmax(np.where(real, values.real, -np.inf)))
    e = vectors[:, i].real
    return float(values[i].real), e * np.sign(-e[-1])  # psi_dot, the last section coordinate, more negative


def sensitivity(v, params, e, h=1e-4):
    """Period, work and their central differences along ``e``."""
    (_, mid), (_, up), (_, down) = (STEP(v + s * h * e, params) for s in (0.0, 1.0, -1.0))
    return dict(T=float(mid.time), W=float(mid.work), dT=float(up.time - down.time) / (2 * h),
                dW=float(up.work - down.work) / (2 * h))


def walk(v, params, e, offset, steps=12):
    """Steps from ``v + offset e`` until one fails: ``(steps completed, status of the last)``."""
    x = v + offset * e
    for n in range(steps):
        x, res = STEP(x, params)
        if int(res.status) != Status.OK:
            return n, Status(int(res.status)).name
    return steps, "OK"


def main():
    line = xr.open_zarr(HERE / "flatfoot_heel_rise_swing_torque_k.zarr").sel(trailing_reset=0.5, swing_torque=0.0)
    rows = []
    for k in STIFFNESSES:
        found = gait(line, k)
        if found is None:
            continue
        params, v = found
        multiplier, e = faster_mode(v, params)
        rows.append(dict(k=float(params["k"]), multiplier=multiplier, **sensitivity(v, params, e)))
        if abs(k - 0.45) < 1e-9:
            rows[-1]["walks"] = {side: walk(v, params, e, s * 2e-3) for side, s in (("faster", 1.0), ("slower", -1.0))}
        print(json.dumps(rows[-1]), flush=True)
    (HERE / "speed_mode.json").write_text(json.dumps(rows, indent=1) + "\n")


if __name__ == "__main__":
    main()
