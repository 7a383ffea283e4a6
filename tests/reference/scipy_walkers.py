"""Independent NumPy/SciPy reference for the passive compass and simplest walkers.

This module is the yardstick the JAX engine is tested against, so it shares no
code with ``jaxwalk`` and derives nothing by automatic differentiation: the
equations of motion below were written by hand from Lagrange's equations in
minimal coordinates, the impact law from conservation of angular momentum,
the way Goswami, Thuilot & Espiau (1998) and Garcia, Chatterjee, Ruina &
Coleman (1998) present them.  Fixed points are found with Newton-Raphson on a
central-difference Jacobian of the step map (the method of those papers).

Conventions (identical to the engine's)
---------------------------------------
* Slope frame: ``x`` along the ground (downhill positive), ``y`` normal to it;
  gravity is ``g * (sin(gamma), -cos(gamma))``; the ground is ``y = 0``.
* Leg angles ``alpha_i`` [rad] are absolute, measured from the slope normal;
  the foot of leg ``i`` is at ``hip + l * (sin(alpha_i), -cos(alpha_i))``.
  Leg 1 is the stance leg, leg 2 the swing leg.  The walker walks toward +x,
  so just after heel-strike ``alpha_1 > 0`` and ``alpha_2 = -alpha_1``.
* Full state (used internally, and for step-down trials where the legs are
  not symmetric after an impact): ``x = (alpha_1, alpha_2, alpha_1_dot,
  alpha_2_dot)``, shape ``(4,)``, rad and rad/s (simplest walker: rad and
  rad per unit of the dimensionless time ``t * sqrt(g / l)``).
* Poincare section: just after heel-strike, after the legs have swapped
  labels, stance foot at the origin.  Section coordinates
  ``v = (alpha_1, alpha_1_dot, alpha_2_dot)``, shape ``(3,)``
  (``alpha_2 = -alpha_1`` is implied).  For the simplest walker Garcia's own
  2-D section ``z = (theta, theta_dot)`` is provided too, with ``theta =
  alpha_1`` and ``phi = alpha_1 - alpha_2``.

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
heel-strike is ``alpha_1 + alpha_2 = 0``).  Terminal failure events in
both legs: the hip falls below half the leg length (``cos alpha_1 < 1/2``,
status ``"fell"``), the stance leg stops and rotates backwards
(``alpha_1_dot`` crosses 0 upward, status ``"stalled"``); no heel-strike
before ``t_max`` is ``"timeout"``.

Status strings are the engine's ``jaxwalk.status.Status`` names in lower
case (``Status[s.upper()]`` converts): ``"ok"``, ``"fell"``, ``"stalled"``,
``"timeout"``, ``"nonfinite"``, ``"no_convergence"``, ``"solver_failed"``.

Models
------
Compass walker (Goswami et al. 1998): two rigid legs of length ``l = a + b``
with a point mass ``m`` on each leg at distance ``a`` from the foot, and a
hip mass ``m_h``.  Parameters (SI): ``gamma`` [rad], ``m`` [kg], ``m_h``
[kg], ``a`` [m], ``b`` [m], ``g`` [m s-2].

Simplest walker (Garcia et al. 1998): the limit of the compass walker with
``m_h = 1``, foot masses ``beta -> 0`` at the feet (``a = 0``, ``b = l = 1``)
and ``g = 1``; its only parameter is the slope ``gamma`` [rad].  Times are
dimensionless (units of ``sqrt(l/g)``).

Derivation (compass walker, stance foot at the origin)
------------------------------------------------------
With ``n(q) = (sin q, -cos q)`` and ``e(q) = dn/dq = (cos q, sin q)``::

    hip          r_H = -l n(a1)                  v_H = -l a1' e(a1)
    stance mass  r_1 = -a n(a1)                  v_1 = -a a1' e(a1)
    swing mass   r_2 = r_H + b n(a2)             v_2 = v_H + b a2' e(a2)

    T = 1/2 [(m_h l^2 + m a^2 + m l^2) a1'^2 - 2 m l b cos(a1-a2) a1' a2'
             + m b^2 a2'^2]
    V = g [(m_h l + m a + m l) cos(a1 - gamma) - m b cos(a2 - gamma)]

Lagrange's equations ``M(q) q'' = f(q, q')``::

    M = [[m_h l^2 + m a^2 + m l^2, -m l b c], [-m l b c, m b^2]]
    f = [ m l b s a2'^2 + g (m_h l + m a + m l) sin(a1 - gamma),
         -m l b s a1'^2 - g m b sin(a2 - gamma)]
    c = cos(a1 - a2), s = sin(a1 - a2)

Impact (plastic, the swing foot sticks, no impulse at the trailing foot):
angular momentum of the whole walker about the new contact point and of the
trailing leg about the hip are conserved, ``Q+ w+ = Q- w-`` with
``w = (stance rate, swing rate)`` and ``c = cos(a1- - a2-)``::

    Q- = [[(m_h l^2 + 2 m a l) c - m a b, -m a b], [-m a b, 0]]
    Q+ = [[m_h l^2 + m a^2 + m l^2 - m l b c, m b^2 - m l b c],
          [-m l b c, m b^2]]

and the legs swap labels: ``a1+ = a2-``, ``a2+ = a1-``.  In the simplest
walker limit these reduce to Garcia's equations ``theta'' = sin(theta -
gamma)``, ``phi'' = sin(theta - gamma) + (theta'^2 - cos(theta - gamma))
sin(phi)`` and impact ``theta'+ = cos(phi-) theta'-``, ``alpha_2'+ =
cos(phi-)^2 theta'-`` (``phi = alpha_1 - alpha_2``).
"""

