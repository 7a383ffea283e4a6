"""Compass-gait walker (Goswami, Thuilot, Espiau 1998) and its limit, the
simplest walking model (Garcia, Chatterjee, Ruina, Coleman 1998).

Two rigid straight legs of length ``l = a + b`` hinged at the hip, a point mass
``m_h`` at the hip and a point mass ``m`` on each leg a distance ``a`` above the
foot (``b`` below the hip); point feet; passive, on a slope ``gamma``.

Single support, split at mid-stance (the stance leg passing the slope normal)
into two phases with the same dynamics: before it the swing foot's passage
through the ground is ignored, as in both papers; at it the swing leg must be
ahead of the stance leg (else its foot would meet the ground at the stance
foot later: ``SCUFFING``); after it, heel-strike is the swing foot reaching the
ground, a perfectly inelastic impact after which the trailing foot leaves the
ground, then the legs swap labels. The split makes both guards monotone
where they matter, so a long solver step cannot step over a brief dip of the
foot below the ground.

Section: just after heel-strike (after the swap), stance foot at the origin.
Independent coordinates ``v = (alpha_1, alpha_1_dot, alpha_2_dot)``: the stance
leg angle and both leg angular velocities (``alpha_2 = -alpha_1``, both feet on
the ground; the hip velocity follows from the stance contact).
"""

from __future__ import annotations

import jax.numpy as jnp

from jaxwalk.parameters import ParamSpec, nonnegative, positive
from jaxwalk.status import Status
from jaxwalk.walker import Transition, Walker, distal

# Guard indices.
HEEL_STRIKE, FALL, STALL, SWING_RANGE, MIDSTANCE = range(5)
# Phases.
EARLY, LATE = 0, 1
# Context entries: the stance foot's x anchor, the ground height at the next touchdown.
X_STANCE, GROUND_NEXT = range(2)

#: Hip height (fraction of leg length, normal to the slope) below which the walker has fallen.
FALL_HEIGHT = 0.5
#: Largest swing-leg angle magnitude (rad) before we call it a fall.
SWING_LIMIT = 1.5
#: A heel-strike must land the swing foot this far (fraction of leg length) ahead
#: of the stance foot; otherwise the guard's root is the legs-together one (the
#: swing foot meeting the ground at the stance foot after mid-stance): a scuff.
MIN_STEP_FRACTION = 0.01


