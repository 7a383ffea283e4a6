"""Guards of the reference flat-foot walker: positive while a phase goes on.

Part of :mod:`tests.reference.flatfoot`; docs/model.md's guard table, every row.
A guard that does not apply returns 1, and each gate opens only where the gated
value is already positive (so opening it is no crossing). The swing foot's
height extrema (docs/model.md's ``heel_extremum``/``toe_extremum``) are not
guards here: they change no phase, so the step integrates through them and
records the minima as non-terminal events (:mod:`tests.reference.flatfoot.step`).

The heel-rise variant (``ctx["heel_rise"]``; docs/model.md, "The heel-rise
walker") adds ``heel_rise`` (the toe side of ``foot_roll``, in swing, locked
swing and heel pivot) and ``heel_drop`` (ankle 1's height, gated on it falling,
in their heel-up twins); there ``foot_roll`` keeps only its heel side in the flat
twins' phases and is 1 in the heel-up ones, and ``running`` and ``slip`` read the
toe's force, and in push-off and shank release ``scuff`` watches the raised
trailing foot's heel coming down (ankle 2 to its toe's height, gated on it
falling or already more than ``SUNK_TOL`` below, so that a section point
with the trailing heel in the floor ends its step at the start). Every guard
of leg 2 in a twin is its flat phase's.
"""

from __future__ import annotations

from typing import Mapping

import numpy as np

from tests.reference.flatfoot import kinematics as kin
from tests.reference.flatfoot.constraints import KNEE_1, KNEE_2
from tests.reference.flatfoot.dynamics import accelerations
from tests.reference.flatfoot.forces import ON_TOE, reactions, stance_spring_torque
from tests.reference.flatfoot.params import (
    FALL_HEIGHT, FLEXION_LIMIT, HEEL_PIVOT, HEEL_UP, IN_AIR, LATCHED, LOCKED_SWING, N_Q, PUSH_OFF, RELEASED,
    SEGMENT_LIMIT, SHANK_RELEASE, SWING, TWIN, X_H, Y_H, foot_arms, leg_2_phase,
)  # fmt: skip

NAMES = ("unlock", "knee_flex", "toe_off", "knee_strike", "heel_strike", "toe_strike", "fall", "leg_range",
         "stall", "running", "scuff", "slip", "knee_buckle", "foot_roll", "heel_rise", "heel_drop")  # fmt: skip
G = {name: i for i, name in enumerate(NAMES)}
#: Failure guards and their status, in order of precedence (the first non-positive wins).
FAILURES = (("fall", "fell"), ("leg_range", "fell"), ("stall", "stalled"), ("running", "running"),
            ("scuff", "scuffing"), ("slip", "slipping"), ("knee_buckle", "knee_buckled"),
            ("foot_roll", "foot_rolling"))  # fmt: skip
#: Leg lengths below its toe at which the trailing ankle counts as sunk into the
#: floor (``scuff`` active whichever way it moves): room for the drift of a flat
#: trailing foot's ankle, the last stance ankle's pin (2.2e-10 at the shoe gait's
#: toe-strike; jaxwalk's 8.2e-11 below).
SUNK_TOL = 1e-6
#: Phases in which the swing knee rests on its extension stop (and may be released).
ON_STOP = (PUSH_OFF, LOCKED_SWING)


def heel_rise_variant(ctx: dict) -> bool:
    """Whether the step in ``ctx`` is the heel-rise variant's (``ctx["heel_rise"]``; absent in the base walker)."""
    return bool(ctx.get("heel_rise", False))


def ground_under(x: float, p: Mapping[str, float], ctx: dict) -> float:
    """Ground height below ``x``: the previous level behind foot 1, 0 under it, the next ahead."""
    a_h, a_t = foot_arms(p)
    if x > ctx["x_ankle_1"] + a_t:
        return ctx["ground_next"]
    if x < ctx["x_ankle_1"] - a_h:
        return ctx["y_toe_2"]
    return 0.0


def cone(force: np.ndarray, p: Mapping[str, float]) -> float:
    """``mu N - |T|`` of a ground force ``(T, N)``: positive inside the friction cone."""
    return p["mu"] * force[1] - abs(force[0])


def clearance(q: np.ndarray, qd: np.ndarray, p: Mapping[str, float], ctx: dict):
    """Heights of foot 2's heel and toe above the ground below them, and their vertical rates, ``(2,)`` each."""
    heel, toe, heel_dot, toe_dot = kin.free_foot(q, qd, p)
    heights = np.array([heel[1] - ground_under(heel[0], p, ctx), toe[1] - ground_under(toe[0], p, ctx)])
    return heights, np.array([heel_dot[1], toe_dot[1]])


