"""Equations of motion and inelastic impacts of the reference flat-foot walker.

Part of :mod:`tests.reference.flatfoot`. Within a phase the active rows hold:

    [ M        -Sigma_a^T ] [ qdd    ]   [ F      ]
    [ Sigma_a   0         ] [ lambda ] = [ -Psi_a ]

(``M qdd = F + Sigma^T lambda``; docs/model.md's sign of the multipliers). An
impact onto rows ``R`` is perfectly inelastic: ``M (qd+ - qd-) = Sigma_R^T
Lambda`` with ``Sigma_R qd+ = 0`` (docs/model.md, "Impacts"). Rows not active
have zero multiplier.
"""

from __future__ import annotations

from typing import Mapping, Sequence

import numpy as np

from tests.reference.flatfoot import kinematics as kin
from tests.reference.flatfoot.constraints import N_C, active_rows, constraint_terms
from tests.reference.flatfoot.forces import joint_forces, spring_energy
from tests.reference.flatfoot.params import N_Q


def _kkt(mass: np.ndarray, sigma: np.ndarray, rhs_top: np.ndarray, rhs_bottom: np.ndarray, rows: Sequence[int]):
    rows = list(rows)
    s = sigma[rows]
    m = len(rows)
    a = np.zeros((N_Q + m, N_Q + m))
    a[:N_Q, :N_Q] = mass
    a[:N_Q, N_Q:] = -s.T
    a[N_Q:, :N_Q] = s
    x = np.linalg.solve(a, np.concatenate([rhs_top, rhs_bottom]))
    full = np.zeros(N_C)
    full[rows] = x[N_Q:]
    return x[:N_Q], full


def accelerations(y: np.ndarray, p: Mapping[str, float], phase: int, ctx: dict) -> tuple[np.ndarray, np.ndarray]:
    """``(qdd (6,), lambda (9,))`` in ``phase``; ``y = (q, qd)``, ``(12,)``."""
    q, qd = y[:N_Q], y[N_Q:]
    mass, force = kin.mass_matrix_and_forces(q, qd, p)
    force = force + joint_forces(q, p, phase, ctx)
    _, sigma, psi = constraint_terms(q, qd, p, ctx)
    rows = active_rows(phase)
    return _kkt(mass, sigma, force, -psi[list(rows)], rows)


def vector_field(y: np.ndarray, p: Mapping[str, float], phase: int, ctx: dict) -> np.ndarray:
    """``dy/dt``, ``(12,)``."""
    qdd, _ = accelerations(y, p, phase, ctx)
    return np.concatenate([y[N_Q:], qdd])


def impact(y: np.ndarray, p: Mapping[str, float], ctx: dict, rows: Sequence[int]) -> tuple[np.ndarray, np.ndarray]:
    """State just after an inelastic impact onto ``rows`` ``(12,)``, and the impulses ``(9,)``."""
    q, qd = y[:N_Q], y[N_Q:]
    mass = kin.mass_matrix(q, p)
    _, sigma, _ = constraint_terms(q, qd, p, ctx)
    qd_plus, impulses = _kkt(mass, sigma, mass @ qd, np.zeros(len(rows)), rows)
    return np.concatenate([q, qd_plus]), impulses


def energy(y: np.ndarray, p: Mapping[str, float], phase: int, ctx: dict) -> float:
    """Kinetic + gravity + spring energy (M g L)."""
    q, qd = y[:N_Q], y[N_Q:]
    return kin.kinetic_energy(q, qd, p) + kin.gravity_potential(q, p) + spring_energy(q, p, phase, ctx)
