"""Ankle springs, hip torque and ground reactions of the reference flat-foot walker.

Part of :mod:`tests.reference.flatfoot` (docs/model.md, "Forces"). A foot on the
ground has its angle ``phi`` (from the slope, toe-up positive) fixed by its
contact: 0 flat, ``atan2`` of the toe-to-ankle or heel-to-ankle vector when
pivoting. Its spring stores ``V = k/2 (shank - rest - phi)^2`` (``rest``: ``ankle_rest``
plus ``ankle_reset`` times the shank's angle at the step's toe-strike; in heel pivot relaxed at
the landing angle ``shank + swing_dorsi``), and the generalized force is
``-dV/dq`` with ``d phi/dq`` written out from ``d atan2(w)/dw = (-w_y, w_x)/|w|^2``.
The hip torque ``P`` acts ``+P`` on the swing thigh, ``-P`` on the stance thigh
(plus ``swing_torque`` in phase ``swing`` or its twin: foot 2 in the air, knee free);
the hip spring ``k_hip`` stores ``k_hip/2 (thigh_2 - thigh_1)^2``. While both feet
touch the ground (foot 2 on its toe or heel) both act at the fraction
``g = hip_double_support``: the torque ``g P`` is an actuator, and of the spring's
force only ``g`` acts, the rest held back by an actuator whose work over a phase is
``(1 - g) k_hip/2`` times the change of ``(thigh_2 - thigh_1)^2``. The ankle
push-off torque ``ankle_push`` (an actuator) adds a constant ``ankle_push`` to the
toe spring's torque ``k (shank - phi)`` while foot 2 pivots on its toe; its work is
``ankle_push`` times the change of ``shank - phi`` over the phase. The heel-brake
torque ``heel_brake`` (an actuator) adds a constant ``heel_brake`` to the heel
spring's torque while foot 2 pivots on its heel; its work is ``-heel_brake``
times the change of the heel spring's stretch.

In the heel-rise variant's heel-up phases (docs/model.md, "The heel-rise
walker") the stance foot pivots on its toe: its angle ``phi_1 = atan2(toe_1 -
ankle_1)`` (negative toe-down, as foot 2's on its toe), its spring
``k/2 (shank_1 - phi_1 - rest_1)^2`` with no actuator, differentiated as foot 2's,
and its ground force the ``TOE_1`` multiplier along the foot plus ``-dV/d ankle_1``.
Everything of leg 2 in a twin is its flat phase's (:func:`params.leg_2_phase`).
"""

from __future__ import annotations

import math
from typing import Mapping

import numpy as np

from tests.reference.flatfoot import kinematics as kin
from tests.reference.flatfoot.constraints import ANKLE_1_X, ANKLE_1_Y, HEEL_2, TOE_1, TOE_2, anchors
from tests.reference.flatfoot.params import (
    HEEL_PIVOT, HEEL_UP, N_Q, PUSH_OFF, SHANK_1, SHANK_2, SHANK_RELEASE, SWING, THIGH_1, THIGH_2, leg_2_phase,
)  # fmt: skip

ON_TOE = (PUSH_OFF, SHANK_RELEASE)


def _angle_gradient(w: np.ndarray) -> np.ndarray:
    """``d atan2(w_y, w_x) / dw``, ``(2,)``."""
    return np.array([-w[1], w[0]]) / float(w @ w)


def _torque(stretch: float, p: Mapping[str, float], phase: int) -> float:
    """The torque ``tau`` with ``-dV/dq = -tau (d rest/dq - d phi/dq)``: the spring's
    ``k (rest - phi)``, less the push-off torque on the toe (whose potential is
    ``-ankle_push (rest - phi)``: it turns the foot toe-down against the shank),
    plus the heel-brake torque on the heel (potential ``heel_brake (rest - phi)``:
    it resists the foot's fall to flat)."""
    leg_2 = leg_2_phase(phase)
    actuator = -p["ankle_push"] if leg_2 in ON_TOE else p["heel_brake"] if leg_2 == HEEL_PIVOT else 0.0
    return p["k"] * stretch + actuator


def _rest(p: Mapping[str, float], ctx: dict, strike: str) -> float:
    """A standing foot's spring rest angle: ``ankle_rest``, plus ``ankle_reset``
    times that leg's ankle angle at the step's toe-strike (``ctx[strike]``: the
    shank's angle from the foot's perpendicular), for the trailing spring
    (``shank_2_strike``) times ``trailing_reset`` as well."""
    share = p["trailing_reset"] if strike == "shank_2_strike" else 1.0
    return p["ankle_rest"] + p["ankle_reset"] * share * ctx[strike]


