"""The step map of the reference flat-foot walker with SciPy's DOP853.

Part of :mod:`tests.reference.flatfoot`. Section (docs/model.md, "Section and
step map"): just after toe-strike, legs swapped, stance ankle at the origin, both
feet flat and both knees locked; ``v = (psi, psi_dot)``, the stance leg's chord
angle (hip to ankle, from the slope normal) and its rate.

Each phase is one ``solve_ivp(method="DOP853", rtol=1e-10, atol=1e-10)`` run with
a terminal event (direction: falling through zero) for every guard that can fire
in it (:func:`tests.reference.flatfoot.guards.active`); the first to fire is the
event, and :func:`tests.reference.flatfoot.resets.on_event` gives the next phase.
As in the engine, a guard already below ``-START_GUARD_MARGIN`` when a phase
starts is an event at once, named by the first failure in the order of
``guards.FAILURES`` below zero. The swing foot's height extrema are non-terminal
events (they change no phase): the minima give ``min_clearance``, and every
extremum counts towards the step's event limit as it does in the engine.

The heel-rise variant (``heel_rise=True``; docs/model.md, "The heel-rise
walker") has the section ``v = (psi, psi_2, psi_dot)``: the trailing leg's chord
angle ``psi_2`` is free (its foot on its toe, the ankle above the ground if the
stance heel was up at toe-strike), ``psi_2 = -psi`` where both feet are flat.
The step marks its ``ctx`` with ``"heel_rise": True``, which switches on the
twins' guards (:mod:`tests.reference.flatfoot.guards`).
"""

from __future__ import annotations

import math
from typing import Mapping

import numpy as np
from scipy.integrate import solve_ivp

from tests.reference.flatfoot import constraints as con
from tests.reference.flatfoot import guards as gd
from tests.reference.flatfoot import kinematics as kin
from tests.reference.flatfoot.dynamics import vector_field
from tests.reference.flatfoot.forces import actuator_work, reset_work
from tests.reference.flatfoot.params import (
    IN_AIR, LATCHED, N_Q, PUSH_OFF, SHANK_1, SHANK_2, THIGH_1, THIGH_2, X_H, Y_H, chord, foot_arms, leg_2_phase,
    params as paper_params,
)  # fmt: skip
from tests.reference.flatfoot.resets import on_event, settle

RTOL = ATOL = 1e-10
#: Longest phase (model time units) before ``"timeout"``; events per step before ``"too_many_events"``.
PHASE_TIME_LIMIT, MAX_EVENTS = 12.0, 16
START_GUARD_MARGIN = 1e-9


def _section_configuration(v, p: Mapping[str, float], heel_rise: bool) -> tuple[np.ndarray, float]:
    """``(q (6,), x_toe_2)`` at the section point ``v``: both knees at ``knee_lock``, ankle 1
    at the origin, the trailing chord at ``-psi`` (base) or ``psi_2`` (variant), its toe
    on the ground ``sqrt(a_t^2 - y_ankle_2^2)`` ahead of its ankle (leg lengths)."""
    psi = float(v[0])
    length, delta = chord(p)
    _, a_t = foot_arms(p)
    kappa = p["knee_lock"]
    hip = np.array([-length * math.sin(psi), length * math.cos(psi)])
    if not heel_rise:
        q = np.array([hip[0], hip[1], psi + delta, psi + delta - kappa, -psi + delta, -psi + delta - kappa])
        return q, -2.0 * length * math.sin(psi) + a_t
    psi_2 = float(v[1])
    q = np.array([hip[0], hip[1], psi + delta, psi + delta - kappa, psi_2 + delta, psi_2 + delta - kappa])
    ankle_2 = hip + length * np.array([math.sin(psi_2), -math.cos(psi_2)])
    return q, float(ankle_2[0]) + math.sqrt(a_t * a_t - float(ankle_2[1]) ** 2)


