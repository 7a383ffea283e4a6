"""Issue 12, item 3: the step-size controller, chosen by the solver steps a step map takes.

A phase's step sizes shrink as it nears its event (the swing knee
extending to its lock, the landing foot falling flat), and a controller that
proposes each step close to the error bound then has every other step
rejected: on the shoe walker's step map 17 of 65 Dopri8 steps were rejected,
each as costly as an accepted one. For each controller setting in
:data:`SETTINGS` (diffrax's ``PIDController``: the integral controller at
several safety factors, and PI controllers at diffrax's default safety), on a
line of configurations per walker:

* ``steps``: solver steps (accepted and rejected) of one step map from the
  model's documented guess, summed over the line's configurations whose step
  at the truth's settings ends well;
* ``err``: the largest difference of the step map's output from the truth
  (rtol = atol = 1e-12, diffrax's default controller);
* ``ms``: wall time of the line's step maps, one configuration at a time,
  compiled apart (best of ``--repeat``).

Then, for each walker, the gait search (``find_gait``) on the same line with
diffrax's default controller and with safety :data:`CANDIDATE_SAFETY` against
the truth's search: fixed point, ``lambda_max`` and the converged step maps' solver steps.

    JAXWALK_CACHE_DIR= PYTHONPATH=. python benchmarks/bench_controller.py

Writes ``benchmarks/results/controller.json``.
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
from jaxwalk.step import SolverOptions, step_map  # noqa: E402

#: ``(label, SolverOptions fields)``; the first is diffrax's default controller.
SETTINGS = (
    ("I, safety 0.9 (diffrax)", {"safety": 0.9}),
    ("I, safety 0.85", {"safety": 0.85}),
    ("I, safety 0.8", {"safety": 0.8}),
    ("I, safety 0.75", {"safety": 0.75}),
    ("I, safety 0.7", {"safety": 0.7}),
    ("PI 0.1 / 0.6", {"safety": 0.9, "pcoeff": 0.1, "icoeff": 0.6}),
    ("PI 0.2 / 0.5", {"safety": 0.9, "pcoeff": 0.2, "icoeff": 0.5}),
    ("PI 0.3 / 0.3", {"safety": 0.9, "pcoeff": 0.3, "icoeff": 0.3}),
)
TRUTH = {"safety": 0.9, "rtol": 1e-12, "atol": 1e-12}
#: The setting whose gait searches are held against the truth beside diffrax's
#: (the flat-foot walker's ``step_safety``).
CANDIDATE_SAFETY = 0.75
#: Slopes (rad) of each passive walker's line, around its default.
SLOPES = {"simplest": (0.004, 0.014), "compass": (0.04, 0.06), "kneed": (0.045, 0.055)}


def line(name: str) -> list[dict]:
    """The configurations a walker is measured at: its slope (passive walkers) or
    foot ratio (the shoe walker of the defaults, then the paper's walker)."""
    model = get_model(name)
    if name == "flatfoot":
        shoe, paper = model.default_params(), benchmark_params(model)
        return ([{**shoe, "r": jnp.asarray(r)} for r in np.linspace(0.30, 0.55, 6)]
                + [{**paper, "r": jnp.asarray(r)} for r in np.linspace(0.39, 0.42, 4)])
    lo, hi = SLOPES[name]
    return [{**model.default_params(), "gamma": jnp.asarray(g)} for g in np.linspace(lo, hi, 6)]


def _step_maps(model, configs, guesses, fields: dict, repeat: int):
    """``(outputs, statuses, steps, best_s)`` of one step map per configuration."""
    opts = SolverOptions(engine="nested", **fields)
    program = jax.jit(lambda v, p: step_map(model, v, p, opts))
    compiled = program.lower(guesses[0], configs[0]).compile()
    best, outs = np.inf, None
    for _ in range(repeat):
        t0 = time.perf_counter()
        outs = [jax.block_until_ready(compiled(v, p)) for v, p in zip(guesses, configs)]
        best = min(best, time.perf_counter() - t0)
    v_next = np.array([np.asarray(o[0]) for o in outs])
    return v_next, np.array([int(o[1].status) for o in outs]), np.array([int(o[1].ode_steps) for o in outs]), best


def controllers(name: str, repeat: int) -> list[dict]:
    """Every setting of :data:`SETTINGS` on ``name``'s line, against the truth."""
    model = get_model(name)
    configs = line(name)
    guesses = [jnp.asarray(model.initial_guess(p)) for p in configs]
    v_true, ok, _, _ = _step_maps(model, configs, guesses, TRUTH, 1)
    ok = ok == 0
    rows = []
    for label, fields in SETTINGS:
        v, status, steps, best = _step_maps(model, configs, guesses, fields, repeat)
        rows.append({"setting": label, **fields, "configs": int(ok.sum()), "steps": int(steps[ok].sum()),
                     "err": float(np.max(np.abs(v[ok] - v_true[ok]))), "ms": 1e3 * best,
                     "same_statuses": bool(np.all((status == 0) == ok))})
        print(f"{name:9s} {label:24s} steps {rows[-1]['steps']:4d}  err {rows[-1]['err']:.1e}  "
              f"{rows[-1]['ms']:7.1f} ms  ({rows[-1]['configs']} configs)", flush=True)
    return rows


def gait_accuracy(name: str, chosen: dict) -> list[dict]:
    """``name``'s gait search at diffrax's default controller and at ``chosen``,
    against the truth's search: largest fixed-point and ``lambda_max`` differences."""
    model = get_model(name)
    configs = line(name)
    out = {}
    for label, fields in (("truth", TRUTH), ("diffrax", {"safety": 0.9}), ("chosen", chosen)):
        opts = SolverOptions(engine="nested", **fields)
        v0 = jnp.asarray(model.initial_guess(configs[0]))
        compiled = find_gait.lower(model, configs[0], v0, solver=opts).compile()
        out[label] = [compiled(p, jnp.asarray(model.initial_guess(p))) for p in configs]
    rows = []
    for label in ("diffrax", "chosen"):
        pairs = [(g, t) for g, t in zip(out[label], out["truth"]) if int(g.status) == 0 and int(t.status) == 0]
        rows.append({"setting": label, "gaits": len(pairs),
                     "fixed_point": max((float(jnp.max(jnp.abs(g.v - t.v))) for g, t in pairs), default=None),
                     "lambda_max": max((abs(float(g.lambda_max - t.lambda_max)) for g, t in pairs), default=None),
                     "ode_steps": int(sum(int(g.stats.ode_steps) for g, _ in pairs))})
        print(f"{name:9s} find_gait {label}: {rows[-1]}", flush=True)
    return rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--models", nargs="+", default=["simplest", "compass", "kneed", "flatfoot"])
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    result = {"settings": [label for label, _ in SETTINGS], "truth": TRUTH,
              "step_maps": {name: controllers(name, args.repeat) for name in args.models}}
    chosen = {"safety": CANDIDATE_SAFETY, "pcoeff": 0.0, "icoeff": 1.0}
    result["chosen"] = chosen
    result["gaits"] = {name: gait_accuracy(name, chosen) for name in args.models}
    write_stamped("controller", result)


if __name__ == "__main__":
    main()
