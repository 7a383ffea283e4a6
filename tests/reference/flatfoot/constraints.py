"""Contact and knee constraints of the reference flat-foot walker, with their
Jacobian ``Sigma`` and convective term ``Psi`` written out by hand.

Part of :mod:`tests.reference.flatfoot`. The rows and their order are
docs/model.md's ("Constraints"): ``xi(q) = 0`` while a row holds, and the
equations of motion are ``M qdd = F + Sigma^T lambda`` with ``Sigma qdd = -Psi``
(``Psi = d/dt(Sigma) qd``). A circle row ``|a - c| - R`` (an ankle pivoting on a
toe or heel at ``c``) has the gradient ``n^T J_a`` with ``n = (a - c)/|a - c|``
and the convective term ``n . (Jdot_a qd) + (|v|^2 - (n . v)^2)/|a - c|`` with
``v = J_a qd`` (the second derivative of a distance).
"""

from __future__ import annotations

from typing import Mapping

import numpy as np

from tests.reference.flatfoot import kinematics as kin
from tests.reference.flatfoot.params import (
    HEEL_PIVOT, HEEL_PIVOT_HEEL_UP, LOCKED_SWING, LOCKED_SWING_HEEL_UP, N_Q, PUSH_OFF, SHANK_RELEASE, SWING,
    SWING_HEEL_UP, foot_arms,
)  # fmt: skip

ANKLE_1_X, ANKLE_1_Y, KNEE_1, KNEE_2, TOE_2, HEEL_2, ANKLE_2_X, ANKLE_2_Y, TOE_1 = range(9)
N_C = 9

_STANCE = (ANKLE_1_X, ANKLE_1_Y, KNEE_1)
#: Active rows of each phase (docs/model.md, the phase table).
ACTIVE = {
    PUSH_OFF: _STANCE + (KNEE_2, TOE_2),
    SHANK_RELEASE: _STANCE + (TOE_2,),
    SWING: _STANCE,
    LOCKED_SWING: _STANCE + (KNEE_2,),
    HEEL_PIVOT: _STANCE + (KNEE_2, HEEL_2),
    # The heel-rise variant's twins: ankle 1's pin replaced by its circle about toe 1.
    SWING_HEEL_UP: (TOE_1, KNEE_1),
    LOCKED_SWING_HEEL_UP: (TOE_1, KNEE_1, KNEE_2),
    HEEL_PIVOT_HEEL_UP: (TOE_1, KNEE_1, KNEE_2, HEEL_2),
}
#: The toe-strike impact: the next step's push-off rows before the legs swap
#: (ankle 2 pinned where it lands, both knees, leg 1 onto its toe circle).
TOE_STRIKE_ROWS = (KNEE_1, KNEE_2, ANKLE_2_X, ANKLE_2_Y, TOE_1)


def anchors(p: Mapping[str, float], ctx: dict) -> dict[str, np.ndarray]:
    """Fixed contact points ``toe_1, toe_2, heel_2, land_2`` (each ``(2,)``) of the step in ``ctx``."""
    a_h, a_t = foot_arms(p)
    gn = ctx["ground_next"]
    heel_2 = np.array([ctx["x_heel_2"], gn])
    return {
        "toe_1": np.array([ctx["x_ankle_1"] + a_t, 0.0]),
        "toe_2": np.array([ctx["x_toe_2"], ctx["y_toe_2"]]),
        "heel_2": heel_2,
        "land_2": heel_2 + np.array([a_h, 0.0]),
    }


def _circle(a, jac, conv, qd, centre, radius):
    w = a - centre
    dist = float(np.hypot(w[0], w[1]))
    n = w / dist
    v = jac @ qd
    vn = float(n @ v)
    psi = float(n @ conv) + (float(v @ v) - vn * vn) / dist
    return dist - radius, n @ jac, psi


def constraint_terms(q: np.ndarray, qd: np.ndarray, p: Mapping[str, float], ctx: dict):
    """``(xi, Sigma, Psi)``: every row's value ``(9,)``, gradient ``(9, 6)`` and convective term ``(9,)``."""
    a_h, a_t = foot_arms(p)
    anc = anchors(p, ctx)
    a1, j1 = kin.ankle(q, p, 1)
    a2, j2 = kin.ankle(q, p, 2)
    c1, c2 = kin.ankle_convective(q, qd, p, 1), kin.ankle_convective(q, qd, p, 2)
    xi, sigma, psi = np.zeros(N_C), np.zeros((N_C, N_Q)), np.zeros(N_C)
    xi[ANKLE_1_X], xi[ANKLE_1_Y] = a1[0] - ctx["x_ankle_1"], a1[1]
    sigma[[ANKLE_1_X, ANKLE_1_Y]] = j1
    psi[[ANKLE_1_X, ANKLE_1_Y]] = c1
    for row, leg in ((KNEE_1, 1), (KNEE_2, 2)):
        xi[row] = kin.flexion(q, leg) - p["knee_lock"]
        sigma[row, kin.THIGH[leg]], sigma[row, kin.SHANK[leg]] = 1.0, -1.0
    for row, a, jac, conv, centre, radius in (
        (TOE_2, a2, j2, c2, anc["toe_2"], a_t),
        (HEEL_2, a2, j2, c2, anc["heel_2"], a_h),
        (TOE_1, a1, j1, c1, anc["toe_1"], a_t),
    ):
        xi[row], sigma[row], psi[row] = _circle(a, jac, conv, qd, centre, radius)
    xi[[ANKLE_2_X, ANKLE_2_Y]] = a2 - anc["land_2"]
    sigma[[ANKLE_2_X, ANKLE_2_Y]] = j2
    psi[[ANKLE_2_X, ANKLE_2_Y]] = c2
    return xi, sigma, psi


def active_rows(phase: int) -> tuple[int, ...]:
    return ACTIVE[phase]
