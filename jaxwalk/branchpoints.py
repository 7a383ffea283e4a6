"""Bifurcations on pseudo-arclength branches: detected, located, switched at.

Along a :class:`jaxwalk.arclength.Branch` the fold, flip and Neimark-Sacker
test functions of :func:`jaxwalk.bifurcation.indicators` are evaluated at
every point; a sign change between points ``i`` and ``i + 1`` is a bracket
in the arclength ``s`` of the step from ``i``: the points ``u(s)`` solving
``F(u) = 0``, ``t_i . (u - u_i) = s`` (the corrector's own system) run from
``u_i`` (``s = 0``) to ``u_(i+1)`` (``s = ds_(i+1)``). Each bracket is shrunk
by Illinois regula falsi on the test function (every fourth trial a
bisection), one corrector solve per trial, all brackets of all branches in
one ``vmap`` per iteration, until narrower than ``2 tol`` in ``s``; the
located point is the corrector's solution at the bracket's midpoint. Since
``|dp/ds| <= 1`` on a unit tangent (to first order in the bracket), its
parameter is within ``tol`` of the test function's root; at a fold (``p``
extremal along the branch) much closer.

A fold test sign change is labelled ``FOLD`` where the tangent's parameter
component changes sign in the bracket (the branch turns back), else
``BRANCH_POINT`` (a multiplier +1 without a turn: branches cross there,
e.g. the period-1 branch seen as a period-2 one at its flip). Neimark-Sacker
changes whose pair is real (a neutral saddle) are dropped.

:func:`switch_at_flip` starts the period-``2k`` branch at a located flip of a
period-``k`` branch: from the flip point ``u*`` along ``(w, 0)`` (``w`` the
multiplier ``-1``'s eigenvector), the pitchfork of ``P^2k``'s tangent, the
first point solves ``w . (v - v*) = eps``.
"""

from __future__ import annotations

import dataclasses
import functools
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from jaxwalk import compiling
from jaxwalk.arclength import ArclengthOptions, Branch, CycleProblem, continue_branch, correct, equations
from jaxwalk.bifurcation import Kind, indicators
from jaxwalk.status import Status

#: Corrector solves per program call during location (padding rows repeat the last).
CALL_ROWS = 16


class BranchPoints(NamedTuple):
    """A table of located points (one row each), rows ordered by branch then arclength.

    Attributes:
        kind: int8 :class:`jaxwalk.bifurcation.Kind`.
        parameter: the continuation parameter there.
        branch: index of the branch (leading axis of the batch given).
        index: the branch point ``i`` that starts the bracket (``i`` to ``i + 1``).
        period: k of the branch.
        status: int8 ``OK``, or why the location failed (the row is then the bracket's midpoint, not to ``tol``).
        v: ``(n_v,)`` the fixed point of ``P^k`` there.
        multipliers: ``(n_v,)`` complex, there.
        eigenvector: ``(n_v,)`` real unit eigenvector of the multiplier nearest the critical one
            (+1 for folds and branch points, -1 for flips; NaN for Neimark-Sacker).
        s: arclength from point ``index``.
    """

    kind: np.ndarray
    parameter: np.ndarray
    branch: np.ndarray
    index: np.ndarray
    period: np.ndarray
    status: np.ndarray
    v: np.ndarray
    multipliers: np.ndarray
    eigenvector: np.ndarray
    s: np.ndarray


@functools.lru_cache(maxsize=None)
def _corrector(problem, options: ArclengthOptions):
    """Batched corrector: rows ``(params, u_base, t_base, s)`` -> ``(u, jacobian, status)``."""

    def one(params, u_base, t_base, s):
        residual, project = equations(problem, params)
        u, jac, status, _ = correct(residual, project, u_base + s * t_base, u_base, t_base, s, options)
        return u, jac, status

    # A walker's cycles compile with its options; a problem without a model
    # (a plain map, as the tests' folds) with XLA's defaults.
    return compiling.jit(jax.vmap(one), getattr(problem, "model", None))


def solve_at(problem, options, params, u_base, t_base, s):
    """The corrector at rows of ``(params, u_base, t_base, s)`` (NumPy in and out), in calls of :data:`CALL_ROWS`."""
    program = _corrector(problem, options)
    n = len(s)
    outs = []
    for lo in range(0, n, CALL_ROWS):
        idx = np.minimum(np.arange(lo, lo + CALL_ROWS), n - 1)
        rows = [jax.tree_util.tree_map(lambda x: jnp.asarray(np.asarray(x)[idx]), a) for a in (params, u_base, t_base, s)]
        outs.append([np.asarray(o)[: min(CALL_ROWS, n - lo)] for o in program(*rows)])
    return tuple(np.concatenate([o[j] for o in outs]) for j in range(3))