from __future__ import annotations

import collections
import math
from typing import Callable, Mapping

import numpy as np
from scipy.integrate import solve_ivp

__all__ = [
    "COMPASS_DEFAULTS",
    "SIMPLEST_GAMMA",
    "GARCIA_FIXED_POINT_0009",
    "COMPASS_GUESS",
    "compass_params",
    "compass_rhs",
    "compass_impact",
    "compass_energy",
    "simplest_rhs",
    "simplest_impact",
    "simplest_energy",
    "v_to_state",
    "state_to_v",
    "garcia_to_v",
    "v_to_garcia",
    "simplest_guess",
    "simplest_step",
    "simplest_step_garcia",
    "simplest_step_full",
    "compass_step",
    "compass_step_full",
    "FixedPointResult",
    "fixed_point",
    "simplest_fixed_point",
    "compass_fixed_point",
    "step_down_trial",
    "h_max",
]

#: Compass-walker defaults (Goswami et al. 1998), SI units; gamma = 3 deg.
COMPASS_DEFAULTS: dict[str, float] = {
    "gamma": 0.0523598775598,
    "m": 5.0,
    "m_h": 10.0,
    "a": 0.5,
    "b": 0.5,
    "g": 9.81,
}

#: Simplest-walker default slope [rad] (Garcia et al. 1998).
SIMPLEST_GAMMA = 0.009

#: Garcia et al. (1998), long-period gait at gamma = 0.009, just after heel-strike:
#: (theta, theta_dot) in dimensionless time.
GARCIA_FIXED_POINT_0009 = (0.2003109005, -0.1998324730)

#: Initial guess for the compass walker's period-one gait at its defaults,
#: section coordinates v = (alpha_1, alpha_1_dot, alpha_2_dot).
COMPASS_GUESS = (0.2711, -1.09, -0.38)

# Integrator defaults: tight enough for ~1e-11 on a step and ~1e-10 on a fixed point.
RTOL = 1e-12
ATOL = 1e-13
# A heel-strike root with the swing foot less than this far ahead (in leg lengths)
# is the legs-together root of the swing-foot height (foot passing the stance foot).
MIN_STEP_LENGTH = 1e-8
# Safety limit on one stride, in units of sqrt(l/g).
T_MAX_SCALED = 30.0


# --------------------------------------------------------------------------- models


