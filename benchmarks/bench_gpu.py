"""Benchmark: the flat-foot (l_f, r) lambda_max map at 1e4-1e6 configs on ``jax.devices()[0]``.

The gait search (Newton from the model's guess, Jacobian, eigenvalues,
lambda_max) on the flat step engine (``SolverOptions(engine="flat")``), as one
jitted ``lax.map`` over sub-batches of ``--sub-batch`` vmapped configurations,
on whatever device JAX gives first (a GPU where one is lent, else the CPU).
Nothing in the step loop calls back to the host: the program is the one a
sweep runs, without the worker threads (one device).

    PYTHONPATH=. EQX_ON_ERROR=nan python benchmarks/bench_gpu.py --sizes 10000 100000 1000000

For each size: compile time (``lower().compile()``), run time (the second
call), configs per second, and the status counts. Grid: l_f in [0.16, 0.28] x
r in [0.2, 0.6], as square as the size allows, other parameters at their
defaults. Writes ``benchmarks/results/gpu_<platform>.json``.
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
from _record import machine, write_result  # noqa: E402

MODEL = get_model("flatfoot")
SOLVER = SolverOptions(engine="flat")


def grid_params(n: int) -> dict:
    """About ``n`` configs on an (l_f, r) grid, flattened (exactly ``side_f * side_r``)."""
    side = int(np.ceil(np.sqrt(n)))
    l_f, r = np.meshgrid(np.linspace(0.16, 0.28, side), np.linspace(0.2, 0.6, -(-n // side)), indexing="ij")
    params = {k: np.full(l_f.size, float(v)) for k, v in benchmark_params(MODEL).items()}
    params["l_f"], params["r"] = l_f.ravel(), r.ravel()
    return params


def program(sub_batch: int):
    def one(p):
        return find_gait(MODEL, p, MODEL.initial_guess(p), SOLVER)

    def run(params):
        n = params["r"].shape[0]
        split = jax.tree_util.tree_map(lambda x: x.reshape((n // sub_batch, sub_batch)), params)
        out = jax.lax.map(jax.vmap(one), split)
        return jax.tree_util.tree_map(lambda x: x.reshape((n,) + x.shape[2:]), (out.status, out.lambda_max))

    return jax.jit(run)


def measure(n: int, sub_batch: int) -> dict:
    params = grid_params(n)
    size = params["r"].shape[0]
    pad = -size % sub_batch
    params = {k: jnp.asarray(np.concatenate([v, np.repeat(v[-1:], pad)])) for k, v in params.items()}
    fn = program(sub_batch)
    t0 = time.perf_counter()
    compiled = fn.lower(params).compile()
    compile_s = time.perf_counter() - t0
    t0 = time.perf_counter()
    status, lam = jax.block_until_ready(compiled(params))
    run_s = time.perf_counter() - t0
    status = np.asarray(status)[:size]
    counts = {str(s): int(c) for s, c in zip(*np.unique(status, return_counts=True))}
    row = {"configs": size, "sub_batch": sub_batch, "compile_s": compile_s, "run_s": run_s, "configs_per_s": size / run_s, "statuses": counts}
    print(f"{size:8d} configs: compile {compile_s:6.1f} s, run {run_s:8.2f} s, {size / run_s:9.1f} configs/s, {counts}", flush=True)
    return row


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[10_000, 100_000, 1_000_000])
    parser.add_argument("--sub-batch", type=int, default=4096, help="configs vmapped together (GPU: thousands; CPU: 64)")
    args = parser.parse_args(argv)
    device = jax.devices()[0]
    result = {
        "benchmark": "flat-foot (l_f, r) gait-search map on the flat engine, one device",
        "date": time.strftime("%Y-%m-%d %H:%M"),
        "device": str(device),
        "platform": device.platform,
        "load_average_at_start": os.getloadavg(),
        "runs": [measure(n, args.sub_batch) for n in args.sizes],
        "machine": machine(),
        "versions": {"jaxwalk": jaxwalk.__version__, "jax": jax.__version__},
    }
    write_result(f"gpu_{device.platform}", result)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
