"""Parameters, indices and derived lengths of the reference flat-foot walker.

Part of the independent NumPy/SciPy reference of the flat-foot walker
(:mod:`tests.reference.flatfoot`). Units: total mass M = leg length L = g = 1
(docs/model.md, "Units"); angles in rad.
"""

from __future__ import annotations

import math
from typing import Mapping

#: The paper's walker, every reference check's parameters, copied from the
#: parameter table of docs/model.md ("Bodies" and "Defaults and the paper's
#: walker": the model's defaults with the paper's walker options).
PAPER: dict[str, float] = {
    "gamma": 0.0,
    "m_h": 0.678, "m_t": 0.100, "m_s": 0.0465, "m_f": 0.0145,
    "l_t": 0.5, "l_s": 0.5, "c_t": 0.433, "c_s": 0.433,
    "l_f": 0.22, "r": 0.4,
    "k": 0.03, "P": 0.0076, "swing_torque": 0.0, "k_hip": 0.0, "ankle_push": 0.0, "heel_brake": 0.0,
    "hip_double_support": 1.0,
    "delay": 0.066, "knee_lock": 0.2,
    "scuff_tol": 0.03, "rho_t": 0.0, "rho_s": 0.0,
    "knee_gate": 0.0, "swing_dorsi": 0.0, "mu": 1e6,
    "impulse_tol": 0.01, "stance_latch": 1.0, "ankle_rest": 0.0, "ankle_reset": 0.0, "trailing_reset": 1.0,
}  # fmt: skip

#: Newton's start for :data:`PAPER`: ``FlatFootWalker.initial_guess`` there
#: (jaxwalk/models/flatfoot/model.py; also docs/model.md's fixed point v*),
#: ``(psi, psi_dot)``: stance chord angle (rad) and its rate (rad per sqrt(L/g)).
PAPER_GUESS = (0.16327572732, -0.186444529299)

# Generalized coordinates q = (x_h, y_h, thigh_1, shank_1, thigh_2, shank_2).
X_H, Y_H, THIGH_1, SHANK_1, THIGH_2, SHANK_2 = range(6)
N_Q = 6

# Phases (the order of docs/model.md's phase table), then the heel-rise variant's
# heel-up twins of swing, locked swing and heel pivot (docs/model.md, "The heel-rise
# walker"): the same leg 2, the stance foot on its toe instead of flat.
PUSH_OFF, SHANK_RELEASE, SWING, LOCKED_SWING, HEEL_PIVOT = range(5)
SWING_HEEL_UP, LOCKED_SWING_HEEL_UP, HEEL_PIVOT_HEEL_UP = range(5, 8)
PHASE_NAMES = ("push_off", "shank_release", "swing", "locked_swing", "heel_pivot",
               "swing_heel_up", "locked_swing_heel_up", "heel_pivot_heel_up")  # fmt: skip
IN_AIR = (SWING, LOCKED_SWING)
#: A flat phase's heel-up twin (``heel_rise``), and a twin's flat phase (``heel_drop``).
TWIN = {SWING: SWING_HEEL_UP, LOCKED_SWING: LOCKED_SWING_HEEL_UP, HEEL_PIVOT: HEEL_PIVOT_HEEL_UP}
FLAT = {up: flat for flat, up in TWIN.items()}
#: Phases with the stance heel up (foot 1 on its toe).
HEEL_UP = tuple(FLAT)


def leg_2_phase(phase: int) -> int:
    """The base phase that says what leg 2 does in ``phase``: a twin's flat phase
    (everything that concerns leg 2 is its twin's), else ``phase`` itself."""
    return FLAT.get(phase, phase)

# Swing-knee latch states (ctx "knee_2").
LATCHED, RELEASED, RELATCHED = "latched", "released", "relatched"

#: Hip height below which the walker fell; largest |segment angle|; largest swing flexion.
FALL_HEIGHT, SEGMENT_LIMIT, FLEXION_LIMIT = 0.5, 1.5, 2.5


def params(**overrides: float) -> dict[str, float]:
    """:data:`PAPER` with ``overrides``; an unknown name raises ``KeyError``."""
    unknown = set(overrides) - set(PAPER)
    if unknown:
        raise KeyError(f"unknown flat-foot parameters: {sorted(unknown)}")
    out = dict(PAPER)
    out.update({k: float(v) for k, v in overrides.items()})
    return out


def foot_arms(p: Mapping[str, float]) -> tuple[float, float]:
    """``(a_h, a_t)``: ankle to heel and ankle to toe (the foot ratio r = a_h / a_t)."""
    return p["l_f"] * p["r"] / (1.0 + p["r"]), p["l_f"] / (1.0 + p["r"])


def chord(p: Mapping[str, float]) -> tuple[float, float]:
    """``(A, delta)`` of a leg locked at flexion ``knee_lock``: hip-to-ankle length,
    and the chord's angle below the thigh's (law of cosines in the hip-knee-ankle triangle)."""
    lt, ls, kappa = p["l_t"], p["l_s"], p["knee_lock"]
    # Hip-knee-ankle triangle: the interior angle at the knee is pi - kappa.
    length = math.sqrt(lt * lt + ls * ls - 2.0 * lt * ls * math.cos(math.pi - kappa))
    # Components of the chord along and across the thigh: (lt + ls cos kappa, ls sin kappa).
    delta = math.atan2(ls * math.sin(kappa), lt + ls * math.cos(kappa))
    return length, delta
