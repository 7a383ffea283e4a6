"""The flat-foot walker's period-one gait by Newton-Raphson on a central-difference
Jacobian of the SciPy step map (the seed paper's method), and its multipliers
(the heel-rise variant's Jacobian by differences inside its section:
:func:`section_jacobian`).

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
    a 2-D ``v0`` there is read as a base section point (``psi_2 = -psi``), and the
    Jacobian is taken inside the section (:func:`section_jacobian`).

    The result's ``status`` is ``"ok"`` or a failure name; ``step_info`` is the
    step at ``v*`` (:func:`tests.reference.flatfoot.step.run_step`'s dict: its
    ``time`` is the period, ``length`` the step length).
    """
    p = paper_params() if p is None else dict(p)
    v0 = np.asarray(v0, float)
    if heel_rise and v0.size == 2:
        v0 = heel_rise_point(v0)
    return fixed_point(lambda v: step_map(v, p, rtol, atol, heel_rise), v0, tol=tol, max_iter=max_iter,
                       fd_step=fd_step, final_fd_step=fd_step, richardson=richardson,
                       jacobian=section_jacobian if heel_rise else None)  # fmt: skip


#: Directions of the heel-rise section's differences (columns): ``psi`` with
#: ``psi_2 + psi`` kept (a flat trailing foot stays flat), ``psi_2`` alone (lowered,
#: it raises the trailing ankle off the ground), ``psi_dot``.
SECTION_DIRECTIONS = np.array([[1.0, 0.0, 0.0], [-1.0, 1.0, 0.0], [0.0, 0.0, 1.0]])


def section_jacobian(step_fn, v, h, args=()):
    """``dP/dv`` of the heel-rise map by differences that stay in its section.

    Points with ``psi_2 + psi > 0`` have ankle 2 below the ground, and a step from
    them ends ``scuffing`` at once (docs/model.md, "The heel-rise walker"), so at a
    heel-down gait, which lies on that boundary, a central difference in ``psi`` or
    ``psi_2`` would step out of the section. Along ``SECTION_DIRECTIONS`` the first
    difference keeps ``psi_2 + psi`` and the third does not touch it; the second
    is one-sided into the section, second order, ``(3 P(v) - 4 P(v - h e) +
    P(v - 2h e)) / 2h``, wherever ``v`` is (the same formula at every ``h``, so the
    Richardson step of :func:`~tests.reference.fixed_points.fixed_point` cancels
    its ``h^2`` term and leaves O(h^3) on that column). ``(J, None)``, or
    ``(None, info)`` of a failed step. Measured at the shoe gait (2026-12-07): Newton from
    its 2-D point converges to it (to 4.7e-11, ``psi_2 + psi`` -6.9e-10) with the
    base walker's multipliers (-0.553647, 0.275931) and a third of 1e-7.
    """
    columns = []
    for j in range(3):
        e = SECTION_DIRECTIONS[:, j]
        if j == 1:
            points, weights = (v, v - h * e, v - 2.0 * h * e), (1.5 / h, -2.0 / h, 0.5 / h)
        else:
            points, weights = (v + h * e, v - h * e), (0.5 / h, -0.5 / h)
        column = np.zeros(3)
        for point, weight in zip(points, weights):
            image, info = step_fn(point, *args)
            if info["status"] != "ok":
                return None, info
            column += weight * image
        columns.append(column)
    return np.stack(columns, axis=1) @ np.linalg.inv(SECTION_DIRECTIONS), None


def heel_rise_point(v) -> np.ndarray:
    """The heel-rise variant's section point ``(psi, -psi, psi_dot)`` of a base one ``(psi, psi_dot)``
    (both feet flat: docs/model.md, "The heel-rise walker", "Section")."""
    return np.array([float(v[0]), -float(v[0]), float(v[1])])