def compass_params(params: Mapping[str, float] | None = None) -> dict[str, float]:
    """Compass-walker defaults updated by ``params`` (unknown names raise KeyError)."""
    out = dict(COMPASS_DEFAULTS)
    if params:
        unknown = sorted(set(params) - set(out))
        if unknown:
            raise KeyError(f"unknown compass parameter(s) {unknown}; known: {sorted(out)}")
        out.update({k: float(v) for k, v in params.items()})
    return out


def compass_rhs(t: float, x: np.ndarray, p: Mapping[str, float]) -> np.ndarray:
    """Single-support equations of motion of the compass walker.

    Args:
        t: time [s] (unused, autonomous system).
        x: ``(alpha_1, alpha_2, alpha_1_dot, alpha_2_dot)`` [rad, rad/s].
        p: full parameter dict (see :func:`compass_params`).

    Returns:
        ``dx/dt``, shape ``(4,)``.
    """
    a1, a2, w1, w2 = x
    gamma, m, mh, a, b, g = p["gamma"], p["m"], p["m_h"], p["a"], p["b"], p["g"]
    l = a + b
    c = math.cos(a1 - a2)
    s = math.sin(a1 - a2)
    m11 = mh * l * l + m * a * a + m * l * l
    m12 = -m * l * b * c
    m22 = m * b * b
    f1 = m * l * b * s * w2 * w2 + g * (mh * l + m * a + m * l) * math.sin(a1 - gamma)
    f2 = -m * l * b * s * w1 * w1 - g * m * b * math.sin(a2 - gamma)
    det = m11 * m22 - m12 * m12
    d1 = (m22 * f1 - m12 * f2) / det
    d2 = (m11 * f2 - m12 * f1) / det
    return np.array([w1, w2, d1, d2])


def compass_impact(x_minus: np.ndarray, p: Mapping[str, float]) -> np.ndarray:
    """Heel-strike map of the compass walker, legs relabelled.

    Args:
        x_minus: full state just before heel-strike, shape ``(4,)``; the
            configuration need not be symmetric (step-downs).
        p: full parameter dict.

    Returns:
        Full state just after heel-strike, new stance leg first, shape ``(4,)``.
    """
    a1, a2, w1, w2 = x_minus
    m, mh, a, b = p["m"], p["m_h"], p["a"], p["b"]
    l = a + b
    c = math.cos(a1 - a2)
    q_minus = np.array([[(mh * l * l + 2.0 * m * a * l) * c - m * a * b, -m * a * b],
                        [-m * a * b, 0.0]])
    q_plus = np.array([[mh * l * l + m * a * a + m * l * l - m * l * b * c, m * b * b - m * l * b * c],
                       [-m * l * b * c, m * b * b]])
    w_plus = np.linalg.solve(q_plus, q_minus @ np.array([w1, w2]))
    return np.array([a2, a1, w_plus[0], w_plus[1]])


def compass_energy(x: np.ndarray, p: Mapping[str, float]) -> float:
    """Total mechanical energy [J] of the compass walker (stance foot at the origin)."""
    a1, a2, w1, w2 = x
    gamma, m, mh, a, b, g = p["gamma"], p["m"], p["m_h"], p["a"], p["b"], p["g"]
    l = a + b
    c = math.cos(a1 - a2)
    kin = 0.5 * ((mh * l * l + m * a * a + m * l * l) * w1 * w1
                 - 2.0 * m * l * b * c * w1 * w2 + m * b * b * w2 * w2)
    pot = g * ((mh * l + m * a + m * l) * math.cos(a1 - gamma) - m * b * math.cos(a2 - gamma))
    return kin + pot


def simplest_rhs(t: float, x: np.ndarray, gamma: float) -> np.ndarray:
    """Garcia's equations of motion, written in the state ``(alpha_1, alpha_2, rates)``.

    ``theta = alpha_1``, ``phi = alpha_1 - alpha_2``::

        theta'' = sin(theta - gamma)
        phi''   = sin(theta - gamma) + (theta'^2 - cos(theta - gamma)) sin(phi)

    Returns ``dx/dt`` (dimensionless time), shape ``(4,)``.
    """
    th, a2, thd, a2d = x
    phi = th - a2
    sg = math.sin(th - gamma)
    thdd = sg
    phidd = sg + (thd * thd - math.cos(th - gamma)) * math.sin(phi)
    return np.array([thd, a2d, thdd, thdd - phidd])


