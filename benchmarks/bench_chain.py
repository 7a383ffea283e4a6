"""Benchmark: the flat-foot walker's dynamics in closed form against automatic derivatives, in one process.

The flat-foot walker declares itself a chain (:mod:`jaxwalk.chain`: mass
matrix and forces in closed form) and writes its constraint Jacobian and
``Psi`` by hand. Its twin here takes both from automatic derivatives of
``points`` and ``constraints`` (the engine's default; ``automatic_twin`` of
tests/test_chain.py). At the shoe gait (the defaults), one configuration, not
vmapped (as the flat-foot walker's lines run), on one core:

* the vector field per call (a loop of 4000 calls) and its XLA kernels;
* the primal step map, and the step with two tangents (``jax.jacfwd`` of the
  step map in ``v``: what a Newton iteration with its Jacobian costs);
* trace + lower and compile of the gait search (``find_gait`` from the
  model's guess), caches off (run it with ``JAXWALK_CACHE_DIR=``).

The compiled programs run in turns, ``--repeat`` rounds, best of each, so a
machine's load falls on both forms alike.

    JAXWALK_CACHE_DIR= PYTHONPATH=. taskset -c 0 python benchmarks/bench_chain.py

Writes ``benchmarks/results/chain_flatfoot.json``.
"""

from __future__ import annotations

import argparse
import os
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import jaxwalk  # noqa: E402,F401  (float64 and the device count before jax starts)
import jax  # noqa: E402
import jax.numpy as jnp  # noqa: E402

from _record import write_stamped  # noqa: E402
from profile_vector_field import kernels, per_call  # noqa: E402
from jaxwalk.gait import find_gait  # noqa: E402
from jaxwalk.models.flatfoot.model import FlatFootWalker  # noqa: E402
from jaxwalk.step import SolverOptions, step_map  # noqa: E402
from tests.test_chain import automatic_twin  # noqa: E402


FORMS = {"closed": FlatFootWalker(), "autodiff": automatic_twin(FlatFootWalker())}


def timed(fn, *args) -> float:
    start = time.perf_counter()
    jax.block_until_ready(fn(*args))
    return time.perf_counter() - start


def build(model, params) -> tuple[dict, dict]:
    """Compiled programs of ``model`` and the gait search's build times."""
    search = jax.jit(lambda p: find_gait(model, p, model.initial_guess(p)))
    t0 = time.perf_counter()
    lowered = search.lower(params)
    t1 = time.perf_counter()
    compiled = lowered.compile()
    t2 = time.perf_counter()
    gait = compiled(params)
    step = jax.jit(lambda v, p: step_map(model, v, p, SolverOptions())[0])
    tangents = jax.jit(jax.jacfwd(lambda v, p: step_map(model, v, p, SolverOptions())[0]))
    y, phase, ctx = jax.jit(model.section_to_state)(gait.v, params)
    field = lambda y_, p, ph, c: model.vector_field(0.0, y_, (p, ph, c))
    field_us, field_loop = per_call(field, y, params, phase, ctx)
    programs = {"step": (step, gait.v, params), "step_with_tangents": (tangents, gait.v, params)}
    for fn, *args in programs.values():
        jax.block_until_ready(fn(*args))  # compile outside the timed rounds
    info = {"gait_search_trace_lower_s": t1 - t0, "gait_search_compile_s": t2 - t1,
            "gait_status": int(gait.status), "lambda_max": float(gait.lambda_max),
            "vector_field_us": field_us, "vector_field_kernels": kernels(field_loop, y, params, phase, ctx)[0]}
    return programs, info


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=7)
    args = ap.parse_args()
    params = {k: jnp.asarray(v) for k, v in FORMS["closed"].default_params().items()}
    programs, result = {}, {"forms": {}}
    for form, model in FORMS.items():
        programs[form], result["forms"][form] = build(model, params)
        print(form, result["forms"][form], flush=True)
    best = {form: {name: float("inf") for name in programs[form]} for form in FORMS}
    for _ in range(args.repeat):
        for form in FORMS:
            for name, (fn, *a) in programs[form].items():
                best[form][name] = min(best[form][name], timed(fn, *a))
    for form in FORMS:
        result["forms"][form].update({f"{name}_ms": 1e3 * t for name, t in best[form].items()})
    closed, auto = result["forms"]["closed"], result["forms"]["autodiff"]
    result["ratios_autodiff_over_closed"] = {
        key: auto[key] / closed[key]
        for key in ("vector_field_us", "step_ms", "step_with_tangents_ms", "gait_search_trace_lower_s",
                    "gait_search_compile_s")}
    result["lambda_max_difference"] = abs(closed["lambda_max"] - auto["lambda_max"])
    print(result["ratios_autodiff_over_closed"], "lambda_max difference", result["lambda_max_difference"])
    write_stamped("chain_flatfoot", result)


if __name__ == "__main__":
    main()
