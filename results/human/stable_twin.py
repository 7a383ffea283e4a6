"""A stable gait beside the heel-rise walker's unstable one at ``k`` 0.29, and
how far it reaches along ``k`` (docs/model.md, "The heel-rise walker", "A stable
twin past a fold").

Newton (``jaxwalk.gait.find_gait``) from the unstable gait of the
``trailing_reset`` 0.5, ``swing_torque`` 0 line of
``sweeps/flatfoot_heel_rise_swing_torque_k.toml`` at ``k`` 0.29, moved along
its speed mode (``speed_mode.py``) by each offset in ``OFFSETS``; every distinct
gait found is then continued along ``k`` both ways (Newton from a secant
through the last two gaits; a step that fails or jumps is halved, down to
``STEP_MIN``).

    jaxwalk sweep sweeps/flatfoot_heel_rise_swing_torque_k.toml --out results/human --no-plot --overwrite
    python results/human/stable_twin.py

Writes ``stable_twin.json`` here: the searches from each offset, and each
branch's gaits (``k``, ``lambda_max``, Froude number, step length L, period
sqrt(L/g), fixed point) with the status that ended it on each side; then
(``scan``) every gait at ``k`` >= 0.25 of the sweep's ``trailing_reset``
0.25 and 0.5 lines without swing torque (the ``k`` 0.29 one again among
them) searched the same way, with each other gait found.
"""

from __future__ import annotations

import json
from pathlib import Path

import jaxwalk  # noqa: F401  (before jax: float64, the caches)
import jax
import jax.numpy as jnp
import numpy as np
import xarray as xr

import speed_mode as sm  # this folder's script: the model, the line's gaits, the mode
from jaxwalk.gait import find_gait
from jaxwalk.status import Status

HERE = Path(__file__).parent
K0 = 0.29
OFFSETS = (-0.08, -0.04, -0.02, 0.02, 0.04, 0.08, 0.12, 0.16, 0.24)
STEP, STEP_MIN, MAX_JUMP = 0.01, 1e-4, 0.05
K_RANGE = (0.0, 0.75)  # the sweep's k axis reaches 0.75
SEARCH = jax.jit(lambda v0, p: find_gait(sm.MODEL, p, v0))


def _row(k, gait):
    period, length = float(gait.period), float(gait.step_length)
    return dict(k=k, lambda_max=float(gait.lambda_max), froude=(length / period) ** 2, step_length=length,
                period=period, fixed_point=np.asarray(gait.v).tolist())


def continue_along_k(params, k0, v0, direction):
    """Gaits from ``(k0, v0)`` along ``k`` in ``direction`` (+1 or -1), and what ended the
    branch: the status of the last failed search, ``JUMP`` (a gait farther than
    ``MAX_JUMP`` from the last) or ``K_RANGE`` (the end of the range reached)."""
    k, v, previous, step, rows, ended = k0, v0, None, STEP * direction, [], "K_RANGE"
    while abs(step) >= STEP_MIN:
        target = k + step
        if not K_RANGE[0] <= target <= K_RANGE[1]:
            ended = "K_RANGE"
            step /= 2.0
            continue
        guess = v if previous is None else v + (v - previous[1]) * (step / (k - previous[0]))
        gait = SEARCH(guess, {**params, "k": jnp.asarray(target)})
        ended = Status(int(gait.status)).name
        if ended == "OK" and float(jnp.max(jnp.abs(gait.v - v))) < MAX_JUMP:
            rows.append(_row(target, gait))
            previous, k, v = (k, v), target, gait.v
        else:
            ended = "JUMP" if ended == "OK" else ended
            step /= 2.0
    return rows, ended


def scan(ds):
    """Every gait at ``k`` >= 0.25 of the two lines: ``(trailing_reset, k, lambda_max, [other gaits])``."""
    rows = []
    for reset in (0.25, 0.5):
        line = ds.sel(trailing_reset=reset, swing_torque=0.0)
        fixed = json.loads(ds.attrs["fixed_parameters"])
        for k in line.k.values[(line.k.values >= 0.25) & (line.status.values == Status.OK)]:
            point = line.sel(k=k)
            params = {**sm.MODEL.default_params(), **fixed, "trailing_reset": reset, "swing_torque": 0.0, "k": float(k)}
            params = {n: jnp.asarray(x, jnp.float64) for n, x in params.items()}
            v = jnp.asarray(point.fixed_point.values)
            _, mode = sm.faster_mode(v, params)
            others = {}
            for offset in OFFSETS:
                gait = SEARCH(v + offset * mode, params)
                if int(gait.status) == Status.OK and float(jnp.max(jnp.abs(gait.v - v))) > 1e-6:
                    others[tuple(np.round(np.asarray(gait.v), 8))] = _row(float(k), gait)
            rows.append(dict(trailing_reset=reset, k=float(k), lambda_max=float(point.lambda_max),
                             others=list(others.values())))
            print(json.dumps({a: b for a, b in rows[-1].items() if a != "others"} | {"others": len(others)}), flush=True)
    return rows


def main():
    line = xr.open_zarr(HERE / "flatfoot_heel_rise_swing_torque_k.zarr").sel(trailing_reset=0.5, swing_torque=0.0)
    params, v = sm.gait(line, K0)
    _, mode = sm.faster_mode(v, params)
    searches, branches = [], []
    for offset in OFFSETS:
        gait = SEARCH(v + offset * mode, params)
        searches.append(dict(offset=offset, status=Status(int(gait.status)).name,
                             **(_row(K0, gait) if int(gait.status) == Status.OK else {})))
        print(json.dumps(searches[-1]), flush=True)
        found = int(gait.status) == Status.OK
        if found and all(np.max(np.abs(np.asarray(gait.v) - b["start"]["fixed_point"])) > 1e-6 for b in branches):
            branch = {"start": _row(K0, gait)}
            for side, direction in (("up", 1), ("down", -1)):
                rows, ended = continue_along_k(params, K0, gait.v, direction)
                branch[side] = {"gaits": rows, "ended": ended}
            branches.append(branch)
    scanned = scan(xr.open_zarr(HERE / "flatfoot_heel_rise_swing_torque_k.zarr"))
    out = {"searches": searches, "branches": branches, "scan": scanned}
    (HERE / "stable_twin.json").write_text(json.dumps(out, indent=1) + "\n")
    for b in branches:
        ks = [r["k"] for r in b["down"]["gaits"] + b["up"]["gaits"]] + [K0]
        stable = [r["k"] for r in b["down"]["gaits"] + b["up"]["gaits"] + [b["start"]] if r["lambda_max"] < 1]
        print(f"branch from lambda_max {b['start']['lambda_max']:.4f}: k {min(ks):.4f}-{max(ks):.4f}, "
              f"stable up to {max(stable) if stable else None}; ended {b['down']['ended']} / {b['up']['ended']}")


if __name__ == "__main__":
    main()
