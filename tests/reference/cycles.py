"""Period-k gaits of the reference walkers: fixed points of the k-step map.

Part of the independent NumPy/SciPy reference (``tests.reference.scipy_walkers``;
no jaxwalk import). A period-k gait is a fixed point of the step map composed
k times; we find it as the attractor is found in practice: walk from a start
near it until the walk repeats, then Newton-Raphson (central-difference
Jacobian, :func:`tests.reference.fixed_points.fixed_point`) on the k-step map.
"""

from __future__ import annotations

import numpy as np

from tests.reference.fixed_points import FixedPointResult, fixed_point
from tests.reference.models import RTOL
from tests.reference.stride import simplest_step


def simplest_k_step(v, gamma: float, k: int, rtol: float = RTOL):
    """``k`` steps of the simplest walker's step map; ``(v_k, info)`` (the failing step's info on failure)."""
    for _ in range(k):
        v, info = simplest_step(v, gamma, rtol=rtol)
        if info["status"] != "ok":
            return v, info
    return v, info


def walk(v0, gamma: float, n_steps: int, rtol: float = RTOL) -> np.ndarray:
    """The ``(n_steps + 1, 3)`` iterates of the simplest walker's step map from ``v0`` (NaN after a failure)."""
    out = np.full((n_steps + 1, 3), np.nan)
    out[0] = v = np.asarray(v0, float)
    for i in range(n_steps):
        v, info = simplest_step(v, gamma, rtol=rtol)
        if info["status"] != "ok":
            break
        out[i + 1] = v
    return out


def simplest_cycle(gamma: float, k: int, v0, **kwargs) -> FixedPointResult:
    """Fixed point of the simplest walker's k-step map from ``v0``; ``J`` is ``d f^k / dv``.

    ``kwargs`` go to :func:`fixed_point`; the cycle's points are ``cycle_points(gamma, k, result.v)``.
    """
    return fixed_point(lambda v: simplest_k_step(v, gamma, k), v0, **kwargs)


def cycle_points(gamma: float, k: int, v) -> np.ndarray:
    """The ``(k, 3)`` points of the cycle through ``v``, in the order walked."""
    return walk(v, gamma, k - 1)
