"""Kinematics and inertia of the reference flat-foot walker, derived by hand.

Part of :mod:`tests.reference.flatfoot`. Coordinates ``q = (x_h, y_h, thigh_1,
shank_1, thigh_2, shank_2)`` in the slope frame (x downhill along the ground, y
normal to it); segment angles are absolute, from the slope normal, and a segment
of length ``l`` at angle ``a`` runs from its top ``p`` to ``p + l u(a)`` with
``u(a) = (sin a, -cos a)`` (docs/model.md, "Coordinates").

Every point of a leg is ``hip + alpha u(thigh) + beta u(shank)`` for two
constants, so its Jacobian and its convective acceleration are written out:
``du/da = (cos a, sin a)`` and ``d^2u/da^2 = -u(a)``. The mass matrix is
``sum m J^T J`` over the point masses plus ``I = m (rho l)^2`` on each segment's
own angle (a rigid segment of radius of gyration ``rho l``: docs/model.md,
"Bodies", which models it as two half masses; the kinetic energy is the same).
"""

from __future__ import annotations

import math
from typing import Mapping

import numpy as np

from tests.reference.flatfoot.params import N_Q, SHANK_1, SHANK_2, THIGH_1, THIGH_2, foot_arms

THIGH = {1: THIGH_1, 2: THIGH_2}
SHANK = {1: SHANK_1, 2: SHANK_2}


def unit(a: float) -> np.ndarray:
    """``u(a) = (sin a, -cos a)``: a segment's direction, top to bottom."""
    return np.array([math.sin(a), -math.cos(a)])


def unit_prime(a: float) -> np.ndarray:
    """``du/da = (cos a, sin a)``."""
    return np.array([math.cos(a), math.sin(a)])


def leg_point(q: np.ndarray, leg: int, alpha: float, beta: float) -> tuple[np.ndarray, np.ndarray]:
    """Position ``(2,)`` and Jacobian ``(2, 6)`` of ``hip + alpha u(thigh) + beta u(shank)``."""
    it, is_ = THIGH[leg], SHANK[leg]
    pos = q[:2] + alpha * unit(q[it]) + beta * unit(q[is_])
    jac = np.zeros((2, N_Q))
    jac[0, 0] = jac[1, 1] = 1.0
    jac[:, it] += alpha * unit_prime(q[it])
    jac[:, is_] += beta * unit_prime(q[is_])
    return pos, jac


def leg_point_convective(q: np.ndarray, qd: np.ndarray, leg: int, alpha: float, beta: float) -> np.ndarray:
    """``(dJ/dt) qd`` of :func:`leg_point`, ``(2,)``: the centripetal terms."""
    it, is_ = THIGH[leg], SHANK[leg]
    return -(alpha * qd[it] ** 2 * unit(q[it]) + beta * qd[is_] ** 2 * unit(q[is_]))


def ankle(q: np.ndarray, p: Mapping[str, float], leg: int) -> tuple[np.ndarray, np.ndarray]:
    """Ankle position ``(2,)`` and Jacobian ``(2, 6)`` of ``leg`` (1 or 2)."""
    return leg_point(q, leg, p["l_t"], p["l_s"])


def ankle_convective(q: np.ndarray, qd: np.ndarray, p: Mapping[str, float], leg: int) -> np.ndarray:
    return leg_point_convective(q, qd, leg, p["l_t"], p["l_s"])


def point_masses(p: Mapping[str, float]) -> list[tuple[float, int, float, float]]:
    """``(mass, leg, alpha, beta)`` of every point mass; the hip is ``leg`` 1 with
    ``alpha = beta = 0`` (its position is ``(x_h, y_h)`` whichever leg)."""
    lt, ls = p["l_t"], p["l_s"]
    out = [(p["m_h"], 1, 0.0, 0.0)]
    for leg in (1, 2):
        out += [
            (p["m_t"], leg, p["c_t"] * lt, 0.0),  # thigh: c_t l_t below the hip
            (p["m_s"], leg, lt, p["c_s"] * ls),  # shank: c_s l_s below the knee
            (p["m_f"], leg, lt, ls),  # foot, lumped at the ankle
        ]
    return out


def segment_inertias(p: Mapping[str, float]) -> np.ndarray:
    """``(6,)`` rotational inertia on each coordinate (zero on the hip's x and y)."""
    it = p["m_t"] * (p["rho_t"] * p["l_t"]) ** 2
    is_ = p["m_s"] * (p["rho_s"] * p["l_s"]) ** 2
    out = np.zeros(N_Q)
    out[[THIGH_1, THIGH_2]] = it
    out[[SHANK_1, SHANK_2]] = is_
    return out


def gravity(p: Mapping[str, float]) -> np.ndarray:
    """Gravity in the slope frame, ``g (sin gamma, -cos gamma)`` with g = 1."""
    return np.array([math.sin(p["gamma"]), -math.cos(p["gamma"])])


