"""The flat-foot walker (Wang, Wei, Wang & Lv): knees, flat feet on ankle springs, hip torque.

A point mass at the hip (upper body), a point mass on each thigh and shank,
the foot's mass at the ankle, rigid massless flat feet on linear torsional ankle
springs, knees that lock and unlock, a constant hip torque ``P`` and an optional
hip spring ``k_hip``. Units:
total mass M = leg length L = g = 1 (time in ``sqrt(L/g)``). See
``docs/model.md`` for every modelling decision and its source.

Section: just after toe-strike (legs swapped), stance ankle at the origin, both
feet flat, both knees locked. That state has one configuration and one velocity
degree of freedom; ``v = (psi, psi_dot)``, the stance leg's chord angle (hip to
ankle, from the slope normal, positive with the ankle ahead of the hip) and its
rate. The trailing leg's chord angle is ``-psi`` (both ankles on the ground).
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
from jaxtyping import Array, Float

from jaxwalk import mechanics
from jaxwalk.models.flatfoot import events, forces, heel_rise
from jaxwalk.models.flatfoot import limits as contact_limits
from jaxwalk.models.flatfoot import geometry as geo
from jaxwalk.models.flatfoot import phases as ph
from jaxwalk.parameters import ParamSpec, nonnegative, positive
from jaxwalk.walker import Walker

#: The paper's walker: the walker options at the paper's values (constant hip
#: torque only, the knee locking at once, the swing foot perpendicular to the
#: shank, a floor penetration of up to 0.03 L tolerated, unbounded friction).
#: These were the defaults until the shoe walker replaced them (docs/model.md,
#: "Defaults and the paper's walker"); every preset below is absolute over these keys.
PAPER_PARAMS = {
    "P": 0.0076, "swing_torque": 0.0, "k_hip": 0.0, "ankle_push": 0.0, "heel_brake": 0.0,
    "hip_double_support": 1.0, "swing_dorsi": 0.0, "knee_gate": 0.0, "scuff_tol": 0.03, "mu": 1e6, "ankle_rest": 0.0,
    "ankle_reset": 0.0, "trailing_reset": 1.0,
}  # fmt: skip
#: Its gait ``(psi, psi_dot)`` (docs/model.md, "Defaults and the paper's walker": the nominal gait).
PAPER_GAIT = (0.16327572732, -0.186444529299)
#: Parameters of the admissible hip-spring gait: a hip
#: spring and more hip torque swing the leg faster, so the knee is still flexed as
#: the swing foot passes the stance foot; the swing foot is turned toe-up so it
#: clears the ground at toe-off; no floor penetration is tolerated (docs/model.md,
#: "The hip-spring gait").
HIP_SPRING_PARAMS = {**PAPER_PARAMS, "k_hip": 0.125, "P": 0.0566, "swing_dorsi": 0.1, "knee_gate": 1.0, "scuff_tol": 0.0}
#: Its fixed point ``(psi, psi_dot)``.
HIP_SPRING_GAIT = (0.16811061518, -0.24466430626)
#: Parameters of the push-off gait, the human-like
#: regime of issue 14: the hip-spring walker with an ankle push-off torque in
#: double support, a stiffer hip spring and less hip torque, at Froude number
#: about 0.1-0.15 (docs/model.md, "The push-off gait").
PUSH_OFF_PARAMS = {**HIP_SPRING_PARAMS, "ankle_push": 0.09, "k_hip": 0.2, "P": 0.035}
#: Its fixed point ``(psi, psi_dot)``.
PUSH_OFF_GAIT = (0.276956094048, -0.394675360412)
#: Parameters of the swing-hip gait: the push-off walker with half its hip torque
#: and hip spring in double support, where they only squeeze the feet against
#: the ground's friction, and a heel-brake torque that loads the landing heel
#: from the first instant (docs/model.md, "The swing-hip gait").
SWING_HIP_PARAMS = {**PUSH_OFF_PARAMS, "hip_double_support": 0.5, "heel_brake": 0.01}
#: Its fixed point ``(psi, psi_dot)``.
SWING_HIP_GAIT = (0.307231367500, -0.390491088404)
#: Parameters of the shoe gait, the model's defaults: the swing-hip walker with a
#: softer hip spring and more hip torque, walking with a shoe's friction
#: coefficient (mu = 0.8) checked at every contact (docs/model.md, "The shoe gait").
SHOE_PARAMS = {**SWING_HIP_PARAMS, "k_hip": 0.12, "P": 0.045, "mu": 0.8}
#: Its fixed point ``(psi, psi_dot)``, the gait of the defaults.
SHOE_GAIT = (0.324519973953, -0.373398980250)

#: The documented gaits, ``(parameters, fixed point)``, in the order :func:`_documented` numbers them.
DOCUMENTED_GAITS = (
    (PAPER_PARAMS, PAPER_GAIT),
    (HIP_SPRING_PARAMS, HIP_SPRING_GAIT),
    (PUSH_OFF_PARAMS, PUSH_OFF_GAIT),
    (SWING_HIP_PARAMS, SWING_HIP_GAIT),
    (SHOE_PARAMS, SHOE_GAIT),
)


def _documented(params):
    """Index in :data:`DOCUMENTED_GAITS` of the gait nearest ``params`` (traced or plain floats)."""
    push_off = params["ankle_push"] >= 0.5 * PUSH_OFF_PARAMS["ankle_push"]
    swing_hip = params["hip_double_support"] <= 0.75
    shoe = swing_hip & (params["mu"] <= 1.0)
    hip_spring = params["k_hip"] >= 0.5 * HIP_SPRING_PARAMS["k_hip"]
    return jnp.where(push_off, jnp.where(swing_hip, jnp.where(shoe, 4, 3), 2), jnp.where(hip_spring, 1, 0))


#: Rows that hold at the start of a step (push-off), used to build the section's velocity.
_SECTION_ROWS = (ph.ANKLE_1_X, ph.ANKLE_1_Y, ph.KNEE_1, ph.KNEE_2, ph.TOE_2)


class FlatFootWalker(Walker):
    name = "flatfoot"
    description = "flat-foot walker with knees, ankle springs and hip torque, Wang, Wei, Wang & Lv"
    # The defaults are the shoe walker's (SHOE_PARAMS); PAPER_PARAMS gives the paper's.
    parameters = (
        ParamSpec("gamma", 0.0, "rad", "slope angle (downhill positive)", lower=-0.5, upper=0.5),
        positive("m_h", 0.678, "1", "hip and upper-body point mass"),
        positive("m_t", 0.100, "1", "thigh point mass (each leg)"),
        positive("m_s", 0.0465, "1", "shank point mass (each leg)"),
        nonnegative("m_f", 0.0145, "1", "foot mass, lumped at the ankle (each leg)"),
        positive("l_t", 0.5, "1", "thigh length, hip to knee"),
        positive("l_s", 0.5, "1", "shank length, knee to ankle"),
        ParamSpec("c_t", 0.433, "1", "thigh mass position below the hip, fraction of l_t", lower=0.0, upper=1.0),
        ParamSpec("c_s", 0.433, "1", "shank mass position below the knee, fraction of l_s", lower=0.0, upper=1.0),
        positive("l_f", 0.22, "1", "foot length, heel to toe"),
        positive("r", 0.4, "1", "foot ratio, (heel to ankle) / (ankle to toe)"),
        nonnegative("k", 0.03, "1", "ankle spring stiffness"),
        ParamSpec("ankle_rest", 0.0, "rad", "shank angle from the foot's perpendicular at which the ankle spring of a foot on the ground is relaxed (positive: shank leaning back, ankle plantarflexed)", lower=0.0, upper=0.5),
        ParamSpec("ankle_reset", 0.0, "1", "fraction of each leg's shank angle at the step's toe-strike added to ankle_rest (1 with ankle_rest 0: both springs start every step relaxed, their stored energy lost at toe-strike, the trailing one by its share trailing_reset; 0: the rest angle is ankle_rest)", lower=0.0, upper=1.0),
        ParamSpec("trailing_reset", 1.0, "1", "fraction of ankle_reset applied to the trailing foot's spring (0: only the stance spring is relaxed at toe-strike; the trailing spring stays relaxed at ankle_rest and keeps the rest of what it stored in stance for push-off)", lower=0.0, upper=1.0),
        ParamSpec("P", 0.045, "1", "hip torque, + on the swing thigh, - on the stance thigh"),
        nonnegative("swing_torque", 0.0, "1",
                    "hip torque added to P in phase swing (foot 2 in the air, knee free; M g L), + on the swing thigh"),
        nonnegative("k_hip", 0.12, "1", "hip spring stiffness between the thighs (M g L per rad), relaxed with the thighs together"),
        nonnegative("ankle_push", 0.09, "1", "push-off torque at the trailing ankle while its foot pivots on its toe (M g L), toe-down on the foot"),
        nonnegative("heel_brake", 0.01, "1", "dorsiflexor torque at the landing ankle while its foot pivots on its heel (M g L), resisting the foot's fall to flat"),
        ParamSpec("hip_double_support", 0.5, "1", "fraction of the hip torque and hip spring acting while both feet touch the ground (0: the hip drives the swing leg only)", lower=0.0, upper=1.0),
        nonnegative("delay", 0.066, "1", "knee-unlock delay after toe-strike"),
        ParamSpec("knee_lock", 0.2, "rad", "knee flexion at the extension stop, where a knee locks", lower=0.0, upper=0.5),
        nonnegative("scuff_tol", 0.0, "1", "allowed depth of the swing foot below ground"),
        ParamSpec("rho_t", 0.0, "1", "thigh radius of gyration about its centre of mass, fraction of l_t", lower=0.0, upper=0.5),
        ParamSpec("rho_s", 0.0, "1", "shank radius of gyration about its centre of mass, fraction of l_s", lower=0.0, upper=0.5),
        ParamSpec("knee_gate", 1.0, "1", "1: the swing knee latches only after its ankle passes the stance ankle (the paper's gate); 0: at once", lower=0.0, upper=1.0),
        ParamSpec("swing_dorsi", 0.1, "rad", "swing foot turned toe-up from perpendicular to the shank", lower=-0.5, upper=0.5),
        positive("mu", 0.8, "1", "friction coefficient at every ground contact"),
        # A contact impulse pulls (or slides) when it is more tensile (or further
        # outside the friction cone) than this fraction of the impact's largest
        # normal impulse: the check scales with the impacts that occur (a fixed
        # 0.01 M sqrt(gL) would exceed every heel-strike impulse).
        nonnegative("impulse_tol", 0.01, "1", "allowed tensile (or sliding) contact impulse, fraction of the impact's largest normal impulse"),
        ParamSpec("stance_latch", 1.0, "1", "1: locked knees are latched (may pull); 0: on their extension stop only (KNEE_BUCKLED when it would pull)", lower=0.0, upper=1.0),
    )
    coordinates = ("x_h", "y_h", "thigh_1", "shank_1", "thigh_2", "shank_2")
    phases = ph.PHASE_NAMES
    guards = events.GUARD_NAMES
    limits = contact_limits.LIMIT_NAMES
    limit_guards = ("slip", "slip", "foot_roll", "foot_roll")  # of stance_friction, heel_friction, cop_toe, cop_heel
    failure_guards = tuple(events.GUARD_NAMES[g] for g in events.FAILURES)
    context = ph.CONTEXT
    event_log = ("history", "n_logged")  # every phase's end and the step's failure; the clearance extrema are not logged
    # The stance heel stays down until the other foot is flat (the paper's
    # phases); FlatFootHeelRiseWalker lets it rise.
    heel_rise = False
    ground_next = ph.C["ground_next"]
    section_names = ("psi", "psi_dot")
    # The half-spans of the default (shoe) gait's basin image
    # (sweeps/basin_flatfoot_shoe.toml; docs/global_stability.md).
    basin_radius = 1.0
    basin_scale = (0.12, 0.25)
    # A quarter of this walker's solver steps were rejected at diffrax's 0.9;
    # 0.75 takes 9.5 % fewer, with more accurate gaits (benchmarks/README.md).
    step_safety = 0.75
    n_constraints = ph.N_CONSTRAINTS
    # One configuration (or continuation line) at a time per device: where the
    # swing scuffs, falls or stalls, a step, a Newton search or a drop costs
    # many times a normal one, and in a vmapped batch everyone waits for it.
    # Measured on the (l_f, r) map's longest-foot quarter (1024 points, 2
    # devices, benchmarks/README.md): 690 s at 8 lines per batch, 110 s at 2,
    # 53 s at 1; on uniform batches vmap gains at most 1.7x (bench_flatfoot.py).
    lockstep_batch = 1
    # One configuration at a time leaves the fusion emitters' vectorised loops
    # nothing to do: the elemental emitters compile the gait search 1.3-1.7x
    # faster and run it as fast; the 64 x 64 map takes half the memory
    # (benchmarks/README.md).
    cpu_fusion_emitters = False

    # ------------------------------------------------------------ mechanics
    def points(self, q, params):
        return geo.points(q, params)

    def masses(self, params):
        return geo.masses(params)

    def chain_weights(self, params):
        return geo.chain_weights(params)

    def constraints(self, q, params, ctx):
        return ph.constraints(q, params, ctx)

    def constraint_mask(self, phase, params):
        return ph.PHASE_MASKS[phase]

    def constraint_terms(self, q, qd, params, ctx):
        return ph.constraint_terms(q, qd, params, ctx)

    def joint_forces(self, q, qd, params, phase, ctx):
        return forces.joint_forces(q, params, phase, ctx, self.heel_rise)

    def spring_energy(self, q, params, phase, ctx):
        return forces.spring_energy(q, params, phase, ctx, self.heel_rise)

    # ------------------------------------------------------------ events
    def guard_values(self, t, y, params, phase, ctx):
        return events.guard_values(self, t, y, params, phase, ctx)

    def on_event(self, guard, t, y, params, phase, ctx):
        return events.on_event(self, guard, t, y, params, phase, ctx)

    # ------------------------------------------------------------ section
    def section_to_state(self, v, params):
        """Full state just after toe-strike from ``v = (psi, psi_dot)`` (see the module docstring)."""
        psi, psi_dot = v[0], v[1]
        length, delta = geo.chord(params)
        _, a_t = geo.foot_arms(params)
        kappa = params["knee_lock"]
        hip = -length * geo.distal(psi)
        th1, th2 = psi + delta, -psi + delta
        q = jnp.stack([hip[0], hip[1], th1, th1 - kappa, th2, th2 - kappa])
        ctx = jnp.zeros(len(self.context), v.dtype).at[ph.C["min_clearance"]].set(ph.NO_MINIMUM)
        ctx = ctx.at[ph.C["x_toe_2"]].set(-2.0 * length * jnp.sin(psi) + a_t)
        ctx = ctx.at[ph.C["shank_1_strike"]].set(q[geo.SHANK_1]).at[ph.C["shank_2_strike"]].set(q[geo.SHANK_2])
        return self._push_off_start(q, psi_dot, params, ctx)

    def _push_off_start(self, q, psi_dot, params, ctx):
        """``(y, phase, ctx)`` at the section from its configuration ``q``, ``psi_dot``
        and its discrete state ``ctx`` (anchors and strike angles set)."""
        # Velocity: the push-off constraints hold, and thigh_1 turns at psi_dot.
        sigma = jax.jacfwd(ph.constraints)(q, params, ctx)[jnp.array(_SECTION_ROWS)]
        lhs = jnp.concatenate([sigma, jnp.eye(6, dtype=q.dtype)[geo.THIGH_1][None]], axis=0)
        rhs = jnp.zeros(6, q.dtype).at[-1].set(psi_dot)
        qd = mechanics.solve(lhs, rhs)  # order 6: the unrolled elimination (mechanics.solve)
        y = jnp.concatenate([q, qd])
        t0 = jnp.zeros((), q.dtype)
        # A toe that would pull leaves at once, a knee that would pull flexes at
        # once; a failure already due at t = 0 is the engine's event at the start.
        phase, ctx, _ = events.settle(self, t0, y, params, jnp.asarray(ph.PUSH_OFF, jnp.int32), ctx)
        return y, phase, ctx

    def state_to_section(self, y, params, ctx):
        _, delta = geo.chord(params)
        return jnp.stack([y[geo.THIGH_1] - delta, y[6 + geo.THIGH_1]])

    def initial_guess(self, params):
        """The documented gait nearest ``params`` in push-off torque, then in the hip's
        share in double support, then in hip-spring stiffness (docs/model.md).

        Five gaits are documented: the paper's walker's of :data:`PAPER_PARAMS` (no
        hip spring; to 3e-8, its step-map residual 1.3e-8 at the default
        tolerances, and the SciPy walker in tests/reference/flatfoot agrees with
        the polished point to 1.6e-8); the hip-spring gait of :data:`HIP_SPRING_PARAMS`, which walks
        with the swing foot above the ground all swing; the push-off gait of
        :data:`PUSH_OFF_PARAMS`, which does so at a human Froude number; and the
        swing-hip gait of :data:`SWING_HIP_PARAMS`, whose stance foot and landing
        heel need friction coefficients of 0.28 and 0.24 where the push-off gait's
        need 1.11 and 3.1; where also ``mu <= 1``, the shoe gait of
        :data:`SHOE_PARAMS`, which walks with ``mu = 0.8`` at every contact: the
        gait of the defaults.
        """
        return jnp.asarray([gait for _, gait in DOCUMENTED_GAITS])[_documented(params)]

    def guess_made_at(self, params):
        """The parameters of the documented gait :meth:`initial_guess` gives at ``params``."""
        return DOCUMENTED_GAITS[int(_documented(params))][0]

    # ------------------------------------------------------------ extras
    def limit_use(self, y, params, phase, ctx):
        """Use of the contact limits in :attr:`limits`; see :func:`~jaxwalk.models.flatfoot.limits.limit_use`."""
        return contact_limits.limit_use(self, y, params, phase, ctx)

    def reactions(self, y, params, phase, ctx):
        """Ground reactions ``(stance, cop, toe_2, heel_2)``; see :func:`forces.contact_reactions`."""
        q, _ = self.split(y)
        _, lam = self.dynamics(y, params, phase, ctx)
        return forces.contact_reactions(q, lam, params, phase, ctx, self.heel_rise)

    def actuator_power(self, q, qd, params, phase, ctx):
        """Power of the hip and ankle actuators (the recorder integrates it to work)."""
        return forces.actuator_power(q, qd, params, phase, ctx)

    def actuator_work(self, y_start, y_end, params, phase, ctx):
        """Hip and ankle actuators' work between two states of one phase."""
        return forces.actuator_work(y_start[:6], y_end[:6], params, phase, ctx)

    # ------------------------------------------------------------ drawing
    def _feet(self, q, params, ctx):
        """``(2, 2, 2)`` heel and toe of foot 1 (stance) and foot 2.

        Foot 2's pose is read off the geometry (figures get no phase): pivoting on
        its toe or heel anchor while the ankle sits at the arm's distance from it
        (the contact constraint holds), else held perpendicular to its shank.
        """
        a_h, a_t = geo.foot_arms(params)
        ankle_1, ankle_2 = geo.ankle(q, params, 1), geo.ankle(q, params, 2)
        toe_1, toe_2, heel_2, _ = ph.anchors(params, ctx)
        # Foot 1 stands flat, or in the heel-rise walker on its toe (angle 0 when flat).
        phi_1 = geo.toe_pivot_angle(ankle_1, toe_1) if self.heel_rise else jnp.zeros_like(a_h)
        e_1 = geo.foot_direction(phi_1)
        foot_1 = jnp.stack([ankle_1 - a_h * e_1, ankle_1 + a_t * e_1])
        on_toe = jnp.abs(jnp.linalg.norm(ankle_2 - toe_2) - a_t) < 1e-6
        on_heel = jnp.abs(jnp.linalg.norm(ankle_2 - heel_2) - a_h) < 1e-6
        e_toe = geo.foot_direction(geo.toe_pivot_angle(ankle_2, toe_2))
        e_heel = geo.foot_direction(geo.heel_pivot_angle(ankle_2, heel_2))
        free_heel, free_toe = geo.free_foot(q, params, 2)
        e = jnp.where(on_toe, e_toe, e_heel)
        pivoting = on_toe | on_heel
        heel = jnp.where(pivoting, ankle_2 - a_h * e, free_heel)
        toe = jnp.where(pivoting, ankle_2 + a_t * e, free_toe)
        return jnp.stack([foot_1, jnp.stack([heel, toe])])

    def skeleton(self, q, params, ctx):
        """``(2, 5, 2)`` polylines hip, knee, ankle, heel, toe of leg 1 and leg 2
        in the slope frame (for :mod:`jaxwalk.figures`)."""
        feet = self._feet(q, params, ctx)
        legs = []
        for i, leg in enumerate((1, 2)):
            legs.append(jnp.stack([q[:2], geo.knee(q, params, leg), geo.ankle(q, params, leg), feet[i, 0], feet[i, 1]]))
        return jnp.stack(legs)

    def foot_points(self, q, params, ctx):
        """``(2, 2, 2)`` heel and toe of each foot (for foot clearance)."""
        return self._feet(q, params, ctx)


