"""Compile time of the flat-foot step map: lower it (optionally under ``jvp``), report
the StableHLO size, compile it (timed), run it (best of 5).

    PYTHONPATH=. python benchmarks/profile_compile.py flat|nested [jvp]

Run with an empty ``JAXWALK_CACHE_DIR`` (else the compile is a cache hit) and the
``XLA_FLAGS`` to compare; sample the compiling thread with gdb
(``gdb -p PID -batch -ex "thread apply all bt"``) to see XLA's passes.
"""
import sys, time, os
import jax, jax.numpy as jnp
jax.config.update("jax_enable_x64", True)
from jaxwalk.models import get_model
from _walkers import benchmark_params
from jaxwalk.step import step_map, SolverOptions
M = get_model("flatfoot")
p = benchmark_params(M)
v = M.initial_guess(p)
engine = sys.argv[1] if len(sys.argv) > 1 else "nested"
jvp = "jvp" in sys.argv
opts = SolverOptions(engine=engine)
if jvp:
    def f(v, dv, p):
        (v1, r), (dv1, _) = jax.jvp(lambda v_: step_map(M, v_, p, opts), (v,), (dv,))
        return v1, dv1
    args = (v, jnp.zeros(2), p)
else:
    f = lambda v, p: step_map(M, v, p, opts)[0]
    args = (v, p)
t = time.time(); low = jax.jit(f).lower(*args); print("trace+lower", round(time.time() - t, 1), flush=True)
txt = low.as_text()
print("stablehlo lines", txt.count("\n"), "while", txt.count("stablehlo.while"), "case", txt.count("stablehlo.case"), "custom_call", txt.count("custom_call"), flush=True)
t = time.time(); c = low.compile(); print("compile", round(time.time() - t, 1), flush=True)
best = 1e9
for _ in range(5):
    t = time.time(); out = c(*args); jax.block_until_ready(out); best = min(best, time.time() - t)
print("run best of 5", round(best, 4), out[0], flush=True)
print("XLA_FLAGS", os.environ.get("XLA_FLAGS"), flush=True)
