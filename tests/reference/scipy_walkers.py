"""Independent NumPy/SciPy reference for the passive compass and simplest walkers.

This module is the yardstick the JAX engine is tested against, so it shares no
code with ``jaxwalk`` and derives nothing by automatic differentiation: the
equations of motion below were written by hand from Lagrange's equations in
minimal coordinates, the impact law from conservation of angular momentum,
the way Goswami, Thuilot & Espiau (1998) and Garcia, Chatterjee, Ruina &
Coleman (1998) present them.  Fixed points are found with Newton-Raphson on a
central-difference Jacobian of the step map (the method of those papers).

The reference in four modules: ``models`` (equations, impacts, energies,
coordinates and the conventions they share with the engine), ``stride`` (one
stride with SciPy, the step maps), ``fixed_points`` (Newton-Raphson) and
``step_down`` (the step-down test). This module gathers their public names:
``from tests.reference import scipy_walkers as ref``.
"""

from tests.reference.fixed_points import FixedPointResult, compass_fixed_point, fixed_point, simplest_fixed_point
from tests.reference.models import (
    COMPASS_DEFAULTS,
    COMPASS_GUESS,
    GARCIA_FIXED_POINT_0009,
    SIMPLEST_GAMMA,
    compass_energy,
    compass_impact,
    compass_params,
    compass_rhs,
    garcia_to_v,
    simplest_energy,
    simplest_guess,
    simplest_impact,
    simplest_rhs,
    state_to_v,
    v_to_garcia,
    v_to_state,
)
from tests.reference.step_down import h_max, step_down_trial
from tests.reference.stride import compass_step, compass_step_full, simplest_step, simplest_step_full, simplest_step_garcia

__all__ = [
    "COMPASS_DEFAULTS",
    "SIMPLEST_GAMMA",
    "GARCIA_FIXED_POINT_0009",
    "COMPASS_GUESS",
    "compass_params",
    "compass_rhs",
    "compass_impact",
    "compass_energy",
    "simplest_rhs",
    "simplest_impact",
    "simplest_energy",
    "v_to_state",
    "state_to_v",
    "garcia_to_v",
    "v_to_garcia",
    "simplest_guess",
    "simplest_step",
    "simplest_step_garcia",
    "simplest_step_full",
    "compass_step",
    "compass_step_full",
    "FixedPointResult",
    "fixed_point",
    "simplest_fixed_point",
    "compass_fixed_point",
    "step_down_trial",
    "h_max",
]
