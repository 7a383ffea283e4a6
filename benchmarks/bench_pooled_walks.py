"""Walks on a few lanes that refill (``pooled_walks``) against sub-batches run in lockstep.

A batch of walks advanced together under ``vmap`` lasts as long as its longest
walk, and steps to a fall on random terrain spread roughly geometrically. The
Monte Carlo walks (``jaxwalk.global_stability.monte_carlo``) ran in
sub-batches of the model's ``lockstep_batch`` (64 for the passive walkers),
each as long as its longest walk; now each lane takes the next walk when its
own ends. Both programs, on the same walks in the same process, one worker
thread per core (``run_chunks``), compile apart (the first call), then best of
``--repeat`` warm calls:

* ``lane_steps``: the steps the lockstep sub-batches pay for (each sub-batch
  ``lanes x (longest walk + 1)``) against the walks' own steps;
* the two programs' per-walk results, which must be identical;

and the basin measure (``global_stability.basin``, the model's default ball at
its default gait) with its walks pooled against ``lax.map`` sub-batches in
lockstep, on one thread.

    JAXWALK_CACHE_DIR= PYTHONPATH=. python benchmarks/bench_pooled_walks.py

Writes ``benchmarks/results/pooled_walks.json``.
"""

from __future__ import annotations

import argparse
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

import jaxwalk  # noqa: E402, F401  (first: it gives XLA one CPU device per core, a worker thread each)
import jax  # noqa: E402
import jax.numpy as jnp  # noqa: E402

from _record import write_stamped  # noqa: E402
from jaxwalk.batching import Rows, over_rows, run_chunks  # noqa: E402
from jaxwalk.gait import find_gait  # noqa: E402
from jaxwalk.global_stability import walks  # noqa: E402
from jaxwalk.models import get_model  # noqa: E402
from jaxwalk.workers import thread_count  # noqa: E402

#: ``model: (sigma, max_steps)``: tests/test_mfpt.py's cases (MFPT 20-25 steps there).
CASES = {"simplest": (1.5e-4, 606), "compass": (3e-3, 700)}


def _lockstep_program(model):
    """The Monte Carlo program as it was: ``steps_to_fall`` of every row, sub-batches in lockstep."""

    def one(p, start: walks.FallStart):
        return walks.steps_to_fall(model, p, start.v0, start.key, start.sigma, start.max_steps)

    return jax.jit(over_rows(one, model.lockstep_batch))


def _timed(program, rows, repeat: int):
    t0 = time.perf_counter()
    out = run_chunks(program, rows, walks.CALL_WALKS, None)
    first = time.perf_counter() - t0
    best = np.inf
    for _ in range(repeat):
        t0 = time.perf_counter()
        run_chunks(program, rows, walks.CALL_WALKS, None)
        best = min(best, time.perf_counter() - t0)
    return out, first - best, best


def _lockstep_lane_steps(steps: np.ndarray, lanes: int) -> int:
    """Steps the lockstep sub-batches run, as ``run_chunks`` and ``run_on_threads`` lay
    the walks out: calls of CALL_WALKS rows (the last padded with copies of the last
    walk), every n-th row to each thread, a sub-batch of padding alone skipped."""
    total, threads, call = 0, thread_count(), walks.CALL_WALKS
    for c0 in range(0, len(steps), call):
        block = steps[c0:c0 + call]
        valid = np.arange(call) < len(block)
        block = np.concatenate([block, np.repeat(block[-1:], call - len(block))])
        for i in range(threads):
            share, real = block[i::threads], valid[i::threads]
            for b0 in range(0, len(share), lanes):
                if real[b0:b0 + lanes].any():
                    total += lanes * (int(share[b0:b0 + lanes].max()) + 1)
    return total