def brackets(branches: Branch) -> list[tuple[int, int, int, int]]:
    """``(kind, column, branch, i)`` for every test-function sign change between points ``i`` and ``i + 1``."""
    mu = np.asarray(branches.multipliers).reshape((-1,) + branches.multipliers.shape[-2:])
    n_points = np.asarray(branches.n_points).reshape(-1)
    tests = indicators(np.where(np.isfinite(mu), mu, 0.0))
    out = []
    for b, n in enumerate(n_points):
        for i in range(int(n) - 1):
            for column, kind in ((0, Kind.FOLD), (1, Kind.FLIP), (2, Kind.NEIMARK_SACKER)):
                if tests[b, i, column] * tests[b, i + 1, column] < 0:
                    out.append((kind, column, b, i))
    return out


def locate_on_branches(problem, params, branches: Branch, tol: float = 1e-6, max_iter: int = 80,
                       options: ArclengthOptions = ArclengthOptions(), advance=None) -> BranchPoints:
    """Every fold, flip and Neimark-Sacker point of a batch of branches, located to ``tol`` in arclength.

    Args:
        problem: the branches' (:class:`jaxwalk.arclength.CycleProblem`).
        params: the branches' model parameters, each leaf ``(n_branches,)`` (as the branches were run under vmap).
        branches: :class:`Branch` with leading axis ``n_branches``.
        advance: ``None``, or ``advance(n)`` called once per round of batched corrector
            solves (at most ``max_iter + 1``: a progress bar's).
    """
    advance = advance or (lambda n: None)
    found = brackets(branches)
    n_v, k = branches.v.shape[-1], problem.period
    if not found:
        return _table([], n_v, k)
    kind, column, b, i = (np.array(c) for c in zip(*found))
    u = np.concatenate([np.asarray(branches.v), np.asarray(branches.p)[..., None]], -1)
    u_i, t_i = u[b, i], np.asarray(branches.tangent)[b, i]
    rows = {key: np.asarray(val)[b] for key, val in params.items()}
    lo, hi = np.zeros(len(b)), np.asarray(branches.ds)[b, i + 1].copy()
    tests = indicators(np.asarray(branches.multipliers))
    f_lo, f_hi = tests[b, i, column].copy(), tests[b, i + 1, column].copy()
    state = np.full(len(b), Status.IN_PROGRESS, np.int8)
    side = np.zeros(len(b), np.int8)  # the end kept last: Illinois halves the other's value when kept twice
    for it in range(max_iter):
        active = (state == Status.IN_PROGRESS) & (hi - lo > 2 * tol)
        state[(state == Status.IN_PROGRESS) & ~active] = Status.OK
        if not active.any():
            break
        secant = hi - f_hi * (hi - lo) / (f_hi - f_lo)
        width = hi - lo
        trial = np.where((it % 4 == 3) | ~np.isfinite(secant), 0.5 * (lo + hi),
                         np.clip(secant, lo + 0.01 * width, hi - 0.01 * width))
        idx = np.flatnonzero(active)
        advance(1)
        _, jac, st = solve_at(problem, options, {kk: x[idx] for kk, x in rows.items()}, u_i[idx], t_i[idx], trial[idx])
        mu = np.linalg.eigvals(np.where(np.isfinite(jac[:, :, :n_v]), jac[:, :, :n_v], 0.0) + np.eye(n_v))
        f_t = indicators(mu)[np.arange(len(idx)), column[idx]]
        state[idx[st != Status.OK]] = st[st != Status.OK]
        for j, g in enumerate(idx):
            if st[j] != Status.OK:
                continue
            if np.sign(f_t[j]) == np.sign(f_lo[g]):
                lo[g], f_lo[g] = trial[g], f_t[j]
                f_hi[g] *= 0.5 if side[g] == 1 else 1.0
                side[g] = 1
            else:
                hi[g], f_hi[g] = trial[g], f_t[j]
                f_lo[g] *= 0.5 if side[g] == -1 else 1.0
                side[g] = -1
    state[state == Status.IN_PROGRESS] = Status.NOT_LOCATED
    mid = 0.5 * (lo + hi)
    advance(1)
    u_m, jac_m, st_m = solve_at(problem, options, rows, u_i, t_i, mid)
    t_next = np.asarray(branches.tangent)[b, i + 1]
    out = []
    for r in range(len(b)):
        mu, vec = np.linalg.eig(jac_m[r][:, :n_v] + np.eye(n_v))
        if kind[r] == Kind.NEIMARK_SACKER and not _complex_pair_on_circle(mu):
            continue
        label = kind[r]
        if kind[r] == Kind.FOLD and np.sign(t_i[r, -1]) == np.sign(t_next[r, -1]):
            label = Kind.BRANCH_POINT
        target = -1.0 if kind[r] == Kind.FLIP else 1.0
        j = int(np.argmin(np.abs(mu - target)))
        w = np.real(vec[:, j]) / np.linalg.norm(np.real(vec[:, j])) if kind[r] != Kind.NEIMARK_SACKER else np.full(n_v, np.nan)
        order = np.argsort(-np.abs(mu))
        out.append({"kind": label, "parameter": u_m[r, -1], "branch": b[r], "index": i[r], "s": mid[r],
                    "status": state[r] if state[r] != Status.OK else st_m[r], "v": u_m[r, :-1],
                    "multipliers": mu[order], "eigenvector": w})
    out.sort(key=lambda row: (row["branch"], row["index"], row["s"]))
    return _table(out, n_v, k)