class FlatFootHeelRiseWalker(FlatFootWalker):
    """The flat-foot walker whose stance heel may rise before the other foot is flat.

    Three more phases, heel-up twins of swing, locked swing and heel pivot, and
    two events, ``heel_rise`` and ``heel_drop`` (:mod:`heel_rise`), so that a
    stiff (human) ankle tips the stance foot onto its toe instead of ending the
    step ``FOOT_ROLLING``. The section is ``v = (psi, psi_2, psi_dot)``: a step
    that ends with the stance heel up leaves the new trailing foot on its toe
    with its ankle above the ground, at chord angle ``psi_2`` (``-psi`` when
    both feet are flat). docs/model.md, "The heel-rise walker".
    """

    name = "flatfoot_heel_rise"
    description = "flat-foot walker whose stance heel may rise before the other foot lands flat"
    heel_rise = True
    phases = ph.HEEL_RISE_PHASE_NAMES
    guards = events.HEEL_RISE_GUARD_NAMES
    section_names = ("psi", "psi_2", "psi_dot")
    # The base walker's half-spans, psi's for psi_2.
    basin_scale = (0.12, 0.12, 0.25)
    cannot_step_up = ("its section keeps the trailing foot's height and its step assumes both feet on one level "
                      "ground (docs/model.md, \"The heel-rise walker\")")

    def section_to_state(self, v, params):
        """Full state just after toe-strike from ``v = (psi, psi_2, psi_dot)``.

        The trailing toe is on the ground ahead of ankle 2 at the foot's toe arm;
        where ankle 2 is below the ground (not a state of the walker, but a point
        Newton may try) the same formulas continue smoothly, and a step from there
        ends ``SCUFFING`` at its start (:func:`heel_rise.trailing_heel_landing`).
        """
        psi, psi_2, psi_dot = v[0], v[1], v[2]
        length, delta = geo.chord(params)
        _, a_t = geo.foot_arms(params)
        kappa = params["knee_lock"]
        hip = -length * geo.distal(psi)
        th1, th2 = psi + delta, psi_2 + delta
        q = jnp.stack([hip[0], hip[1], th1, th1 - kappa, th2, th2 - kappa])
        ankle_2 = geo.ankle(q, params, 2)
        ctx = jnp.zeros(len(self.context), v.dtype).at[ph.C["min_clearance"]].set(ph.NO_MINIMUM)
        ctx = ctx.at[ph.C["x_toe_2"]].set(ankle_2[0] + jnp.sqrt(a_t**2 - ankle_2[1] ** 2))
        ctx = ctx.at[ph.C["shank_1_strike"]].set(q[geo.SHANK_1])
        return self._push_off_start(q, psi_dot, params, heel_rise.relax_trailing_spring(q, params, ctx))

    def state_to_section(self, y, params, ctx):
        _, delta = geo.chord(params)
        return jnp.stack([y[geo.THIGH_1] - delta, y[geo.THIGH_2] - delta, y[6 + geo.THIGH_1]])

    def into_section(self, v: Float[Array, "3"], params) -> Float[Array, "3"]:
        """``v`` with ankle 2 raised to the ground where the step counts it as sunk.

        Ankle 2's height is ``A (cos psi - cos psi_2)`` (both chords ``A`` long).
        Where it is more than :data:`heel_rise.SUNK_TOL` below the ground (a step
        from there ends ``SCUFFING`` at its start), ``psi_2`` alone moves to the
        nearer root of that height: ``-|psi|``, both feet flat with the trailing
        foot behind, or ``+|psi|`` (the legs together) if ``psi_2 > 0``. Within
        ``SUNK_TOL`` (the integrator's drift of a flat foot) and above, ``v`` is
        returned as it is. A heel-down gait lies on the edge, and Newton's linear
        step towards it from a heel-up side can cross it (docs/model.md,
        "Contacts and starts").
        """
        psi, psi_2 = v[0], v[1]
        length, _ = geo.chord(params)
        sunk = length * (jnp.cos(psi) - jnp.cos(psi_2)) < -heel_rise.SUNK_TOL
        edge = jnp.where(psi_2 > 0.0, 1.0, -1.0) * jnp.abs(psi)
        return v.at[1].set(jnp.where(sunk, edge, psi_2))

    def initial_guess(self, params):
        """The base walker's documented gait (:meth:`FlatFootWalker.initial_guess`), both feet flat: ``psi_2 = -psi``."""
        psi, psi_dot = super().initial_guess(params)
        return jnp.stack([psi, -psi, psi_dot])