def measure(name: str, n_walks: int, repeat: int) -> dict:
    model = get_model(name)
    params = {s.name: jnp.asarray(s.default, jnp.float64) for s in model.parameters}
    gait = find_gait(model, params, model.initial_guess(params))
    sigma, max_steps = CASES[name]
    keys = np.asarray(jax.vmap(lambda i: jax.random.fold_in(jax.random.PRNGKey(0), i))(jnp.arange(n_walks)))
    start = walks.FallStart(np.repeat(np.asarray(gait.v)[None], n_walks, 0), keys, np.full(n_walks, sigma),
                            np.full(n_walks, max_steps, np.int32))
    rows = Rows({k: np.full(n_walks, float(x)) for k, x in params.items()}, start)
    old, old_compile, old_run = _timed(_lockstep_program(model), rows, repeat)
    new, new_compile, new_run = _timed(walks._fall_program(model, walks.SolverOptions()), rows, repeat)
    same = bool(np.array_equal(old.steps, new.steps) and np.array_equal(old.status, new.status))
    steps = np.asarray(new.steps)
    row = {"model": name, "walks": n_walks, "sigma": sigma, "mean_steps": float(steps.mean()),
           "longest": int(steps.max()), "walk_steps": int(steps.sum() + n_walks),
           "lockstep_lane_steps": _lockstep_lane_steps(steps, model.lockstep_batch), "lanes": model.lockstep_batch,
           "lockstep_s": old_run, "pooled_s": new_run, "speedup": old_run / new_run,
           "lockstep_compile_s": old_compile, "pooled_compile_s": new_compile, "identical": same}
    print(f"{name}: {n_walks} walks, mean {row['mean_steps']:.1f} steps (longest {row['longest']}); lockstep "
          f"{old_run:.2f} s, pooled {new_run:.2f} s ({row['speedup']:.2f}x); lane-steps "
          f"{row['lockstep_lane_steps'] / row['walk_steps']:.2f}x the walks' own; compile {old_compile:.1f} / "
          f"{new_compile:.1f} s; identical results: {same}", flush=True)
    return row


def _lockstep_fates(model, params, starts, targets, scale, options, solver=walks.SolverOptions()):
    """The basin's walks as they were: ``lax.map`` over sub-batches of ``lockstep_batch`` in lockstep."""
    from jaxwalk.global_stability.basin import fate

    return jax.lax.map(lambda v: fate(model, params, v, targets, scale, options, solver), starts,
                       batch_size=model.lockstep_batch)


def measure_basin(name: str, repeat: int) -> dict:
    """The basin measure at the model's default gait (its default ball and settings),
    the walks pooled against the same walks in lockstep sub-batches."""
    from jaxwalk.global_stability import basin as basin_mod

    model = get_model(name)
    params = {s.name: jnp.asarray(s.default, jnp.float64) for s in model.parameters}
    v = find_gait(model, params, model.initial_guess(params)).v
    options = basin_mod.BasinOptions()
    results = {}
    for label, fates in (("lockstep", _lockstep_fates), ("pooled", basin_mod.fates)):
        original, basin_mod.fates = basin_mod.fates, fates
        try:
            program = jax.jit(lambda p, v: basin_mod.basin(model, p, v, v[None], options))
            t0 = time.perf_counter()
            out = jax.block_until_ready(program(params, v))
            first = time.perf_counter() - t0
        finally:
            basin_mod.fates = original
        best = np.inf
        for _ in range(repeat):
            t0 = time.perf_counter()
            jax.block_until_ready(program(params, v))
            best = min(best, time.perf_counter() - t0)
        results[label] = (out, first - best, best)
    (old, old_compile, old_run), (new, new_compile, new_run) = results["lockstep"], results["pooled"]
    same = all(bool(np.array_equal(np.asarray(a), np.asarray(b))) for a, b in zip(old, new))
    row = {"model": name, "measure": "basin", "lockstep_s": old_run, "pooled_s": new_run, "speedup": old_run / new_run,
           "lockstep_compile_s": old_compile, "pooled_compile_s": new_compile, "identical": same,
           "fraction": float(new.fraction)}
    print(f"{name} basin (one worker thread): lockstep {old_run:.2f} s, pooled {new_run:.2f} s ({row['speedup']:.2f}x); "
          f"compile {old_compile:.1f} / {new_compile:.1f} s; identical results: {same}", flush=True)
    return row


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--models", nargs="+", default=list(CASES), choices=list(CASES))
    ap.add_argument("--walks", type=int, default=2000)
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    rows = [measure(name, args.walks, args.repeat) for name in args.models]
    rows += [measure_basin(name, args.repeat) for name in args.models]
    write_stamped("pooled_walks", {"rows": rows, "threads": thread_count()})


if __name__ == "__main__":
    main()