def section_to_state(v, p: Mapping[str, float], heel_rise: bool = False):
    """``(y (12,), phase, ctx)`` just after toe-strike from ``v = (psi, psi_dot)`` (rad, rad per
    sqrt(L/g)), or ``(psi, psi_2, psi_dot)`` with ``heel_rise`` (the variant's step)."""
    q, x_toe_2 = _section_configuration(v, p, heel_rise)
    psi_dot = float(v[-1])
    ctx = {"x_ankle_1": 0.0, "x_toe_2": x_toe_2, "y_toe_2": 0.0, "x_heel_2": 0.0,
           "ground_next": 0.0, "knee_2": LATCHED, "events": [], "min_clearance": math.inf,
           "shank_1_strike": q[SHANK_1], "shank_2_strike": q[SHANK_2]}  # fmt: skip
    if heel_rise:
        ctx["heel_rise"] = True
        # The trailing spring's ankle angle at toe-strike: its shank less its foot's (toe-down) angle.
        ankle_2, _ = kin.ankle(q, p, 2)
        ctx["shank_2_strike"] = q[SHANK_2] - math.atan2(-float(ankle_2[1]), x_toe_2 - float(ankle_2[0]))
    # Velocity: ankle 1 pinned, both knees locked, ankle 2 on its toe circle, and thigh_1 turning at psi_dot.
    _, sigma, _ = con.constraint_terms(q, np.zeros(N_Q), p, ctx)
    rows = [con.ANKLE_1_X, con.ANKLE_1_Y, con.KNEE_1, con.KNEE_2, con.TOE_2]
    lhs = np.vstack([sigma[rows], np.eye(N_Q)[THIGH_1]])
    qd = np.linalg.solve(lhs, np.array([0.0, 0.0, 0.0, 0.0, 0.0, psi_dot]))
    y = np.concatenate([q, qd])
    phase, ctx, _ = settle(0.0, y, p, PUSH_OFF, ctx)
    return y, phase, ctx


def state_to_section(y: np.ndarray, p: Mapping[str, float], heel_rise: bool = False) -> np.ndarray:
    """``(psi, psi_dot)`` of a state ``y`` ``(12,)`` just after toe-strike, or
    ``(psi, psi_2, psi_dot)`` with ``heel_rise``."""
    _, delta = chord(p)
    if heel_rise:
        return np.array([y[THIGH_1] - delta, y[THIGH_2] - delta, y[N_Q + THIGH_1]])
    return np.array([y[THIGH_1] - delta, y[N_Q + THIGH_1]])


def _cached_guards(p, phase, ctx):
    last = {}

    def values(t, y):
        key = (t, y.tobytes())
        if last.get("key") != key:
            last["key"], last["g"] = key, gd.guard_values(t, y, p, phase, ctx)
        return last["g"]

    return values


def _events(p, phase, ctx):
    """Terminal guard events ``[(name, fn)]`` of ``phase`` and the swing foot's extrema ``[(kind, fn)]``."""
    values = _cached_guards(p, phase, ctx)
    terminal = []
    for i in gd.active(phase, p, ctx):
        fn = lambda t, y, i=i: values(t, y)[i]
        fn.terminal, fn.direction = True, -1.0
        terminal.append((gd.NAMES[i], fn))
    extrema = []
    if leg_2_phase(phase) in IN_AIR:
        for point in (0, 1):  # heel, toe
            for kind, direction in (("minimum", 1.0), ("maximum", -1.0)):
                fn = lambda t, y, point=point: gd.clearance(y[:N_Q], y[N_Q:], p, ctx)[1][point]
                fn.terminal, fn.direction = False, direction
                extrema.append(((kind, point), fn))
    return terminal, extrema


def solve_phase(t0: float, y0: np.ndarray, p, phase: int, ctx: dict, rtol=RTOL, atol=ATOL):
    """Integrate ``phase`` to its first event: ``(status, name, t, y, extrema)``; ``status`` is
    ``None`` at an event, else ``"timeout"`` or ``"solver_failed"``; ``extrema`` lists
    ``((kind, point), t, y)`` of the swing foot's height extrema on the way (``kind``
    ``"minimum"`` or ``"maximum"``, ``point`` 0 for the heel, 1 for the toe)."""
    terminal, extrema = _events(p, phase, ctx)
    sol = solve_ivp(lambda t, y: vector_field(y, p, phase, ctx), (t0, t0 + PHASE_TIME_LIMIT), y0,
                    method="DOP853", rtol=rtol, atol=atol, events=[f for _, f in terminal + extrema])  # fmt: skip
    if sol.status == 0:
        return "timeout", None, sol.t[-1], sol.y[:, -1], []
    if sol.status != 1:
        return "solver_failed", None, sol.t[-1], sol.y[:, -1], []
    fired = [(sol.t_events[i][0], i) for i in range(len(terminal)) if len(sol.t_events[i])]
    t_ev, i = min(fired)
    found = [(kind, te, ye) for j, (kind, _) in enumerate(extrema)
             for te, ye in zip(sol.t_events[len(terminal) + j], sol.y_events[len(terminal) + j]) if te <= t_ev]  # fmt: skip
    return None, terminal[i][0], t_ev, sol.y_events[i][0], sorted(found, key=lambda e: e[0])


