"""Benchmark: two forms of the KKT solve of the kneed and flat-foot walkers, in one
process. The forms (``--compare BASELINE NEW``):

* ``looped``: the pivoted elimination in a ``fori_loop`` (to 2026-12-06);
* ``gesv``: today's :func:`jaxwalk.mechanics.solve`, LAPACK one matrix per call, a
  whole solve (factor and substitute) per use, NaN for a singular matrix;
* ``unchecked``: the same with ``jnp.linalg.solve`` as each LAPACK call's body (to
  2026-12-06, session 43): no singularity check there (impacts' looped
  elimination keeps its own).

(A third form, the matrix factored once for the primal, its tangents and
cotangents, was measured against ``gesv`` at commit d925c2b, where this script
has it as ``factored``: no faster, so it was not kept; benchmarks/README.md.)

Per walker and batch size, ``jit(vmap(...))`` on one CPU device, compile
(``lower().compile()``, trace included) apart; both forms compiled first, then run
in turn (A B A B ...) and the best of ``--repeat`` runs of each kept:

* ``step``: one step map from the model's stored initial guess;
* ``gait``: the gait search (:func:`jaxwalk.gait.find_gait`: Newton, forward-mode
  Jacobian, eigenvalues).

The flat-foot walker runs the paper's walker with ``r`` spread over [0.39, 0.41],
the kneed walker its defaults with ``gamma`` spread by 1 %. Both forms must give
the same gaits: the largest difference of fixed point and ``lambda_max`` is
reported. Caches off (``JAXWALK_CACHE_DIR=``), so both forms really compile.

    JAXWALK_CACHE_DIR= PYTHONPATH=. python benchmarks/bench_kkt_solve.py [--compare looped gesv] [--models flatfoot kneed] [--batches 1 64]

Writes ``benchmarks/results/kkt_solve_<BASELINE>_<NEW>.json``.
"""

from __future__ import annotations

import argparse
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

import jaxwalk  # noqa: E402,F401  (before jax: the device-count flag)
import jax  # noqa: E402
import jax.numpy as jnp  # noqa: E402

from _record import write_stamped  # noqa: E402
from _walkers import benchmark_params  # noqa: E402
from jaxwalk import mechanics  # noqa: E402
from jaxwalk.gait import find_gait  # noqa: E402
from jaxwalk.models import get_model  # noqa: E402
from jaxwalk.step import step_map  # noqa: E402

LAPACK_SOLVE = mechanics.solve
SPREAD = {"flatfoot": ("r", 0.39, 0.41), "kneed": ("gamma", 0.99, 1.01)}


def looped_solve(a, b):
    """The solve before: unrolled up to order 8, the looped elimination above."""
    if a.shape[0] <= mechanics.UNROLLED_SOLVE_MAX:
        return mechanics._unrolled_solve(a, b)
    return mechanics._looped_solve(a, b)


FORMS = {"looped": looped_solve, "gesv": LAPACK_SOLVE, "unchecked": LAPACK_SOLVE}
CHECKED_BODY = mechanics._solve_or_nan


def install(form: str) -> None:
    """Make ``form`` the solve every walker traces from now on."""
    mechanics.solve = FORMS[form]
    mechanics._solve_or_nan = unchecked_body if form == "unchecked" else CHECKED_BODY


def unchecked_body(a, b):
    """``jnp.linalg.solve`` with ``_solve_or_nan``'s shapes (a vector ``b`` per matrix)."""
    return jnp.linalg.solve(a, b[..., None])[..., 0] if b.ndim == a.ndim - 1 else jnp.linalg.solve(a, b)


def batch(model, n: int) -> tuple[dict, jax.Array]:
    """``(params, v0)`` of ``n`` configurations around the benchmark walker."""
    base = benchmark_params(model)
    name, lo, hi = SPREAD[model.name]
    params = {k: jnp.full((n,), v, jnp.float64) for k, v in base.items()}
    if name == "r":
        params[name] = jnp.linspace(lo, hi, n)
    else:
        params[name] = base[name] * jnp.linspace(lo, hi, n)
    v0 = jnp.broadcast_to(model.initial_guess(base), (n, len(model.section_names)))
    return params, v0


def programs(model):
    step = jax.jit(jax.vmap(lambda a: step_map(model, a[1], a[0])[0]))
    gait = jax.jit(jax.vmap(lambda a: find_gait(model, a[0], a[1])))
    return {"step": step, "gait": gait}


def compile_form(model, form: str, n: int) -> dict:
    """``{program: (compiled, compile_s)}`` with ``form`` as the solve; ``args`` of batch ``n``."""
    install(form)
    jax.clear_caches()  # every jitted function below the programs traces again with this solve
    args = batch(model, n)
    out = {}
    for name, program in programs(model).items():
        t0 = time.perf_counter()
        out[name] = (program.lower(args).compile(), time.perf_counter() - t0)
    return out


def measure(model, forms: tuple[str, str], n: int, repeat: int) -> dict:
    """Both forms' programs compiled, then run in turn ``repeat`` times each (A B A B ...),
    so that a change in the machine's speed meets both alike; the best run of each kept."""
    compiled = {form: compile_form(model, form, n) for form in forms}
    args = batch(model, n)
    out = {form: {} for form in forms}
    for name in ("step", "gait"):
        best = {form: np.inf for form in forms}
        for _ in range(repeat):
            for form in forms:
                t0 = time.perf_counter()
                result = jax.block_until_ready(compiled[form][name][0](args))
                best[form] = min(best[form], time.perf_counter() - t0)
                values = result if name == "step" else (result.v, result.lambda_max)
                out[form][name] = {"compile_s": compiled[form][name][1], "ms_per_config": 1e3 * best[form] / n,
                                   "values": [np.asarray(v).tolist() for v in jax.tree_util.tree_leaves(values)]}
        for form in forms:
            print(f"{model.name:8s} {form:8s} batch {n:4d} {name}: compile {compiled[form][name][1]:5.1f} s, "
                  f"{out[form][name]['ms_per_config']:7.2f} ms per config", flush=True)
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--models", nargs="+", default=["flatfoot", "kneed"])
    ap.add_argument("--batches", nargs="+", type=int, default=[1, 64])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--compare", nargs=2, choices=sorted(FORMS), default=["looped", "gesv"],
                    metavar=("BASELINE", "NEW"))
    args = ap.parse_args()
    base, new = args.compare
    rows = []
    for name in args.models:
        model = get_model(name)
        for n in args.batches:
            forms = measure(model, (base, new), n, args.repeat)
            for program in ("step", "gait"):
                before, after = forms[base][program], forms[new][program]
                diff = max(float(np.nanmax(np.abs(np.asarray(a) - np.asarray(b))))
                           for a, b in zip(before["values"], after["values"]))
                row = {"model": name, "batch": n, "program": program,
                       base: {k: v for k, v in before.items() if k != "values"},
                       new: {k: v for k, v in after.items() if k != "values"},
                       "speedup": before["ms_per_config"] / after["ms_per_config"], "largest_difference": diff}
                rows.append(row)
                print(f"{name:8s} batch {n:4d} {program}: {row['speedup']:.2f}x, values differ by {diff:.1e}", flush=True)
    install("gesv")
    write_stamped(f"kkt_solve_{base}_{new}", {"rows": rows, "command": " ".join(sys.argv)})


if __name__ == "__main__":
    main()
