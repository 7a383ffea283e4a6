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
"""

from tests.reference.flatfoot.newton import gait
from tests.reference.flatfoot.params import PAPER, PAPER_GUESS, params
from tests.reference.flatfoot.step import run_step, section_to_state, state_to_section, step_map

__all__ = ["PAPER", "PAPER_GUESS", "params", "gait", "run_step", "section_to_state", "state_to_section", "step_map"]
