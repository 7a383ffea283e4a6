"""Benchmark: how many configurations a worker thread should advance together.

``Walker.lockstep_batch`` sets how many configurations (or continuation lines) a
worker thread runs as one ``vmap`` in a grid analysis (``jaxwalk.grid``). A
vmapped while loop runs until its slowest element is done, so a large batch
gains from vectorisation where every configuration costs about the same and
loses where a few cost many times the rest. This script runs the same grid
with the model's class at several batch sizes, in this process, on every CPU
device (as ``jaxwalk sweep`` runs it), twice each: the first call traces,
compiles and runs, the second only runs (compile ~ first - second). It checks
that the batch size changes no status, and reports how far ``lambda_max`` and
the fixed points move (a vmap of one and of many compile differently, so the
last digits may).

    PYTHONPATH=. EQX_ON_ERROR=nan python benchmarks/bench_lockstep.py [--model kneed] [--batches 64 8 1]

Writes ``benchmarks/results/lockstep_<model>.json``.
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

import jax  # noqa: E402

import jaxwalk  # noqa: E402
from jaxwalk.grid import AnalysisOptions, analyse_grid  # noqa: E402
from jaxwalk.models import get_model  # noqa: E402

#: Per model: the swept axes and the continuation axis (``None``: independent
#: searches from the model's guess are timed too).
GRIDS = {
    "kneed": ({"gamma": np.linspace(0.03, 0.07, 64), "m_h": np.linspace(0.3, 0.8, 8)}, "gamma"),
    "compass": ({"gamma": np.linspace(0.02, 0.075, 64), "m_h": np.linspace(5.0, 20.0, 8)}, "gamma"),
}


def with_batch(model, batch: int):
    """The model's class with ``lockstep_batch = batch`` (a new class: a new program)."""
    cls = type(model)
    return type(f"{cls.__name__}Lockstep{batch}", (cls,), {"lockstep_batch": batch})()


def timed(model, grid, continuation, options) -> tuple[dict, float, float]:
    times, out = [], None
    for _ in range(2):
        t0 = time.perf_counter()
        out = analyse_grid(model, {}, grid, continuation, options)
        times.append(time.perf_counter() - t0)
    return out, times[0], times[1]


def compare(a: dict, b: dict) -> dict:
    ok = (a["status"] == 0) & (b["status"] == 0)
    return {
        "same_status": bool(np.array_equal(a["status"], b["status"])),
        "status_changed": int((a["status"] != b["status"]).sum()),
        "max_lambda_diff": float(np.max(np.abs(a["lambda_max"][ok] - b["lambda_max"][ok]), initial=0.0)),
        "max_fixed_point_diff": float(np.max(np.abs(a["fixed_point"][ok] - b["fixed_point"][ok]), initial=0.0)),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--model", choices=sorted(GRIDS), default="kneed")
    parser.add_argument("--batches", type=int, nargs="+", default=[64, 8, 1])
    parser.add_argument("--modes", nargs="+", choices=("continuation", "independent"), default=["continuation", "independent"])
    args = parser.parse_args()
    base = get_model(args.model)
    grid, along = GRIDS[args.model]
    n = int(np.prod([len(v) for v in grid.values()]))
    options = AnalysisOptions(chunk_size=n)  # one chunk: every line or configuration in one call
    result = {
        "date": time.strftime("%Y-%m-%d"),
        "machine": {"cpus": os.cpu_count(), "platform": platform.platform(), "python": platform.python_version()},
        "jax": jax.__version__,
        "jaxwalk": jaxwalk.__version__,
        "devices": jax.device_count(),
        "model": args.model,
        "default_lockstep_batch": base.lockstep_batch,
        "grid": {k: [float(v.min()), float(v.max()), len(v)] for k, v in grid.items()},
        "points": n,
        "runs": [],
    }
    for mode in args.modes:
        continuation = along if mode == "continuation" else None
        reference = None
        for batch in args.batches:
            out, first, run = timed(with_batch(base, batch), grid, continuation, options)
            reference = reference or out
            statuses = {str(s): int(c) for s, c in zip(*np.unique(out["status"], return_counts=True))}
            row = {"mode": mode, "batch": batch, "first_s": first, "run_s": run, "statuses": statuses, **compare(reference, out)}
            result["runs"].append(row)
            print(
                f"{mode:12s} batch {batch:3d}: first {first:7.1f} s, run {run:7.2f} s, statuses {statuses}, "
                f"vs batch {args.batches[0]}: {row['status_changed']} changed, |d lambda| {row['max_lambda_diff']:.1e}",
                flush=True,
            )
    path = os.path.join(os.path.dirname(os.path.abspath(__file__)), "results", f"lockstep_{args.model}.json")
    with open(path, "w") as f:
        json.dump(result, f, indent=2)
        f.write("\n")


if __name__ == "__main__":
    main()
