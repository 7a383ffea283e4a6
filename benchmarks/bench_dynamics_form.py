"""Benchmark: the two forms of a walker's dynamics (``mechanics.ENTRYWISE_MAX``), in one process.

For one model, the gait search (Newton from the model's guess, the Jacobian at
the fixed point, lambda_max) as ``jit(vmap(find_gait))`` at batch ``n`` on one
CPU device, built twice: entry by entry (``ENTRYWISE_MAX`` huge) and from
stacked Jacobians (``ENTRYWISE_MAX = 0``). Trace + lower and XLA compile are
timed apart (caches off: run it with ``JAXWALK_CACHE_DIR=``), then the two
compiled programs run in turns, ``--repeat`` rounds, so that a machine's load
falls on both alike; the ratio is per configuration, best of the rounds.

    JAXWALK_CACHE_DIR= PYTHONPATH=. python benchmarks/bench_dynamics_form.py --model flatfoot --n 1
    JAXWALK_CACHE_DIR= PYTHONPATH=. python benchmarks/bench_dynamics_form.py --model compass --n 64

Configurations: the model's defaults with one parameter spread over a small
range inside the gaits' stable band (one configuration: its middle). Writes ``benchmarks/results/dynamics_form_<model>.json``.
"""

from __future__ import annotations

import argparse
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

import jax  # noqa: E402
import jax.numpy as jnp  # noqa: E402

import jaxwalk  # noqa: E402,F401 (its import sets the cache and EQX_ON_ERROR)
from jaxwalk import mechanics  # noqa: E402
from jaxwalk.gait import find_gait  # noqa: E402
from jaxwalk.models import get_model  # noqa: E402
from _walkers import benchmark_params  # noqa: E402
from _record import write_stamped  # noqa: E402

SPREAD = {"flatfoot": ("r", 0.39, 0.43), "simplest": ("gamma", 0.004, 0.014), "compass": ("gamma", 0.02, 0.06),
          "kneed": ("gamma", 0.006, 0.010)}
FORMS = {"entrywise": 10**9, "stacked": 0}


def batch(model, n: int) -> dict:
    name, lo, hi = SPREAD[model.name]
    params = {k: jnp.full(n, float(v), jnp.float64) for k, v in benchmark_params(model).items()}
    params[name] = jnp.asarray(np.linspace(lo, hi, n) if n > 1 else [0.5 * (lo + hi)])
    return params


def build(model, params, form: str):
    """Trace, lower and compile the gait search with the dynamics in ``form``."""
    mechanics.ENTRYWISE_MAX = FORMS[form]  # read while tracing
    program = jax.jit(jax.vmap(lambda p: find_gait(model, p, model.initial_guess(p))))
    t0 = time.perf_counter()
    lowered = program.lower(params)
    t1 = time.perf_counter()
    compiled = lowered.compile()
    t2 = time.perf_counter()
    lines = lowered.as_text().count("\n")
    return compiled, {"trace_lower_s": t1 - t0, "compile_s": t2 - t1, "stablehlo_lines": lines}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--model", default="flatfoot", choices=sorted(SPREAD))
    ap.add_argument("--n", type=int, default=1)
    ap.add_argument("--repeat", type=int, default=4)
    args = ap.parse_args()
    model = get_model(args.model)
    params = batch(model, args.n)
    compiled, result = {}, {"model": args.model, "n": args.n, "forms": {}}
    default = mechanics.ENTRYWISE_MAX
    for form in FORMS:
        compiled[form], result["forms"][form] = build(model, params, form)
    mechanics.ENTRYWISE_MAX = default
    outs, runs = {}, {form: [] for form in FORMS}
    for _ in range(args.repeat):
        for form in FORMS:
            t0 = time.perf_counter()
            outs[form] = jax.block_until_ready(compiled[form](params))
            runs[form].append(time.perf_counter() - t0)
    for form in FORMS:
        entry = result["forms"][form]
        entry["run_ms_per_config"] = 1e3 * min(runs[form]) / args.n
        entry["ok"] = int((np.asarray(outs[form].status) == 0).sum())
        print(f"{args.model} n={args.n} {form}: trace+lower {entry['trace_lower_s']:.1f} s, compile "
              f"{entry['compile_s']:.1f} s, {entry['stablehlo_lines']} StableHLO lines, "
              f"{entry['run_ms_per_config']:.3f} ms/config, ok {entry['ok']}/{args.n}", flush=True)
    ok = (np.asarray(outs["entrywise"].status) == 0) & (np.asarray(outs["stacked"].status) == 0)
    d_lam = np.abs(np.asarray(outs["entrywise"].lambda_max) - np.asarray(outs["stacked"].lambda_max))[ok]
    result["max_abs_d_lambda_max"] = float(d_lam.max()) if d_lam.size else None
    e, s = result["forms"]["entrywise"], result["forms"]["stacked"]
    result["stacked_over_entrywise"] = {k: s[k] / e[k] for k in ("trace_lower_s", "compile_s", "stablehlo_lines", "run_ms_per_config")}
    print(f"stacked / entrywise: {result['stacked_over_entrywise']}; max |d lambda_max| {result['max_abs_d_lambda_max']}")
    write_stamped(f"dynamics_form_{args.model}", result)


if __name__ == "__main__":
    main()
