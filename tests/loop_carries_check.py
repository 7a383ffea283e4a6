"""Run by tests/test_loop_carries.py in a subprocess: marked against unmarked loop carries.

Prints one JSON line: ``passes`` (JAX's while-loop jvp and batching fixpoint
passes per loop while tracing a vmapped simplest-walker gait search, marked and
unmarked) and ``same_numbers`` (the simplest walker's step map under ``jvp``,
compiled marked and unmarked, equal to the last bit, per step engine).

The pass counts read JAX's private while-loop rules (``jax._src``, as of JAX
0.10): a JAX that renames them fails the test, which then needs the new names,
not a looser assertion. Unmarked means :func:`jaxwalk.stepbase.state_dependent`
swapped for a function that returns its value unmarked in the modules that call
it; JAX's caches are cleared before each trace, so none is reused across forms.
"""

from __future__ import annotations

import json
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

import jaxwalk  # noqa: E402,F401  (float64 before jax starts)
import jax  # noqa: E402
import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402
from jax._src.interpreters import ad, batching  # noqa: E402
from jax._src.lax.control_flow import loops  # noqa: E402

from jaxwalk import flatstep, gait, step, stepbase  # noqa: E402
from jaxwalk.gait import find_gait  # noqa: E402
from jaxwalk.models import get_model  # noqa: E402
from jaxwalk.step import SolverOptions, step_map  # noqa: E402

MODEL = get_model("simplest")
PARAMS = {"gamma": jnp.asarray(0.009)}


def marking(on: bool) -> None:
    for module in (step, gait, flatstep):
        module.state_dependent = stepbase.state_dependent if on else (lambda value, y: jnp.asarray(value))


def loop_passes(fn, *args) -> list[int]:
    """Passes of the while-loop jvp and batching fixpoints, one entry per loop transformed."""
    passes = []

    def counted(rule, module, name):
        def wrapper(*a, **kw):
            body, count, inner = kw["body_jaxpr"], [0], getattr(module, name)

            def transform(jaxpr, *b, **k):
                count[0] += jaxpr is body
                return inner(jaxpr, *b, **k)

            setattr(module, name, transform)
            try:
                return rule(*a, **kw)
            finally:
                setattr(module, name, inner)
                passes.append(count[0])
        return wrapper

    jvp_rule = ad.primitive_jvps[loops.while_p]
    batch_rule = batching.fancy_primitive_batchers[loops.while_p]
    ad.primitive_jvps[loops.while_p] = counted(jvp_rule, ad, "jvp_jaxpr")
    batching.fancy_primitive_batchers[loops.while_p] = counted(batch_rule, batching, "batch_jaxpr")
    try:
        jax.clear_caches()
        jax.jit(fn).trace(*args)
    finally:
        ad.primitive_jvps[loops.while_p] = jvp_rule
        batching.fancy_primitive_batchers[loops.while_p] = batch_rule
    return passes


def step_outputs(engine: str) -> list[np.ndarray]:
    opts = SolverOptions(engine=engine)
    v0 = MODEL.initial_guess(PARAMS)
    fn = lambda v, dv: jax.jvp(lambda v_: step_map(MODEL, v_, PARAMS, opts), (v,), (dv,))
    jax.clear_caches()
    return [np.asarray(x) for x in jax.tree_util.tree_leaves(jax.jit(fn)(v0, jnp.ones_like(v0)))]


def main() -> None:
    batch = {"gamma": jnp.linspace(0.008, 0.010, 3)}
    search = jax.vmap(lambda p, v: find_gait(MODEL, p, v))
    args = (batch, jax.vmap(MODEL.initial_guess)(batch))
    result = {"passes": {}, "same_numbers": {}}
    outputs = {}
    for form in ("marked", "unmarked"):
        marking(form == "marked")
        result["passes"][form] = loop_passes(search, *args)
        outputs[form] = {engine: step_outputs(engine) for engine in ("nested", "flat")}
    for engine in ("nested", "flat"):
        pairs = zip(outputs["marked"][engine], outputs["unmarked"][engine])
        # Bit for bit, every output (int tangents are float0: compared as bytes too).
        result["same_numbers"][engine] = all(a.shape == b.shape and a.dtype == b.dtype and a.tobytes() == b.tobytes()
                                             for a, b in pairs)
    print(json.dumps(result))


if __name__ == "__main__":
    main()
