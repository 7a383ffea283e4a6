"""``jax.jit`` with a walker's XLA compiler options: how its programs are compiled.

XLA's CPU backend emits fused loops with its fusion emitters by default.
Its older elemental emitters compile every walker's gait search 1.2-1.9x
faster; they run as fast where a program advances one configuration at a
time (the flat-foot walker, ``lockstep_batch`` 1: 0.9-1.1x over the runs
measured) or its batched loops are mostly small linear algebra (the kneed
walker: 2-3 % slower), and 1.5x slower for the passive walkers' 64-wide
batches, whose elementwise loops the fusion emitters vectorise
(``benchmarks/bench_compile_options.py``, benchmarks/README.md, docs/engine.md).
So the choice is the model's (:attr:`jaxwalk.walker.Walker.cpu_fusion_emitters`),
made where jaxwalk
compiles a program: every top-level program it builds (sweeps, lines,
analyses, walks, simulation, optimisation) goes through :func:`jit`. JAX
accepts compiler options only on a top-level ``jit``, so the jitted building
blocks (:func:`jaxwalk.gait.find_gait`, :func:`jaxwalk.step.run_step`) stay
plain: called directly, or inside a program of your own, they compile with
XLA's defaults unless that program is made with :func:`jit`. The options are
part of the persistent compilation cache's key, so a program compiled one
way is never loaded for the other.
"""

from __future__ import annotations

import jax


def compiler_options(model) -> dict[str, bool] | None:
    """The XLA compiler options of ``model``'s programs on this backend (a
    :class:`~jaxwalk.walker.Walker` or its class); ``None``: XLA's defaults."""
    if getattr(model, "cpu_fusion_emitters", True) or jax.default_backend() != "cpu":
        return None
    return {"xla_cpu_use_fusion_emitters": False}


def jit(fn, model, **kwargs):
    """``jax.jit(fn, **kwargs)`` compiled with ``model``'s options (:func:`compiler_options`).

    Only for programs called at the top level: JAX refuses compiler options on
    a ``jit`` traced inside another.
    """
    return jax.jit(fn, compiler_options=compiler_options(model), **kwargs)
