"""Benchmark: the flat-foot walker's step map and gait search, one config against many.

Two programs, each at batch 1 and batch ``--n`` (default 1024), compile time
measured apart (``lower().compile()``) and the best of ``--repeat`` runs timed:

* ``step map``: one step from the model's stored initial guess (seven phases,
  five events), ``jit(vmap(step_map))``;
* ``gait``: Newton's fixed point with the forward-mode Jacobian, its
  eigenvalues and lambda_max (:func:`jaxwalk.gait.find_gait`), ``jit(vmap(...))``.

Both on one CPU device; the batched gait search is also timed through
:func:`jaxwalk.grid.analyse_grid` on every device (one program per device, each
from its own thread), which gives the second core's speed-up. The baseline is
batch 1 (one config at a time, the way a loop over single runs would go), in
the same process: the ratios say what batching and the second core buy.

The configs are foot ratios ``r`` spread over [0.38, 0.42] around the nominal
gait (every other parameter at its default), where every search converges.

    PYTHONPATH=. XLA_FLAGS=--xla_force_host_platform_device_count=2 \\
        python benchmarks/bench_flatfoot.py [--n 1024] [--repeat 2]

Writes ``benchmarks/results/flatfoot.json``.
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
import jax.numpy as jnp  # noqa: E402

import jaxwalk  # noqa: E402
from jaxwalk.gait import find_gait  # noqa: E402
from jaxwalk.grid import AnalysisOptions, analyse_grid  # noqa: E402
from jaxwalk.models import get_model  # noqa: E402
from _walkers import benchmark_params  # noqa: E402
from jaxwalk.step import step_map  # noqa: E402
from _record import time_compiled  # noqa: E402

R_RANGE = (0.38, 0.42)
MODEL = get_model("flatfoot")


def batch_params(n: int) -> dict:
    """``n`` configs: the defaults with ``r`` spread over :data:`R_RANGE`."""
    params = {k: jnp.full((n,), v, jnp.float64) for k, v in benchmark_params(MODEL).items()}
    params["r"] = jnp.linspace(*R_RANGE, n) if n > 1 else jnp.full((1,), 0.4)
    return params


def one_step(p):
    return step_map(MODEL, MODEL.initial_guess(p), p)


def one_gait(p):
    return find_gait(MODEL, p, MODEL.initial_guess(p))


def time_program(fn, n: int, repeat: int) -> dict:
    """Compile ``jit(vmap(fn))`` for batch ``n`` and time it (best of ``repeat``)."""
    params = batch_params(n)
    compile_s, best, out = time_compiled(jax.jit(jax.vmap(fn)), params, repeat)
    status = np.asarray(out.status if hasattr(out, "status") else out[1].status)  # Gait, or (v, StepResult)
    return {"n": n, "compile_s": compile_s, "run_s": best, "per_config_s": best / n, "ok": int(np.sum(status == 0))}


def time_grid(n: int, repeat: int) -> dict:
    """The batched gait search through ``analyse_grid`` on every CPU device."""
    grid = {"r": np.linspace(*R_RANGE, n)}
    options = AnalysisOptions(chunk_size=n)
    t0 = time.perf_counter()
    analyse_grid(MODEL, {}, grid, None, options)  # compiles (one copy per device) and runs once
    first_s = time.perf_counter() - t0
    best, out = np.inf, None
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = analyse_grid(MODEL, {}, grid, None, options)
        best = min(best, time.perf_counter() - t0)
    return {
        "n": n,
        "devices": jax.device_count(),
        "first_call_s": first_s,
        "run_s": best,
        "per_config_s": best / n,
        "ok": int(np.sum(out["status"] == 0)),
        "lambda_max_range": [float(np.nanmin(out["lambda_max"])), float(np.nanmax(out["lambda_max"]))],
        "mean_newton_iterations": float(np.mean(out["newton_iterations"])),
    }


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=1024, help="large batch (configs)")
    parser.add_argument("--repeat", type=int, default=2)
    parser.add_argument("--only", choices=("step_map", "gait"), default=None, help="time one of the two programs")
    parser.add_argument("--out", default=os.path.join(os.path.dirname(__file__), "results", "flatfoot.json"))
    args = parser.parse_args(argv)

    result = {"benchmark": "flat-foot walker: step map and gait search (fixed point + Jacobian), batch 1 against batch n"}
    for name, fn in (("step_map", one_step), ("gait", one_gait)):
        if args.only not in (None, name):
            continue
        single = time_program(fn, 1, max(args.repeat, 3))
        batched = time_program(fn, args.n, args.repeat)
        result[name] = {
            "batch_1": single,
            "batch_n": batched,
            "batching_speedup": single["per_config_s"] / batched["per_config_s"],
        }
        print(
            f"{name:8s} batch 1: compile {single['compile_s']:.1f} s, {single['per_config_s'] * 1e3:.2f} ms/config | "
            f"batch {args.n}: compile {batched['compile_s']:.1f} s, {batched['per_config_s'] * 1e3:.3f} ms/config, "
            f"ok {batched['ok']}/{args.n} | batching {result[name]['batching_speedup']:.1f}x",
            flush=True,
        )
    if jax.device_count() > 1 and "gait" in result:
        devices = time_grid(args.n, args.repeat)
        devices["second_core_speedup"] = result["gait"]["batch_n"]["per_config_s"] / devices["per_config_s"]
        result["gait_all_devices"] = devices
        print(
            f"gait on {devices['devices']} devices (analyse_grid): {devices['per_config_s'] * 1e3:.3f} ms/config, "
            f"ok {devices['ok']}/{args.n}, speed-up over one device {devices['second_core_speedup']:.2f}x",
            flush=True,
        )
    result["machine"] = {"cpus": os.cpu_count(), "platform": platform.platform(), "python": platform.python_version()}
    result["versions"] = {"jaxwalk": jaxwalk.__version__, "jax": jax.__version__}
    result["xla_flags"] = os.environ.get("XLA_FLAGS", "")
    os.makedirs(os.path.dirname(args.out), exist_ok=True)
    with open(args.out, "w") as fh:
        json.dump(result, fh, indent=2)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
