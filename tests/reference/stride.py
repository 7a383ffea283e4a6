"""One stride of a reference walker with SciPy's DOP853, and the step maps built on it.

Part of the independent NumPy/SciPy reference (``tests.reference.scipy_walkers``).

Step phases and events
----------------------
A stride is integrated with ``scipy.integrate.solve_ivp(method="DOP853")`` in
two legs: (A) from the section until the stance leg passes the slope normal
(``alpha_1`` crosses 0 downward), during which the swing foot's passage
through the ground (foot scuffing of the compass gait) is ignored; (B) until
heel-strike, i.e. the swing-foot height ``y_sw = l (cos alpha_1 - cos
alpha_2)`` crosses the ground level (``0``, or ``-drop`` for a step-down)
downward.  A heel-strike with the swing foot not ahead of the stance foot
(the legs-together root of ``y_sw``, swing foot reaching the ground at the
stance foot after mid-stance; detected as a step length below
``MIN_STEP_LENGTH * l``) is a failure, status ``"fell"``; ``scuffing="ignore"``
switches to Garcia's rule instead (the foot passes through the ground, and
heel-strike is ``alpha_1 + alpha_2`` crossing 0 downward, the foot coming down
ahead; Garcia's ``phi - 2 theta = 0``).  Terminal failure events in
both legs: the hip falls below half the leg length (``cos alpha_1 < 1/2``,
status ``"fell"``), the stance leg stops and rotates backwards
(``alpha_1_dot`` crosses 0 upward, status ``"stalled"``); no heel-strike
before ``t_max`` is ``"timeout"``.

Status strings are the engine's ``jaxwalk.status.Status`` names in lower
case (``Status[s.upper()]`` converts): ``"ok"``, ``"fell"``, ``"stalled"``,
``"timeout"``, ``"nonfinite"``, ``"no_convergence"``, ``"solver_failed"``.
"""

from __future__ import annotations

import math
from typing import Mapping

import numpy as np
from scipy.integrate import solve_ivp

from tests.reference.models import (
    ATOL,
    MIN_STEP_LENGTH,
    RTOL,
    SIMPLEST_GAMMA,
    T_MAX_SCALED,
    _compass_model,
    _Model,
    _simplest_model,
    garcia_to_v,
    state_to_v,
    v_to_state,
)

# --------------------------------------------------------------------------- one stride


def _ev_stall(t, x):
    return x[2]


_ev_stall.terminal = True
_ev_stall.direction = 1.0


def _ev_fall(t, x):
    return math.cos(x[0]) - 0.5


_ev_fall.terminal = True
_ev_fall.direction = -1.0


def _ev_midstance(t, x):
    return x[0]


_ev_midstance.terminal = True
_ev_midstance.direction = -1.0


def _fail(info: dict, status: str, reason: str) -> dict:
    info["status"] = status
    info["reason"] = reason
    return info


def _leg_failure(sol, info: dict, timeout: str, stalled: str) -> dict | None:
    """The failure of one ``solve_ivp`` leg with events ``[end, stall, fall]``, or ``None``.
    Counts its evaluations in ``info``; ``timeout``/``stalled`` say what they mean in this leg."""
    info["nfev"] += sol.nfev
    if sol.status == -1:
        return _fail(info, "solver_failed", sol.message)
    if not np.all(np.isfinite(sol.y)):
        return _fail(info, "nonfinite", "non-finite state in single support")
    if sol.status == 0:
        return _fail(info, "timeout", timeout)
    if sol.t_events[1].size:
        return _fail(info, "stalled", stalled)
    if sol.t_events[2].size:
        return _fail(info, "fell", "hip below half the leg length")
    return None


