"""Profile: where one flat-foot step's time goes, and how lambda_max moves with rtol.

Three parts (``--parts``), all at the nominal gait (the model's stored guess,
a fixed point to 1e-9), on one CPU device:

* ``loop``: the flat engine's loop run one iteration at a time
  (``jaxwalk.flatstep._advance`` jitted): iterations (solver steps, accepted
  and rejected) per phase, and the events; this is the work one lane does.
* ``pieces``: per-lane cost of the loop's pieces at batch 64 (``jit(vmap)``):
  the vector field (mass matrix, forces, the 15x15 KKT solve), the KKT solve
  alone, the guards (one more KKT solve), one Dopri8 step (13 new stages),
  one event location (``event_iterations`` guard ``jvp``s) and one reset.
* ``rtol``: the gait search (Newton, Jacobian, lambda_max) on the flat engine
  at rtol = atol in 1e-7 .. 1e-12, all in one program (the tolerance is
  traced, vmapped), against rtol 1e-12.

    PYTHONPATH=. EQX_ON_ERROR=nan python benchmarks/profile_flatfoot.py [--parts loop pieces rtol]

Writes ``benchmarks/results/profile_<model>.json``.
"""

from __future__ import annotations

import argparse
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

import diffrax  # noqa: E402
import jax  # noqa: E402
import jax.numpy as jnp  # noqa: E402

from jaxwalk import flatstep, mechanics  # noqa: E402
from jaxwalk.gait import find_gait  # noqa: E402
from jaxwalk.models import get_model  # noqa: E402
from _walkers import benchmark_params  # noqa: E402
from jaxwalk.status import Status  # noqa: E402
from jaxwalk.step import SolverOptions  # noqa: E402
from _record import write_result  # noqa: E402

MODEL = get_model("flatfoot")
OPTS = SolverOptions(engine="flat")
BATCH = 64


def _start():
    p = benchmark_params(MODEL)
    y, phase, ctx = MODEL.section_to_state(MODEL.initial_guess(p), p)
    return p, y, phase, ctx


def profile_loop() -> dict:
    """Iterations per phase and events of one step, one lane."""
    p, y, phase, ctx = _start()
    zero, one = jnp.zeros(()), jnp.ones(())
    c = flatstep._Carry(
        t=zero, dt=jnp.full((), flatstep.FIRST_STEP), y=y, phase=jnp.int32(phase), ctx=ctx,
        g=flatstep._min_guard(MODEL, p, zero, y, phase, ctx, 0.0), offsets=jnp.zeros(len(MODEL.guards)), fresh=jnp.asarray(True), f0=jnp.zeros_like(y),
        pid=(one, one), n_steps=jnp.int32(0), t_start=zero, y_start=y, length=zero,
        status=jnp.asarray(Status.IN_PROGRESS, jnp.int8), n_events=jnp.int32(0), work=zero,
    )  # fmt: skip
    advance = jax.jit(lambda c: flatstep._advance(MODEL, p, OPTS, c))
    per_phase, rejected, it = {}, 0, 0
    while int(c.status) == Status.IN_PROGRESS and it < 10_000:
        name = MODEL.phases[int(c.phase)]
        t_before, events_before = float(c.t), int(c.n_events)
        c = advance(c)
        it += 1
        per_phase[name] = per_phase.get(name, 0) + 1
        rejected += int(float(c.t) == t_before and int(c.n_events) == events_before)
    out = {"iterations": it, "per_phase": per_phase, "rejected": rejected, "events": int(c.n_events), "status": int(c.status)}
    print(f"loop: {out}", flush=True)
    return out


def _per_lane(fn, *args, repeat: int = 20) -> float:
    """Seconds per lane of ``jit(vmap(fn))`` on ``BATCH`` copies of ``args``."""
    batched = [jnp.broadcast_to(a, (BATCH,) + jnp.shape(a)) for a in args]
    compiled = jax.jit(jax.vmap(fn)).lower(*batched).compile()
    jax.block_until_ready(compiled(*batched))
    t0 = time.perf_counter()
    for _ in range(repeat):
        jax.block_until_ready(compiled(*batched))
    return (time.perf_counter() - t0) / repeat / BATCH