def _complex_pair_on_circle(mu: np.ndarray) -> bool:
    """Whether the pair of multipliers with product nearest 1 is a complex-conjugate pair."""
    i, j = np.triu_indices(mu.shape[-1], 1)
    nearest = int(np.argmin(np.abs(mu[i] * mu[j] - 1.0)))
    return abs(mu[i[nearest]].imag) > 1e-6 and abs(mu[i[nearest]] - np.conj(mu[j[nearest]])) < 1e-6


def _table(rows: list[dict], n_v: int, k: int) -> BranchPoints:
    col = lambda key, dtype: np.array([r[key] for r in rows], dtype)
    return BranchPoints(
        kind=col("kind", np.int8), parameter=col("parameter", np.float64), branch=col("branch", np.int32),
        index=col("index", np.int32), period=np.full(len(rows), k, np.int32), status=col("status", np.int8),
        v=np.array([r["v"] for r in rows], np.float64).reshape(-1, n_v),
        multipliers=np.array([r["multipliers"] for r in rows], np.complex128).reshape(-1, n_v),
        eigenvector=np.array([r["eigenvector"] for r in rows], np.float64).reshape(-1, n_v),
        s=col("s", np.float64),
    )


def switch_direction(point_v, eigenvector, parameter, sign=1.0):
    """``(u*, t0)``: the flip point ``(v*, p*)`` and the unit direction ``(sign w, 0)`` of the
    period-doubled branch (JAX arrays; traceable, so :func:`switch_at_flip` vmaps)."""
    v = jnp.asarray(point_v, jnp.float64)
    u = jnp.concatenate([v, jnp.asarray(parameter, v.dtype)[None]])
    t0 = jnp.concatenate([sign * jnp.asarray(eigenvector, v.dtype), jnp.zeros(1, v.dtype)])
    return u, t0 / jnp.linalg.norm(t0)


def switch_at_flip(problem: CycleProblem, params, v: np.ndarray, eigenvector: np.ndarray, parameter: float,
                   p_min: float, p_max: float, eps: float = 1e-2, sign: float = 1.0,
                   options: ArclengthOptions = ArclengthOptions()) -> Branch:
    """The period-``2k`` branch born at a located flip of ``problem``'s period-``k`` branch (one branch; vmap it).

    Its first point solves ``P^2k(v) = v`` with ``w . (v - v*) = eps sign`` (``w`` the flip's unit
    eigenvector, ``(v*, p*)`` the flip, ``p`` free); it is then continued as
    :func:`jaxwalk.arclength.continue_branch` does, away from the period-``k`` branch.
    """
    u, t0 = switch_direction(v, eigenvector, parameter, sign)
    doubled = dataclasses.replace(problem, k=2 * problem.k)
    return continue_branch(doubled, params, u[:-1], u[-1], t0, jnp.asarray(eps, u.dtype), p_min, p_max, options)
