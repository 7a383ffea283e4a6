"""Where one flat-foot step's time goes at one configuration (not vmapped).

The shoe walker's gait (the defaults) on one core: the primal step map (best
of 7), its ODE steps and events, and per call, each in a ``fori_loop`` of
4000 calls at the step's start state: the vector field (phase traced, as in a
step, and phase a constant, as a per-phase program would have it), the
guards, and the 15 x 15 KKT solve's pieces (LAPACK ``getrf``, the two
``trsm``, and the pivots made a permutation and applied). Also the kernels
(XLA fusions and custom calls) one vector-field evaluation runs: at this size
XLA's CPU runtime pays per kernel, so their count, not their arithmetic, sets
the cost.

    PYTHONPATH=. taskset -c 0 python benchmarks/profile_vector_field.py

Writes ``benchmarks/results/profile_vector_field.json``.
"""

from __future__ import annotations

import os
import re
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import jaxwalk  # noqa: E402,F401  (float64 and the device count before jax starts)
import jax  # noqa: E402
import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402

from _record import write_stamped  # noqa: E402
from jaxwalk.gait import find_gait  # noqa: E402
from jaxwalk.models import get_model  # noqa: E402
from jaxwalk.step import SolverOptions, step_map  # noqa: E402

MODEL = get_model("flatfoot")
CALLS = 4000


def best(fn, *args, repeat: int = 7) -> float:
    """Least wall time (s) of ``repeat`` calls, after one to compile."""
    jax.block_until_ready(fn(*args))
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        jax.block_until_ready(fn(*args))
        times.append(time.perf_counter() - start)
    return min(times)


def per_call(fn, y, *args) -> tuple[float, object]:
    """Microseconds per ``fn(y + acc, *args)`` in a loop of :data:`CALLS`, and the loop (jitted)."""
    def loop(y, *args):
        body = lambda i, acc: acc + 1e-9 * jnp.sum(fn(y + acc, *args))
        return jax.lax.fori_loop(0, CALLS, body, jnp.zeros_like(y))
    program = jax.jit(loop)
    return best(program, y, *args) / CALLS * 1e6, program


def kernels(program, *args) -> tuple[int, dict]:
    """Fusions and custom calls in the body of ``program``'s outer while loop, and
    how many come from each transformation of the model's code (the op name's
    path inside the loop body, last element dropped: ``vmap(jvp())`` the point
    masses' Jacobian, ``jvp(jvp())`` the constraints' convective terms, ...)."""
    text = program.lower(*args).compile().as_text()
    body = re.search(r"body=(%[\w.\-]+)", text.split("ENTRY")[1]).group(1)
    block = re.search(re.escape(body) + r" .*?\n}\n", text, re.S).group(0)
    lines = [line for line in block.splitlines() if re.search(r"= \S+ (?:fusion|custom-call)\(", line)]
    sources: dict = {}
    for line in lines:
        name = re.search(r'op_name="([^"]*)"', line)
        path = name.group(1).split("/while/body/")[-1].split("/")[1:-1] if name else []
        key = "/".join(path) or "(top)"
        sources[key] = sources.get(key, 0) + 1
    return len(lines), dict(sorted(sources.items(), key=lambda kv: -kv[1]))


def kkt_pieces(n: int = 15) -> dict:
    """Microseconds per call of an order-``n`` solve's pieces (a random system)."""
    rng = np.random.default_rng(0)
    a, b = jnp.asarray(rng.normal(size=(n, n))), jnp.asarray(rng.normal(size=n))

    def lu_perm(a, b):
        lu, _, perm = jax.lax.linalg.lu(a)
        y = jax.lax.linalg.triangular_solve(lu, b[perm][:, None], left_side=True, lower=True, unit_diagonal=True)
        return jax.lax.linalg.triangular_solve(lu, y, left_side=True, lower=False)[:, 0]

    def getrf(a, b):
        lu, pivots, _ = jax.lax.linalg.lu(a)
        return b + lu[0] + pivots[0]

    def trsm(a, b):
        y = jax.lax.linalg.triangular_solve(a, b[:, None], left_side=True, lower=True, unit_diagonal=True)
        return jax.lax.linalg.triangular_solve(a, y, left_side=True, lower=False)[:, 0]

    return {name: per_call(lambda b_, a_: fn(a_ + 1e-12 * b_[0], b_), b, a)[0]
            for name, fn in (("solve", lu_perm), ("getrf", getrf), ("two_trsm", trsm))}


def main() -> None:
    params = {k: jnp.asarray(v) for k, v in MODEL.default_params().items()}
    gait = jax.jit(lambda p, v0: find_gait(MODEL, p, v0))(params, MODEL.initial_guess(params))
    step = jax.jit(lambda v, p: step_map(MODEL, v, p, SolverOptions()))
    _, result = step(gait.v, params)
    y, phase, ctx = MODEL.section_to_state(gait.v, params)
    field = lambda y_, p, ph, c: MODEL.vector_field(0.0, y_, (p, ph, c))
    guards = lambda y_, p, ph, c: MODEL.guard_values(0.0, y_, p, ph, c)
    out = {"step_ms": best(step, gait.v, params) * 1e3, "ode_steps": int(result.ode_steps),
           "events": int(result.n_events), "phases": {}}
    for ph in range(len(MODEL.phases)):
        traced = jnp.int32(ph)
        vf_us, vf_loop = per_call(field, y, params, traced, ctx)
        out["phases"][MODEL.phases[ph]] = {
            "vector_field_us": vf_us,
            "vector_field_constant_phase_us": per_call(lambda y_, p, c: field(y_, p, ph, c), y, params, ctx)[0],
            "guards_us": per_call(guards, y, params, traced, ctx)[0],
        }
        count, sources = kernels(vf_loop, y, params, traced, ctx)
        out["phases"][MODEL.phases[ph]].update(vector_field_kernels=count, kernels_by_source=sources)
        print(MODEL.phases[ph], out["phases"][MODEL.phases[ph]], flush=True)
    out["kkt_15_us"] = kkt_pieces()
    print({k: v for k, v in out.items() if k != "phases"})
    write_stamped("profile_vector_field", out)


if __name__ == "__main__":
    main()