def mass_matrix(q: np.ndarray, p: Mapping[str, float]) -> np.ndarray:
    """``(6, 6)`` mass matrix ``sum m J^T J + diag(I)``."""
    mass = np.diag(segment_inertias(p))
    for m, leg, alpha, beta in point_masses(p):
        _, jac = leg_point(q, leg, alpha, beta)
        mass += m * jac.T @ jac
    return mass


def _leg_sums(p: Mapping[str, float]) -> tuple[float, float, float, float, float]:
    """``(sum m alpha, sum m beta, sum m alpha^2, sum m beta^2, sum m alpha beta)`` over one leg's masses."""
    legs = [(m, a, b) for m, leg, a, b in point_masses(p)[1:] if leg == 1]
    return tuple(sum(m * f(a, b) for m, a, b in legs) for f in (
        lambda a, b: a, lambda a, b: b, lambda a, b: a * a, lambda a, b: b * b, lambda a, b: a * b))  # fmt: skip


def mass_matrix_and_forces(q: np.ndarray, qd: np.ndarray, p: Mapping[str, float]) -> tuple[np.ndarray, np.ndarray]:
    """Mass matrix ``(6, 6)`` and generalized gravity and velocity-product forces
    ``sum J^T m (g - Jdot qd)``, ``(6,)``, in closed form: each leg is a double
    pendulum hung from the hip. With ``A_t = sum m alpha``, ``A_s = sum m beta``,
    ``B_.. = sum m alpha^2, m beta^2, m alpha beta`` over the leg's masses,
    ``M[xy, t] = A_t u'(t)``, ``M[t, t] = B_tt + I_t``, ``M[t, s] = B_ts cos(t - s)``, and
    ``F_t = A_t u'(t).g + B_ts sd^2 sin(s - t)``, ``F_s = A_s u'(s).g + B_ts td^2 sin(t - s)``
    (the same sums as :func:`mass_matrix`, faster: the vector field calls this)."""
    g = gravity(p)
    a_t, a_s, b_tt, b_ss, b_ts = _leg_sums(p)
    total = sum(m for m, _, _, _ in point_masses(p))
    inertia = segment_inertias(p)
    mass = np.zeros((N_Q, N_Q))
    mass[0, 0] = mass[1, 1] = total
    force = np.zeros(N_Q)
    force[:2] = total * g
    for leg in (1, 2):
        it, is_ = THIGH[leg], SHANK[leg]
        t, s, td, sd = q[it], q[is_], qd[it], qd[is_]
        ut, us, upt, ups = unit(t), unit(s), unit_prime(t), unit_prime(s)
        mass[:2, it] = mass[it, :2] = a_t * upt
        mass[:2, is_] = mass[is_, :2] = a_s * ups
        mass[it, it], mass[is_, is_] = b_tt + inertia[it], b_ss + inertia[is_]
        mass[it, is_] = mass[is_, it] = b_ts * math.cos(t - s)
        force[:2] += a_t * td * td * ut + a_s * sd * sd * us
        force[it] = a_t * float(upt @ g) + b_ts * sd * sd * math.sin(s - t)
        force[is_] = a_s * float(ups @ g) + b_ts * td * td * math.sin(t - s)
    return mass, force


def kinetic_energy(q: np.ndarray, qd: np.ndarray, p: Mapping[str, float]) -> float:
    return 0.5 * float(qd @ mass_matrix(q, p) @ qd)


def gravity_potential(q: np.ndarray, p: Mapping[str, float]) -> float:
    """``-sum m g . position`` (zero at the slope-frame origin)."""
    g = gravity(p)
    return -sum(m * float(g @ leg_point(q, leg, a, b)[0]) for m, leg, a, b in point_masses(p))


def flexion(v: np.ndarray, leg: int) -> float:
    """Knee flexion ``thigh - shank`` of ``leg`` (also its rate, given ``qd``)."""
    return float(v[THIGH[leg]] - v[SHANK[leg]])


def free_foot(q: np.ndarray, qd: np.ndarray, p: Mapping[str, float]) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Heel and toe of foot 2 held in the air (angle ``shank_2 + swing_dorsi`` from
    the slope, toe-up positive), and their velocities: ``(heel, toe, heel_dot, toe_dot)``, each ``(2,)``."""
    a_h, a_t = foot_arms(p)
    a2, jac = ankle(q, p, 2)
    phi = q[SHANK_2] + p["swing_dorsi"]
    e = np.array([math.cos(phi), math.sin(phi)])
    e_dot = np.array([-math.sin(phi), math.cos(phi)]) * qd[SHANK_2]
    a2_dot = jac @ qd
    return a2 - a_h * e, a2 + a_t * e, a2_dot - a_h * e_dot, a2_dot + a_t * e_dot