def simplest_impact(x_minus: np.ndarray) -> np.ndarray:
    """Garcia's heel-strike map (general configuration), legs relabelled.

    ``theta+ = alpha_2-``, ``alpha_2+ = theta-``, ``theta'+ = cos(phi-) theta'-``,
    ``alpha_2'+ = cos(phi-)^2 theta'-`` with ``phi- = theta- - alpha_2-``; for a
    symmetric strike (``phi- = 2 theta-``) this is Garcia's ``theta+ = -theta-``,
    ``theta'+ = cos(2 theta) theta'-``, ``phi+ = -phi-``,
    ``phi'+ = cos(2 theta)(1 - cos(2 theta)) theta'-``.
    """
    a1, a2, w1, _ = x_minus
    c = math.cos(a1 - a2)
    w1p = c * w1
    return np.array([a2, a1, w1p, c * w1p])


def simplest_energy(x: np.ndarray, gamma: float) -> float:
    """Energy of the hip mass (units ``m_h g l``), conserved in the simplest walker's swing.

    The swing leg's foot mass is infinitesimal: it does not act on the hip, so
    the hip pendulum ``theta'' = sin(theta - gamma)`` conserves
    ``theta'^2 / 2 + cos(theta - gamma)``.
    """
    return 0.5 * x[2] * x[2] + math.cos(x[0] - gamma)


class _Model:
    """A walker: its equations, impact, leg length and time scale."""

    def __init__(self, name: str, rhs, impact, l: float, gamma: float, t_scale: float):
        self.name = name
        self.rhs = rhs
        self.impact = impact
        self.l = l
        self.gamma = gamma
        self.t_scale = t_scale


def _simplest_model(gamma: float) -> _Model:
    gamma = float(gamma)
    return _Model("simplest", lambda t, x: simplest_rhs(t, x, gamma), simplest_impact, 1.0, gamma, 1.0)


def _compass_model(params: Mapping[str, float] | None) -> _Model:
    p = compass_params(params)
    l = p["a"] + p["b"]
    return _Model("compass", lambda t, x: compass_rhs(t, x, p), lambda x: compass_impact(x, p),
                  l, p["gamma"], math.sqrt(l / p["g"]))


# --------------------------------------------------------------------------- coordinates


def v_to_state(v) -> np.ndarray:
    """Section coordinates ``(alpha_1, alpha_1_dot, alpha_2_dot)`` -> full state (``alpha_2 = -alpha_1``)."""
    v = np.asarray(v, dtype=float)
    return np.array([v[0], -v[0], v[1], v[2]])


def state_to_v(x) -> np.ndarray:
    """Full state -> section coordinates ``(alpha_1, alpha_1_dot, alpha_2_dot)``."""
    x = np.asarray(x, dtype=float)
    return np.array([x[0], x[2], x[3]])


def garcia_to_v(z) -> np.ndarray:
    """Garcia's section ``(theta, theta_dot)`` (just after heel-strike) -> ``v``.

    After a symmetric heel-strike ``phi = 2 theta`` and ``phi_dot = (1 - cos 2theta)
    theta_dot``, hence ``alpha_2_dot = theta_dot - phi_dot = cos(2 theta) theta_dot``.
    """
    th, thd = float(z[0]), float(z[1])
    return np.array([th, thd, math.cos(2.0 * th) * thd])


def v_to_garcia(v) -> np.ndarray:
    """``v`` -> Garcia's ``(theta, theta_dot)`` (drops ``alpha_2_dot``)."""
    return np.array([float(v[0]), float(v[1])])