class CompassWalker(Walker):
    name = "compass"
    description = "compass-gait walker, Goswami, Thuilot & Espiau (1998)"
    parameters = (
        ParamSpec("gamma", 0.0523598775598, "rad", "slope angle (downhill positive)", lower=-0.5, upper=0.5),
        positive("m", 5.0, "kg", "leg mass"),
        positive("m_h", 10.0, "kg", "hip mass"),
        nonnegative("a", 0.5, "m", "distance from foot to leg mass"),
        positive("b", 0.5, "m", "distance from leg mass to hip"),
        positive("g", 9.81, "m s-2", "gravitational acceleration"),
    )
    coordinates = ("x_h", "y_h", "alpha_1", "alpha_2")
    phases = ("single_support_early", "single_support_late")
    guards = ("heel_strike", "fall", "stall", "swing_range", "midstance")
    context = ("x_stance", "ground_next")
    ground_next = GROUND_NEXT
    section_names = ("alpha_1", "alpha_1_dot", "alpha_2_dot")
    # The basin of the default gait is thin in alpha_1 and alpha_1_dot and long
    # in alpha_2_dot (ray extents along the signed axes, unscaled: 0.018 / 0.035,
    # 0.062 / 0.14-0.20, 0.89 / 1.37; docs/global_stability.md): each scale is
    # the mean of its axis's two extents.
    basin_radius = 1.0
    basin_scale = (0.026, 0.1, 1.1)
    n_constraints = 4  # stance foot (x, y), swing foot (x, y)
    units = {"length": "m", "time": "s"}

    # The mass model; the simplest walker overrides this one method.
    def mass_model(self, params) -> tuple:
        """``(m, m_h, a, b, g)`` as scalars."""
        return params["m"], params["m_h"], params["a"], params["b"], params["g"]

    def leg_length(self, params):
        _, _, a, b, _ = self.mass_model(params)
        return a + b

    def time_scale(self, params):
        _, _, a, b, g = self.mass_model(params)
        return jnp.sqrt((a + b) / g)

    def gravity(self, params):
        *_, g = self.mass_model(params)
        gamma = self.slope(params)
        return g * jnp.stack([jnp.sin(gamma), -jnp.cos(gamma)])

    # ------------------------------------------------------------ kinematics
    def feet(self, q, params):
        """``(2, 2)`` positions of foot 1 (stance) and foot 2 (swing)."""
        l = self.leg_length(params)
        hip = q[:2]
        return jnp.stack([hip + l * distal(a) for a in (q[2], q[3])])

    def points(self, q, params):
        _, _, _, b, _ = self.mass_model(params)
        hip = q[:2]
        legs = [hip + b * distal(a) for a in (q[2], q[3])]
        return jnp.stack([hip, *legs])

    def masses(self, params):
        m, m_h, *_ = self.mass_model(params)
        return jnp.stack([m_h, m, m])

    def constraints(self, q, params, ctx):
        feet = self.feet(q, params)
        return jnp.stack(
            # The swing row's x value is never used: it only enters impacts, which
            # need its Jacobian, not its value.
            [feet[0, 0] - ctx[X_STANCE], feet[0, 1], feet[1, 0], feet[1, 1] - ctx[GROUND_NEXT]]
        )

    def constraint_mask(self, phase, params):
        return jnp.array([1.0, 1.0, 0.0, 0.0])

    # ------------------------------------------------------------ events
    def guard_values(self, t, y, params, phase, ctx):
        q, qd = self.split(y)
        l = self.leg_length(params)
        feet = self.feet(q, params)
        a1, a2 = q[2], q[3]
        early = phase == EARLY
        # Mid-stance: the stance leg reaches the slope normal (alpha_1 is monotone,
        # so no solver step can miss it). Before it, the swing foot's passage
        # through the ground is ignored, as in both papers.
        midstance = jnp.where(early, a1, 1.0)
        # After it the swing foot is ahead of the hip and can only come down.
        heel = jnp.where(early, 1.0, feet[1, 1] - ctx[GROUND_NEXT])
        fall = q[1] / l - FALL_HEIGHT
        # Walking forward, the stance leg always rotates forward (alpha_1 decreasing).
        stall = -qd[2]
        swing = SWING_LIMIT - jnp.abs(a2)
        return jnp.stack([heel, fall, stall, swing, midstance])

    def on_event(self, guard, t, y, params, phase, ctx):
        q, _ = self.split(y)
        feet = self.feet(q, params)
        # Heel-strike: the swing foot becomes the pivot, the trailing foot lifts off.
        y_plus, _ = self.apply_impact(y, params, ctx, jnp.array([0.0, 0.0, 1.0, 1.0]))
        q_p, qd_p = self.split(y_plus)
        shift = feet[1, 0]
        swapped_q = jnp.stack([q_p[0] - shift, q_p[1] - ctx[GROUND_NEXT], q_p[3], q_p[2]])
        swapped_qd = jnp.stack([qd_p[0], qd_p[1], qd_p[3], qd_p[2]])
        y_next = jnp.concatenate([swapped_q, swapped_qd])
        ahead = feet[1, 0] - feet[0, 0] > MIN_STEP_FRACTION * self.leg_length(params)
        heel_status = jnp.where(ahead, Status.IN_PROGRESS, Status.SCUFFING)
        # At mid-stance a swing leg still behind the stance leg must cross it
        # later, below the hip: its foot meets the ground at the stance foot.
        # At t = 0 (the step's start) it means the new stance foot landed behind
        # the hip (after a large drop): the walker pitches forward, a fall.
        mid_status = jnp.where(
            t <= 0.0, Status.FELL, jnp.where(q[3] > q[2], Status.IN_PROGRESS, Status.SCUFFING)
        )
        status = jnp.select(
            [guard == HEEL_STRIKE, guard == STALL, guard == MIDSTANCE],
            [heel_status, Status.STALLED, mid_status],
            Status.FELL,
        ).astype(jnp.int8)
        done = (guard == HEEL_STRIKE) & ahead
        y_out = jnp.where(done, y_next, y)
        ctx_out = jnp.where(done, jnp.zeros_like(ctx), ctx)
        next_phase = jnp.where(done, EARLY, jnp.where(guard == MIDSTANCE, LATE, phase)).astype(jnp.int32)
        return Transition(next_phase, y_out, ctx_out, status, done, jnp.where(done, shift, 0.0))

    # ------------------------------------------------------------ section
    def section_to_state(self, v, params):
        l = self.leg_length(params)
        a1, a1d, a2d = v[0], v[1], v[2]
        q = jnp.stack([-l * jnp.sin(a1), l * jnp.cos(a1), a1, -a1])
        qd = jnp.stack([-l * jnp.cos(a1) * a1d, -l * jnp.sin(a1) * a1d, a1d, a2d])
        return jnp.concatenate([q, qd]), jnp.asarray(0, jnp.int32), jnp.zeros(len(self.context), v.dtype)

    def state_to_section(self, y, params, ctx):
        return jnp.stack([y[2], y[6], y[7]])

    def initial_guess(self, params):
        # The default parameters' gait (l = 1 m, g = 9.81), rates rescaled to
        # this config's natural frequency sqrt(g / l).
        omega = 1.0 / (self.time_scale(params) * jnp.sqrt(9.81))
        return jnp.stack([0.271 * jnp.ones_like(omega), -1.092 * omega, -0.377 * omega])

    # ------------------------------------------------------------ drawing
    def skeleton(self, q, params, ctx):
        """``(2, 2, 2)`` polylines of leg 1 (stance) and leg 2 (swing), hip to foot,
        in the slope frame (for figures; :mod:`jaxwalk.figures`)."""
        hip = q[:2]
        feet = self.feet(q, params)
        return jnp.stack([jnp.stack([hip, feet[0]]), jnp.stack([hip, feet[1]])])

    def foot_points(self, q, params, ctx):
        """``(2, 1, 2)`` the points of foot 1 and foot 2 that can touch the ground
        (point feet), in the slope frame (for foot clearance)."""
        return self.feet(q, params)[:, None, :]
