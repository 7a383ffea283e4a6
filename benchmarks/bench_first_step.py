"""Benchmark: each phase's first step carried from the phase before, against 0.01 always.

``SolverOptions.carry_step``: with ``True`` (since 2026-12-06 the default of
every walker but the simplest, ``Walker.carry_step``) a phase starts with the
step the controller proposed at the end of the phase before; with ``False``
every phase starts at ``FIRST_STEP = 0.01``, as before.
A flat-foot step has 11 events (six phase ends, five swing-foot height
extrema that restart the solve), and each restart at 0.01 had to grow its
steps again.

Per walker and batch size, ``jit(vmap(...))`` on one CPU device, compile
(``lower().compile()``, trace included) apart; both settings compiled first,
then run in turn (A B A B ...) and the best of ``--repeat`` runs of each kept:

* ``step``: one step map from the model's stored initial guess (with its
  solver steps, accepted and rejected: the cost that does not depend on the
  machine);
* ``gait``: the gait search (:func:`jaxwalk.gait.find_gait`: Newton, forward-mode
  Jacobian, eigenvalues), with the solver steps of the step from its fixed point.

The walkers and their spread of configurations are ``bench_kkt_solve.py``'s
(the flat-foot walker is the paper's, ``r`` over [0.39, 0.41]; the others
their defaults, the slope spread by 1 %). The largest differences of fixed
point and ``lambda_max`` between the settings are reported: the integration
noise of a different step sequence at rtol 1e-10.

    JAXWALK_CACHE_DIR= PYTHONPATH=. python benchmarks/bench_first_step.py [--models flatfoot kneed simplest] [--batches 1 64]

Writes ``benchmarks/results/first_step.json``.
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
from jaxwalk.gait import NewtonOptions, find_gait  # noqa: E402
from jaxwalk.models import get_model  # noqa: E402
from jaxwalk.step import SolverOptions, step_map  # noqa: E402

SPREAD = {"flatfoot": ("r", 0.39, 0.41)}  # other walkers: the slope, by 1 %
SETTINGS = {"fixed": False, "carried": True}


def batch(model, n: int) -> tuple[dict, jax.Array]:
    """``(params, v0)`` of ``n`` configurations around the benchmark walker."""
    base = benchmark_params(model)
    name, lo, hi = SPREAD.get(model.name, ("gamma", 0.99, 1.01))
    params = {k: jnp.full((n,), v, jnp.float64) for k, v in base.items()}
    params[name] = jnp.linspace(lo, hi, n) if name == "r" else base[name] * jnp.linspace(lo, hi, n)
    v0 = jnp.broadcast_to(model.initial_guess(base), (n, len(model.section_names)))
    return params, v0


def programs(model, opts: SolverOptions, newton: NewtonOptions = NewtonOptions()) -> dict:
    """``{name: jitted program}``; each returns ``(values to compare, solver steps per
    config, Newton iterations per config (0 for the step map))``."""

    def step(a):
        v, res = step_map(model, a[1], a[0], opts)
        return (v,), res.ode_steps, jnp.zeros_like(res.ode_steps)

    def gait(a):
        g = find_gait(model, a[0], a[1], opts, newton)
        return (g.v, g.lambda_max), g.stats.ode_steps, g.iterations

    return {"step": jax.jit(jax.vmap(step)), "gait": jax.jit(jax.vmap(gait))}


def compile_programs(model, n: int, opts: SolverOptions, form: str, into: dict,
                     newton: NewtonOptions = NewtonOptions()) -> None:
    """``into[form, name] = (compiled, compile_s)`` for each of :func:`programs`, at batch ``n``."""
    args = batch(model, n)
    for name, program in programs(model, opts, newton).items():
        t0 = time.perf_counter()
        into[form, name] = (program.lower(args).compile(), time.perf_counter() - t0)


def compare(model, n: int, compiled: dict, forms: tuple[str, str], repeat: int) -> list[dict]:
    """Two forms' compiled programs (:func:`compile_programs`) run in turn ``repeat`` times
    each (A B A B, so a change of the machine's speed meets both alike), the best run kept;
    one row per program: times, solver steps, speed-up and the largest differences of the values."""
    args = batch(model, n)
    base, new = forms
    rows = []
    for name in ("step", "gait"):
        best, outs = {f: np.inf for f in forms}, {}
        for _ in range(repeat):
            for f in forms:
                t0 = time.perf_counter()
                outs[f] = jax.block_until_ready(compiled[f, name][0](args))
                best[f] = min(best[f], time.perf_counter() - t0)
        values_a, values_b = outs[base][0], outs[new][0]
        diff = [float(np.nanmax(np.abs(np.asarray(a) - np.asarray(b)))) for a, b in zip(values_a, values_b)]
        row = {"model": model.name, "batch": n, "program": name, "largest_difference": diff,
               "speedup": best[base] / best[new]}
        for f in forms:
            row[f] = {"compile_s": compiled[f, name][1], "ms_per_config": 1e3 * best[f] / n,
                      "solver_steps_mean": float(np.mean(outs[f][1])),
                      "newton_iterations_mean": float(np.mean(outs[f][2]))}
        print(f"{model.name:8s} batch {n:4d} {name}: solver steps {row[base]['solver_steps_mean']:.1f} -> "
              f"{row[new]['solver_steps_mean']:.1f}, Newton iterations {row[base]['newton_iterations_mean']:.2f} -> "
              f"{row[new]['newton_iterations_mean']:.2f}, {row[base]['ms_per_config']:.2f} -> "
              f"{row[new]['ms_per_config']:.2f} ms per config ({row['speedup']:.2f}x), "
              f"values differ by {', '.join(f'{d:.1e}' for d in diff)}", flush=True)
        rows.append(row)
    return rows


def measure(model, n: int, repeat: int) -> list[dict]:
    """Both settings compiled, then compared (:func:`compare`)."""
    compiled = {}
    for setting, carry in SETTINGS.items():
        compile_programs(model, n, SolverOptions(carry_step=carry), setting, compiled)
    return compare(model, n, compiled, tuple(SETTINGS), repeat)


def cli(description: str, measure, result_name: str) -> None:
    """The command line of this benchmark and of those built on it: ``measure(model, n, repeat)``
    for every walker and batch, the rows written to ``benchmarks/results/<result_name>.json``."""
    ap = argparse.ArgumentParser(description=description)
    ap.add_argument("--models", nargs="+", default=["flatfoot", "kneed", "simplest"])
    ap.add_argument("--batches", nargs="+", type=int, default=[1, 64])
    ap.add_argument("--repeat", type=int, default=5)
    args = ap.parse_args()
    rows = [row for name in args.models for n in args.batches for row in measure(get_model(name), n, args.repeat)]
    write_stamped(result_name, {"rows": rows, "command": " ".join(sys.argv)})


if __name__ == "__main__":
    cli(__doc__.splitlines()[0], measure, "first_step")
