"""One configuration's gait search compiled under ``vmap`` of one row, and without it.

A grid analysis of the flat-foot walker runs one row per sub-batch
(``lockstep_batch = 1``). Under ``vmap``, even of one row, every ``lax.cond``
becomes a ``select`` of both branches and every while loop masks its carry;
``jaxwalk.batching.in_sub_batches`` calls the row's function on the row itself
instead. This times both forms of the same gait search (Newton from the model's
guess, Jacobian, eigenvalues) at the paper's walker and the shoe walker
(the defaults): trace + lower, the StableHLO size, XLA's compile (with the
model's compiler options, as a sweep compiles), and the run (best of
``--repeat``), caches off.

    JAXWALK_CACHE_DIR= PYTHONPATH=. taskset -c 0 python benchmarks/bench_one_row.py --form row
    JAXWALK_CACHE_DIR= PYTHONPATH=. taskset -c 1 python benchmarks/bench_one_row.py --form vmap
"""

from __future__ import annotations

import argparse
import time

import jax
import jax.numpy as jnp
import numpy as np

from jaxwalk import compiling
from jaxwalk.batching import _one_row
from jaxwalk.gait import find_gait
from jaxwalk.models import get_model

from _record import write_stamped
from _walkers import benchmark_params


def _forms(model):
    """``{form: function of (1,)-leading params}``: the vmapped and the plain row."""
    search = lambda p: find_gait(model, p, model.initial_guess(p))
    return {"vmap of one row": jax.vmap(search), "one row, no vmap": _one_row(search)}


def measure(model, params: dict, fn, repeat: int) -> dict:
    """Trace + lower, StableHLO lines, compile and best run time of ``fn`` at ``params``."""
    rows = {k: jnp.asarray(v)[None] for k, v in params.items()}
    t = time.perf_counter()
    lowered = compiling.jit(fn, model).lower(rows)
    trace = time.perf_counter() - t
    lines = lowered.as_text().count("\n")
    t = time.perf_counter()
    compiled = lowered.compile()
    compile_s = time.perf_counter() - t
    gait = jax.block_until_ready(compiled(rows))
    runs = []
    for _ in range(repeat):
        t = time.perf_counter()
        jax.block_until_ready(compiled(rows))
        runs.append(time.perf_counter() - t)
    return {"trace_lower_s": trace, "hlo_lines": lines, "compile_s": compile_s, "run_ms": 1e3 * min(runs),
            "status": int(gait.status[0]), "v": np.asarray(gait.v[0]).tolist(), "lambda_max": float(gait.lambda_max[0])}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--form", choices=("vmap", "row"), help="only this form (each in its own process: "
                        "the second form traced in a process reuses the first's cached inner traces)")
    args = parser.parse_args(argv)
    model = get_model("flatfoot")
    walkers = {"paper's walker": benchmark_params(model), "shoe walker (defaults)": model.default_params()}
    result = {}
    for walker, params in walkers.items():
        for form, fn in _forms(model).items():
            if args.form and not form.startswith({"vmap": "vmap", "row": "one row"}[args.form]):
                continue
            row = measure(model, params, fn, args.repeat)
            result[f"{walker}: {form}"] = row
            print(f"{walker:24s} {form:18s} trace+lower {row['trace_lower_s']:5.1f} s  {row['hlo_lines']:6d} lines  "
                  f"compile {row['compile_s']:5.1f} s  run {row['run_ms']:6.1f} ms  status {row['status']}  "
                  f"lambda_max {row['lambda_max']:.9f}", flush=True)
    write_stamped("one_row" + (f"_{args.form}" if args.form else ""), result)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
