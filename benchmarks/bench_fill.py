"""Benchmark: what the lines' fill costs (``jaxwalk.lines.fill_from_neighbours``).

After a continuation walk, every failed point beside a found one is solved again
from that neighbour's gait (docs/engine.md, section 5). This script runs the
same grid of the flat-foot walker twice warm in one process, once as
``jaxwalk sweep`` does (walk and fill) and once with the fill switched off, and
reports the ratio and the points the fill found. The grid
is the paper walker's long-foot corner, where the fill finds gaits (l_f 0.255-0.29,
all 64 ratios of the 64 x 64 map), run after one untimed call that compiles.

    PYTHONPATH=. python benchmarks/bench_fill.py [--lines 12]

Writes ``benchmarks/results/fill_flatfoot.json``.
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

import jaxwalk  # noqa: E402
from jaxwalk import lines as L  # noqa: E402
from jaxwalk.grid import AnalysisOptions, analyse_grid  # noqa: E402
from jaxwalk.models import get_model  # noqa: E402
from jaxwalk.models.flatfoot.model import PAPER_PARAMS  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--lines", type=int, default=12, help="l_f lines from 0.255 to 0.29")
    args = ap.parse_args()
    model = get_model("flatfoot")
    grid = {"l_f": np.linspace(0.255, 0.29, args.lines), "r": np.linspace(0.1, 1.0, 64)}
    options = AnalysisOptions(chunk_size=1024)
    fill = L.fill_from_neighbours

    def run(with_fill: bool) -> tuple[dict, float]:
        L.fill_from_neighbours = fill if with_fill else (lambda model, lines, positions, gaits, program, chunk_size: gaits)
        t0 = time.perf_counter()
        out = analyse_grid(model, PAPER_PARAMS, grid, "r", options)
        return out, time.perf_counter() - t0

    run(True)  # compile
    walk, t_walk = run(False)
    filled, t_fill = run(True)
    L.fill_from_neighbours = fill
    found = int(((filled["status"] == 0) & (walk["status"] != 0)).sum())
    lost = int(((filled["status"] != 0) & (walk["status"] == 0)).sum())
    result = {
        "grid": f"l_f {args.lines} lines 0.255-0.29 x r 64 (0.1-1)", "points": int(walk["status"].size),
        "walk_s": t_walk, "walk_and_fill_s": t_fill, "ratio": t_fill / t_walk,
        "gaits_walk": int((walk["status"] == 0).sum()), "gaits_filled": int((filled["status"] == 0).sum()),
        "found_by_fill": found, "lost_by_fill": lost,
        "jaxwalk": jaxwalk.__version__, "machine": platform.machine(), "cpus": os.cpu_count(),
        "date": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()),
    }
    print(json.dumps(result, indent=1))
    os.makedirs("benchmarks/results", exist_ok=True)
    with open("benchmarks/results/fill_flatfoot.json", "w") as f:
        json.dump(result, f, indent=1)


if __name__ == "__main__":
    main()
