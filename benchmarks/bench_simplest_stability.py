"""Benchmark: stability sweep of the simplest walker, jaxwalk against SciPy.

Per configuration (a slope gamma): the period-one gait by Newton-Raphson, the
Jacobian of the step map at it, its eigenvalues and lambda_max.

* jaxwalk: ``analyse_grid`` (vmap over configs in sub-batches, one worker thread per CPU device,
  forward-mode Jacobians), compile time measured apart (``lower().compile()``).
* baseline: the paper's method in SciPy, one config at a time (DOP853 with
  events at rtol 1e-10, Newton with a central-difference Jacobian), from
  ``benchmarks/scipy_baseline.py`` / ``tests/reference/scipy_walkers.py``.

Both start Newton from the same guess (jaxwalk's ``SimplestWalker.initial_guess``
law, theta* ~ gamma^(1/3)) and both run in this process, on this machine.
The marginal cost per config is ``(T(N) - T(N/8)) / (N - N/8)`` for jaxwalk
(the fixed cost of a call and of the slowest element removed) and the mean
per config for SciPy.

    PYTHONPATH=. python benchmarks/bench_simplest_stability.py [--n 2048] [--scipy-n 24]

Writes ``benchmarks/results/simplest_stability.json``.
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

import jaxwalk  # noqa: E402
from jaxwalk.grid import AnalysisOptions, _independent_program, analyse_grid, parameter_grid  # noqa: E402
from jaxwalk.models import get_model  # noqa: E402
from tests.reference import scipy_walkers as ref  # noqa: E402

GAMMA_RANGE = (0.004, 0.014)


def jaxwalk_guess(gamma: float) -> np.ndarray:
    """The same law as ``SimplestWalker.initial_guess``, in NumPy."""
    scale = (abs(gamma) / 0.009) ** (1.0 / 3.0)
    theta, theta_dot = 0.2003 * scale, -0.1998 * scale
    return np.array([theta, theta_dot, theta_dot * np.cos(2.0 * theta)])


def time_jaxwalk(n: int, repeat: int) -> dict:
    model = get_model("simplest")
    options = AnalysisOptions(chunk_size=n)
    gammas = np.linspace(*GAMMA_RANGE, n)
    program = _independent_program(model, options.solver, options.newton)
    params = {k: v.reshape(-1) for k, v in parameter_grid(model, {}, {"gamma": gammas}).items()}
    t0 = time.perf_counter()
    program.lower(params).compile()
    compile_s = time.perf_counter() - t0

    def run(m):
        best = np.inf
        for _ in range(repeat):
            t0 = time.perf_counter()
            out = analyse_grid(model, {}, {"gamma": np.linspace(*GAMMA_RANGE, m)}, None, options)
            best = min(best, time.perf_counter() - t0)
        return best, out

    analyse_grid(model, {}, {"gamma": gammas}, None, options)  # warm: jit cache of this shape
    small = n // 8
    analyse_grid(model, {}, {"gamma": np.linspace(*GAMMA_RANGE, small)}, None, AnalysisOptions(chunk_size=small))
    t_n, out = run(n)
    best_small = np.inf
    for _ in range(repeat):
        t0 = time.perf_counter()
        analyse_grid(model, {}, {"gamma": np.linspace(*GAMMA_RANGE, small)}, None, AnalysisOptions(chunk_size=small))
        best_small = min(best_small, time.perf_counter() - t0)
    return {
        "n": n,
        "devices": jax.device_count(),
        "compile_s": compile_s,
        "run_s": t_n,
        "per_config_s": t_n / n,
        "marginal_per_config_s": (t_n - best_small) / (n - small),
        "ok": int(np.sum(out["status"] == 0)),
        "mean_newton_iterations": float(np.mean(out["newton_iterations"])),
        "lambda_max_range": [float(np.nanmin(out["lambda_max"])), float(np.nanmax(out["lambda_max"]))],
    }


def time_scipy(n: int) -> dict:
    gammas = np.linspace(*GAMMA_RANGE, n)
    ref.fixed_point(lambda v: ref.simplest_step(v, gammas[0], rtol=1e-10, atol=1e-12), jaxwalk_guess(gammas[0]))
    t0 = time.perf_counter()
    results = [
        ref.fixed_point(
            lambda v, g=g: ref.simplest_step(v, g, rtol=1e-10, atol=1e-12),
            jaxwalk_guess(g),
            tol=1e-10,
            fd_step=1e-6,
            richardson=False,
        )
        for g in gammas
    ]
    total = time.perf_counter() - t0
    return {
        "n": n,
        "run_s": total,
        "per_config_s": total / n,
        "ok": sum(r.status == "ok" for r in results),
        "mean_newton_iterations": float(np.mean([r.n_iter for r in results])),
    }


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=2048, help="jaxwalk batch (configs)")
    parser.add_argument("--scipy-n", type=int, default=24, help="configs timed for the SciPy baseline")
    parser.add_argument("--repeat", type=int, default=2)
    parser.add_argument("--out", default=os.path.join(os.path.dirname(__file__), "results", "simplest_stability.json"))
    args = parser.parse_args(argv)

    jw = time_jaxwalk(args.n, args.repeat)
    sp = time_scipy(args.scipy_n)
    result = {
        "benchmark": "simplest walker stability sweep (fixed point + Jacobian + lambda_max)",
        "gamma_range": GAMMA_RANGE,
        "jaxwalk": jw,
        "scipy": sp,
        "speedup_marginal": sp["per_config_s"] / jw["marginal_per_config_s"],
        "speedup_total": sp["per_config_s"] / jw["per_config_s"],
        "machine": {"cpus": os.cpu_count(), "platform": platform.platform(), "python": platform.python_version()},
        "versions": {"jaxwalk": jaxwalk.__version__, "jax": jax.__version__},
        "xla_flags": os.environ.get("XLA_FLAGS", ""),
    }
    os.makedirs(os.path.dirname(args.out), exist_ok=True)
    with open(args.out, "w") as fh:
        json.dump(result, fh, indent=2)
    print(f"jaxwalk  N={jw['n']} on {jw['devices']} device(s): compile {jw['compile_s']:.1f} s, "
          f"run {jw['run_s']:.2f} s, {jw['per_config_s'] * 1e3:.3f} ms/config, "
          f"marginal {jw['marginal_per_config_s'] * 1e3:.3f} ms/config, ok {jw['ok']}/{jw['n']}, "
          f"Newton iterations {jw['mean_newton_iterations']:.2f}")
    print(f"scipy    N={sp['n']}: {sp['per_config_s'] * 1e3:.1f} ms/config, ok {sp['ok']}/{sp['n']}, "
          f"Newton iterations {sp['mean_newton_iterations']:.2f}")
    print(f"speed-up per config: marginal {result['speedup_marginal']:.0f}x, total {result['speedup_total']:.0f}x")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
