"""Benchmark: the cost of attractor classification and bifurcation location,
as ratios to the period-1 sweep on the same grid (issue 16; target <= 2x).

Grid: the simplest walker's slope line gamma = 0.004 ... 0.019 (``--n`` points,
continuation along gamma), which crosses the first period doubling (0.01509)
and the second: past the first, every point's period-1 gait is unstable and
the attractor search walks from it (up to 200 steps, then Newton on the
k-step map). Each timing is the best of ``--repeat`` warm runs (programs
compiled and loaded before timing; compile time apart):

* ``period1``: ``analyse_grid`` (gaits and multipliers only);
* ``attractors``: ``analyse_grid`` with ``AnalysisOptions(attractors=...)``
  (the period-1 sweep plus the attractor search; the ratio is of the whole);
* ``bifurcations``: :func:`jaxwalk.bifurcation.locate` on the period-1
  results (the ratio is of the location alone, to 1e-6).

    PYTHONPATH=. python benchmarks/bench_attractors.py [--n 64] [--repeat 2]

Writes ``benchmarks/results/attractors_simplest.json``.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

import jaxwalk  # noqa: E402,F401
from jaxwalk.attractor import AttractorOptions  # noqa: E402
from jaxwalk.bifurcation import locate  # noqa: E402
from jaxwalk.grid import AnalysisOptions, analyse_grid  # noqa: E402
from jaxwalk.models import get_model  # noqa: E402


def best(fn, repeat: int):
    times, out = [], None
    for _ in range(repeat):
        t = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t)
    return min(times), out


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--n", type=int, default=64)
    parser.add_argument("--repeat", type=int, default=2)
    args = parser.parse_args()
    model = get_model("simplest")
    grid = {"gamma": np.linspace(0.004, 0.019, args.n)}
    plain, with_attr = AnalysisOptions(), AnalysisOptions(attractors=AttractorOptions())

    t0 = time.perf_counter()
    analyse_grid(model, {}, grid, "gamma", with_attr)  # compiles (or loads) both programs
    first = time.perf_counter() - t0
    t_p1, res = best(lambda: analyse_grid(model, {}, grid, "gamma", plain), args.repeat)
    t_attr, res_a = best(lambda: analyse_grid(model, {}, grid, "gamma", with_attr), args.repeat)
    lines = {"gamma": grid["gamma"][None]}
    status, v, mu = res["status"][None], res["fixed_point"][None], res["eigenvalues"][None]
    locate(model, lines, "gamma", status, v, mu)  # compiles the re-solve program
    t_bif, found = best(lambda: locate(model, lines, "gamma", status, v, mu), args.repeat)
    out = {
        "date": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()),
        "machine": f"{platform.machine()}, {os.cpu_count()} cores, load average {os.getloadavg()[0]:.1f} (shared)",
        "grid": f"simplest, gamma {grid['gamma'][0]}..{grid['gamma'][-1]}, {args.n} points, continuation",
        "unstable_points": int(((res["status"] == 0) & (res["lambda_max"] >= 1)).sum()),
        "attractor_periods": {int(k): int((res_a["attractor_period"] == k).sum()) for k in np.unique(res_a["attractor_period"])},
        "bifurcations": [(int(k), float(p)) for k, p in zip(found.kind, found.parameter)],
        "first_call_s": first,
        "period1_s": t_p1,
        "with_attractors_s": t_attr,
        "bifurcation_location_s": t_bif,
        "attractors_ratio": t_attr / t_p1,
        "bifurcations_ratio": t_bif / t_p1,
    }
    print(json.dumps(out, indent=1))
    path = os.path.join(os.path.dirname(os.path.abspath(__file__)), "results", "attractors_simplest.json")
    with open(path, "w") as f:
        json.dump(out, f, indent=1)


if __name__ == "__main__":
    main()
