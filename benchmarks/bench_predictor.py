"""Issue 12: the continuation lines' predictor, secant against order zero, on a sweep's own grid.

Each continuation line starts Newton at its next point either from the gait of
the point before (``NewtonOptions.predictor = "previous"``, the only start
before 2026-12-05) or on the secant through the gaits of the two points before,
falling back to the point before's gait where that search fails (``"secant"``,
the default since). Both run here in one process on the same grid: a sweep
config's grid with every ``--every``-th value of each axis but the continuation
axis (whose lines are kept whole), through ``analyse_grid`` with the config's
options (seed lines included). Each predictor's program is compiled first on a
one-line grid (timed apart), then the grid is timed ``--repeat`` times.

Reported per predictor: wall time per point (best pass), Newton iterations in
all and per found gait, and the points whose status differs between the two,
each with its parameters, the two statuses and both searches' iterations, and
the largest differences of fixed point and ``lambda_max`` where both found the gait.

    PYTHONPATH=. python benchmarks/bench_predictor.py [--config sweeps/flatfoot_human_lf_r_map.toml] [--every 8]

Writes ``benchmarks/results/predictor_<config name>.json``.
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

from _record import write_stamped  # noqa: E402
from jaxwalk.grid import analyse_grid  # noqa: E402
from jaxwalk.models import get_model  # noqa: E402
from jaxwalk.status import Status  # noqa: E402
from jaxwalk.sweep.config import load_config  # noqa: E402
from jaxwalk.sweep.runner import analysis_options  # noqa: E402

PREDICTORS = ("previous", "secant")


def _grid(config, every: int) -> dict[str, np.ndarray]:
    """The config's grid, thinned to every ``every``-th value off the continuation axis."""
    return {a.name: a.values if a.name == config.continuation else a.values[::every] for a in config.axes}


def _run(config, grid, predictor: str, repeat: int) -> tuple[dict, dict]:
    """Compile on one line, then run ``grid`` ``repeat`` times: ``(timings, results)``."""
    model = get_model(config.model)
    base = analysis_options(config)
    options = dataclasses.replace(base, newton=dataclasses.replace(base.newton, predictor=predictor))
    run = lambda g: analyse_grid(model, config.fixed, g, config.continuation, options, seed_axis=config.seed_axis)
    one_line = {k: (v if k == config.continuation else v[:1]) for k, v in grid.items()}
    t0 = time.perf_counter()
    run(one_line)
    first_s = time.perf_counter() - t0
    best = np.inf
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = run(grid)
        best = min(best, time.perf_counter() - t0)
    status, iters = out["status"], out["newton_iterations"]
    timing = {"first_call_s": first_s, "best_s": best, "ms_per_point": 1e3 * best / status.size,
              "gaits": int((status == Status.OK).sum()), "newton_iterations": int(iters.sum()),
              "iterations_per_gait": float(iters[status == Status.OK].mean())}
    return timing, out


def _compare(grid, a: dict, b: dict) -> dict:
    """Points whose status differs, and the gaits' largest differences where both were found."""
    names = list(grid)
    changed = []
    for index in zip(*np.nonzero(a["status"] != b["status"])):
        changed.append({**{n: float(grid[n][i]) for n, i in zip(names, index)},
                        "previous": Status(int(a["status"][index])).name.lower(),
                        "secant": Status(int(b["status"][index])).name.lower(),
                        "iterations": [int(a["newton_iterations"][index]), int(b["newton_iterations"][index])]})
    both = (a["status"] == Status.OK) & (b["status"] == Status.OK)
    dv = np.abs(a["fixed_point"] - b["fixed_point"]).max(axis=-1)[both]
    dlam = np.abs(a["lambda_max"] - b["lambda_max"])[both]
    return {"changed": changed, "points": int(a["status"].size), "both_found": int(both.sum()),
            "fixed_point_max": float(dv.max(initial=0)), "lambda_max_max": float(dlam.max(initial=0)),
            "lambda_max_median": float(np.median(dlam)) if dlam.size else None}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--config", default="sweeps/flatfoot_human_lf_r_map.toml")
    ap.add_argument("--every", type=int, default=8, help="keep every N-th value of the other axes")
    ap.add_argument("--repeat", type=int, default=1)
    args = ap.parse_args()
    config = load_config(args.config)
    grid = _grid(config, args.every)
    timings, outs = {}, {}
    for predictor in PREDICTORS:
        timings[predictor], outs[predictor] = _run(config, grid, predictor, args.repeat)
        t = timings[predictor]
        print(f"{predictor:8s}: first call {t['first_call_s']:.1f} s, {t['ms_per_point']:.1f} ms/point, "
              f"{t['gaits']} gaits, {t['newton_iterations']} Newton iterations ({t['iterations_per_gait']:.2f} per gait)",
              flush=True)
    diff = _compare(grid, outs["previous"], outs["secant"])
    ratio = timings["previous"]["best_s"] / timings["secant"]["best_s"]
    print(f"secant / previous: {ratio:.2f}x faster; {len(diff['changed'])} of {diff['points']} statuses differ; "
          f"where both found the gait: |dv*| <= {diff['fixed_point_max']:.1e}, |dlambda_max| <= {diff['lambda_max_max']:.1e}")
    for c in diff["changed"]:
        print("  ", c)
    write_stamped(f"predictor_{config.name}", {"config": args.config, "every": args.every,
                                               "grid": {k: v.tolist() for k, v in grid.items()},
                                               "timings": timings, "speedup": ratio, "comparison": diff})


if __name__ == "__main__":
    main()
