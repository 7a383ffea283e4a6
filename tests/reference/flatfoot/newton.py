"""The flat-foot walker's period-one gait by Newton-Raphson on a central-difference
Jacobian of the SciPy step map (the seed paper's method), and its multipliers.

Part of :mod:`tests.reference.flatfoot`; the Newton iteration is the reference's
own (:func:`tests.reference.fixed_points.fixed_point`, shared with the simplest
and compass walkers), run on :func:`tests.reference.flatfoot.step.step_map`.

Finite-difference steps, measured at the nominal gait (rtol = atol = 1e-10):
plain central differences of the step map lose ``2.3e4 h^2`` on ``lambda_max``
(h = 1e-4: 2.3e-4; 1e-5: 2.3e-6), a fragile gait's large third derivatives, so
the Jacobian at the converged point is Richardson-extrapolated from h = 1e-5
and 2e-5 (``lambda_max`` then moves by under 1e-9 between h = 5e-6 and 2e-5).
"""

from __future__ import annotations

from typing import Mapping

import numpy as np

from tests.reference.fixed_points import FixedPointResult, fixed_point
from tests.reference.flatfoot.params import PAPER_GUESS, params as paper_params
from tests.reference.flatfoot.step import ATOL, RTOL, step_map

#: Central-difference step of the Newton iterations and of the final (Richardson) Jacobian.
FD_STEP = 1e-5
#: Newton stops when ``max|P(v) - v|`` is below this.
TOL = 1e-11


def gait(p: Mapping[str, float] | None = None, v0=PAPER_GUESS, rtol: float = RTOL, atol: float = ATOL,
         fd_step: float = FD_STEP, richardson: bool = True, tol: float = TOL, max_iter: int = 20,
         heel_rise: bool = False) -> FixedPointResult:
    """Fixed point ``v* = (psi, psi_dot)``, Jacobian ``dP/dv`` ``(2, 2)``, its eigenvalues
    and ``lambda_max`` at parameters ``p`` (the paper walker's, :data:`PAPER`, if ``None``).
    With ``heel_rise`` the heel-rise variant's: ``v* = (psi, psi_2, psi_dot)``, ``(3, 3)``;
    a 2-D ``v0`` there is read as a base section point (``psi_2 = -psi``).

    The result's ``status`` is ``"ok"`` or a failure name; ``step_info`` is the
    step at ``v*`` (:func:`tests.reference.flatfoot.step.run_step`'s dict: its
    ``time`` is the period, ``length`` the step length).
    """
    p = paper_params() if p is None else dict(p)
    v0 = np.asarray(v0, float)
    if heel_rise and v0.size == 2:
        v0 = heel_rise_point(v0)
    return fixed_point(lambda v: step_map(v, p, rtol, atol, heel_rise), v0, tol=tol, max_iter=max_iter,
                       fd_step=fd_step, final_fd_step=fd_step, richardson=richardson)  # fmt: skip


def heel_rise_point(v) -> np.ndarray:
    """The heel-rise variant's section point ``(psi, -psi, psi_dot)`` of a base one ``(psi, psi_dot)``
    (both feet flat: docs/model.md, "The heel-rise walker", "Section")."""
    return np.array([float(v[0]), -float(v[0]), float(v[1])])
