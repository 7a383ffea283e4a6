"""The reference walkers' physics: equations of motion, impacts, energies, coordinates.

Part of the independent NumPy/SciPy reference (``tests.reference.scipy_walkers``
gathers it); hand-derived, no ``jaxwalk`` import.

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

import math
from typing import Mapping

import numpy as np

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
