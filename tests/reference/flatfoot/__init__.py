"""Independent NumPy/SciPy reference of the flat-foot walker (docs/model.md).

A second implementation of jaxwalk's seed walker, written from docs/model.md
with no jaxwalk and no JAX import: the mass matrix, the constraint Jacobians,
their convective terms and the spring forces are derived by hand (each leg a
double pendulum from the hip; distances and ``atan2`` differentiated on paper),
the step is ``scipy.integrate.solve_ivp(method="DOP853", rtol=1e-10,
atol=1e-10)`` with terminal events, and the gait is Newton-Raphson on a
central-difference Jacobian (the seed paper's method). It checks the JAX model
(tests/test_flatfoot.py) and is the baseline of benchmarks/scipy_baseline.py.

Modules, one concept each: ``params`` (the paper walker's parameters, indices, the stored guess),
``kinematics`` (points, Jacobians, mass matrix), ``constraints`` (rows,
``Sigma``, ``Psi``, phase table), ``forces`` (springs, hip torque, ground
reactions), ``dynamics`` (equations of motion, impacts, energy), ``guards``,
``resets`` (events, impacts' checks, the leg swap), ``step`` (section and step
map), ``newton`` (fixed point, Jacobian, multipliers).

What the engine checks during a step, and what is here: every guard of
docs/model.md's table (unlock, knee_flex, toe_off, knee_strike with its gate,
heel_strike, toe_strike, fall, leg_range, stall, running, scuff, slip,
knee_buckle) is a terminal event in the phases where it applies; the entry
checks (a toe that would pull leaves, a released knee whose stop would pull
flexes, a failure guard already due, a heel pivot not toe-up, a trailing heel
that would sink), the engine's start rule (a guard below -1e-9 when a phase
starts is an event there), the impulse checks of the three impacts, heel-strike
on a released knee or a rising heel, and the limits on phase time (12) and
events (16). Left out or done differently, none of which changes a step of the
paper's walker: the swing foot's height extrema (``heel_extremum``, ``toe_extremum``)
are non-terminal events here, not phase ends: they change no state, so the
integration runs through them (the engine restarts its solver at each: the same
trajectory to integration accuracy), and they still count towards the event
limit and give ``min_clearance``; there is no step-down entry point (the
ground ahead is level, ``ground_next = 0``, though the geometry reads it). The
engine's own statuses have their counterparts: ``timeout``, ``solver_failed``,
``too_many_events``, ``nonfinite``.

The heel-rise variant (docs/model.md, "The heel-rise walker"; ``heel_rise=True``
on ``section_to_state``, ``state_to_section``, ``step_map`` and ``gait``; the
step's ``ctx`` then carries ``"heel_rise": True``, which ``run_step`` reads) is
written into the same modules: the heel-up twins of swing, locked swing and heel
pivot (phases 5-7, ``params.TWIN``; in a twin everything of leg 2 is its flat
phase's, ``params.leg_2_phase``), the stance foot on its toe (``forces.stance_toe``),
the guards ``heel_rise`` and ``heel_drop`` (no entry check: ankle 1's
acceleration, ``resets.ankle_1_lift``, has the guard's sign, which the tests
check), the trailing spring's rest angle reset from its ankle angle (shank less
foot) at toe-strike, and the 3-D section ``(psi, psi_2, psi_dot)``
(``newton.heel_rise_point`` maps a base point onto it). Without the flag every
step is the base walker's, bit for bit; the toe-1 impulse check at toe-strike
is in both (zero for a flat foot), and so is ``trailing_reset`` (the share of
``ankle_reset`` the trailing spring gets).

A limit of this reference (both walkers), found with the variant: SciPy's
event detection looks for sign changes at the solver's steps, so a gated guard
whose gate closes within one step (the swing heel landing past toe 1 and
moving back behind it before the step ends, at the shoe walker with
``ankle_reset = 1``, ``k = 0.2``) or a guard that dips below zero and back
within one step (a grazing toe-strike) is missed; there the reference ends
``scuffing`` where jaxwalk locates the heel-strike. With ``max_step = 0.01`` the
two agree (the variant's next point to 1e-8).
"""

from tests.reference.flatfoot.newton import gait, heel_rise_point
from tests.reference.flatfoot.params import PAPER, PAPER_GUESS, params
from tests.reference.flatfoot.step import run_step, section_to_state, state_to_section, step_map

__all__ = ["PAPER", "PAPER_GUESS", "params", "gait", "heel_rise_point", "run_step", "section_to_state",
           "state_to_section", "step_map"]
