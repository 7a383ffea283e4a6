"""The phase table of the flat-foot walker: constraints, their masks, discrete state.

One step (leg 1 just became stance with its foot flat, leg 2 trails on its toe)
runs through five continuous phases, separated by events:

====  ================  ==================================================  =====
 idx   phase             active constraints                                  DOF
====  ================  ==================================================  =====
 0     push_off          ankle 1 pinned, knees 1 and 2 locked, toe circle 2   1
 1     shank_release     ankle 1 pinned, knee 1 locked, toe circle 2          2
 2     swing             ankle 1 pinned, knee 1 locked                        3
 3     locked_swing      ankle 1 pinned, knees 1 and 2 locked                 2
 4     heel_pivot        ankle 1 pinned, knees locked, heel circle 2          1
====  ================  ==================================================  =====

The paper's seven phases are: 1 push_off, 2 shank_release, 3 swing, 4 the
knee-strike impact and the locked swing after it, 5 the heel-strike impact,
6 heel_pivot, 7 the toe-strike impact (onto ankle 2 pinned and toe circle 1,
after which the legs swap and the step ends).

Constraint rows (every row exists in every phase; a 0/1 mask switches them):
ankle 1 (x, y) on its anchor; knee flexions ``- knee_lock``; ankle 2 on the
circle of radius ``a_t`` about its toe (the paper's xi_4); ankle 2 on the circle
of radius ``a_h`` about its heel (xi_8); ankle 2 (x, y) on its landing point
(xi_2, used by the toe-strike impact); ankle 1 on the circle about its toe (for
the toe-strike impact, after which leg 1 trails on its toe).

The heel-rise walker (``flatfoot_heel_rise``) has three more phases, heel-up
twins of swing, locked swing and heel pivot (5, 6, 7) in which the stance foot
pivots on its toe: its twin's rows with ankle 1's pin replaced by ankle 1 on
the circle about its toe (docs/model.md, "The heel-rise walker"). The tables
below have a row for each of the eight; the base walker never enters 5-7.
"""

from __future__ import annotations

import jax.numpy as jnp

from jaxwalk import chain, event_log
from jaxwalk.models.flatfoot import geometry as geo

# Phases.
PUSH_OFF, SHANK_RELEASE, SWING, LOCKED_SWING, HEEL_PIVOT = range(5)
PHASE_NAMES = ("push_off", "shank_release", "swing", "locked_swing", "heel_pivot")
# The heel-rise walker's heel-up twins of swing, locked swing and heel pivot.
SWING_HEEL_UP, LOCKED_SWING_HEEL_UP, HEEL_PIVOT_HEEL_UP = range(5, 8)
HEEL_RISE_PHASE_NAMES = PHASE_NAMES + ("swing_heel_up", "locked_swing_heel_up", "heel_pivot_heel_up")
#: A heel-up twin is its flat phase plus this (swing -> swing_heel_up, ...).
HEEL_UP_OFFSET = SWING_HEEL_UP - SWING

# Constraint rows.
ANKLE_1_X, ANKLE_1_Y, KNEE_1, KNEE_2, TOE_2, HEEL_2, ANKLE_2_X, ANKLE_2_Y, TOE_1 = range(9)
N_CONSTRAINTS = 9

