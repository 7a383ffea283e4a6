"""Benchmark: tracing time with the step's and Newton's loop carries marked state-dependent.

JAX's ``jvp`` and ``vmap`` rules for ``lax.while_loop`` trace the body again
until the set of carries with a tangent (a batch axis) stops growing; a carry
that starts as a constant costs one more trace of the whole body, nested
loops included. :func:`jaxwalk.stepbase.state_dependent` marks those carries
from the start (docs/engine.md section 3). This script traces each program
with the marking on and off (the function swapped for one that returns its
value unmarked, in the modules that call it), alternating, caches cleared
before every trace (``jax.clear_caches``), best of ``--repeat``; it then
compiles and runs both forms of each program once and compares their outputs
bit for bit.

    JAXWALK_CACHE_DIR= PYTHONPATH=. taskset -c 0 python benchmarks/bench_loop_carries.py

Writes ``benchmarks/results/loop_carries.json``.
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
from jaxwalk import cache, flatstep, gait, step, stepbase  # noqa: E402
from jaxwalk.gait import find_gait  # noqa: E402
from jaxwalk.models import get_model  # noqa: E402
from jaxwalk.step import SolverOptions, step_map  # noqa: E402

MARKED = stepbase.state_dependent
_USERS = (step, gait, flatstep)


def _marking(on: bool) -> None:
    unmarked = lambda value, y: jnp.asarray(value)
    for module in _USERS:
        module.state_dependent = MARKED if on else unmarked


def step_under_jvp(name: str):
    model = get_model(name)
    p = benchmark_params(model)
    v = model.initial_guess(p)

    def fn(v, dv):
        (v1, _), (dv1, _) = jax.jvp(lambda v_: step_map(model, v_, p, SolverOptions()), (v,), (dv,))
        return v1, dv1

    return fn, (v, jnp.ones_like(v))


def gait_search(name: str, batch: int):
    model = get_model(name)
    p = benchmark_params(model)
    if batch == 1:
        return (lambda p, v: find_gait(model, p, v)), (p, model.initial_guess(p))
    pb = {k: jnp.full((batch,), v) for k, v in p.items()}
    return jax.vmap(lambda p, v: find_gait(model, p, v)), (pb, jax.vmap(model.initial_guess)(pb))


PROGRAMS = {
    "flatfoot step map under jvp": lambda: step_under_jvp("flatfoot"),
    "flatfoot gait search, batch 1": lambda: gait_search("flatfoot", 1),
    "flatfoot gait search, batch 4": lambda: gait_search("flatfoot", 4),
    "kneed gait search, batch 1": lambda: gait_search("kneed", 1),
    "simplest gait search, batch 64": lambda: gait_search("simplest", 64),
}


def _trace(fn, args) -> tuple[float, object]:
    jax.clear_caches()
    t = time.perf_counter()
    traced = jax.jit(fn).trace(*args)
    return time.perf_counter() - t, traced


def measure(label: str, repeat: int) -> dict:
    fn, args = PROGRAMS[label]()
    best = {"unmarked": float("inf"), "marked": float("inf")}
    traced = {}
    for _ in range(repeat):
        for form in best:
            _marking(form == "marked")
            seconds, traced[form] = _trace(fn, args)
            best[form] = min(best[form], seconds)
    _marking(True)
    outputs = {form: jax.tree_util.tree_leaves(jax.block_until_ready(t.lower().compile()(*args)))
               for form, t in traced.items()}
    same = all(np.array_equal(np.asarray(a), np.asarray(b), equal_nan=True)
               for a, b in zip(outputs["unmarked"], outputs["marked"]))
    row = {"program": label, "trace_s": best, "gain": best["unmarked"] / best["marked"], "bit_identical": same}
    print(f"{label:32s} trace {best['unmarked']:6.2f} -> {best['marked']:6.2f} s ({row['gain']:.2f}x)  "
          f"outputs bit for bit: {same}", flush=True)
    return row


def main() -> None:
    cache.configure(enabled=False)
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--programs", nargs="+", default=list(PROGRAMS), choices=list(PROGRAMS))
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    rows = [measure(label, args.repeat) for label in args.programs]
    write_stamped("loop_carries", {"rows": rows, "cores": len(os.sched_getaffinity(0))})


if __name__ == "__main__":
    main()