def _stride(model: _Model, x0: np.ndarray, drop: float, rtol: float, atol: float,
            t_max: float | None, scuffing: str = "fail") -> tuple[np.ndarray | None, dict]:
    """Integrate single support from ``x0`` to the next heel-strike.

    ``drop`` [m, slope-normal] lowers the ground for this touchdown: heel-strike
    when ``y_sw = -drop``.  Returns the state just before impact (or None) and info.
    ``scuffing``: see :func:`simplest_step`.
    """
    if scuffing not in ("fail", "ignore"):
        raise ValueError(f"scuffing must be 'fail' or 'ignore', got {scuffing!r}")
    info = {"status": "ok", "reason": "", "step_time": math.nan, "step_length": math.nan,
            "x_minus": None, "x_plus": None, "nfev": 0}
    x0 = np.asarray(x0, dtype=float)
    if t_max is None:
        t_max = T_MAX_SCALED * model.t_scale
    if not np.all(np.isfinite(x0)):
        return None, _fail(info, "nonfinite", "non-finite initial state")
    if math.cos(x0[0]) < 0.5:
        return None, _fail(info, "fell", "hip below half the leg length at the start")
    if x0[2] >= 0.0:
        return None, _fail(info, "stalled", "stance leg not rotating forward at the start")
    l = model.l
    kw = dict(method="DOP853", rtol=rtol, atol=atol)

    t0 = 0.0
    x = x0
    if x[0] > 0.0:  # leg A: until the stance leg passes the slope normal
        sol = solve_ivp(model.rhs, (0.0, t_max), x, events=[_ev_midstance, _ev_stall, _ev_fall], **kw)
        failed = _leg_failure(sol, info, "stance leg never passed the slope normal", "stance leg stopped before mid-stance")
        if failed:
            return None, failed
        t0 = float(sol.t_events[0][0])
        x = np.array(sol.y_events[0][0])
        if x[1] <= x[0] and scuffing == "fail":
            # The swing leg still trails at mid-stance: the legs must cross below
            # the hip, the swing foot meeting the ground at the stance foot. The
            # foot's dip below ground after that crossing can be shorter than one
            # solver step (event detection checks step ends only), so decide here.
            return None, _fail(info, "scuffing", "swing leg behind the stance leg at mid-stance")

    def ev_heel(t, y):  # swing-foot height above the ground of this touchdown
        return l * (math.cos(y[0]) - math.cos(y[1])) + drop

    ev_heel.terminal = True
    ev_heel.direction = -1.0

    def ev_symmetric(t, y):  # Garcia's phi - 2 theta = 0, i.e. alpha_1 + alpha_2 = 0
        return math.sin(0.5 * (y[0] + y[1]))

    ev_symmetric.terminal = True
    # Downward only: with the swing leg ahead, y_sw has the sign of alpha_1 + alpha_2.
    # After the legs-together root alpha_1 + alpha_2 = 2 alpha_1 < 0, and its first
    # (upward) zero is the foot rising back out of the ground, not a heel-strike.
    ev_symmetric.direction = -1.0

    heel = ev_heel
    while True:  # leg B: until heel-strike
        sol = solve_ivp(model.rhs, (t0, t_max), x, events=[heel, _ev_stall, _ev_fall], **kw)
        failed = _leg_failure(sol, info, "no heel-strike before t_max", "stance leg rotated backwards after mid-stance")
        if failed:
            return None, failed
        x_minus = np.array(sol.y_events[0][0])
        info["step_time"] = float(sol.t_events[0][0])
        info["x_minus"] = x_minus
        step_length = l * (math.sin(x_minus[1]) - math.sin(x_minus[0]))
        info["step_length"] = step_length
        if step_length > MIN_STEP_LENGTH * l:
            return x_minus, info
        if scuffing == "ignore" and heel is ev_heel and drop == 0.0:
            # The root found is the legs-together one (swing foot passing the stance
            # foot at ground level after mid-stance). Garcia's rule ignores it: the foot
            # rises back through the ground and the strike is its next descent to it.
            info["scuffed_after_midstance"] = True
            heel, t0, x = ev_symmetric, info["step_time"], x_minus
            continue
        return None, _fail(info, "scuffing", "heel-strike with the swing foot not ahead of the stance foot")


def _step_full(model: _Model, x0, drop: float = 0.0, rtol: float = RTOL, atol: float = ATOL,
               t_max: float | None = None, scuffing: str = "fail") -> tuple[np.ndarray, dict]:
    x_minus, info = _stride(model, x0, drop, rtol, atol, t_max, scuffing)
    if x_minus is None:
        return np.full(4, math.nan), info
    x_plus = model.impact(x_minus)
    if not np.all(np.isfinite(x_plus)):
        return np.full(4, math.nan), _fail(info, "nonfinite", "non-finite state after impact")
    info["x_plus"] = x_plus
    return x_plus, info


