"""Benchmark: XLA's CPU fusion emitters against its elemental emitters, per walker.

Each walker's gait search (Newton, Jacobian, eigenvalues: :func:`jaxwalk.gait.find_gait`)
at the batch its grid runs together (``Walker.lockstep_batch``: 64 for the
passive and kneed walkers, 1 for the flat-foot walker), plus the flat-foot
step map under ``jvp`` (what each Newton iteration runs). One trace per
program, compiled twice from the same lowering (``Lowered.compile`` with and
without ``xla_cpu_use_fusion_emitters = False``; the fusion emitters'
first, after the trace, so a one-time warm-up left, if any, would favour
the elemental compile slightly), then run in turn
(A B A B, best of ``--repeat``). Caches off (the script turns them off).
The choice it informs is :attr:`jaxwalk.walker.Walker.cpu_fusion_emitters`
(:mod:`jaxwalk.compiling`).

    JAXWALK_CACHE_DIR= PYTHONPATH=. taskset -c 0 python benchmarks/bench_compile_options.py [--models flatfoot kneed ...]

Writes ``benchmarks/results/compile_options.json``; with ``--batches 1 8 64``
the gait searches at those batch sizes instead (no step map), to
``benchmarks/results/compile_options_batches.json``.
"""

from __future__ import annotations

import argparse
import os
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import jaxwalk  # noqa: E402,F401  (sets float64 and the device count before jax starts)
import jax  # noqa: E402
import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402

from _record import write_stamped  # noqa: E402
from _walkers import benchmark_params  # noqa: E402
from jaxwalk import cache  # noqa: E402
from jaxwalk.gait import find_gait  # noqa: E402
from jaxwalk.models import get_model  # noqa: E402
from jaxwalk.step import SolverOptions, step_map  # noqa: E402

ELEMENTAL = {"xla_cpu_use_fusion_emitters": False}
#: Each walker's swept parameter and its range for the batch (the benchmark's usual ones).
SPREAD = {"simplest": ("gamma", 0.009, 0.011), "compass": ("gamma", 0.052, 0.053), "kneed": ("gamma", 0.050, 0.051),
          "flatfoot": ("r", 0.39, 0.41)}


def gait_search(name: str, batch: int | None = None):
    """``(fn, args, batch)``: the vmapped gait search of ``batch`` configurations
    (default: the walker's lockstep batch)."""
    model = get_model(name)
    batch = model.lockstep_batch if batch is None else batch
    key, lo, hi = SPREAD[name]
    params = {k: jnp.full((batch,), v) for k, v in benchmark_params(model).items()}
    params[key] = jnp.linspace(lo, hi, batch)
    v0 = jax.vmap(model.initial_guess)(params)
    return jax.vmap(lambda p, v: find_gait(model, p, v)), (params, v0), batch


def flatfoot_step_jvp():
    """``(fn, args, 1)``: one flat-foot step map with one tangent, from the stored guess."""
    model = get_model("flatfoot")
    p = benchmark_params(model)

    def fn(v, dv):
        (v1, _), (dv1, _) = jax.jvp(lambda v_: step_map(model, v_, p, SolverOptions()), (v,), (dv,))
        return v1, dv1

    return fn, (model.initial_guess(p), jnp.array([1.0, 0.0])), 1


#: What is compared between the two compiles' outputs: a gait's fixed point and
#: lambda_max (NaN where the search failed, in both), a step's next section point and tangent.
KEYS = {"search": {"v": lambda g: g.v, "lambda_max": lambda g: g.lambda_max,
                   "status_differs": lambda g: g.status.astype(float)},
        "jvp": {"v_next": lambda out: out[0], "dv_next": lambda out: out[1]}}


def measure(label: str, fn, args, batch: int, repeat: int) -> dict:
    t = time.perf_counter()
    lowered = jax.jit(fn).lower(*args)
    trace = time.perf_counter() - t
    compiled, compile_s = {}, {}
    for form, options in (("fusion", None), ("elemental", ELEMENTAL)):
        t = time.perf_counter()
        compiled[form] = lowered.compile(options)
        compile_s[form] = time.perf_counter() - t
    run_s = {form: float("inf") for form in compiled}
    outputs = {}
    for _ in range(repeat):
        for form, exe in compiled.items():
            t = time.perf_counter()
            outputs[form] = jax.block_until_ready(exe(*args))
            run_s[form] = min(run_s[form], time.perf_counter() - t)
    differ = {key: float(np.nanmax(np.abs(np.asarray(pick(outputs["fusion"])) - np.asarray(pick(outputs["elemental"])))))
              for key, pick in KEYS[label.split()[-1]].items()}
    row = {"program": label, "batch": batch, "trace_lower_s": trace, "compile_s": compile_s,
           "run_s": run_s, "per_config_ms": {f: 1e3 * s / batch for f, s in run_s.items()},
           "compile_gain": compile_s["fusion"] / compile_s["elemental"],
           "run_gain": run_s["fusion"] / run_s["elemental"], "largest_output_difference": differ}
    print(f"{label:28s} batch {batch:4d}  trace+lower {trace:5.1f} s  compile {compile_s['fusion']:6.1f} -> "
          f"{compile_s['elemental']:6.1f} s ({row['compile_gain']:.2f}x)  run {1e3 * run_s['fusion']:8.2f} -> "
          f"{1e3 * run_s['elemental']:8.2f} ms ({row['run_gain']:.2f}x)  differences {differ}", flush=True)
    return row


def main() -> None:
    cache.configure(enabled=False)  # every compile measured, none loaded
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--models", nargs="+", default=["flatfoot", "kneed", "compass", "simplest"])
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--batches", type=int, nargs="+", default=None,
                        help="gait-search batch sizes to measure (default: each walker's lockstep batch); "
                             "the results go to compile_options_batches.json")
    args = parser.parse_args()
    rows = []
    for name in args.models:
        for batch in args.batches or [None]:
            rows.append(measure(f"{name} gait search", *gait_search(name, batch), args.repeat))
        if name == "flatfoot" and args.batches is None:
            rows.append(measure("flatfoot step map, jvp", *flatfoot_step_jvp(), args.repeat))
    out = "compile_options" if args.batches is None else "compile_options_batches"
    write_stamped(out, {"rows": rows, "cores": len(os.sched_getaffinity(0))})


if __name__ == "__main__":
    main()
