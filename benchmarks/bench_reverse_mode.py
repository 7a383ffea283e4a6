"""Reverse mode through a step against forward mode (issue 12, item 4).

    JAXWALK_CACHE_DIR= PYTHONPATH=. taskset -c 0 python benchmarks/bench_reverse_mode.py

The compass walker's step map on the flat engine, a scalar function of it (a
weighted sum of the next section point plus the step's time), differentiated
with respect to all of the model's parameters: ``jax.jacfwd`` on the ordinary
loop, ``jax.grad`` on the checkpointed one (``SolverOptions.reverse_mode``),
and the primal on both loops. Trace and compile apart from run time (best of 5).
"""

from __future__ import annotations

import time

import jax
import jax.numpy as jnp

from jaxwalk.models import get_model
from jaxwalk.step import SolverOptions, step_map


def metric(model, v, weights, opts):
    def f(p):
        v1, res = step_map(model, v, p, opts)
        return jnp.dot(weights, v1) + res.time

    return f


def main() -> None:
    model = get_model("compass")
    p0 = {k: jnp.asarray(v) for k, v in model.default_params().items()}
    v = model.initial_guess(p0)
    weights = jnp.linspace(1.0, -0.5, v.shape[0])
    plain, checkpointed = SolverOptions(engine="flat"), SolverOptions(engine="flat", reverse_mode=True)
    programs = {
        "forward (jacfwd), plain loop": jax.jit(jax.jacfwd(metric(model, v, weights, plain))),
        "reverse (grad), checkpointed loop": jax.jit(jax.grad(metric(model, v, weights, checkpointed))),
        "primal, plain loop": jax.jit(metric(model, v, weights, plain)),
        "primal, checkpointed loop": jax.jit(metric(model, v, weights, checkpointed)),
    }
    for name, program in programs.items():
        start = time.perf_counter()
        compiled = program.lower(p0).compile()
        compile_s = time.perf_counter() - start
        jax.block_until_ready(compiled(p0))
        runs = []
        for _ in range(5):
            start = time.perf_counter()
            jax.block_until_ready(compiled(p0))
            runs.append(time.perf_counter() - start)
        print(f"{name}: trace + compile {compile_s:.1f} s, run {1e3 * min(runs):.2f} ms (best of 5)", flush=True)
    print(f"{len(p0)} parameters")


if __name__ == "__main__":
    main()
