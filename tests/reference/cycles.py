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


def critical_multiplier(result: FixedPointResult) -> float:
    """The most negative real multiplier of a cycle (its flip test: -1 at a period doubling)."""
    mu = result.eigenvalues
    return float(mu.real[np.abs(mu.imag) < 1e-12].min())


def simplest_flip(k: int, gamma_lo: float, gamma_hi: float, v0, xtol: float = 1e-12,
                  **kwargs) -> tuple[float, FixedPointResult]:
    """Slope [rad] where the simplest walker's period-k cycle has a multiplier -1, and the cycle there.

    Brent's method (``scipy.optimize.brentq``) on :func:`critical_multiplier` ``+ 1`` of the
    k-step map's Richardson-extrapolated Jacobian, between ``gamma_lo`` and ``gamma_hi``
    (their values must have opposite signs); each trial's Newton starts from the last
    trial's cycle (first ``v0``, shape ``(3,)``). ``kwargs`` go to :func:`simplest_cycle`.
    Accuracy: the multiplier is converged to about 3e-9 in the difference step and the
    integration (rtol 1e-12 against 1e-13: 1e-8) at the period-2 flip near 0.01767, where
    it changes by about -961 per radian of slope: the slope to about 1e-11.
    """
    from scipy.optimize import brentq

    last = {"v": np.asarray(v0, float)}

    def cycle(gamma):
        result = simplest_cycle(gamma, k, last["v"], **kwargs)
        if result.status != "ok":
            raise RuntimeError(f"no period-{k} cycle at gamma = {gamma!r}: {result.status}")
        last["v"] = result.v
        return result

    gamma = brentq(lambda g: critical_multiplier(cycle(g)) + 1.0, gamma_lo, gamma_hi, xtol=xtol, rtol=4 * np.finfo(float).eps)
    return gamma, cycle(gamma)