def _named_at_start(g0: np.ndarray) -> str:
    """The guard an event at a phase's start names: the first failure (in
    ``guards.FAILURES``' order) below zero, else the least guard."""
    failing = [name for name, _ in gd.FAILURES if g0[gd.G[name]] < 0.0]
    return failing[0] if failing else gd.NAMES[int(np.argmin(g0))]


def run_step(y: np.ndarray, phase: int, ctx: dict, p: Mapping[str, float], rtol=RTOL, atol=ATOL) -> dict:
    """One step from a full state; a dict with ``status`` (``"ok"`` or a status name),
    ``y`` (after the swap), ``ctx``, ``time``, ``length``, ``work`` (hip and ankle actuators, and
    ``reset_work``: the ankle springs wound up at toe-strike, ``forces.reset_work``), ``n_events``,
    ``events`` (the ``(name, t)`` log) and ``min_clearance`` (NaN without an interior minimum)."""
    t, n_events, length, work, wound = 0.0, 0, 0.0, 0.0, 0.0
    while True:
        g0 = gd.guard_values(t, y, p, phase, ctx)
        if g0.min() < -START_GUARD_MARGIN:
            status, name, t_ev, y_ev, extrema = None, _named_at_start(g0), t, y, []
        else:
            status, name, t_ev, y_ev, extrema = solve_phase(t, y, p, phase, ctx, rtol, atol)
        n_events += len(extrema)
        for (kind, point), _, ye in extrema:
            if kind == "minimum":
                h, _ = gd.clearance(ye[:N_Q], ye[N_Q:], p, ctx)
                ctx = dict(ctx, min_clearance=min(ctx["min_clearance"], float(h[point])))
        if status is None:
            n_events += 1
            work += actuator_work(y[:N_Q], y_ev[:N_Q], p, phase, ctx)
            tr = on_event(name, t_ev, y_ev, p, phase, ctx)
            status = tr.status
            if status is None and tr.done:
                wound = reset_work(y_ev[:N_Q], ctx, tr.y[:N_Q], tr.ctx, p, phase)
                work += wound
            if status is None and not np.all(np.isfinite(tr.y)):
                status = "nonfinite"
        t = t_ev
        if status is None:
            y, phase, ctx, length = tr.y, tr.phase, tr.ctx, length + tr.shift
            if tr.done:
                status = "ok"
            elif n_events >= MAX_EVENTS:
                status = "too_many_events"
        if status is not None:
            clear = ctx["min_clearance"]
            return {"status": status, "y": y if status == "ok" else y_ev, "ctx": ctx, "phase": phase, "time": t,
                    "length": length, "work": work, "reset_work": wound, "n_events": n_events, "events": ctx["events"],
                    "min_clearance": clear if math.isfinite(clear) else math.nan}  # fmt: skip


def step_map(v, p: Mapping[str, float] | None = None, rtol=RTOL, atol=ATOL,
             heel_rise: bool = False) -> tuple[np.ndarray, dict]:
    """The Poincaré map ``v -> (v_next, info)`` (``info``: :func:`run_step`'s dict; ``v_next`` NaN on
    failure); ``v`` is ``(psi, psi_dot)``, or ``(psi, psi_2, psi_dot)`` with ``heel_rise``."""
    p = paper_params() if p is None else p
    y, phase, ctx = section_to_state(v, p, heel_rise)
    info = run_step(y, phase, ctx, p, rtol, atol)
    n = 3 if heel_rise else 2
    v_next = state_to_section(info["y"], p, heel_rise) if info["status"] == "ok" else np.full(n, math.nan)
    return v_next, info
