"""Trace, compile and run time of a second-order program along one parameter:
the simplest walker's gait sensitivity norm and its gradient in gamma
(:func:`jaxwalk.global_stability.sensitivity_norm.norm_and_gradient`), with the
outer derivative as one ``jvp`` (``jaxwalk.gait.jacfwd_with_aux``, the default)
or as ``jax.jacfwd`` (a ``vmap`` over a basis of one).

    JAXWALK_CACHE_DIR= PYTHONPATH=. python benchmarks/bench_one_direction.py

Each variant runs in a fresh process, one after the other; the outputs are compared.
"""

import json
import subprocess
import sys

CHILD = r"""
import json, sys, time
import jax, jax.numpy as jnp
import jaxwalk.gait as gait
from jaxwalk.global_stability.sensitivity_norm import norm_and_gradient
from jaxwalk.models import get_model

if sys.argv[1] == "jacfwd":
    gait.jacfwd_with_aux = lambda fn, x: jax.jacfwd(fn, has_aux=True)(x)
model = get_model("simplest")
g = jnp.asarray(0.009)
f = jax.jit(lambda p, v0: norm_and_gradient(model, p, v0, ("gamma",)))
args = ({"gamma": g}, model.initial_guess({"gamma": g}))
t0 = time.perf_counter(); traced = f.trace(*args)
t1 = time.perf_counter(); lowered = traced.lower()
t2 = time.perf_counter(); compiled = lowered.compile()
t3 = time.perf_counter(); value, grad = jax.block_until_ready(compiled(*args))
t4 = time.perf_counter()
print(json.dumps({"trace": t1 - t0, "lower": t2 - t1, "compile": t3 - t2, "run": t4 - t3,
                  "hlo_mb": len(lowered.as_text()) / 1e6, "value": float(value), "grad": float(grad[0])}))
"""


def main() -> None:
    rows = {}
    for variant in ("jvp", "jacfwd"):
        out = subprocess.run([sys.executable, "-c", CHILD, variant], capture_output=True, text=True, check=True)
        rows[variant] = json.loads(out.stdout.strip().splitlines()[-1])
        r = rows[variant]
        print(f"{variant:7s} trace {r['trace']:5.1f} s  lower {r['lower']:4.1f} s  compile {r['compile']:5.1f} s  "
              f"run {r['run']:.3f} s  HLO {r['hlo_mb']:.2f} MB  norm {r['value']!r}  gradient {r['grad']!r}", flush=True)
    a, b = rows["jvp"], rows["jacfwd"]
    print(f"trace ratio (jacfwd / jvp) {b['trace'] / a['trace']:.2f}x; "
          f"gradient relative difference {abs(a['grad'] - b['grad']) / abs(b['grad']):.1e}")


if __name__ == "__main__":
    main()