def stance_spring_torque(q: np.ndarray, p: Mapping[str, float], ctx: dict) -> float:
    """The stance ankle spring's torque on the shank, ``-k (shank_1 - rest)`` (forward
    positive; the foot feels its opposite)."""
    return -p["k"] * (q[SHANK_1] - _rest(p, ctx, "shank_1_strike"))


def stance_toe(q: np.ndarray, p: Mapping[str, float], ctx: dict) -> tuple[np.ndarray, float, np.ndarray]:
    """Foot 1 on its toe: ``(w, stretch, jac)`` with ``w = toe_1 - ankle_1`` ``(2,)``
    (``phi_1 = atan2(w)``, rad, negative toe-down), the spring's deflection
    ``stretch = shank_1 - rest_1 - phi_1`` (rad) and ankle 1's Jacobian ``(2, 6)``."""
    a1, jac = kin.ankle(q, p, 1)
    w = anchors(p, ctx)["toe_1"] - a1
    return w, q[SHANK_1] - _rest(p, ctx, "shank_1_strike") - math.atan2(w[1], w[0]), jac


def stance_stretch(q: np.ndarray, p: Mapping[str, float], phase: int, ctx: dict) -> float:
    """The stance spring's deflection ``shank_1 - rest_1 - phi_1`` (rad), ``phi_1 = 0`` flat."""
    if phase in HEEL_UP:
        return stance_toe(q, p, ctx)[1]
    return q[SHANK_1] - _rest(p, ctx, "shank_1_strike")


def _pivot(q, p, ctx, phase):
    """``(w, sign, rest)`` of foot 2's pivot in ``phase``: ``phi = atan2(w)`` with
    ``w = sign (ankle_2 - anchor)`` and the spring's rest angle; ``None`` off the ground."""
    anc = anchors(p, ctx)
    a2, _ = kin.ankle(q, p, 2)
    if phase in ON_TOE:
        return anc["toe_2"] - a2, -1.0, q[SHANK_2] - _rest(p, ctx, "shank_2_strike")
    if leg_2_phase(phase) == HEEL_PIVOT:
        return a2 - anc["heel_2"], 1.0, q[SHANK_2] + p["swing_dorsi"]
    return None


def spring_energy(q: np.ndarray, p: Mapping[str, float], phase: int, ctx: dict) -> float:
    energy = 0.5 * p["k"] * stance_stretch(q, p, phase, ctx) ** 2 + 0.5 * p["k_hip"] * (q[THIGH_2] - q[THIGH_1]) ** 2
    pivot = _pivot(q, p, ctx, phase)
    if pivot is not None:
        w, _, rest = pivot
        energy += 0.5 * p["k"] * (rest - math.atan2(w[1], w[0])) ** 2
    return energy


def reset_work(q_before: np.ndarray, ctx_before: dict, q_after: np.ndarray, ctx_after: dict, p: Mapping[str, float],
               phase_before: int = HEEL_PIVOT) -> float:
    """Work done on the ankle springs at toe-strike (docs/model.md, "Forces"): the old
    stance spring becomes the trailing toe's, the landing heel's becomes the stance
    spring, each by a move of its relaxed angle past the still foot. Energy let go
    on the way is lost; energy wound up is an actuator's work. A deflection that
    changes sign went through slack: all of it let go, then wound from zero.
    ``phase_before``: the phase toe-strike ended (heel pivot, or its heel-up twin,
    where the old stance spring's deflection is on the toe: :func:`stance_stretch`)."""

    def stance(q, ctx, phase=PUSH_OFF):
        return stance_stretch(q, p, phase, ctx)

    def pivoting(q, ctx, phase):
        w, _, rest = _pivot(q, p, ctx, phase)
        return rest - math.atan2(w[1], w[0])

    def wound(before, after):
        kept = before**2 if before * after > 0.0 else 0.0
        return 0.5 * p["k"] * max(after**2 - kept, 0.0)

    return (wound(stance(q_before, ctx_before, phase_before), pivoting(q_after, ctx_after, PUSH_OFF))
            + wound(pivoting(q_before, ctx_before, phase_before), stance(q_after, ctx_after)))