#: Discrete state ``ctx``. Anchors are in the slope frame of the current step
#: (stance ankle at x = 0 after re-origin). ``knee_2`` is the swing knee's latch:
#: :data:`LATCHED` before the unlock, :data:`RELEASED` after it (the knee then
#: rests on its extension stop or flexes freely), :data:`RELATCHED` after
#: knee-strike. ``history`` packs the guard indices of the events so far (base
#: 16, the last :data:`HISTORY_DEPTH`) and ``n_logged`` counts them; ``t_*`` are
#: event times (model time units, 0 if not reached). ``min_clearance`` is the
#: lowest interior minimum of the swing foot's heel or toe height above the
#: ground since the section (:data:`NO_MINIMUM` if none); ``heel_dir`` and
#: ``toe_dir`` (+1 rising, -1 falling) tell :mod:`clearance` which extremum
#: comes next. ``shank_1_strike``, ``shank_2_strike`` are the ankle angles of
#: both legs at the step's toe-strike (the shank's from the foot's perpendicular:
#: the shank angles where both feet are flat; the heel-rise walker's raised
#: trailing foot's less its toe-pivot angle), where the springs of
#: ``ankle_reset`` are relaxed (:func:`jaxwalk.models.flatfoot.forces.rest_angles`).
CONTEXT = (
    "x_ankle_1",
    "x_toe_2",
    "y_toe_2",
    "x_heel_2",
    "ground_next",
    "knee_2",
    "history",
    "n_logged",
    "t_unlock",
    "t_knee_flex",
    "t_toe_off",
    "t_knee_strike",
    "t_heel_strike",
    "min_clearance",
    "heel_dir",
    "toe_dir",
    "shank_1_strike",
    "shank_2_strike",
)
C = {name: i for i, name in enumerate(CONTEXT)}
LATCHED, RELEASED, RELATCHED = 0.0, 1.0, 2.0
#: ``min_clearance`` before the swing foot has passed a minimum (no foot in the
#: air reaches a leg length above the ground).
NO_MINIMUM = 1.0
HISTORY_BASE = event_log.BASE
HISTORY_DEPTH = event_log.DEPTH  # 16**13 = 2**52: exact in float64


def _mask(*rows: int) -> list[float]:
    return [1.0 if i in rows else 0.0 for i in range(N_CONSTRAINTS)]


_STANCE = (ANKLE_1_X, ANKLE_1_Y, KNEE_1)
_ON_TOE_1 = (TOE_1, KNEE_1)
#: ``(8, n_c)`` which rows hold in each phase.
PHASE_MASKS = jnp.array(
    [
        _mask(*_STANCE, KNEE_2, TOE_2),
        _mask(*_STANCE, TOE_2),
        _mask(*_STANCE),
        _mask(*_STANCE, KNEE_2),
        _mask(*_STANCE, KNEE_2, HEEL_2),
        _mask(*_ON_TOE_1),
        _mask(*_ON_TOE_1, KNEE_2),
        _mask(*_ON_TOE_1, KNEE_2, HEEL_2),
    ]
)
#: Rows of the toe-strike impact: the constraints of the next step's push-off, before the swap.
TOE_STRIKE_MASK = jnp.array(_mask(KNEE_1, KNEE_2, ANKLE_2_X, ANKLE_2_Y, TOE_1))

#: ``(8,)`` the flat phase of each phase (a heel-up twin's twin): what leg 2
#: does, its guards and resets, depends on this alone.
FLAT_PHASE = jnp.array([PUSH_OFF, SHANK_RELEASE, SWING, LOCKED_SWING, HEEL_PIVOT, SWING, LOCKED_SWING, HEEL_PIVOT])
#: ``(8,)`` phases in which the stance heel is up (foot 1 pivots on its toe).
HEEL_UP = jnp.array([False] * 5 + [True] * 3)
#: Phases in which leg 2 stands on its toe, swings, or stands on its heel.
ON_TOE = jnp.array([True, True, False, False, False, False, False, False])
ON_HEEL = jnp.array([False, False, False, False, True, False, False, True])
KNEE_2_FREE = jnp.array([False, True, True, False, False, True, False, False])


def anchors(params, ctx):
    """Fixed contact points: ``toe_1, toe_2, heel_2, landing ankle_2``, each ``(2,)``."""
    a_h, a_t = geo.foot_arms(params)
    gn = ctx[C["ground_next"]]
    toe_1 = jnp.stack([ctx[C["x_ankle_1"]] + a_t, jnp.zeros_like(gn)])
    toe_2 = jnp.stack([ctx[C["x_toe_2"]], ctx[C["y_toe_2"]]])
    heel_2 = jnp.stack([ctx[C["x_heel_2"]], gn])
    land_2 = heel_2 + jnp.stack([a_h, jnp.zeros_like(gn)])
    return toe_1, toe_2, heel_2, land_2


