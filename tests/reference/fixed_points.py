"""Period-one gaits of the reference walkers: Newton-Raphson on a central-difference
Jacobian of the step map (the method of Goswami et al. and Garcia et al.).

Part of the independent NumPy/SciPy reference (``tests.reference.scipy_walkers``).
"""

from __future__ import annotations

import collections
import math
from typing import Callable, Mapping

import numpy as np

from tests.reference.models import COMPASS_GUESS, RTOL, SIMPLEST_GAMMA, simplest_guess
from tests.reference.stride import compass_step, simplest_step

# --------------------------------------------------------------------------- fixed points


class FixedPointResult(collections.namedtuple("FixedPointResult", "v J eigenvalues lambda_max")):
    """Result of :func:`fixed_point`; unpacks as ``(v, J, eigenvalues, lambda_max)``.

    Extra attributes: ``status`` (str), ``n_iter`` (Newton iterations), ``residual``
    (max-norm of ``P(v) - v`` at ``v``), ``step_info`` (info dict of the step at ``v``).
    """


def _jacobian(step_fn: Callable, v: np.ndarray, fd_step: float, args: tuple):
    n = v.size
    J = np.empty((n, n))
    for j in range(n):
        dv = np.zeros(n)
        dv[j] = fd_step
        vp, ip = step_fn(v + dv, *args)
        vm, im = step_fn(v - dv, *args)
        if ip["status"] != "ok" or im["status"] != "ok":
            return None, ip if ip["status"] != "ok" else im
        J[:, j] = (vp - vm) / (2.0 * fd_step)
    return J, None


def _extrapolated(jacobian: Callable, step_fn: Callable, v, h: float, args: tuple, richardson: bool):
    """``jacobian`` at step ``h``, Richardson-extrapolated from ``h`` and ``2h`` if asked: ``(J, bad)``."""
    J, bad = jacobian(step_fn, v, h, args)
    if J is None or not richardson:
        return J, bad
    J2, bad = jacobian(step_fn, v, 2.0 * h, args)
    return (None, bad) if J2 is None else ((4.0 * J - J2) / 3.0, None)


def fixed_point(step_fn: Callable, v0, args: tuple = (), tol: float = 1e-12, max_iter: int = 30,
                fd_step: float = 1e-6, final_fd_step: float = 2e-5,
                richardson: bool = True, max_halvings: int = 10, jacobian: Callable | None = None) -> FixedPointResult:
    """Period-one fixed point of a step map by Newton-Raphson (central-difference Jacobian).

    Args:
        step_fn: ``step_fn(v, *args) -> (v_next, info)`` with ``info["status"]``.
        v0: initial guess, shape ``(n,)``.
        args: extra positional arguments of ``step_fn``.
        tol: convergence when ``max|P(v) - v| < tol`` (or the Newton update
            falls below ``tol / 10``).
        max_iter: Newton iterations.
        max_halvings: a Newton update whose step fails (walker falls, stalls, ...)
            is halved up to this many times (damped Newton); plain Newton otherwise.
        fd_step: central-difference step on each coordinate (Newton iterations).
        final_fd_step, richardson: the Jacobian returned at the converged point is
            ``(4 J(h) - J(2h)) / 3`` with ``h = final_fd_step`` (Richardson-extrapolated
            central differences, error O(h^4) instead of O(h^2): ~1e-10 on the
            eigenvalues instead of ~1e-8); with ``richardson=False`` it is the plain
            central difference ``J(fd_step)``.
        jacobian: ``jacobian(step_fn, v, h, args) -> (J, None)``, or ``(None, info)`` of
            a failed step, in place of central differences on each coordinate (a
            section with a boundary needs differences that stay inside it). It must
            use the same formulas at ``h`` and ``2h``, each with a leading error
            ``c h^2``, so that the Richardson step cancels it (O(h^4) for central
            differences, O(h^3) for one-sided second-order ones).

    Returns:
        :class:`FixedPointResult`: ``v`` (shape ``(n,)``), ``J`` (``(n, n)``,
        ``dP/dv`` at ``v``), ``eigenvalues`` (``(n,)``, complex, sorted by decreasing
        modulus), ``lambda_max`` (largest modulus); NaNs and a non-"ok" ``status``
        on failure.
    """
    v = np.array(v0, dtype=float)
    n = v.size
    _jacobian_at = _jacobian if jacobian is None else jacobian
    nan_out = (np.full(n, math.nan), np.full((n, n), math.nan), np.full(n, math.nan + 0j), math.nan)

    def failed(status, it, res, info):
        out = FixedPointResult(*nan_out)
        out.status, out.n_iter, out.residual, out.step_info = status, it, res, info
        return out

    last_dv = math.inf
    pv, info = step_fn(v, *args)
    if info["status"] != "ok":
        return failed(info["status"], 0, math.nan, info)
    for it in range(max_iter + 1):
        r = pv - v
        res = float(np.max(np.abs(r)))
        converged = res < tol or last_dv < tol / 10
        h = final_fd_step if converged and richardson else fd_step
        J, bad = _extrapolated(_jacobian_at, step_fn, v, h, args, converged and richardson)
        if J is None:
            return failed(bad["status"], it, res, bad)
        if converged:
            eig = np.linalg.eigvals(J).astype(complex)
            eig = eig[np.argsort(-np.abs(eig), kind="stable")]
            out = FixedPointResult(v, J, eig, float(np.max(np.abs(eig))))
            out.status, out.n_iter, out.residual, out.step_info = "ok", it, res, info
            return out
        if it == max_iter:
            break
        try:
            dv = np.linalg.solve(J - np.eye(n), -r)
        except np.linalg.LinAlgError:
            return failed("no_convergence", it, res, info)
        # Safeguard: halve the Newton update while the step from v + dv fails.
        for _ in range(max_halvings + 1):
            pv_try, info_try = step_fn(v + dv, *args)
            if info_try["status"] == "ok":
                break
            dv = 0.5 * dv
        else:
            return failed("no_convergence", it, res, info_try)
        v, pv, info = v + dv, pv_try, info_try
        last_dv = float(np.max(np.abs(dv)))
    return failed("no_convergence", max_iter, res, info)


def simplest_fixed_point(gamma: float = SIMPLEST_GAMMA, v0=None, rtol: float = RTOL,
                         scuffing: str = "fail", **kwargs) -> FixedPointResult:
    """Stable gait of the simplest walker on the 3-D section (guess :func:`simplest_guess`).

    ``kwargs`` go to :func:`fixed_point`.
    """
    v0 = simplest_guess(gamma) if v0 is None else v0
    return fixed_point(lambda v: simplest_step(v, gamma, rtol=rtol, scuffing=scuffing), v0, **kwargs)


def compass_fixed_point(params: Mapping[str, float] | None = None, v0=None, rtol: float = RTOL,
                        scuffing: str = "fail", **kwargs) -> FixedPointResult:
    """Period-one gait of the compass walker (guess :data:`COMPASS_GUESS`, made for the defaults).

    ``kwargs`` go to :func:`fixed_point`.
    """
    v0 = COMPASS_GUESS if v0 is None else v0
    return fixed_point(lambda v: compass_step(v, params, rtol=rtol, scuffing=scuffing), v0, **kwargs)
