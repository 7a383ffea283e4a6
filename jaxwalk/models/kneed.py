"""Point-foot kneed walker (McGeer 1990, "Passive walking with knees"; Hsu Chen
2007, "Passive dynamic walking with knees: a point foot model", MIT thesis).

Each leg is a thigh and a shank hinged at a knee, with one point mass per
segment; a point mass ``m_h`` at the hip; point feet; passive, on a slope
``gamma``. Along a leg, from the foot up: the shank mass ``m_s`` lies ``a1``
above the foot and ``b1`` below the knee, the thigh mass ``m_t`` lies ``a2``
above the knee and ``b2`` below the hip (Hsu Chen's table 3.1 names). Shank
length ``l_s = a1 + b1``, thigh length ``l_t = a2 + b2``, leg length
``L = l_s + l_t``.

Coordinates ``q = (x_h, y_h, thigh_1, shank_1, thigh_2, shank_2)``: the hip in
the slope frame and absolute segment angles from the slope normal (engine
convention, see :mod:`jaxwalk.walker`). Knee flexion is ``thigh - shank``: a
bent knee folds the shank back, so its foot trails (smaller angle); flexion is
``>= 0`` while the knee is free and ``0`` when it is locked. Hsu Chen measures
angles from the vertical: ``angle_here = angle_hers + gamma``.

One step, two phases (leg 1 stance, leg 2 swing):

1. ``unlocked_swing``: stance knee locked, swing knee free (three links). Ends
   at knee-strike: the swing knee's flexion falls to zero while extending; a
   perfectly inelastic impact onto the swing knee's lock.
2. ``locked_swing``: both knees locked (two links, a compass walker). Ends at
   heel-strike: the swing foot reaches the ground, once the stance leg has
   passed the slope normal (the mid-stance passage does not count, as in the
   compass walker). A perfectly inelastic impact with both knees locked; the
   trailing foot leaves the ground; the legs swap labels and the new swing
   knee is released.

Knee locks. In Hsu Chen's model (and McGeer's analysis) the stance leg is one
rigid link: its knee is *latched*, holding whatever torque it must; so is the
swing knee from knee-strike to heel-strike. :class:`KneedWalker` (``"kneed"``)
is that model. A bare knee *stop* only pushes (against hyperextension):
:class:`KneedStopWalker` (``"kneed_stop"``) ends the step with ``KNEE_BUCKLED``
as soon as the stance knee's lock torque (the multiplier of its constraint)
would have to pull, including just after an impact. With Hsu Chen's defaults
the stance knee buckles right after heel-strike: her gait needs the latch
(``docs/models/kneed.md``).

The swing knee is released after heel-strike only if it would flex; if it
would hyperextend instead, it stays on its stop and the step goes straight to
``locked_swing`` (a compass-gait step).

Failures: heel-strike with the swing knee still free (``SHANK_RELEASING``),
no knee-strike within ``KNEE_TIME_LIMIT`` time scales (``TIMEOUT``), the hip
too low or a swing segment out of range (``FELL``), the stance leg turning
back before it passes the normal (``STALLED``), a swing foot landing behind
the stance foot (``SCUFFING``), a heel-strike impulse that would pull the new
stance foot down (``RUNNING``).

Section: just after heel-strike (after the swap), stance foot at the origin,
both knees straight, both feet on the ground. Independent coordinates
``v = (alpha_1, alpha_1_dot, alpha_2_dot)``: the stance leg angle and the leg
angular rates. Then ``thigh_1 = shank_1 = alpha_1``,
``thigh_2 = shank_2 = -alpha_1`` and, because the heel-strike impact acts with
both knees locked, the new swing thigh and shank share the rate ``alpha_2_dot``;
the hip position and velocity follow from the stance contact. (Hsu Chen's
section is the same with her ``q1 = alpha_1 - gamma``.)
"""

from __future__ import annotations

import math

import jax.numpy as jnp

from jaxwalk.parameters import ParamSpec, nonnegative, positive
from jaxwalk.status import Status
from jaxwalk.walker import Transition, Walker, distal

# Phase indices.
UNLOCKED, LOCKED = range(2)
# Guard indices.
HEEL_STRIKE, KNEE_STRIKE, FALL, STALL, KNEE_BUCKLE, KNEE_LATE, SWING_RANGE = range(7)
# Constraint rows.
STANCE_X, STANCE_Y, STANCE_KNEE, SWING_KNEE, SWING_X, SWING_Y = range(6)
# Context entries: the stance foot's anchor, the ground height at the next touchdown.
X_STANCE, Y_STANCE, GROUND_NEXT = range(3)

