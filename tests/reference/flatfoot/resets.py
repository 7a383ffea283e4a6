"""What happens at each event of the reference flat-foot walker: impacts, the knee
latch, the leg swap, the checks on entering a phase, and the statuses.

Part of :mod:`tests.reference.flatfoot` (docs/model.md, "Resets" and the
paragraphs after it). ``ctx`` is a dict: the contact anchors ``x_ankle_1``,
``x_toe_2``, ``y_toe_2``, ``x_heel_2``, the next ground level ``ground_next``, the
swing knee's latch ``knee_2``, the event log ``events`` (``(name, t)`` pairs) and
the swing foot's lowest interior minimum so far, ``min_clearance`` (``inf`` if none).

The heel-rise variant's events (docs/model.md, "The heel-rise walker"):
``heel_rise`` takes a flat phase to its heel-up twin with no impact (no entry
check: :func:`ankle_1_lift`); ``heel_drop`` takes a twin back to its flat phase through an inelastic
impact onto ankle 1's pin, its impulses checked as any impact's. In both
walkers the toe-1 normal impulse of toe-strike must push (zero for a flat foot).
"""

from __future__ import annotations

import math
from typing import Mapping, NamedTuple

import numpy as np

from tests.reference.flatfoot import kinematics as kin
from tests.reference.flatfoot import constraints as con
from tests.reference.flatfoot.dynamics import accelerations, impact
from tests.reference.flatfoot.forces import ON_TOE
from tests.reference.flatfoot.guards import G, clearance, first_failure, guard_values
from tests.reference.flatfoot.params import (
    FLAT, HEEL_PIVOT, HEEL_PIVOT_HEEL_UP, IN_AIR, LATCHED, LOCKED_SWING, LOCKED_SWING_HEEL_UP, N_Q, PUSH_OFF,
    RELATCHED, RELEASED, SHANK_1, SHANK_2, SHANK_RELEASE, SWING, SWING_HEEL_UP, TWIN, foot_arms, leg_2_phase,
)  # fmt: skip

#: Below this (M sqrt(gL)) an impulse is numerical zero.
IMPULSE_FLOOR = 1e-12
#: The phase after each phase-changing event, from the phase before it.
_NEXT = {
    "knee_flex": {PUSH_OFF: SHANK_RELEASE, LOCKED_SWING: SWING, LOCKED_SWING_HEEL_UP: SWING_HEEL_UP},
    "toe_off": {PUSH_OFF: LOCKED_SWING, SHANK_RELEASE: SWING},
    "knee_strike": {SWING: LOCKED_SWING, LOCKED_SWING: LOCKED_SWING, SHANK_RELEASE: PUSH_OFF,
                    SWING_HEEL_UP: LOCKED_SWING_HEEL_UP, LOCKED_SWING_HEEL_UP: LOCKED_SWING_HEEL_UP},
    "heel_strike": {SWING: HEEL_PIVOT, LOCKED_SWING: HEEL_PIVOT,
                    SWING_HEEL_UP: HEEL_PIVOT_HEEL_UP, LOCKED_SWING_HEEL_UP: HEEL_PIVOT_HEEL_UP},
    "heel_rise": TWIN,
    "heel_drop": FLAT,
}  # fmt: skip


class Transition(NamedTuple):
    """After an event: the new ``phase``, state ``y`` ``(12,)`` and ``ctx``; ``status``
    (``None`` while the step goes on, else a status name); ``done`` (toe-strike
    ended the step); ``shift`` (step length, the frame's move at the swap)."""

    phase: int
    y: np.ndarray
    ctx: dict
    status: str | None
    done: bool
    shift: float


def logged(ctx: dict, name: str, t: float, **changes) -> dict:
    out = dict(ctx, **changes)
    out["events"] = ctx["events"] + [(name, t)]
    return out


def settle(t: float, y: np.ndarray, p: Mapping[str, float], phase: int, ctx: dict):
    """Contacts on entering ``phase``: a toe that would pull leaves, a released knee
    whose stop would pull flexes (each logged). ``(phase, ctx, guards)`` in the final phase."""
    for _ in range(3):
        g = guard_values(t, y, p, phase, ctx)
        if phase in ON_TOE and g[G["toe_off"]] < 0.0:
            phase, ctx = _NEXT["toe_off"][phase], logged(ctx, "toe_off", t)
        elif g[G["knee_flex"]] < 0.0:
            phase, ctx = _NEXT["knee_flex"][phase], logged(ctx, "knee_flex", t)
        else:
            return phase, ctx, g
    raise AssertionError("more than two contact changes on entering a phase")


