"""Benchmark: one gradient of lambda_max against one lambda_max evaluation, batched.

Per configuration:

* evaluation: the period-one gait by Newton from the model's initial guess, the
  step map's Jacobian at it, its eigenvalues and lambda_max
  (``jit(vmap(find_gait))``, what a sweep runs);
* gradient: the same search, then d lambda_max / d params (and the derivatives
  of v*, speed, step length, period, cost of transport) by the implicit
  function theorem at the fixed point and forward-over-forward second
  derivatives of the step (``jaxwalk.optimize.engine.sensitivity_program``,
  what ``jaxwalk optimize`` runs each iteration).

Both are compiled first (``lower().compile()``, timed apart), then each is run
``--repeat`` times on the same batch in this process; the ratio of the medians
is the cost of a gradient in evaluations. One CPU device (a vmapped program uses
one core).

    PYTHONPATH=. python benchmarks/bench_gradient.py [--model simplest] [--n 64] [--names gamma]

Writes ``benchmarks/results/gradient_<model>.json``.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

import jax  # noqa: E402
import jax.numpy as jnp  # noqa: E402

import jaxwalk  # noqa: E402,F401  (float64)
from jaxwalk import compiling  # noqa: E402
from jaxwalk.gait import NewtonOptions, find_gait  # noqa: E402
from jaxwalk.models import get_model  # noqa: E402
from _walkers import benchmark_params  # noqa: E402
from jaxwalk.optimize.engine import sensitivity_program  # noqa: E402
from jaxwalk.step import SolverOptions  # noqa: E402

#: A batch around each model's default where its gait exists: (parameter, half-width).
SPREAD = {"simplest": ("gamma", 0.004), "compass": ("gamma", 0.01), "flatfoot": ("r", 0.01)}


def batch(model, n: int):
    name, half = SPREAD[model.name]
    d = benchmark_params(model)
    params = {k: jnp.full((n,), v) for k, v in d.items()}
    params[name] = jnp.asarray(d[name] + np.linspace(-half, half, n))
    return params, jax.vmap(model.initial_guess)(params)


def timed(compiled, *args, repeat: int) -> list[float]:
    out = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        jax.block_until_ready(compiled(*args))
        out.append(time.perf_counter() - t0)
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--model", default="simplest", choices=sorted(SPREAD))
    ap.add_argument("--n", type=int, default=64, help="configurations per batch")
    ap.add_argument("--names", default=None, help="parameters to differentiate, comma-separated (default: the spread one)")
    ap.add_argument("--repeat", type=int, default=5)
    args = ap.parse_args()
    model = get_model(args.model)
    names = tuple(args.names.split(",")) if args.names else (SPREAD[args.model][0],)
    params, v0 = batch(model, args.n)
    solver, newton = SolverOptions(), NewtonOptions()

    # Both compiled as jaxwalk compiles the model's programs (jaxwalk.compiling).
    evaluate = compiling.jit(jax.vmap(lambda p, v: find_gait(model, p, v, solver, newton)), model)
    gradient = sensitivity_program(model, names, solver, newton)
    result = {"model": args.model, "n": args.n, "names": list(names), "repeat": args.repeat}
    compiled = {}
    for label, program in (("evaluation", evaluate), ("gradient", gradient)):
        t0 = time.perf_counter()
        lowered = program.lower(params, v0)
        t1 = time.perf_counter()
        compiled[label] = lowered.compile()
        t2 = time.perf_counter()
        result[f"{label}_trace_s"], result[f"{label}_compile_s"] = t1 - t0, t2 - t1
    for label in compiled:  # a first run apart (allocation), then the timed ones
        jax.block_until_ready(compiled[label](params, v0))
    times = {label: timed(compiled[label], params, v0, repeat=args.repeat) for label in compiled}
    for label, ts in times.items():
        result[f"{label}_s"] = statistics.median(ts)
        result[f"{label}_all_s"] = ts
        result[f"{label}_per_config_ms"] = 1e3 * statistics.median(ts) / args.n
    result["ratio"] = result["gradient_s"] / result["evaluation_s"]
    out = compiled["gradient"](params, v0)
    result["statuses_ok"] = int(np.sum(np.asarray(out.status) == 0))
    result["newton_iterations_median"] = float(np.median(np.asarray(out.metrics.iterations)))
    result["machine"] = {
        "cpus": os.cpu_count(), "platform": platform.platform(), "python": platform.python_version(),
        "jax": jax.__version__, "devices": len(jax.devices()),
    }
    print(json.dumps({k: v for k, v in result.items() if not k.endswith("_all_s")}, indent=1))
    path = os.path.join(os.path.dirname(os.path.abspath(__file__)), "results", f"gradient_{args.model}.json")
    with open(path, "w") as f:
        json.dump(result, f, indent=1)


if __name__ == "__main__":
    main()