def simplest_step_full(x, gamma: float, drop: float = 0.0, rtol: float = RTOL, atol: float = ATOL,
                       t_max: float | None = None, scuffing: str = "fail") -> tuple[np.ndarray, dict]:
    """One step of the simplest walker on the full state.

    Args:
        x: full state just after heel-strike ``(alpha_1, alpha_2, alpha_1_dot, alpha_2_dot)``.
        gamma: slope [rad].
        drop: slope-normal depth of the ground at this touchdown below the stance foot
            (``h cos(gamma)`` for a vertical step-down ``h``); 0 on flat slope.
        rtol, atol: DOP853 tolerances.
        t_max: stride time limit (dimensionless), default 30.
        scuffing: see :func:`simplest_step`.

    Returns:
        ``(x_next, info)``: full state just after the next heel-strike (legs swapped,
        re-origined at the new stance foot; NaN on failure) and the info dict of
        :func:`simplest_step`.
    """
    return _step_full(_simplest_model(gamma), x, drop, rtol, atol, t_max, scuffing)


def compass_step_full(x, params: Mapping[str, float] | None = None, drop: float = 0.0,
                      rtol: float = RTOL, atol: float = ATOL,
                      t_max: float | None = None, scuffing: str = "fail") -> tuple[np.ndarray, dict]:
    """One step of the compass walker on the full state (see :func:`simplest_step_full`).

    ``drop`` in metres; ``t_max`` in seconds (default ``30 sqrt(l/g)``).
    """
    return _step_full(_compass_model(params), x, drop, rtol, atol, t_max, scuffing)


def simplest_step(v, gamma: float = SIMPLEST_GAMMA, rtol: float = RTOL, atol: float = ATOL,
                  scuffing: str = "fail") -> tuple[np.ndarray, dict]:
    """Step map of the simplest walker on the section ``v``.

    Args:
        v: ``(alpha_1, alpha_1_dot, alpha_2_dot)`` just after heel-strike, shape ``(3,)``;
            rad and rad per dimensionless time.
        gamma: slope [rad].
        rtol, atol: DOP853 tolerances (default 1e-12 / 1e-13).
        scuffing: what a swing foot that reaches the ground level at the stance
            foot *after* mid-stance (``alpha_1 < 0``; legs together) means.
            ``"fail"`` (the engine's rule, default): a heel-strike with the swing
            foot not ahead of the stance foot, status ``"fell"``.  ``"ignore"``:
            Garcia's rule, the foot passes through the ground and heel-strike is
            ``alpha_1 + alpha_2 = 0`` (``phi = 2 theta``); only for flat ground.

    Returns:
        ``(v_next, info)``; ``v_next`` shape ``(3,)`` (NaN on failure); ``info`` has
        ``status`` (str), ``reason`` (str), ``step_time`` (dimensionless),
        ``step_length`` (in leg lengths, along the slope), ``x_minus`` / ``x_plus``
        (full states around the impact) and ``nfev``.
    """
    x_next, info = simplest_step_full(v_to_state(v), gamma, 0.0, rtol, atol, scuffing=scuffing)
    return state_to_v(x_next), info


def simplest_step_garcia(z, gamma: float = SIMPLEST_GAMMA, rtol: float = RTOL, atol: float = ATOL,
                         scuffing: str = "fail") -> tuple[np.ndarray, dict]:
    """Step map on Garcia's 2-D section ``z = (theta, theta_dot)``; returns ``(z_next, info)``."""
    x_next, info = simplest_step_full(v_to_state(garcia_to_v(z)), gamma, 0.0, rtol, atol, scuffing=scuffing)
    return np.array([x_next[0], x_next[2]]), info


def compass_step(v, params: Mapping[str, float] | None = None, rtol: float = RTOL,
                 atol: float = ATOL, scuffing: str = "fail") -> tuple[np.ndarray, dict]:
    """Step map of the compass walker on the section ``v``.

    Args:
        v: ``(alpha_1, alpha_1_dot, alpha_2_dot)`` just after heel-strike, shape ``(3,)``;
            rad, rad/s.
        params: parameter overrides (defaults :data:`COMPASS_DEFAULTS`).
        rtol, atol: DOP853 tolerances.
        scuffing: see :func:`simplest_step`.

    Returns:
        ``(v_next, info)`` as in :func:`simplest_step`; ``step_time`` in s, ``step_length`` in m.
    """
    x_next, info = compass_step_full(v_to_state(v), params, 0.0, rtol, atol, scuffing=scuffing)
    return state_to_v(x_next), info