def guard_values(t: float, y: np.ndarray, p: Mapping[str, float], phase: int, ctx: dict) -> np.ndarray:
    """``(16,)`` guards in the order of :data:`NAMES` at time ``t`` of the step."""
    q, qd = y[:N_Q], y[N_Q:]
    _, lam = accelerations(y, p, phase, ctx)
    stance, toe, heel = reactions(q, lam, p, phase, ctx)
    _, a_t = foot_arms(p)
    g = np.ones(len(NAMES))
    knee_2, leg_2 = ctx["knee_2"], leg_2_phase(phase)
    if leg_2 in ON_STOP and knee_2 == LATCHED:
        g[G["unlock"]] = p["delay"] - t
    if leg_2 in ON_STOP and knee_2 == RELEASED:
        g[G["knee_flex"]] = lam[KNEE_2]  # the stop's torque, positive while it pushes
    if phase in ON_TOE:
        g[G["toe_off"]] = cone(toe, p)
    if leg_2 in (SHANK_RELEASE, SWING) and kin.flexion(qd, 2) < 0.0:
        g[G["knee_strike"]] = kin.flexion(q, 2) - p["knee_lock"]
    a2, jac_2 = kin.ankle(q, p, 2)
    if p["knee_gate"] > 0.5 and leg_2 == LOCKED_SWING and knee_2 == RELEASED:
        g[G["knee_strike"]] = ctx["x_ankle_1"] - a2[0]  # the paper's gate: the latch closes as the ankle passes
    heel_pt, toe_pt, _, _ = kin.free_foot(q, qd, p)
    if leg_2 in IN_AIR and heel_pt[0] > ctx["x_ankle_1"] + a_t:
        g[G["heel_strike"]] = heel_pt[1] - ctx["ground_next"]
    if leg_2 == HEEL_PIVOT:
        g[G["toe_strike"]] = a2[1] - ctx["ground_next"]
    g[G["fall"]] = q[Y_H] - FALL_HEIGHT
    g[G["leg_range"]] = min(SEGMENT_LIMIT - np.max(np.abs(q[2:])), FLEXION_LIMIT - kin.flexion(q, 2))
    g[G["stall"]] = qd[X_H]
    g[G["running"]] = stance[1]
    if leg_2 in IN_AIR:
        heights, _ = clearance(q, qd, p, ctx)
        g[G["scuff"]] = np.min(heights) + p["scuff_tol"]
    # A raised trailing foot's heel coming down to the ground, or a start with it already below.
    above_toe = a2[1] - ctx["y_toe_2"]
    if heel_rise_variant(ctx) and phase in ON_TOE and (float(jac_2[1] @ qd) < 0.0 or above_toe < -SUNK_TOL):
        g[G["scuff"]] = above_toe
    g[G["slip"]] = min(cone(stance, p), cone(heel, p) if leg_2 == HEEL_PIVOT else 1.0)
    if p["stance_latch"] < 0.5:
        g[G["knee_buckle"]] = min(lam[KNEE_1], lam[KNEE_2] if leg_2 == HEEL_PIVOT else 1.0)
    _stance_foot_guards(g, y, p, phase, ctx, stance[1])
    return g


def _stance_foot_guards(g: np.ndarray, y: np.ndarray, p: Mapping[str, float], phase: int, ctx: dict, normal: float):
    """Fill ``foot_roll``, ``heel_rise`` and ``heel_drop`` of ``g`` (in place); ``normal``: the
    stance foot's normal force ``N`` (M g).

    The massless flat stance foot is in moment balance about its ankle: the
    normal force's moment N * cop (counter-clockwise positive) cancels the
    spring's torque on the foot, the opposite of its torque on the shank; the
    centre of pressure must lie on the foot (a_h behind the ankle, a_t ahead).
    In the heel-rise variant the toe side is ``heel_rise`` in swing, locked swing
    and heel pivot, and a foot on its toe has no centre of pressure to move."""
    q, qd = y[:N_Q], y[N_Q:]
    a_h, a_t = foot_arms(p)
    if phase in HEEL_UP:
        a1, jac = kin.ankle(q, p, 1)
        g[G["heel_drop"]] = a1[1] if float(jac[1] @ qd) < 0.0 else 1.0  # gated on the ankle falling
        return
    cop_moment = stance_spring_torque(q, p, ctx)
    if heel_rise_variant(ctx) and phase in TWIN:
        g[G["heel_rise"]] = a_t * normal - cop_moment
        g[G["foot_roll"]] = cop_moment + a_h * normal
    else:
        g[G["foot_roll"]] = min(a_t * normal - cop_moment, cop_moment + a_h * normal)


def first_failure(g: np.ndarray) -> str | None:
    """Status of the first failure guard that is not positive, or ``None``."""
    for name, status in FAILURES:
        if g[G[name]] <= 0.0:
            return status
    return None


def active(phase: int, p: Mapping[str, float], ctx: dict) -> list[int]:
    """Guards that can fire in ``phase`` with latch state ``ctx["knee_2"]`` (the others are 1 throughout)."""
    leg_2 = leg_2_phase(phase)
    names = ["fall", "leg_range", "stall", "running", "slip"] + (["heel_drop"] if phase in HEEL_UP else ["foot_roll"])
    if leg_2 in ON_STOP:
        names.append("unlock" if ctx["knee_2"] == LATCHED else "knee_flex" if ctx["knee_2"] == RELEASED else None)
    if phase in ON_TOE:
        names.append("toe_off")
    if leg_2 in (SHANK_RELEASE, SWING) or (p["knee_gate"] > 0.5 and leg_2 == LOCKED_SWING):
        names.append("knee_strike")
    if leg_2 in IN_AIR:
        names += ["heel_strike", "scuff"]
    if leg_2 == HEEL_PIVOT:
        names.append("toe_strike")
    if p["stance_latch"] < 0.5:
        names.append("knee_buckle")
    if heel_rise_variant(ctx) and phase in TWIN:
        names.append("heel_rise")
    if heel_rise_variant(ctx) and phase in ON_TOE:
        names.append("scuff")
    return [G[n] for n in names if n is not None]
