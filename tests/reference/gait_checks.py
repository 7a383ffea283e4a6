"""Is a simplest-walker gait physical? Its swing, contact forces and impacts, from its section point.

Part of the independent NumPy/SciPy reference (no ``jaxwalk`` import). The
checks a gait of the step map can fail while still being a fixed point:
the swing leg trailing at mid-stance (its foot must then pass through the
ground after it, a scuff the engine's rule forbids and Garcia's ignores), a
stance leg that pulls on the ground, a heel-strike impulse that pulls, a
trailing foot that does not lift off.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.integrate import solve_ivp

from tests.reference.models import ATOL, RTOL, simplest_rhs, v_to_state
from tests.reference.stride import simplest_step


def simplest_gait_checks(v, gamma: float, scuffing: str = "fail", samples: int = 4001) -> dict:
    """Physical checks of the step from section point ``v`` (shape ``(3,)``) at slope ``gamma`` [rad].

    Returns a dict (lengths in leg lengths, forces in units of the hip's weight ``m_h g``,
    impulses in ``m_h sqrt(g l)``, times in ``sqrt(l/g)``):
    ``step_time``, ``step_length``; ``swing_at_midstance``: ``alpha_2`` [rad] when the
    stance leg passes the slope normal (> 0: the swing leg is ahead); ``min_compression``:
    the least stance-leg force ``cos(alpha_1 - gamma) - alpha_1_dot^2`` over the step (> 0:
    the leg pushes; the massless swing leg loads nothing); ``lowest_foot_before`` /
    ``lowest_foot_after``: the swing foot's lowest height over the ground before / after
    mid-stance (the heel-strike's own zero excluded; negative: through the ground);
    ``strike_impulse``: the heel-strike impulse along the new stance leg (> 0: pushes);
    ``trailing_lift``: the trailing foot's slope-normal speed just after it (> 0: lifts off).
    """
    _, info = simplest_step(v, gamma, scuffing=scuffing)
    if info["status"] != "ok":
        raise ValueError(f"the step from {v} at gamma = {gamma} fails: {info['status']} ({info['reason']})")
    period = info["step_time"]
    sol = solve_ivp(lambda t, x: simplest_rhs(t, x, gamma), (0.0, period), v_to_state(v),
                    method="DOP853", rtol=RTOL, atol=ATOL, dense_output=True)
    t = np.linspace(0.0, period, samples)
    a1, a2, w1, _ = sol.sol(t)
    height = np.cos(a1) - np.cos(a2)
    inner = (t > 0.01 * period) & (t < 0.99 * period)  # both zeros of the height at the step's ends excluded
    mid = np.flatnonzero(np.diff(np.sign(a1)) < 0)[0]
    s = (0.0 - a1[mid]) / (a1[mid + 1] - a1[mid])  # linear interpolation to alpha_1 = 0
    b1, b2, u1, _ = info["x_minus"]
    hip_velocity = -u1 * np.array([math.cos(b1), math.sin(b1)])
    to_hip = -np.array([math.sin(b2), -math.cos(b2)])  # from the new stance foot to the hip
    c1, _, d1, d2 = info["x_plus"]
    return {
        "step_time": period,
        "step_length": info["step_length"],
        "swing_at_midstance": float(a2[mid] + s * (a2[mid + 1] - a2[mid])),
        "min_compression": float(np.min(np.cos(a1 - gamma) - w1 * w1)),
        "lowest_foot_before": float(height[inner & (a1 > 0)].min()),
        "lowest_foot_after": float(height[inner & (a1 < 0)].min()),
        "strike_impulse": float(-hip_velocity @ to_hip),
        "trailing_lift": float(-math.sin(c1) * (d1 + d2)),
    }