def profile_pieces() -> dict:
    p, y, phase, ctx = _start()
    args = (p, jnp.int32(phase), ctx)
    solver = flatstep._solver(OPTS)
    term = diffrax.ODETerm(MODEL.vector_field)

    def kkt(y):
        q, qd = MODEL.split(y)
        mass, forces = mechanics.mass_matrix_and_forces(lambda q_: MODEL.points(q_, p), MODEL.masses(p), MODEL.gravity(p), q, qd)
        sigma, psi = MODEL.constraint_terms(q, qd, p, ctx)
        return mass, forces, sigma, psi

    m0 = kkt(y)
    mask = MODEL.constraint_mask(jnp.int32(phase), p)
    rk = lambda y: solver.step(term, 0.0, 0.05, y, args, (True, jnp.zeros_like(y)), True)[0]
    step = lambda y: solver.step(term, 0.0, 0.05, y, args, (True, jnp.zeros_like(y)), True)
    y1, _, dense, _, _ = jax.jit(step)(y)
    g0 = flatstep._min_guard(MODEL, p, 0.0, y, phase, ctx, 0.0)
    g1 = flatstep._min_guard(MODEL, p, 0.05, y1, phase, ctx, 0.0)
    locate = lambda y: flatstep._locate_in_step(MODEL, p, OPTS, solver.interpolation_cls, 0.0, 0.05, g0, jnp.minimum(g1, -1e-3), {**dense, "y0": y}, jnp.int32(phase), ctx, 0.0)[0]
    out = {
        "vector_field_s": _per_lane(lambda y: MODEL.vector_field(0.0, y, args), y),
        "kkt_solve_s": _per_lane(lambda a, b, c, d: mechanics.constrained_accelerations(a, b, c, d, mask), *m0),
        "guards_s": _per_lane(lambda y: MODEL.guard_values(0.0, y, p, jnp.int32(phase), ctx), y),
        "dopri8_step_s": _per_lane(rk, y),
        "event_location_s": _per_lane(locate, y),
        "reset_s": _per_lane(lambda y: MODEL.on_event(jnp.int32(0), 0.3, y, p, jnp.int32(phase), ctx).y, y),
    }
    print("pieces (per lane, batch 64): " + ", ".join(f"{k} {v * 1e6:.1f} us" for k, v in out.items()), flush=True)
    return out


def profile_rtol() -> dict:
    tols = jnp.array([1e-7, 1e-8, 1e-9, 1e-10, 1e-11, 1e-12])
    p = benchmark_params(MODEL)

    def gait(tol):
        opts = SolverOptions(engine="flat", rtol=tol, atol=tol)  # traced tolerances: one program for all
        return find_gait(MODEL, p, MODEL.initial_guess(p), opts)

    t0 = time.perf_counter()
    out = jax.block_until_ready(jax.jit(jax.vmap(gait))(tols))
    wall = time.perf_counter() - t0
    lam, v = np.asarray(out.lambda_max), np.asarray(out.v)
    rows = [
        {"rtol": float(t), "status": int(s), "lambda_max": float(l), "d_lambda": float(abs(l - lam[-1])), "d_v": float(np.max(np.abs(x - v[-1])))}
        for t, s, l, x in zip(np.asarray(tols), np.asarray(out.status), lam, v)
    ]
    for r in rows:
        print(f"rtol {r['rtol']:.0e}: status {r['status']}, lambda_max {r['lambda_max']:.10f}, |d lambda| {r['d_lambda']:.1e}, |d v*| {r['d_v']:.1e}", flush=True)
    return {"rows": rows, "compile_and_run_s": wall}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--model", default="flatfoot", help="another walker, to try the script in seconds")
    parser.add_argument("--parts", nargs="+", choices=("loop", "pieces", "rtol"), default=["loop", "pieces", "rtol"])
    args = parser.parse_args(argv)
    global MODEL
    MODEL = get_model(args.model)
    result = {"model": args.model, "date": time.strftime("%Y-%m-%d %H:%M"), "load_average_at_start": os.getloadavg()}
    for part in args.parts:
        result[part] = {"loop": profile_loop, "pieces": profile_pieces, "rtol": profile_rtol}[part]()
    result["load_average_at_end"] = os.getloadavg()
    write_result(f"profile_{args.model}", result)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
