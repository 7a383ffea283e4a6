"""Benchmark: ``jaxwalk optimize`` cold, with its background grid beside the
optimisation (the default since 2026-12-06) against after it (the order before).

Issue 12 asks for ``jaxwalk optimize sweeps/optimize/flatfoot_foot_ratio.toml``
in at most 5 minutes cold. Its time goes to compiling: the second-order program
(the gradient of lambda_max through the implicit fixed-point derivative) is one
XLA compile on one core for minutes, and the background grid's gait search is
another; run one after the other, the second core idles through the first.

Each form runs in a fresh process with empty caches (``JAXWALK_CACHE_DIR`` and
``XDG_CACHE_HOME`` in a new temporary directory), forms interleaved (A B A B
...), wall time of the whole command:

* ``beside``: ``run_optimize`` as the CLI calls it (the background grid on a
  thread of its own from the start);
* ``after``: the same steps in the order before: ``optimise`` to its end, then
  ``compute_heatmap``, then the dataset and figure.

Both write their datasets; every repeat's pair of datasets (variables and
coordinates) is compared bit for bit (concurrency must change no number), and
each run's peak resident memory is recorded (two compiles at once hold both
programs' compiler memory).

    PYTHONPATH=. python benchmarks/bench_optimize_background.py [--config sweeps/optimize/flatfoot_foot_ratio.toml] [--repeat 1]

Writes ``benchmarks/results/optimize_background.json``.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
sys.path.insert(0, HERE)

#: One cold run of a form: its own process, so nothing compiled is shared.
CHILD = r"""
import sys, time
t0 = time.perf_counter()
import jaxwalk  # noqa: F401  (before jax: the device-count flag)
from jaxwalk.optimize.config import load_optimize_config
from jaxwalk.optimize import output
from jaxwalk.optimize.engine import optimise
from jaxwalk.files import write_zarr
from jaxwalk.models import get_model

form, config_path, out = sys.argv[1:4]
config = load_optimize_config(config_path)
if form == "beside":
    output.run_optimize(config, out, plot=True)
else:  # the order before 2026-12-06: the path, then the background grid
    target, figure = output.check_output(out, config.name, False)
    model = get_model(config.model)
    solver, newton = output.solver_options(config)
    path = optimise(model, config.problem, config.fixed_per_start(), config.starts, solver, newton)
    t1 = time.perf_counter()
    background = output.compute_heatmap(config, model, solver, newton)
    print(f"background alone {time.perf_counter() - t1:.1f} s", file=sys.stderr)
    ds = output.build_dataset(config, model, path, background, None)
    write_zarr(ds, target)
    from jaxwalk.optimize.figure import draw_paths
    draw_paths(ds, figure)
import resource
print(f"PEAK_RSS_MB {resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024:.0f}")
print(f"WALL {time.perf_counter() - t0:.2f}")
"""


def run_form(form: str, config: str, out: str) -> tuple[float, float]:
    """Wall seconds (the child's own clock, imports included) and peak RSS (MB) of one cold run of ``form``."""
    with tempfile.TemporaryDirectory() as cache:
        env = {**os.environ, "JAXWALK_CACHE_DIR": cache, "XDG_CACHE_HOME": cache, "PYTHONPATH": ROOT}
        t0 = time.perf_counter()
        proc = subprocess.run([sys.executable, "-c", CHILD, form, config, out], env=env, capture_output=True, text=True)
        outer = time.perf_counter() - t0
    if proc.returncode != 0:
        raise SystemExit(f"{form} failed:\n{proc.stderr[-3000:]}")
    inner = float(proc.stdout.split("WALL")[-1])
    rss = float(proc.stdout.split("PEAK_RSS_MB")[-1].split()[0])
    print(f"{form}: {inner:.1f} s ({outer:.1f} s with the interpreter's start), peak RSS {rss:.0f} MB", flush=True)
    return inner, rss


def compare(a: str, b: str) -> dict:
    """Largest differences between two optimize datasets' variables and coordinates (0.0 where bit for bit)."""
    import numpy as np
    import xarray as xr

    x, y = xr.open_zarr(a), xr.open_zarr(b)
    out = {}
    for name in [*x.data_vars, *x.coords]:
        u, v = np.asarray(x[name].values), np.asarray(y[name].values)
        if u.dtype.kind in "fc":
            same = (u == v) | (np.isnan(u) & np.isnan(v))
            out[name] = 0.0 if same.all() else float(np.nanmax(np.abs(u - v)))
        else:
            out[name] = 0.0 if np.array_equal(u, v) else float("nan")
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--config", default=os.path.join(ROOT, "sweeps", "optimize", "flatfoot_foot_ratio.toml"))
    parser.add_argument("--repeat", type=int, default=1)
    args = parser.parse_args()
    forms = ("after", "beside")
    times, rss = {f: [] for f in forms}, {f: [] for f in forms}
    name = os.path.splitext(os.path.basename(args.config))[0]
    diff = {}
    with tempfile.TemporaryDirectory() as work:
        for k in range(args.repeat):
            for form in forms[::-1] if k % 2 else forms:  # A B, B A, ...: neither always first
                wall, peak = run_form(form, args.config, os.path.join(work, f"{form}{k}"))
                times[form].append(wall)
                rss[form].append(peak)
            pair = compare(*(os.path.join(work, f"{f}{k}", f"{name}.zarr") for f in forms))
            diff = {v: max(diff.get(v, 0.0), d) for v, d in pair.items()}
    best = {f: min(t) for f, t in times.items()}
    print(f"best: after {best['after']:.1f} s, beside {best['beside']:.1f} s, speed-up {best['after'] / best['beside']:.2f}x;"
          f" peak RSS {max(rss['after']):.0f} MB against {max(rss['beside']):.0f} MB")
    print("largest differences:", {k: v for k, v in diff.items() if v != 0.0} or "none (bit for bit)")
    from _record import write_stamped

    write_stamped("optimize_background", {"config": os.path.relpath(args.config, ROOT), "wall_s": times, "best_s": best,
                                          "speed_up": best["after"] / best["beside"], "peak_rss_mb": rss,
                                          "largest_difference": diff})


if __name__ == "__main__":
    main()