def simplest_guess(gamma: float) -> np.ndarray:
    """Initial guess ``v`` for the simplest walker's stable (long-period) gait.

    Garcia's small-slope scaling ``theta* ~ gamma^(1/3)``, with a quadratic
    correction in ``s = gamma^(1/3)`` fitted to this module's own fixed points
    for ``5e-5 <= gamma <= 0.019`` (error < 1e-5; it only seeds Newton).
    """
    s = float(gamma) ** (1.0 / 3.0)
    th = s * (0.9710 - 0.0016 * s - 0.1776 * s * s)
    thd = s * (-1.0150 + 0.0042 * s + 1.2347 * s * s)
    return garcia_to_v((th, thd))


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
        info["nfev"] += sol.nfev
        if sol.status == -1:
            return None, _fail(info, "solver_failed", sol.message)
        if not np.all(np.isfinite(sol.y)):
            return None, _fail(info, "nonfinite", "non-finite state in single support")
        if sol.status == 0:
            return None, _fail(info, "timeout", "stance leg never passed the slope normal")
        if sol.t_events[1].size:
            return None, _fail(info, "stalled", "stance leg stopped before mid-stance")
        if sol.t_events[2].size:
            return None, _fail(info, "fell", "hip below half the leg length")
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
    ev_symmetric.direction = 0.0

    heel = ev_heel
    while True:  # leg B: until heel-strike
        sol = solve_ivp(model.rhs, (t0, t_max), x, events=[heel, _ev_stall, _ev_fall], **kw)
        info["nfev"] += sol.nfev
        if sol.status == -1:
            return None, _fail(info, "solver_failed", sol.message)
        if not np.all(np.isfinite(sol.y)):
            return None, _fail(info, "nonfinite", "non-finite state in single support")
        if sol.status == 0:
            return None, _fail(info, "timeout", "no heel-strike before t_max")
        if sol.t_events[1].size:
            return None, _fail(info, "stalled", "stance leg rotated backwards after mid-stance")
        if sol.t_events[2].size:
            return None, _fail(info, "fell", "hip below half the leg length")
        x_minus = np.array(sol.y_events[0][0])
        info["step_time"] = float(sol.t_events[0][0])
        info["x_minus"] = x_minus
        step_length = l * (math.sin(x_minus[1]) - math.sin(x_minus[0]))
        info["step_length"] = step_length
        if step_length > MIN_STEP_LENGTH * l:
            return x_minus, info
        if scuffing == "ignore" and heel is ev_heel and drop == 0.0:
            # The root found is the legs-together one (swing foot passing the stance
            # foot at ground level after mid-stance). Garcia's rule ignores it: go on
            # to alpha_1 + alpha_2 = 0 (the foot then rises back through the ground).
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


# --------------------------------------------------------------------------- fixed points


class FixedPointResult(collections.namedtuple("FixedPointResult", "v J eigenvalues lambda_max")):
    """Result of :func:`fixed_point`; unpacks as ``(v, J, eigenvalues, lambda_max)``.

    Extra attributes: ``status`` (str), ``n_iter`` (Newton iterations), ``residual``
    (max-norm of ``P(v) - v`` at ``v``), ``step_info`` (info dict of the step at ``v``).
    """


def _jacobian(step_fn: Callable, v: np.ndarray, fd_step: float, args: tuple):
    n = v.size
    J = np.empty((n, n))
    for j in range(n):
        dv = np.zeros(n)
        dv[j] = fd_step
        vp, ip = step_fn(v + dv, *args)
        vm, im = step_fn(v - dv, *args)
        if ip["status"] != "ok" or im["status"] != "ok":
            return None, ip if ip["status"] != "ok" else im
        J[:, j] = (vp - vm) / (2.0 * fd_step)
    return J, None


