"""Would chord Newton from the line neighbour's Jacobian pay on the shoe walker's map?

At six points of two continuation lines of the map (l_f 0.29 and 0.205, the map's r
grid), from the secant predictor through the two gaits before (as a sweep's line
starts): full Newton's iterations (each a step with both tangents, plus one at the
fixed point), against chord iterations (primal steps only, updated with the gait
before's ``J - I``, stopped by the same rate test) plus the one evaluation with
tangents at the end; the primal step's and the tangent step's cost (best of 5), and
``rho``, the spectral radius of ``(J_before - I)^-1 (J - J_before)`` (the chord's contraction).

    PYTHONPATH=. taskset -c 0 python benchmarks/profile_chord_newton.py
"""
import time, numpy as np, jax, jax.numpy as jnp
import jaxwalk
from jaxwalk.models import get_model
from jaxwalk.gait import find_gait, value_and_jacfwd, step_residual
from jaxwalk.step import step_map, SolverOptions
model = get_model("flatfoot")
P = model.default_params()
solver = SolverOptions()
prim = jax.jit(lambda v, p: step_map(model, v, p, solver)[0])
full = jax.jit(lambda v, p: value_and_jacfwd(step_residual(model, p, solver), v)[:2])
fg = jax.jit(lambda p, v0: find_gait(model, p, v0))
r_grid = np.linspace(0.1, 1.0, 64)
def params(lf, r):
    return {**P, "l_f": jnp.asarray(lf), "r": jnp.asarray(r)}
def best(f, *a, n=5):
    jax.block_until_ready(f(*a)); ts = []
    for _ in range(n):
        t = time.perf_counter(); jax.block_until_ready(f(*a)); ts.append(time.perf_counter() - t)
    return min(ts)
for lf, ks in ((0.29, (10, 30, 50)), (0.205, (15, 25, 33))):
    v = model.initial_guess(params(lf, r_grid[ks[0] - 2]))
    for k in ks:
        gs = []
        for j in (k - 2, k - 1, k):
            g = fg(params(lf, r_grid[j]), v); v = g.v; gs.append(g)
        if any(int(g.status) for g in gs):
            print(lf, k, "statuses", [int(g.status) for g in gs]); continue
        p2 = params(lf, r_grid[k])
        v_pred = 2 * gs[1].v - gs[0].v
        newton = fg(p2, v_pred)
        J1 = np.asarray(gs[1].jacobian); A = J1 - np.eye(2)
        x = np.asarray(v_pred); last = np.inf; its = 0
        while its < 30:
            r = np.asarray(prim(jnp.asarray(x), p2)) - x
            u = -np.linalg.solve(A, r); s = np.abs(u).max(); its += 1
            theta = s / last
            x = x + u
            if s < 1e-8 or (np.isfinite(last) and theta < 1 and theta / (1 - theta) * s < 1e-8): break
            last = s
        J2 = np.asarray(gs[2].jacobian)
        rho = np.abs(np.linalg.eigvals(np.linalg.solve(A, J2 - J1))).max()
        tp, tj = best(prim, gs[2].v, p2), best(full, gs[2].v, p2)
        print(f"l_f {lf} r {r_grid[k]:.3f}: predictor error {np.abs(v_pred - gs[2].v).max():.1e}; Newton iterations {int(newton.iterations)} (+1 final jvp); "
              f"chord iterations {its} (rho {rho:.3f}), chord end error {np.abs(x - np.asarray(gs[2].v)).max():.1e}; "
              f"primal {1e3*tp:.1f} ms, jvp(2 tangents) {1e3*tj:.1f} ms ({tj/tp:.2f}x); "
              f"cost now {(int(newton.iterations)+1)*tj*1e3:.0f} ms, chord {its*tp*1e3 + tj*1e3:.0f} ms", flush=True)