def joint_forces(q: np.ndarray, p: Mapping[str, float], phase: int, ctx: dict) -> np.ndarray:
    """``(6,)`` generalized spring forces ``-dV/dq`` plus the hip torque."""
    force = np.zeros(N_Q)
    if phase in HEEL_UP:  # V = k/2 stretch^2, d stretch/dq = e_shank_1 - d phi_1/dq, d phi_1/dq = -grad(w) J_1
        w, stretch, jac = stance_toe(q, p, ctx)
        force[SHANK_1] -= p["k"] * stretch
        force -= p["k"] * stretch * (_angle_gradient(w) @ jac)
    else:
        force[SHANK_1] -= p["k"] * (q[SHANK_1] - _rest(p, ctx, "shank_1_strike"))
    pivot = _pivot(q, p, ctx, phase)
    if pivot is not None:
        w, sign, rest = pivot
        _, jac = kin.ankle(q, p, 2)
        stretch = rest - math.atan2(w[1], w[0])
        dphi = sign * (_angle_gradient(w) @ jac)  # d phi / dq
        drest = np.zeros(N_Q)
        drest[SHANK_2] = 1.0  # the rest angle turns with the shank (swing_dorsi, ankle_rest are constant)
        force -= _torque(stretch, p, phase) * (drest - dphi)
    spread = q[THIGH_2] - q[THIGH_1]
    g = _hip_gain(p, phase)
    hip = g * (p["P"] - p["k_hip"] * spread) + _swing_torque(p, phase)
    force[THIGH_2] += hip
    force[THIGH_1] -= hip
    return force


def _swing_torque(p: Mapping[str, float], phase: int) -> float:
    """``swing_torque``, added to the hip torque in phase ``swing`` and its heel-up twin."""
    return p["swing_torque"] if leg_2_phase(phase) == SWING else 0.0


def _hip_gain(p: Mapping[str, float], phase: int) -> float:
    """The fraction of the hip torque and spring acting in ``phase``."""
    return p["hip_double_support"] if phase in ON_TOE or leg_2_phase(phase) == HEEL_PIVOT else 1.0


def hip_work(q_start: np.ndarray, q_end: np.ndarray, p: Mapping[str, float], phase: int) -> float:
    """Work of the hip torque and of the hold on the hip spring between two configurations of one phase."""
    g = _hip_gain(p, phase)
    s0, s1 = q_start[THIGH_2] - q_start[THIGH_1], q_end[THIGH_2] - q_end[THIGH_1]
    return (g * p["P"] + _swing_torque(p, phase)) * (s1 - s0) + (1.0 - g) * 0.5 * p["k_hip"] * (s1**2 - s0**2)


def actuator_work(q_start: np.ndarray, q_end: np.ndarray, p: Mapping[str, float], phase: int, ctx: dict) -> float:
    """Work of the hip actuators and the ankle push-off torque between two configurations of one phase."""
    work = hip_work(q_start, q_end, p, phase)
    if phase in ON_TOE:
        stretch = lambda q: q[SHANK_2] - math.atan2(*_pivot(q, p, ctx, phase)[0][::-1])
        work += p["ankle_push"] * (stretch(q_end) - stretch(q_start))
    if leg_2_phase(phase) == HEEL_PIVOT:
        stretch = lambda q: _pivot(q, p, ctx, phase)[2] - math.atan2(*_pivot(q, p, ctx, phase)[0][::-1])
        work -= p["heel_brake"] * (stretch(q_end) - stretch(q_start))
    return work


def reactions(q: np.ndarray, lam: np.ndarray, p: Mapping[str, float], phase: int, ctx: dict):
    """Ground forces ``(stance, toe_2, heel_2)``, each ``(tangential, normal)``.

    The flat stance foot's force is its ankle pin's multiplier. A pivoting foot
    (foot 2 on toe or heel, foot 1 on its toe in a heel-up phase: then it is
    ``stance``) is massless, so the ground supplies what the ankle feels from the
    foot: the circle row's multiplier along ``(ankle - anchor)/|ankle - anchor|``
    plus the spring's reaction ``-dV/d ankle`` (at fixed shank angle) across it.
    Zero when that contact is not made.
    """
    stance = np.array([lam[ANKLE_1_X], lam[ANKLE_1_Y]])
    if phase in HEEL_UP:  # sign -1: radial (ankle_1 - toe_1)/|.| = -w/|w|, -dV/da_1 = k stretch (-grad(w))
        w, stretch, _ = stance_toe(q, p, ctx)
        stance = -(lam[TOE_1] * w / math.hypot(w[0], w[1]) + p["k"] * stretch * _angle_gradient(w))
    toe = np.zeros(2)
    heel = np.zeros(2)
    pivot = _pivot(q, p, ctx, phase)
    if pivot is not None:
        w, sign, rest = pivot
        radial = sign * w / math.hypot(w[0], w[1])  # (ankle - anchor) / |ankle - anchor|
        stretch = rest - math.atan2(w[1], w[0])
        across = _torque(stretch, p, phase) * sign * _angle_gradient(w)  # -dV/da = (k (rest - phi) - push) dphi/da
        if phase in ON_TOE:
            toe = lam[TOE_2] * radial + across
        else:
            heel = lam[HEEL_2] * radial + across
    return stance, toe, heel
