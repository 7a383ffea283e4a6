"""Benchmark: the MFPT chain's step maps on the flat-foot walker, by sub-batch size.

A chain's steps (mesh points x terrain samples) all start near one gait. The
flat-foot walker runs its gait searches one configuration at a time
(``lockstep_batch = 1``), and the transition program used to as well; this
measures what batching the chain's steps gains. Rows: ``--n`` steps from the
shoe-gait walker's fixed point at l_f 0.22, r 0.4768 (the configuration of
``sweeps/flatfoot_human_mfpt_r.toml``), perturbed by N(0, 3e-3) in each
section coordinate, with ground drops N(0, 0.002) (the sweep's sigma). Each
sub-batch size is its own program: the first call compiles it, the second is
timed. Reports ms per step and the largest difference in the successors
against sub-batch 1.

    PYTHONPATH=. EQX_ON_ERROR=nan python benchmarks/bench_mfpt_steps.py [--n 1024] [--sub 1 16 64]
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

import jaxwalk  # noqa: E402,F401
from jaxwalk.batching import Rows, over_rows, run_chunks  # noqa: E402
from jaxwalk.gait import find_gait  # noqa: E402
from jaxwalk.global_stability.mfpt import Transition  # noqa: E402
from jaxwalk.models import get_model  # noqa: E402
from jaxwalk.models.flatfoot.model import SHOE_PARAMS  # noqa: E402
from jaxwalk.step import SolverOptions, step_map  # noqa: E402


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--n", type=int, default=1024)
    parser.add_argument("--sub", type=int, nargs="+", default=[1, 16, 64])
    args = parser.parse_args()
    model, solver = get_model("flatfoot"), SolverOptions()
    params = {k: float(v) for k, v in model.default_params().items()}
    params.update(SHOE_PARAMS, l_f=0.22, r=0.4768)
    p = {k: jnp.asarray(v) for k, v in params.items()}
    gait = find_gait(model, p, model.initial_guess(p), solver)
    print(f"gait: status {int(gait.status)}, v* {np.asarray(gait.v)}, lambda_max {float(gait.lambda_max):.4f}")
    rng = np.random.default_rng(0)
    v = np.asarray(gait.v) + rng.normal(0.0, 3e-3, (args.n, gait.v.shape[0]))
    rows = Rows({k: np.full(args.n, x) for k, x in params.items()}, Transition(v, rng.normal(0.0, 0.002, args.n)))

    def one(pp, t: Transition):
        v_next, res = step_map(model, t.v, pp, solver, ground_drop=t.drop)
        return v_next, res.status

    first = None
    for sub in args.sub:
        program = jax.jit(over_rows(one, sub))
        t0 = time.perf_counter()
        run_chunks(program, rows, args.n, None)
        t1 = time.perf_counter()
        v_next, status = run_chunks(program, rows, args.n, None)
        t2 = time.perf_counter()
        first = np.asarray(v_next) if first is None else first
        print(f"sub-batch {sub:3d}: compile + run {t1 - t0:6.1f} s, run {t2 - t1:6.2f} s = {1e3 * (t2 - t1) / args.n:6.2f} ms/step; "
              f"{int((np.asarray(status) == 0).sum())}/{args.n} ok; successors differ from the first by {np.nanmax(np.abs(np.asarray(v_next) - first)):.1e}",
              flush=True)


if __name__ == "__main__":
    main()
