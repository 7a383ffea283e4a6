"""The reference step-down test: drop the ground at the next heel-strike, walk on,
and the largest drop survived (the paper's h_m).

Part of the independent NumPy/SciPy reference (``tests.reference.scipy_walkers``).
"""

from __future__ import annotations

import math
from typing import Mapping

import numpy as np

from tests.reference.fixed_points import compass_fixed_point, simplest_fixed_point
from tests.reference.models import (
    ATOL,
    RTOL,
    SIMPLEST_GAMMA,
    _compass_model,
    _Model,
    _simplest_model,
    state_to_v,
    v_to_state,
)
from tests.reference.stride import _step_full

# --------------------------------------------------------------------------- step-down


def _resolve_model(params, model: str | None) -> _Model:
    if isinstance(params, (int, float)):
        params = {"gamma": float(params)}
    params = dict(params or {})
    if model is None:
        model = "compass" if set(params) - {"gamma"} else "simplest"
    if model == "simplest":
        unknown = sorted(set(params) - {"gamma"})
        if unknown:
            raise KeyError(f"unknown simplest-walker parameter(s) {unknown}; known: ['gamma']")
        return _simplest_model(params.get("gamma", SIMPLEST_GAMMA))
    if model == "compass":
        return _compass_model(params)
    raise ValueError(f"unknown model {model!r} (simplest, compass)")


def _default_fixed_point(params, model: _Model, rtol: float, scuffing: str) -> np.ndarray:
    if model.name == "simplest":
        fp = simplest_fixed_point(model.gamma, rtol=rtol, scuffing=scuffing)
    else:
        fp = compass_fixed_point(params if isinstance(params, Mapping) else None, rtol=rtol,
                                 scuffing=scuffing)
    if fp.status != "ok":
        raise RuntimeError(f"no period-one gait found for {model.name} {params}: {fp.status}")
    return fp.v


def step_down_trial(h: float, params=None, n_steps: int = 10, model: str | None = None,
                    v_star=None, rtol: float = RTOL, atol: float = ATOL,
                    scuffing: str = "fail") -> tuple[bool, dict]:
    """One step-down trial from the fixed point.

    The ground at the next touchdown is lower by ``h`` (vertical; slope-normal
    ``h cos(gamma)``); afterwards the walker goes on over flat slope from its new
    stance foot and must complete ``n_steps`` further steps.

    Args:
        h: vertical drop [m for the compass walker, leg lengths for the simplest].
        params: simplest: ``{"gamma": ...}`` or a float; compass: overrides dict.
        n_steps: steps to complete after the drop touchdown.
        model: ``"simplest"`` / ``"compass"``; inferred from ``params`` if None
            (a dict with only ``gamma`` means the simplest walker).
        v_star: the fixed point ``v`` to start from (computed if None).
        rtol, atol: DOP853 tolerances.
        scuffing: see :func:`simplest_step` (applies to the flat-ground steps).

    Returns:
        ``(survived, info)``; info has ``status`` / ``reason`` of the first failed step,
        ``failed_step`` (0 = the drop step, k = k-th step after it, None if survived)
        and ``v_final``.
    """
    mdl = _resolve_model(params, model)
    if v_star is None:
        v_star = _default_fixed_point(params, mdl, rtol, scuffing)
    x = v_to_state(v_star)
    drop = float(h) * math.cos(mdl.gamma)
    for k in range(n_steps + 1):
        x, info = _step_full(mdl, x, drop if k == 0 else 0.0, rtol, atol, None, scuffing)
        if info["status"] != "ok":
            return False, {"status": info["status"], "reason": info["reason"], "failed_step": k,
                           "v_final": None}
    return True, {"status": "ok", "reason": "", "failed_step": None, "v_final": state_to_v(x)}


def h_max(params=None, dh: float = 0.0005, K: int = 100, n_steps: int = 10, model: str | None = None,
          v_star=None, stop_at_first_failure: bool = True, return_details: bool = False,
          rtol: float = RTOL, atol: float = ATOL, scuffing: str = "fail"):
    """Largest survivable step-down on the grid ``h = k dh`` (k = 1..K).

    ``h_max = (k_f - 1) dh`` where ``k_f`` is the first grid point whose trial
    (:func:`step_down_trial`, ``n_steps`` further steps) fails, so every smaller
    tested ``h`` survives; ``K dh`` if none fails (0.0 if ``h = dh`` already fails).

    Args:
        params: simplest: ``{"gamma": ...}`` or a float; compass: overrides dict
            (use ``model="compass"`` for the pure defaults, ``params=None``).
        dh, K: grid spacing and number of grid points.
        n_steps: steps to survive after the drop.
        model, v_star, rtol, atol, scuffing: see :func:`step_down_trial`.
        stop_at_first_failure: skip the grid points above the first failure.
        return_details: also return the list of ``(h, survived, info)``.

    Returns:
        ``h_max`` (float), or ``(h_max, details)``.
    """
    mdl = _resolve_model(params, model)
    if v_star is None:
        v_star = _default_fixed_point(params, mdl, rtol, scuffing)
    details = []
    best = None
    for k in range(1, K + 1):
        h = k * dh
        ok, info = step_down_trial(h, params, n_steps, mdl.name, v_star, rtol, atol, scuffing)
        details.append((h, ok, info))
        if not ok and best is None:
            best = (k - 1) * dh
            if stop_at_first_failure:
                break
    if best is None:
        best = K * dh
    return (best, details) if return_details else best