def entry_status(g: np.ndarray, phase: int) -> str | None:
    """A failure already due on entering ``phase``; a heel pivot with the ankle not above ground is a scuff."""
    status = first_failure(g)
    if status is None and leg_2_phase(phase) == HEEL_PIVOT and g[G["toe_strike"]] <= 0.0:
        status = "scuffing"
    return status


def _normal(a: np.ndarray, c: np.ndarray) -> float:
    w = a - c
    return w[1] / math.hypot(w[0], w[1])


def impulse_status(q: np.ndarray, imp: np.ndarray, p: Mapping[str, float], ctx: dict) -> str | None:
    """``"running"`` if foot 1 (flat or on its toe), toe 2 or the landing ankle pulls, ``"knee_buckled"`` if
    a knee on its stop alone (``stance_latch = 0``) is pulled, ``"slipping"`` if foot 1
    or the landing ankle leaves its friction cone, beyond ``impulse_tol`` of the
    impact's largest normal impulse (docs/model.md, "Impulses"). A pivoting foot's impulse
    lies along the massless foot: its friction is checked on the force that follows (``slip``)."""
    anc = con.anchors(p, ctx)
    a1, _ = kin.ankle(q, p, 1)
    a2, _ = kin.ankle(q, p, 2)
    normal = np.array([
        imp[con.ANKLE_1_Y],
        imp[con.TOE_2] * _normal(a2, anc["toe_2"]),
        imp[con.HEEL_2] * _normal(a2, anc["heel_2"]),
        imp[con.ANKLE_2_Y],
        imp[con.TOE_1] * _normal(a1, anc["toe_1"]),
    ])  # fmt: skip
    scale = p["impulse_tol"] * np.max(np.abs(normal)) + IMPULSE_FLOOR
    pulls = min(normal[0], normal[1], normal[3], normal[4]) < -scale
    buckles = p["stance_latch"] < 0.5 and min(imp[con.KNEE_1], imp[con.KNEE_2]) < -scale
    cone = lambda tx, ny: p["mu"] * ny - abs(tx)
    slides = min(cone(imp[con.ANKLE_1_X], imp[con.ANKLE_1_Y]), cone(imp[con.ANKLE_2_X], imp[con.ANKLE_2_Y])) < -scale
    return "running" if pulls else "knee_buckled" if buckles else "slipping" if slides else None


def swap_legs(y: np.ndarray, p: Mapping[str, float], ctx: dict):
    """After toe-strike: leg 2 stands, leg 1 trails on its toe; origin at the new stance ankle. ``(y, ctx, shift)``."""
    _, a_t = foot_arms(p)
    q, qd = y[:N_Q], y[N_Q:]
    landing, _ = kin.ankle(q, p, 2)
    order = [0, 1, 4, 5, 2, 3]
    q_new, qd_new = q[order].copy(), qd[order].copy()
    q_new[:2] -= landing
    ctx_new = dict(ctx, x_ankle_1=0.0, x_toe_2=ctx["x_ankle_1"] + a_t - landing[0], y_toe_2=-landing[1],
                   x_heel_2=0.0, ground_next=0.0, knee_2=LATCHED,
                   shank_1_strike=q_new[SHANK_1], shank_2_strike=q_new[SHANK_2])  # fmt: skip
    if ctx.get("heel_rise"):  # the new trailing foot may stand raised on its toe: its ankle angle, not its shank's
        ankle, _ = kin.ankle(q_new, p, 2)
        toe = np.array([ctx_new["x_toe_2"], ctx_new["y_toe_2"]]) - ankle
        ctx_new["shank_2_strike"] = q_new[SHANK_2] - math.atan2(toe[1], toe[0])
    return np.concatenate([q_new, qd_new]), ctx_new, float(landing[0])


def trailing_heel_sinks(y: np.ndarray, p: Mapping[str, float], ctx: dict) -> bool:
    """The new trailing foot (flat, on its toe circle) would turn heel-down: the rate of
    ``atan2(toe - ankle)`` is positive."""
    q, qd = y[:N_Q], y[N_Q:]
    a2, jac = kin.ankle(q, p, 2)
    w = con.anchors(p, ctx)["toe_2"] - a2
    w_dot = -jac @ qd
    return (w[0] * w_dot[1] - w[1] * w_dot[0]) / float(w @ w) > 0.0


def _latch_after_strike(q, p, phase, ctx) -> str:
    """Closed, unless the paper's gate (``knee_gate``) holds it open until the swing
    ankle passes the stance ankle (a strike in locked_swing is that passing)."""
    a2, _ = kin.ankle(q, p, 2)
    passed = a2[0] > ctx["x_ankle_1"] or leg_2_phase(phase) == LOCKED_SWING
    return RELATCHED if (p["knee_gate"] < 0.5 or passed) else RELEASED


