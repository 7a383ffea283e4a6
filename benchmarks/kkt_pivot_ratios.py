"""Check: how far the KKT systems of a walker's step are from the singularity test
of :func:`jaxwalk.mechanics._solve_or_nan` (a smallest LU pivot of at most
``mechanics.SINGULAR_PIVOT_RATIO``, 1e-10, of the largest gives NaN).

One step map from each model's stored initial guess at its default parameters,
``jit`` with the caches off; every LAPACK solve on the way (vector field, guards,
event location, impacts with a mask known when tracing) reports the ratio of its
LU's smallest to largest pivot through ``jax.debug.callback``. Impacts by the
looped elimination (a traced mask) are not seen.

    JAXWALK_CACHE_DIR= PYTHONPATH=. python benchmarks/kkt_pivot_ratios.py [kneed flatfoot]

Measured 2026-12-06 (session 43): kneed 330 solves, least ratio 3.6e-4; flat-foot
951 solves, least ratio 1.7e-3; the threshold 1e-10.
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


def least_pivot_ratios(name: str) -> list[float]:
    """The least pivot ratio of every LAPACK solve in one default step of ``name``."""
    ratios: list[float] = []

    def reporting(a, b):
        pivots = jnp.abs(jnp.diagonal(jax.lax.linalg.lu(a)[0], axis1=-2, axis2=-1))
        jax.debug.callback(lambda r: ratios.append(float(np.min(r))), jnp.min(pivots, -1) / jnp.max(pivots, -1))
        return CHECKED(a, b)

    mechanics._solve_or_nan = reporting
    try:
        jax.clear_caches()
        model = get_model(name)
        params = model.default_params()
        jax.block_until_ready(jax.jit(lambda v: step_map(model, v, params))(model.initial_guess(params)))
    finally:
        mechanics._solve_or_nan = CHECKED
    return ratios


def main() -> None:
    for name in sys.argv[1:] or ["kneed", "flatfoot"]:
        ratios = least_pivot_ratios(name)
        print(f"{name}: {len(ratios)} solves, least pivot ratio {min(ratios):.2g} "
              f"(singular at {mechanics.SINGULAR_PIVOT_RATIO:.0e})")


if __name__ == "__main__":
    main()
