"""Check: how far the KKT systems of a walker's step are from the singularity test
of :func:`jaxwalk.mechanics._solve_or_nan` (a smallest LU pivot of at most
``mechanics.SINGULAR_PIVOT_RATIO``, 1e-10, of the largest gives NaN).

One step map from each model's stored initial guess at its default parameters,
``jit`` with the caches off; every LAPACK solve on the way (vector field, guards,
event location, impacts with a mask known when tracing) and every impact by the
looped elimination (a traced mask) reports the ratio of its LU's smallest to
largest pivot through ``jax.debug.callback``.

    JAXWALK_CACHE_DIR= PYTHONPATH=. python benchmarks/kkt_pivot_ratios.py [simplest kneed flatfoot]

Measured 2026-12-06 (session 43), least ratio: kneed 3.6e-4 (330 LAPACK solves of
order 12), 0.025 (4 impacts); flat-foot 1.7e-3 (951 of order 15), 2.1e-3 (9
impacts); the simplest walker's impacts (order 8, untested) 9.6e-13, below the
threshold of 1e-10 that systems above order 8 are held to.
"""

from __future__ import annotations

import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

import jaxwalk  # noqa: E402,F401  (before jax: the device-count flag)
import jax  # noqa: E402
import jax.numpy as jnp  # noqa: E402

from jaxwalk import mechanics  # noqa: E402
from jaxwalk.models import get_model  # noqa: E402
from jaxwalk.step import step_map  # noqa: E402

CHECKED = mechanics._solve_or_nan
LOOPED = mechanics._looped_solve


def least_pivot_ratios(name: str) -> dict[str, list[float]]:
    """The pivot ratio of every LAPACK solve (``"lapack"``) and of every impact by
    the looped elimination (``"looped"``, the same pivots as LAPACK's partial
    pivoting) in one default step of ``name``, with each system's order."""
    ratios: dict[str, list[tuple[int, float]]] = {"lapack": [], "looped": []}

    def reporting(kind, solve):
        def wrapped(a, b):
            pivots = jnp.abs(jnp.diagonal(jax.lax.linalg.lu(a)[0], axis1=-2, axis2=-1))
            record = lambda r: ratios[kind].append((a.shape[-1], float(np.min(r))))
            jax.debug.callback(record, jnp.min(pivots, -1) / jnp.max(pivots, -1))
            return solve(a, b)
        return wrapped

    mechanics._solve_or_nan = reporting("lapack", CHECKED)
    mechanics._looped_solve = reporting("looped", LOOPED)
    try:
        jax.clear_caches()
        model = get_model(name)
        params = model.default_params()
        jax.block_until_ready(jax.jit(lambda v: step_map(model, v, params))(model.initial_guess(params)))
    finally:
        mechanics._solve_or_nan, mechanics._looped_solve = CHECKED, LOOPED
    return ratios


def main() -> None:
    for name in sys.argv[1:] or ["simplest", "kneed", "flatfoot"]:
        for kind, found in least_pivot_ratios(name).items():
            if found:
                orders = sorted({n for n, _ in found})
                print(f"{name} {kind}: {len(found)} solves of order {orders}, least pivot ratio "
                      f"{min(r for _, r in found):.2g} (tested above order {mechanics.UNROLLED_SOLVE_MAX}, "
                      f"singular at {mechanics.SINGULAR_PIVOT_RATIO:.0e})")


if __name__ == "__main__":
    main()
