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
"""

from __future__ import annotations

import math
from typing import Mapping

import numpy as np
from scipy.integrate import solve_ivp

from tests.reference.flatfoot import constraints as con
from tests.reference.flatfoot import guards as gd
from tests.reference.flatfoot.dynamics import vector_field
from tests.reference.flatfoot.forces import actuator_work, reset_work
from tests.reference.flatfoot.params import (
    IN_AIR, LATCHED, N_Q, PUSH_OFF, SHANK_1, SHANK_2, THIGH_1, X_H, Y_H, chord, foot_arms, params as paper_params,
)  # fmt: skip
from tests.reference.flatfoot.resets import on_event, settle

RTOL = ATOL = 1e-10
#: Longest phase (model time units) before ``"timeout"``; events per step before ``"too_many_events"``.
PHASE_TIME_LIMIT, MAX_EVENTS = 12.0, 16
START_GUARD_MARGIN = 1e-9


def section_to_state(v, p: Mapping[str, float]):
    """``(y (12,), phase, ctx)`` just after toe-strike from ``v = (psi, psi_dot)``."""
    psi, psi_dot = float(v[0]), float(v[1])
    length, delta = chord(p)
    _, a_t = foot_arms(p)
    kappa = p["knee_lock"]
    hip = np.array([-length * math.sin(psi), length * math.cos(psi)])
    q = np.array([hip[0], hip[1], psi + delta, psi + delta - kappa, -psi + delta, -psi + delta - kappa])
    ctx = {"x_ankle_1": 0.0, "x_toe_2": -2.0 * length * math.sin(psi) + a_t, "y_toe_2": 0.0, "x_heel_2": 0.0,
           "ground_next": 0.0, "knee_2": LATCHED, "events": [], "min_clearance": math.inf,
           "shank_1_strike": q[SHANK_1], "shank_2_strike": q[SHANK_2]}  # fmt: skip
    # Velocity: ankle 1 pinned, both knees locked, ankle 2 on its toe circle, and thigh_1 turning at psi_dot.
    _, sigma, _ = con.constraint_terms(q, np.zeros(N_Q), p, ctx)
    rows = [con.ANKLE_1_X, con.ANKLE_1_Y, con.KNEE_1, con.KNEE_2, con.TOE_2]
    lhs = np.vstack([sigma[rows], np.eye(N_Q)[THIGH_1]])
    qd = np.linalg.solve(lhs, np.array([0.0, 0.0, 0.0, 0.0, 0.0, psi_dot]))
    y = np.concatenate([q, qd])
    phase, ctx, _ = settle(0.0, y, p, PUSH_OFF, ctx)
    return y, phase, ctx


def state_to_section(y: np.ndarray, p: Mapping[str, float]) -> np.ndarray:
    _, delta = chord(p)
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
    if phase in IN_AIR:
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
                wound = reset_work(y_ev[:N_Q], ctx, tr.y[:N_Q], tr.ctx, p)
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


def step_map(v, p: Mapping[str, float] | None = None, rtol=RTOL, atol=ATOL) -> tuple[np.ndarray, dict]:
    """The Poincaré map ``v -> (v_next, info)`` (``info``: :func:`run_step`'s dict; ``v_next`` NaN on failure)."""
    p = paper_params() if p is None else p
    y, phase, ctx = section_to_state(v, p)
    info = run_step(y, phase, ctx, p, rtol, atol)
    v_next = state_to_section(info["y"], p) if info["status"] == "ok" else np.full(2, math.nan)
    return v_next, info