def constraints(q, params, ctx):
    """``(n_c,)`` every constraint row; zero when it holds."""
    a_h, a_t = geo.foot_arms(params)
    ankle_1, ankle_2 = geo.ankle(q, params, 1), geo.ankle(q, params, 2)
    toe_1, toe_2, heel_2, land_2 = anchors(params, ctx)
    kappa = params["knee_lock"]
    return jnp.stack(
        [
            ankle_1[0] - ctx[C["x_ankle_1"]],
            ankle_1[1],
            geo.flexion(q, 1) - kappa,
            geo.flexion(q, 2) - kappa,
            jnp.linalg.norm(ankle_2 - toe_2) - a_t,
            jnp.linalg.norm(ankle_2 - heel_2) - a_h,
            ankle_2[0] - land_2[0],
            ankle_2[1] - land_2[1],
            jnp.linalg.norm(ankle_1 - toe_1) - a_t,
        ]
    )


def constraint_terms(q, qd, params, ctx):
    """``Sigma`` ``(n_c, 6)`` and ``Psi`` ``(n_c,)``: the Jacobian of :func:`constraints`
    and their second derivative along ``qd``, in closed form (:mod:`jaxwalk.chain`;
    the ankles are chain points). Equal to their automatic derivatives to
    rounding (tests/test_chain.py); a vector-field call runs 52 XLA kernels with
    them, 58 with the automatic ones (benchmarks/README.md, "Closed-form chain
    dynamics", which counts each piece)."""
    toe_1, toe_2, heel_2, _ = anchors(params, ctx)
    zero = jnp.zeros_like(params["l_t"])
    leg_1 = jnp.stack([params["l_t"], params["l_s"], zero, zero])
    leg_2 = jnp.stack([zero, zero, params["l_t"], params["l_s"]])
    ankle_1, v_1, jac_1, conv_1 = chain.point_terms(leg_1, q, qd)
    ankle_2, v_2, jac_2, conv_2 = chain.point_terms(leg_2, q, qd)
    _, toe_2_row, toe_2_psi = chain.distance_terms(ankle_2 - toe_2, v_2, jac_2, conv_2)
    _, heel_2_row, heel_2_psi = chain.distance_terms(ankle_2 - heel_2, v_2, jac_2, conv_2)
    _, toe_1_row, toe_1_psi = chain.distance_terms(ankle_1 - toe_1, v_1, jac_1, conv_1)
    # Rows in the order of :func:`constraints` (ANKLE_1_X ... TOE_1).
    knees = jnp.asarray([[0.0, 0.0, 1.0, -1.0, 0.0, 0.0], [0.0, 0.0, 0.0, 0.0, 1.0, -1.0]], q.dtype)
    sigma = jnp.concatenate([jac_1, knees, jnp.stack([toe_2_row, heel_2_row]), jac_2, toe_1_row[None]])
    psi = jnp.concatenate([conv_1, jnp.zeros(2, q.dtype), jnp.stack([toe_2_psi, heel_2_psi]), conv_2, toe_1_psi[None]])
    return sigma, psi


def log_event(ctx, code):
    """Append event code ``code`` (int) to the history in ``ctx``."""
    return ctx.at[C["history"]].set(event_log.append(ctx[C["history"]], code)).at[C["n_logged"]].add(1.0)


def decode_history(ctx) -> list[int]:
    """Event codes logged in ``ctx`` (oldest first; at most the last HISTORY_DEPTH). Host-side."""
    h, n = int(ctx[C["history"]]), int(ctx[C["n_logged"]])
    codes = []
    for _ in range(min(n, HISTORY_DEPTH)):
        codes.append(h % HISTORY_BASE)
        h //= HISTORY_BASE
    return codes[::-1]
