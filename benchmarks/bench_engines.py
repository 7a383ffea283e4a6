"""Benchmark: the flat step engine against the nested one, in one process.

For one model, the gait search (Newton from the model's guess, the Jacobian at
the fixed point, its eigenvalues, lambda_max) as ``jit(vmap(find_gait))`` on
one CPU device, at batch 1 and at batch ``n``, on each engine
(``SolverOptions.engine``); compile time (``lower().compile()``) apart from
run time (best of ``--repeat``). Then the batch-``n`` results of the two
engines point by point: statuses, |d lambda_max|, |d v*|.

    PYTHONPATH=. EQX_ON_ERROR=nan python benchmarks/bench_engines.py --model flatfoot --n 64

Configurations: the model's defaults with one parameter spread over a small
range (flat-foot: r in [0.38, 0.42]; simplest: gamma in [0.004, 0.014];
compass: gamma in [0.02, 0.06]), where every search converges on both engines.
Writes ``benchmarks/results/engines_<model>.json``.
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

import jaxwalk  # noqa: E402
from jaxwalk.gait import find_gait  # noqa: E402
from jaxwalk.models import get_model  # noqa: E402
from _walkers import benchmark_params  # noqa: E402
from jaxwalk.step import SolverOptions  # noqa: E402
from _record import machine, time_compiled, write_result  # noqa: E402

SPREAD = {"flatfoot": ("r", 0.38, 0.42), "simplest": ("gamma", 0.004, 0.014), "compass": ("gamma", 0.02, 0.06)}


def batch_params(model, n: int) -> dict:
    name, lo, hi = SPREAD[model.name]
    params = {k: jnp.full((n,), v, jnp.float64) for k, v in benchmark_params(model).items()}
    params[name] = jnp.linspace(lo, hi, n) if n > 1 else jnp.full((1,), 0.5 * (lo + hi))
    return params


def time_gait(model, engine: str, n: int, repeat: int) -> tuple[dict, object]:
    """Compile ``jit(vmap(find_gait))`` for batch ``n`` on ``engine``; best of ``repeat`` runs."""
    solver = SolverOptions(engine=engine)
    params = batch_params(model, n)
    fn = jax.jit(jax.vmap(lambda p: find_gait(model, p, model.initial_guess(p), solver)))
    compile_s, best, out = time_compiled(fn, params, repeat)
    status = np.asarray(out.status)
    row = {"engine": engine, "n": n, "compile_s": compile_s, "run_s": best, "per_config_s": best / n, "ok": int(np.sum(status == 0))}
    print(
        f"{engine:6s} batch {n:5d}: compile {compile_s:7.1f} s, {best / n * 1e3:9.3f} ms/config, ok {row['ok']}/{n}, "
        f"Newton its {float(np.mean(np.asarray(out.iterations))):.2f}",
        flush=True,
    )
    return row, out


def compare(a, b) -> dict:
    """Point-by-point differences of two batches of gaits (``a`` the reference)."""
    sa, sb = np.asarray(a.status), np.asarray(b.status)
    ok = (sa == 0) & (sb == 0)
    changed = np.nonzero(sa != sb)[0]
    return {
        "status_changed": [{"index": int(i), "from": int(sa[i]), "to": int(sb[i])} for i in changed],
        "max_lambda_diff": float(np.max(np.abs(np.asarray(a.lambda_max)[ok] - np.asarray(b.lambda_max)[ok]), initial=0.0)),
        "max_fixed_point_diff": float(np.max(np.abs(np.asarray(a.v)[ok] - np.asarray(b.v)[ok]), initial=0.0)),
    }


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--model", choices=sorted(SPREAD), default="flatfoot")
    parser.add_argument("--n", type=int, default=64, help="large batch (configs)")
    parser.add_argument("--repeat", type=int, default=2)
    parser.add_argument("--engines", nargs="+", choices=("flat", "nested"), default=["flat", "nested"])
    parser.add_argument("--no-batch-1", action="store_true", help="skip batch 1 (its compile is a second one)")
    args = parser.parse_args(argv)
    model = get_model(args.model)
    result = {
        "benchmark": "gait search (fixed point + Jacobian + eigenvalues), flat engine against nested, batch 1 and n",
        "date": time.strftime("%Y-%m-%d %H:%M"),
        "model": args.model,
        "load_average_at_start": os.getloadavg(),
        "runs": [],
    }
    outs = {}
    for engine in args.engines:
        big, outs[engine] = time_gait(model, engine, args.n, args.repeat)
        result["runs"].append(big)
        if not args.no_batch_1:
            single, _ = time_gait(model, engine, 1, max(args.repeat, 3))
            result["runs"].append(single)
            big["batching_speedup"] = single["per_config_s"] / big["per_config_s"]
            print(f"{engine:6s} batching gain at {args.n}: {big['batching_speedup']:.1f}x", flush=True)
    if len(outs) == 2:
        result["flat_vs_nested"] = compare(outs["nested"], outs["flat"])
        runs = {r["engine"]: r for r in result["runs"] if r["n"] == args.n}
        result["flat_speedup_at_n"] = runs["nested"]["per_config_s"] / runs["flat"]["per_config_s"]
        print(f"flat vs nested at batch {args.n}: {result['flat_speedup_at_n']:.2f}x faster; {result['flat_vs_nested']}", flush=True)
    result["load_average_at_end"] = os.getloadavg()
    result["machine"] = machine()
    result["versions"] = {"jaxwalk": jaxwalk.__version__, "jax": jax.__version__}
    write_result(f"engines_{args.model}", result)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