#: Hip height (fraction of leg length, normal to the slope) below which the walker has fallen.
FALL_HEIGHT = 0.5
#: Largest swing thigh or shank angle magnitude (rad) before we call it a fall.
SWING_LIMIT = 1.5
#: Longest unlocked swing (in time scales ``sqrt(L/g)``) before the knee-strike counts as missing.
KNEE_TIME_LIMIT = 4.0

_MASK_UNLOCKED = (1.0, 1.0, 1.0, 0.0, 0.0, 0.0)
_MASK_LOCKED = (1.0, 1.0, 1.0, 1.0, 0.0, 0.0)
#: Heel-strike impact: both knees locked, the new foot pinned, the trailing foot free.
_MASK_HEEL_STRIKE = (0.0, 0.0, 1.0, 1.0, 1.0, 1.0)


class KneedWalker(Walker):
    name = "kneed"
    units = {"length": "m", "time": "s"}
    description = "point-foot kneed walker, McGeer (1990) and Hsu Chen (2007)"
    parameters = (
        ParamSpec(
            "gamma", math.asin(7.25 / 144.0), "rad", "slope angle (downhill positive)", lower=-0.5, upper=0.5
        ),
        positive("m_h", 0.5, "kg", "hip mass"),
        positive("m_t", 0.5, "kg", "thigh mass (each leg)"),
        positive("m_s", 0.05, "kg", "shank mass (each leg)"),
        nonnegative("a1", 0.375, "m", "distance from foot to shank mass"),
        positive("b1", 0.125, "m", "distance from shank mass to knee"),
        nonnegative("a2", 0.175, "m", "distance from knee to thigh mass"),
        positive("b2", 0.325, "m", "distance from thigh mass to hip"),
        positive("g", 9.81, "m s-2", "gravitational acceleration"),
    )
    coordinates = ("x_h", "y_h", "thigh_1", "shank_1", "thigh_2", "shank_2")
    phases = ("unlocked_swing", "locked_swing")
    guards = ("heel_strike", "knee_strike", "fall", "stall", "knee_buckle", "knee_late", "swing_range")
    context = ("x_stance", "y_stance", "ground_next")
    ground_next = GROUND_NEXT
    section_names = ("alpha_1", "alpha_1_dot", "alpha_2_dot")
    # As the compass gait's (its ray extents along the signed axes at the
    # default gait, unscaled: 0.032 / 0.029, 0.088 / 0.25, 1.18 / 1.46;
    # docs/global_stability.md): each scale the mean of its axis's two extents.
    basin_radius = 1.0
    basin_scale = (0.031, 0.17, 1.3)
    # stance foot (x, y), stance knee lock, swing knee lock, swing foot (x, y)
    n_constraints = 6
    # The elemental emitters compile its gait search 1.2-1.4x faster and run
    # it, 64 configurations together, 2-3 % slower (benchmarks/README.md): a
    # cold run is mostly compiling.
    cpu_fusion_emitters = False
    #: Whether the stance knee's lock is a bare stop (pushes only) rather than a latch.
    stance_knee_stop: bool = False

    # ------------------------------------------------------------ geometry
    @staticmethod
    def lengths(params):
        """``(l_t, l_s, L)``: thigh, shank and leg length."""
        l_t = params["a2"] + params["b2"]
        l_s = params["a1"] + params["b1"]
        return l_t, l_s, l_t + l_s

    def time_scale(self, params):
        *_, leg = self.lengths(params)
        return jnp.sqrt(leg / params["g"])

    def knees(self, q, params):
        """``(2, 2)`` positions of knee 1 (stance) and knee 2 (swing)."""
        l_t, _, _ = self.lengths(params)
        hip = q[:2]
        return jnp.stack([hip + l_t * distal(q[2]), hip + l_t * distal(q[4])])

    def feet(self, q, params):
        """``(2, 2)`` positions of foot 1 (stance) and foot 2 (swing)."""
        _, l_s, _ = self.lengths(params)
        knees = self.knees(q, params)
        return jnp.stack([knees[0] + l_s * distal(q[3]), knees[1] + l_s * distal(q[5])])

    def points(self, q, params):
        """Hip; thigh 1, shank 1; thigh 2, shank 2 (``(5, 2)``)."""
        hip = q[:2]
        knees = self.knees(q, params)
        b1, b2 = params["b1"], params["b2"]
        return jnp.stack(
            [
                hip,
                hip + b2 * distal(q[2]),
                knees[0] + b1 * distal(q[3]),
                hip + b2 * distal(q[4]),
                knees[1] + b1 * distal(q[5]),
            ]
        )

    def masses(self, params):
        m_t, m_s = params["m_t"], params["m_s"]
        return jnp.stack([params["m_h"], m_t, m_s, m_t, m_s])

    def constraints(self, q, params, ctx):
        feet = self.feet(q, params)
        return jnp.stack(
            [
                feet[0, 0] - ctx[X_STANCE],
                feet[0, 1] - ctx[Y_STANCE],
                q[2] - q[3],
                q[4] - q[5],
                # The swing x row's value is never used: it only enters the
                # heel-strike impact, which needs its Jacobian.
                feet[1, 0],
                feet[1, 1] - ctx[GROUND_NEXT],
            ]
        )

    def constraint_mask(self, phase, params):
        return jnp.where(phase == LOCKED, jnp.array(_MASK_LOCKED), jnp.array(_MASK_UNLOCKED))

    # ------------------------------------------------------------ events
    def knee_lock_torque(self, y, params, phase, ctx):
        """Torque of the stance knee's lock, in units of ``M g L`` (scalar).

        Positive when it pushes against hyperextension (the flexing sense), as
        a stop can; negative when it must hold the knee from flexing, which
        only a latch can (``M`` the total mass, ``L`` the leg length).
        """
        _, lam = self.dynamics(y, params, phase, ctx)
        *_, leg = self.lengths(params)
        weight = jnp.sum(self.masses(params)) * params["g"] * leg
        return lam[STANCE_KNEE] / weight

    def release_phase(self, y, params, ctx):
        """Phase that starts a step from a state with both knees straight.

        ``unlocked_swing`` when the freed swing knee would flex, else
        ``locked_swing`` (the knee stays on its stop).
        """
        qdd, _ = self.dynamics(y, params, jnp.asarray(UNLOCKED, jnp.int32), ctx)
        return jnp.where(qdd[4] - qdd[5] > 0.0, UNLOCKED, LOCKED).astype(jnp.int32)

    def guard_values(self, t, y, params, phase, ctx):
        q, qd = self.split(y)
        *_, leg = self.lengths(params)
        feet = self.feet(q, params)
        stance, flexion, flexion_rate = q[2], q[4] - q[5], qd[4] - qd[5]
        unlocked = phase == UNLOCKED
        # Open only after the stance leg passed the normal: there the swing foot
        # is at height >= drop >= 0 whatever its knee, so opening is never a crossing.
        heel = jnp.where(stance < 0.0, feet[1, 1] - ctx[GROUND_NEXT], 1.0)
        # Open only while the knee extends: it opens at the largest flexion (> 0).
        # Just after heel-strike flexion and its rate are both zero: closed.
        knee = jnp.where(unlocked & (flexion_rate < 0.0), flexion, 1.0)
        fall = q[1] / leg - FALL_HEIGHT
        stall = jnp.where(stance > 0.0, -qd[2], 1.0)
        if self.stance_knee_stop:
            buckle = self.knee_lock_torque(y, params, phase, ctx)
        else:
            buckle = jnp.ones((), y.dtype)
        late = jnp.where(unlocked, KNEE_TIME_LIMIT * self.time_scale(params) - t, 1.0)
        swing = SWING_LIMIT - jnp.maximum(jnp.abs(q[4]), jnp.abs(q[5]))
        return jnp.stack([heel, knee, fall, stall, buckle, late, swing])

    def on_event(self, guard, t, y, params, phase, ctx):
        q, _ = self.split(y)
        feet = self.feet(q, params)

        # Knee-strike: the swing knee locks; the stance foot stays pinned.
        y_knee, _ = self.apply_impact(y, params, ctx, jnp.array(_MASK_LOCKED))

        # Heel-strike: the swing foot becomes the pivot, the trailing foot lifts off.
        y_heel, impulses = self.apply_impact(y, params, ctx, jnp.array(_MASK_HEEL_STRIKE))
        q_p, qd_p = self.split(y_heel)
        shift = feet[1, 0]
        swapped_q = jnp.stack([q_p[0] - shift, q_p[1] - ctx[GROUND_NEXT], q_p[4], q_p[5], q_p[2], q_p[3]])
        swapped_qd = jnp.stack([qd_p[0], qd_p[1], qd_p[4], qd_p[5], qd_p[2], qd_p[3]])
        y_swapped = jnp.concatenate([swapped_q, swapped_qd])
        ctx_swapped = jnp.zeros_like(ctx)
        ahead = feet[1, 0] > feet[0, 0]
        pushes = impulses[SWING_Y] > 0.0
        heel_status = jnp.select(
            [phase == UNLOCKED, ~ahead, ~pushes],
            [Status.SHANK_RELEASING, Status.SCUFFING, Status.RUNNING],
            Status.IN_PROGRESS,
        )

        is_heel = guard == HEEL_STRIKE
        is_knee = guard == KNEE_STRIKE
        status = jnp.select(
            [is_heel, is_knee, guard == STALL, guard == KNEE_BUCKLE, guard == KNEE_LATE],
            [heel_status, Status.IN_PROGRESS, Status.STALLED, Status.KNEE_BUCKLED, Status.TIMEOUT],
            Status.FELL,
        )
        done = is_heel & (heel_status == Status.IN_PROGRESS)
        y_out = jnp.where(done, y_swapped, jnp.where(is_knee, y_knee, y))
        ctx_out = jnp.where(done, ctx_swapped, ctx)
        phase_out = jnp.where(done, self.release_phase(y_swapped, params, ctx_swapped), jnp.where(is_knee, LOCKED, phase))
        if self.stance_knee_stop:
            # An impact changes the accelerations, so the lock torque jumps: a
            # start below zero is no downward crossing and no guard would see it.
            goes_on = done | (status == Status.IN_PROGRESS)
            pulls = self.knee_lock_torque(y_out, params, phase_out, ctx_out) < 0.0
            buckled = goes_on & pulls
            status = jnp.where(buckled, Status.KNEE_BUCKLED, status)
            done = done & ~buckled
            y_out = jnp.where(buckled, y, y_out)
            ctx_out = jnp.where(buckled, ctx, ctx_out)
            phase_out = jnp.where(buckled, phase, phase_out)
        return Transition(
            phase_out.astype(jnp.int32), y_out, ctx_out, status.astype(jnp.int8), done, jnp.where(done, shift, 0.0)
        )

    # ------------------------------------------------------------ section
    def section_to_state(self, v, params):
        *_, leg = self.lengths(params)
        a1, a1d, a2d = v[0], v[1], v[2]
        q = jnp.stack([-leg * jnp.sin(a1), leg * jnp.cos(a1), a1, a1, -a1, -a1])
        qd = jnp.stack([-leg * jnp.cos(a1) * a1d, -leg * jnp.sin(a1) * a1d, a1d, a1d, a2d, a2d])
        ctx = jnp.zeros(len(self.context), v.dtype)
        y = jnp.concatenate([q, qd])
        return y, self.release_phase(y, params, ctx), ctx

    def state_to_section(self, y, params, ctx):
        return jnp.stack([y[2], y[8], y[10]])

    def initial_guess(self, params):
        # The period-one gait of the defaults (Hsu Chen's table 3.1 and slope),
        # as found here by Newton's method; rates scaled to the model's time unit.
        omega = 1.0 / self.time_scale(params)
        return jnp.stack([jnp.asarray(0.2385), -0.3542 * omega, -0.0184 * omega])

    # ------------------------------------------------------------ drawing
    def skeleton(self, q, params, ctx):
        """``(2, 3, 2)`` polylines of leg 1 (stance) and leg 2 (swing): hip, knee,
        foot, in the slope frame (for figures; :mod:`jaxwalk.figures`)."""
        hip = q[:2]
        knees = self.knees(q, params)
        feet = self.feet(q, params)
        return jnp.stack([jnp.stack([hip, knees[i], feet[i]]) for i in range(2)])

    def foot_points(self, q, params, ctx):
        """``(2, 1, 2)`` the points of foot 1 and foot 2 that can touch the ground
        (point feet), in the slope frame (for foot clearance)."""
        return self.feet(q, params)[:, None, :]


class KneedStopWalker(KneedWalker):
    """The kneed walker whose stance knee is held by a bare stop, not a latch:
    the step ends with ``KNEE_BUCKLED`` when the stop would have to pull."""

    name = "kneed_stop"
    description = "point-foot kneed walker with a push-only stance knee stop"
    stance_knee_stop = True