def fixed_point(step_fn: Callable, v0, args: tuple = (), tol: float = 1e-12, max_iter: int = 30,
                fd_step: float = 1e-6, final_fd_step: float = 2e-5,
                richardson: bool = True, max_halvings: int = 10) -> FixedPointResult:
    """Period-one fixed point of a step map by Newton-Raphson (central-difference Jacobian).

    Args:
        step_fn: ``step_fn(v, *args) -> (v_next, info)`` with ``info["status"]``.
        v0: initial guess, shape ``(n,)``.
        args: extra positional arguments of ``step_fn``.
        tol: convergence when ``max|P(v) - v| < tol`` (or the Newton update
            falls below ``tol / 10``).
        max_iter: Newton iterations.
        max_halvings: a Newton update whose step fails (walker falls, stalls, ...)
            is halved up to this many times (damped Newton); plain Newton otherwise.
        fd_step: central-difference step on each coordinate (Newton iterations).
        final_fd_step, richardson: the Jacobian returned at the converged point is
            ``(4 J(h) - J(2h)) / 3`` with ``h = final_fd_step`` (Richardson-extrapolated
            central differences, error O(h^4) instead of O(h^2): ~1e-10 on the
            eigenvalues instead of ~1e-8); with ``richardson=False`` it is the plain
            central difference ``J(fd_step)``.

    Returns:
        :class:`FixedPointResult`: ``v`` (shape ``(n,)``), ``J`` (``(n, n)``,
        ``dP/dv`` at ``v``), ``eigenvalues`` (``(n,)``, complex, sorted by decreasing
        modulus), ``lambda_max`` (largest modulus); NaNs and a non-"ok" ``status``
        on failure.
    """
    v = np.array(v0, dtype=float)
    n = v.size
    nan_out = (np.full(n, math.nan), np.full((n, n), math.nan), np.full(n, math.nan + 0j), math.nan)

    def failed(status, it, res, info):
        out = FixedPointResult(*nan_out)
        out.status, out.n_iter, out.residual, out.step_info = status, it, res, info
        return out

    last_dv = math.inf
    pv, info = step_fn(v, *args)
    if info["status"] != "ok":
        return failed(info["status"], 0, math.nan, info)
    for it in range(max_iter + 1):
        r = pv - v
        res = float(np.max(np.abs(r)))
        converged = res < tol or last_dv < tol / 10
        if converged and richardson:
            J, bad = _jacobian(step_fn, v, final_fd_step, args)
            if J is not None:
                J2, bad = _jacobian(step_fn, v, 2.0 * final_fd_step, args)
                J = None if J2 is None else (4.0 * J - J2) / 3.0
        else:
            J, bad = _jacobian(step_fn, v, fd_step, args)
        if J is None:
            return failed(bad["status"], it, res, bad)
        if converged:
            eig = np.linalg.eigvals(J).astype(complex)
            eig = eig[np.argsort(-np.abs(eig), kind="stable")]
            out = FixedPointResult(v, J, eig, float(np.max(np.abs(eig))))
            out.status, out.n_iter, out.residual, out.step_info = "ok", it, res, info
            return out
        if it == max_iter:
            break
        try:
            dv = np.linalg.solve(J - np.eye(n), -r)
        except np.linalg.LinAlgError:
            return failed("no_convergence", it, res, info)
        # Safeguard: halve the Newton update while the step from v + dv fails.
        for _ in range(max_halvings + 1):
            pv_try, info_try = step_fn(v + dv, *args)
            if info_try["status"] == "ok":
                break
            dv = 0.5 * dv
        else:
            return failed("no_convergence", it, res, info_try)
        v, pv, info = v + dv, pv_try, info_try
        last_dv = float(np.max(np.abs(dv)))
    return failed("no_convergence", max_iter, res, info)


def simplest_fixed_point(gamma: float = SIMPLEST_GAMMA, v0=None, rtol: float = RTOL,
                         scuffing: str = "fail", **kwargs) -> FixedPointResult:
    """Stable gait of the simplest walker on the 3-D section (guess :func:`simplest_guess`).

    ``kwargs`` go to :func:`fixed_point`.
    """
    v0 = simplest_guess(gamma) if v0 is None else v0
    return fixed_point(lambda v: simplest_step(v, gamma, rtol=rtol, scuffing=scuffing), v0, **kwargs)


def compass_fixed_point(params: Mapping[str, float] | None = None, v0=None, rtol: float = RTOL,
                        scuffing: str = "fail", **kwargs) -> FixedPointResult:
    """Period-one gait of the compass walker (guess :data:`COMPASS_GUESS`, made for the defaults).

    ``kwargs`` go to :func:`fixed_point`.
    """
    v0 = COMPASS_GUESS if v0 is None else v0
    return fixed_point(lambda v: compass_step(v, params, rtol=rtol, scuffing=scuffing), v0, **kwargs)


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
