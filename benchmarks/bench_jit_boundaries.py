"""Benchmark: tracing with and without the jit boundaries inside a program, in one process.

``find_gait``, ``run_step`` and a phase's solve (``jaxwalk.step._solve_phase``)
are jitted functions. Inside a larger program that is a boundary JAX can cache
at: the jvp and vmap of a jitted function's jaxpr are kept, so the fixpoint
iterations of the enclosing while loops' batching and jvp rules (which
transform a loop's body once per iteration) transform a step only once per
distinct input batching. This script traces, compiles and runs the same
programs with the boundaries (as the package ships) and with the three
functions replaced by their unjitted bodies (``__wrapped__``), each variant in
a fresh process of its own (a process's first trace also pays one-time costs,
which would favour whichever variant ran second), and compares the outputs.

    JAXWALK_CACHE_DIR= PYTHONPATH=. python benchmarks/bench_jit_boundaries.py --model simplest

Programs (``jit(vmap(...))`` over ``--n`` configurations near the defaults):

* ``gait_search``: :func:`jaxwalk.gait.find_gait` from the model's guess;
* ``sensitivity``: :func:`jaxwalk.sensitivity.gait_sensitivity` of every
  parameter in ``SENSITIVITY`` (the optimiser's second-order program);
* ``direct_call``: two direct ``find_gait`` calls on one configuration (the
  second call is what a user waits for when calling again).

Writes ``benchmarks/results/jit_boundaries_<model>.json``.
"""

from __future__ import annotations

import argparse
import contextlib
import os
import pickle
import subprocess
import sys
import tempfile
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

import jax  # noqa: E402
import jax.numpy as jnp  # noqa: E402

import jaxwalk  # noqa: E402,F401 (its import sets the cache and EQX_ON_ERROR)
from jaxwalk import gait, sensitivity, step  # noqa: E402
from jaxwalk.gait import NewtonOptions  # noqa: E402
from jaxwalk.models import get_model  # noqa: E402
from _walkers import benchmark_params  # noqa: E402
from jaxwalk.step import SolverOptions  # noqa: E402
from _record import write_stamped  # noqa: E402

SPREAD = {"simplest": ("gamma", 0.006, 0.012), "compass": ("gamma", 0.02, 0.06), "kneed": ("gamma", 0.006, 0.010),
          "flatfoot": ("r", 0.39, 0.43)}
#: Unjitted first: the order of the two processes is then against the boundaries, if anything.
VARIANTS = ("unjitted", "boundaries")
#: The parameters the sensitivity program differentiates by.
SENSITIVITY = {"simplest": ("gamma",), "compass": ("gamma",), "kneed": ("gamma",), "flatfoot": ("r",)}


@contextlib.contextmanager
def unjitted():
    """The three boundaries removed: every module that calls them gets the bare function."""
    saved = (step._solve_phase, step.run_step, gait.find_gait, sensitivity.find_gait)
    step._solve_phase, step.run_step = step._solve_phase.__wrapped__, step.run_step.__wrapped__
    gait.find_gait = sensitivity.find_gait = gait.find_gait.__wrapped__
    try:
        yield
    finally:
        step._solve_phase, step.run_step, gait.find_gait, sensitivity.find_gait = saved


def programs(model, names):
    search = lambda p: gait.find_gait(model, p, model.initial_guess(p))  # noqa: E731
    sens = lambda p: sensitivity.gait_sensitivity(model, p, model.initial_guess(p), names, SolverOptions(), NewtonOptions())  # noqa: E731
    return {"gait_search": jax.jit(jax.vmap(search)), "sensitivity": jax.jit(jax.vmap(sens))}


def build(program, params) -> tuple:
    t0 = time.perf_counter()
    traced = program.trace(params)
    t1 = time.perf_counter()
    lowered = traced.lower()
    t2 = time.perf_counter()
    compiled = lowered.compile()
    t3 = time.perf_counter()
    out = jax.block_until_ready(compiled(params))
    return jax.tree_util.tree_map(np.asarray, out), {"trace_s": t1 - t0, "lower_s": t2 - t1, "compile_s": t3 - t2}


def direct_calls(model, p) -> tuple:
    times = []
    for _ in range(2):
        t0 = time.perf_counter()
        out = jax.block_until_ready(gait.find_gait(model, p, model.initial_guess(p)))
        times.append(time.perf_counter() - t0)
    return jax.tree_util.tree_map(np.asarray, out), {"first_call_s": times[0], "second_call_s": times[1]}


def same(a, b) -> bool:
    return all(np.array_equal(x, y, equal_nan=x.dtype.kind in "fc")
               for x, y in zip(jax.tree_util.tree_leaves(a), jax.tree_util.tree_leaves(b)))


def run_variant(model_name: str, n: int, variant: str, out_path: str) -> None:
    """One variant in this process: its times and outputs pickled to ``out_path``."""
    model = get_model(model_name)
    name, lo, hi = SPREAD[model_name]
    params = {k: jnp.full(n, float(v), jnp.float64) for k, v in benchmark_params(model).items()}
    params[name] = jnp.asarray(np.linspace(lo, hi, n))
    one = {k: v[0] for k, v in params.items()}
    with (unjitted if variant == "unjitted" else contextlib.nullcontext)():
        runs = {k: build(p, params) for k, p in programs(model, SENSITIVITY[model_name]).items()}
        runs["direct_call"] = direct_calls(model, one)
    with open(out_path, "wb") as fh:
        pickle.dump(runs, fh)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--model", default="simplest", choices=sorted(SPREAD))
    ap.add_argument("--n", type=int, default=4)
    ap.add_argument("--variant", choices=VARIANTS, help=argparse.SUPPRESS)  # a child process's one variant
    ap.add_argument("--out", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.variant:
        return run_variant(args.model, args.n, args.variant, args.out)
    result, outputs = {"model": args.model, "n": args.n, "programs": {}}, {}
    with tempfile.TemporaryDirectory() as tmp:
        for variant in VARIANTS:
            path = os.path.join(tmp, variant)
            subprocess.run([sys.executable, __file__, "--model", args.model, "--n", str(args.n), "--variant", variant,
                            "--out", path], check=True)
            with open(path, "rb") as fh:
                for k, (out, times) in pickle.load(fh).items():
                    outputs[k, variant] = out
                    result["programs"].setdefault(k, {})[variant] = times
                    print(f"{args.model} {k} {variant}: " + ", ".join(f"{t} {v:.2f} s" for t, v in times.items()), flush=True)
    for k, entry in result["programs"].items():
        entry["bit_identical"] = same(outputs[k, "boundaries"], outputs[k, "unjitted"])
        key = "second_call_s" if k == "direct_call" else "trace_s"
        entry["unjitted_over_boundaries"] = entry["unjitted"][key] / entry["boundaries"][key]
        print(f"{k}: unjitted / boundaries {key} {entry['unjitted_over_boundaries']:.2f}x, "
              f"bit-identical {entry['bit_identical']}", flush=True)
    write_stamped(f"jit_boundaries_{args.model}", result)


if __name__ == "__main__":
    main()
