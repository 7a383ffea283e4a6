"""Issue 12, item 3: how the flat-foot gait search's accuracy and cost move with
the integrator tolerance, to choose the cheapest ``rtol = atol`` that keeps the
reference tests.

For each tolerance in ``--tols`` the sweep's program (``jaxwalk.gait.find_gait``,
one configuration at a time, the nested engine, Dopri8) is compiled
(``lower().compile()``, timed apart) and run on a few configurations of two
walkers: the paper's walker (``PAPER_PARAMS``) with ``r`` over [0.3933, 0.42]
and the shoe walker (the defaults) with ``r`` over [0.40, 0.50]. Each is held
against the same search at the tightest tolerance in the run (the truth here),
and the paper walker's first configuration (r = 0.3933; only that one, a
SciPy search takes seconds) also against the SciPy reference walker
(tests/reference/flatfoot, DOP853) at rtol = atol = 1e-12:

* ``fixed point``: largest ``|v* - v*_truth|``;
* ``lambda_max``: largest ``|lambda_max - truth|``;
* ``ode steps``: solver steps of the converged step map (accepted and rejected);
* ``ms/config``: wall time of one search, the best of ``--repeat`` passes.

    JAXWALK_CACHE_DIR= PYTHONPATH=. python benchmarks/bench_tolerance.py

Writes ``benchmarks/results/tolerance_flatfoot.json``. The reference tests'
tolerances against SciPy (tests/test_flatfoot.py) are 1e-7 on the fixed point
and 1e-5 on lambda_max.
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

from _record import write_stamped  # noqa: E402
from _walkers import benchmark_params  # noqa: E402
from jaxwalk.gait import find_gait  # noqa: E402
from jaxwalk.models import get_model  # noqa: E402
from jaxwalk.step import SolverOptions  # noqa: E402

MODEL = get_model("flatfoot")
WALKERS = {"paper": (benchmark_params(MODEL), (0.3933, 0.42)), "shoe": (MODEL.default_params(), (0.40, 0.50))}


def _configs(n: int) -> list[tuple[str, dict]]:
    """``(walker, params)`` pairs: ``n`` ratios per walker."""
    out = []
    for name, (params, (lo, hi)) in WALKERS.items():
        for r in np.linspace(lo, hi, n):
            out.append((name, {**params, "r": jnp.asarray(r)}))
    return out


def _run(tol: float, configs, repeat: int) -> dict:
    """Compile the search at ``tol``, run every config ``repeat`` times; per-config outputs."""
    solver = SolverOptions(rtol=tol, atol=tol, engine="nested")
    p0 = configs[0][1]
    v0 = MODEL.initial_guess(p0)
    t0 = time.perf_counter()
    compiled = find_gait.lower(MODEL, p0, v0, solver=solver).compile()
    compile_s = time.perf_counter() - t0
    rows, best = [], np.inf
    guesses = [jax.block_until_ready(MODEL.initial_guess(p)) for _, p in configs]  # outside the timing
    for _ in range(repeat):
        t0 = time.perf_counter()
        gaits = [jax.block_until_ready(compiled(p, v0)) for (_, p), v0 in zip(configs, guesses)]
        best = min(best, time.perf_counter() - t0)
    for (name, p), g in zip(configs, gaits):
        rows.append({"walker": name, "r": float(p["r"]), "status": int(g.status), "v": np.asarray(g.v).tolist(),
                     "lambda_max": float(g.lambda_max), "period": float(g.period),
                     "iterations": int(g.iterations), "ode_steps": int(g.stats.ode_steps)})
    return {"tol": tol, "compile_s": compile_s, "ms_per_config": 1e3 * best / len(configs), "gaits": rows}


def _scipy_truth(params: dict) -> dict:
    """The SciPy reference walker's gait at rtol = atol = 1e-12."""
    from tests.reference import flatfoot as ref

    p = {k: float(v) for k, v in params.items() if k in ref.PAPER}
    t0 = time.perf_counter()
    g = ref.gait(ref.params(**p), rtol=1e-12, atol=1e-12)
    return {"v": np.asarray(g.v).tolist(), "lambda_max": float(g.lambda_max), "status": g.status,
            "seconds": time.perf_counter() - t0}


def _errors(run: dict, truth: dict) -> dict:
    """Largest fixed-point and lambda_max differences from ``truth`` over the converged gaits, per walker."""
    out = {}
    for walker in WALKERS:
        pairs = [(a, b) for a, b in zip(run["gaits"], truth["gaits"]) if a["walker"] == walker
                 and a["status"] == 0 and b["status"] == 0]
        out[walker] = {
            "fixed_point": max((float(np.max(np.abs(np.subtract(a["v"], b["v"])))) for a, b in pairs), default=None),
            "lambda_max": max((abs(a["lambda_max"] - b["lambda_max"]) for a, b in pairs), default=None),
            "ode_steps": float(np.mean([a["ode_steps"] for a, _ in pairs])) if pairs else None,
            "same_statuses": all(a["status"] == b["status"] for a, b in zip(run["gaits"], truth["gaits"])
                                 if a["walker"] == walker),
        }
    return out


def _summary(walker: str, e: dict) -> str:
    """One walker's errors, printed; a status that differs from the truth's is said."""
    if e["fixed_point"] is None:
        return f"{walker}: no gait"
    differ = "" if e["same_statuses"] else ", STATUSES DIFFER FROM THE TRUTH'S"
    return f"{walker}: v* {e['fixed_point']:.1e}, lambda {e['lambda_max']:.1e}, {e['ode_steps']:.0f} steps{differ}"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--tols", type=float, nargs="+", default=[1e-12, 1e-11, 1e-10, 1e-9, 1e-8])
    ap.add_argument("--n", type=int, default=3, help="ratios per walker")
    ap.add_argument("--repeat", type=int, default=2)
    ap.add_argument("--no-scipy", action="store_true", help="skip the SciPy reference (about a minute)")
    args = ap.parse_args()
    configs = _configs(args.n)
    runs = []
    for tol in sorted(args.tols):
        runs.append(_run(tol, configs, args.repeat))
        print(f"rtol = atol = {tol:.0e}: compile {runs[-1]['compile_s']:.1f} s, "
              f"{runs[-1]['ms_per_config']:.1f} ms/config", flush=True)
    truth = runs[0]
    scipy = None if args.no_scipy else _scipy_truth(configs[0][1])
    for run in runs:
        run["errors"] = _errors(run, truth)
        paper = run["gaits"][0]
        if scipy is not None and paper["status"] == 0:
            run["against_scipy"] = {"fixed_point": float(np.max(np.abs(np.subtract(paper["v"], scipy["v"])))),
                                    "lambda_max": abs(paper["lambda_max"] - scipy["lambda_max"])}
        line = " | ".join(_summary(w, e) for w, e in run["errors"].items())
        sp = run.get("against_scipy")
        sp = f" | SciPy 1e-12: v* {sp['fixed_point']:.1e}, lambda {sp['lambda_max']:.1e}" if sp else ""
        print(f"{run['tol']:.0e}: {run['ms_per_config']:6.1f} ms/config | {line}{sp}", flush=True)
    write_stamped("tolerance_flatfoot", {"truth_tol": truth["tol"], "scipy_1e-12": scipy, "runs": runs})


if __name__ == "__main__":
    main()