def _turned_up(y_before, y_after, p, ctx, minimum):
    """``min(minimum, height)`` of a swing-foot point that an impact turns from falling to rising."""
    h, rate_before = clearance(y_before[:N_Q], y_before[N_Q:], p, ctx)
    _, rate_after = clearance(y_after[:N_Q], y_after[N_Q:], p, ctx)
    turned = (rate_before < 0.0) & (rate_after >= 0.0)
    return min([minimum] + list(h[turned]))


_FAILURE_OF_GUARD = {"fall": "fell", "leg_range": "fell", "stall": "stalled", "running": "running",
                     "scuff": "scuffing", "slip": "slipping", "knee_buckle": "knee_buckled",
                     "foot_roll": "foot_rolling"}  # fmt: skip


def _strike_status(name, q, qd, p, ctx):
    """Heel-strike with the heel already rising (a scuff), or with the knee released and not relocked."""
    if name != "heel_strike":
        return None
    _, _, heel_dot, _ = kin.free_foot(q, qd, p)
    if heel_dot[1] >= 0.0:
        return "scuffing"  # the heel gate opened on a heel below ground and rising
    return "shank_releasing" if ctx["knee_2"] == RELEASED else None


def ankle_1_lift(y: np.ndarray, p: Mapping[str, float], phase: int, ctx: dict) -> float:
    """Ankle 1's vertical acceleration (g, up positive) in ``phase`` at ``y`` ``(12,)``:
    ``(J_1 qdd + Jdot_1 qd)_y``. Entering a heel-up twin it is ``-D (a_t N - tau) / a_t``
    (``D > 0``, the ankle's inverse effective mass): zero where ``heel_rise`` crosses
    zero and positive after, so the heel always rises and no entry check is made
    (docs/model.md); tests/test_reference_heel_rise.py checks that."""
    q, qd = y[:N_Q], y[N_Q:]
    qdd, _ = accelerations(y, p, phase, ctx)
    _, jac = kin.ankle(q, p, 1)
    return float(jac[1] @ qdd + kin.ankle_convective(q, qd, p, 1)[1])


def on_event(name: str, t: float, y: np.ndarray, p: Mapping[str, float], phase: int, ctx: dict) -> Transition:
    """The reset after guard ``name`` fired at ``(t, y)`` in ``phase``."""
    q, qd = y[:N_Q], y[N_Q:]
    if name in _FAILURE_OF_GUARD:
        return Transition(phase, y, logged(ctx, name, t), _FAILURE_OF_GUARD[name], False, 0.0)
    changes = {}
    if name == "unlock":
        changes["knee_2"] = RELEASED
    elif name == "knee_strike":
        changes["knee_2"] = _latch_after_strike(q, p, phase, ctx)
    elif name == "heel_strike":
        heel, _, _, _ = kin.free_foot(q, qd, p)
        changes["x_heel_2"] = float(heel[0])
    ctx_new = logged(ctx, name, t, **changes)
    next_phase = phase if name == "unlock" else PUSH_OFF if name == "toe_strike" else _NEXT[name][phase]
    rows = {"knee_strike": con.ACTIVE[next_phase], "heel_strike": con.ACTIVE[next_phase],
            "heel_drop": con.ACTIVE[next_phase], "toe_strike": con.TOE_STRIKE_ROWS}.get(name)  # fmt: skip
    y_next, status = y, _strike_status(name, q, qd, p, ctx)
    if rows is not None:
        y_next, impulses = impact(y, p, ctx_new, rows)
        status = status or impulse_status(q, impulses, p, ctx_new)
    # An impact with the swing foot in the air before and after (knee-strike; in the
    # heel-rise variant also the stance heel's drop) may turn a falling point up.
    if rows is not None and leg_2_phase(phase) in IN_AIR and leg_2_phase(next_phase) in IN_AIR:
        ctx_new["min_clearance"] = _turned_up(y, y_next, p, ctx_new, ctx_new["min_clearance"])
    done, shift = name == "toe_strike", 0.0
    if done:
        y_next, ctx_new, shift = swap_legs(y_next, p, ctx_new)
    next_phase, ctx_new, g = settle(t, y_next, p, next_phase, ctx_new)
    status = status or entry_status(g, next_phase)
    if status is None and done and next_phase == PUSH_OFF and trailing_heel_sinks(y_next, p, ctx_new):
        status = "scuffing"  # a double flat stance is not modelled
    if status is not None:
        return Transition(phase, y, logged(ctx, name, t), status, False, 0.0)
    return Transition(next_phase, y_next, ctx_new, None, done, shift)
