"""Mean first-passage time on random terrain (Byl & Tedrake 2009).

Every step's ground height change is drawn i.i.d. from ``N(0, sigma^2)``: the
drop ``e_k`` of the ground at step ``k``'s touchdown below its stance foot
(model length units, vertical; negative: a step-up). The section state then
follows a Markov chain, ``v_{k+1} = f(v_k, e_k)``, with one absorbing state,
failure (any failed step). The MFPT is the expected number of completed steps
before the first failure.

Discretisation (all of it batched: the mesh points x terrain samples are the rows of
:data:`CALL_ROWS`-row calls of one compiled step program, split over the worker threads):

* **Mesh.** A regular grid around the gait ``v*`` along the principal axes of
  the linearised chain's stationary covariance ``P = sigma^2 sum_k J^k B B^T
  J^kT`` (:func:`~jaxwalk.global_stability.sensitivity_norm.linearise`; for an
  unstable gait the first 8 terms), ``mesh`` points per axis spanning
  ``+-span`` standard deviations. Axes whose standard deviation is below
  ``1e-2`` of the largest (the simplest walker's ``beta -> 0`` direction, erased
  in one step; states off the meshed axes are projected onto them), and all but the ``max_axes`` largest, get one point: the chain
  lives on the others.
* **Terrain.** ``samples`` drops at the midpoints of equal cells of
  ``[-5 sigma, 5 sigma]``, each weighted by its cell's normal probability (the
  tails beyond go to the end cells). The midpoint rule on a survival
  indicator errs by under half a cell per mesh point, with either sign, so
  the errors largely cancel over the chain.
* **Transitions.** Each ``(mesh point, sample)`` is one step; a failed step
  goes to the absorbing state, a successful one is spread over the ``2^d``
  corners of its mesh cell (multilinear weights; a state outside the box is
  moved onto its surface, and the fraction of the mass that was is reported).

From the substochastic matrix ``Q`` over mesh points: the expected number of
completed steps from each state ``t = (I - Q)^-1 Q 1``, read at the gait (what
a walk started on the gait measures: :func:`jaxwalk.global_stability.walks.monte_carlo`),
and the quasi-stationary MFPT ``1 / (1 - lambda_d)`` from the dominant
eigenvalue of ``Q`` (Byl & Tedrake's). **Error estimate**: the same chain on a
coarser mesh and terrain grid (``(mesh + 1) // 2`` points per axis, half the
samples); ``error = |t - t_coarse|``, the error of the coarse chain, an upper
bound on the fine chain's error where refinement converges at first order or
faster (checked against Monte Carlo in ``tests/test_global_stability.py``).
``sigma = 0``: the walker never falls, ``inf``; so too where no sampled step
of the chain fails, or the chain's failure rate per step is below
:data:`UNRESOLVED_FAILURE_RATE` (beyond what it resolves).
"""

from __future__ import annotations

import dataclasses
import functools
from typing import Callable, NamedTuple

import jax.numpy as jnp
import numpy as np
import scipy.sparse
import scipy.sparse.linalg
from scipy.special import ndtr

from jaxwalk import compiling, program_cache
from jaxwalk.batching import Rows, over_rows, run_chunks, sub_batch_size
from jaxwalk.global_stability.sensitivity_norm import linearise, observability_gramian
from jaxwalk.status import Status
from jaxwalk.step import SolverOptions, step_map
from jaxwalk.walker import Walker, require


@dataclasses.dataclass(frozen=True)
class MFPTOptions:
    """Settings of the chain (hashable).

    Attributes:
        sigma: standard deviation of each step's ground height change (model length units).
        mesh: mesh points per principal axis.
        span: the mesh spans ``+-span`` standard deviations of the linearised chain.
        samples: terrain samples per mesh point.
        max_axes: largest number of principal axes meshed.
    """

    sigma: float
    mesh: int = 15
    span: float = 4.0
    samples: int = 64
    max_axes: int = 3


class MFPTResult(NamedTuple):
    """The chain's answer for one gait.

    Attributes:
        mfpt: expected completed steps before a failure, from the gait (``inf`` for ``sigma = 0``).
        error: discretisation error estimate (module docstring).
        quasi_stationary: ``1 / (1 - lambda_d)``, the MFPT from the chain's quasi-stationary distribution.
        escaped: fraction of the surviving transition mass that left the mesh box (moved onto
            its surface), averaged over the quasi-stationary distribution.
        n_states: mesh points of the chain.
    """

    mfpt: float
    error: float
    quasi_stationary: float
    escaped: float
    n_states: int


class Mesh(NamedTuple):
    """A regular grid on ``d`` principal axes: ``v = v* + axes @ (scale * xi)``, ``xi`` in ``[-1, 1]^d``."""

    v_star: np.ndarray
    axes: np.ndarray  # (n_v, d) orthonormal
    half_width: np.ndarray  # (d,) section units
    points: int


def principal_mesh(J: np.ndarray, B: np.ndarray, v_star: np.ndarray, options: MFPTOptions, points: int) -> Mesh:
    """The mesh along the principal axes of the linearised stationary covariance."""
    stable = np.max(np.abs(np.linalg.eigvals(J))) < 1.0
    doublings = 48 if stable else 3
    cov = options.sigma**2 * np.asarray(observability_gramian(jnp.asarray(J.T), jnp.asarray(B[None, :]), doublings))
    s2, u = np.linalg.eigh(0.5 * (cov + cov.T))
    order = np.argsort(-s2)
    std = np.sqrt(np.maximum(s2[order], 0.0))
    keep = [i for i in range(len(std)) if std[i] > 1e-2 * std[0]][: options.max_axes]
    return Mesh(v_star, u[:, order][:, keep], options.span * std[keep], points)


def mesh_states(mesh: Mesh) -> np.ndarray:
    """``(points^d, n_v)`` the mesh's states, C order over the axes."""
    line = np.linspace(-1.0, 1.0, mesh.points)
    d = mesh.axes.shape[1]
    xi = np.stack(np.meshgrid(*([line] * d), indexing="ij"), -1).reshape(-1, d)
    return mesh.v_star + (xi * mesh.half_width) @ mesh.axes.T


def terrain_samples(sigma: float, samples: int) -> tuple[np.ndarray, np.ndarray]:
    """``(drops, weights)``: cell midpoints of ``[-5 sigma, 5 sigma]`` and their normal probabilities."""
    edges = np.linspace(-5.0, 5.0, samples + 1)
    mid = 0.5 * (edges[1:] + edges[:-1])
    cdf = ndtr(edges)
    cdf[0], cdf[-1] = 0.0, 1.0  # the tails to the end cells
    return sigma * mid, np.diff(cdf)


class Transition(NamedTuple):
    """The input of the transition program beside the parameters, one step per row."""

    v: np.ndarray  # (n, n_v) section state before the step
    drop: np.ndarray  # (n,) the step's ground drop (model length units)


#: Steps per call of the transition program: every mesh (fine, coarse, any
#: ``mesh`` and ``samples``) runs in calls of this one shape, so one compile
#: serves them all (:func:`jaxwalk.batching.run_chunks`; the padding of the last
#: call costs at most one sub-batch).
CALL_ROWS = 4096


#: Steps one worker thread advances together: the engine's sub-batch size, but
#: at least this many. A walker whose gait searches run one at a time (the
#: flat-foot walker's ``lockstep_batch`` is 1: configurations far apart wait for
#: each other at every phase) still batches a chain's steps, which all start near
#: one gait and pass the same phases and events together. Measured on 1,024 steps
#: from the shoe gait's neighbourhood: 18.4 ms per step one at a time, 11.1 ms
#: sixteen at a time, 10.7 ms 64 at a time (benchmarks/bench_mfpt_steps.py). Not
#: more: a failing step (a fall, a timeout) holds up its own sub-batch.
MIN_STEP_SUB_BATCH = 16


@functools.lru_cache(maxsize=None)
def _step_program(model: Walker, solver: SolverOptions):
    def one(p, t: Transition):
        v_next, res = step_map(model, t.v, p, solver, ground_drop=t.drop)
        return v_next, res.status

    program = compiling.jit(over_rows(one, max(sub_batch_size(model, solver), MIN_STEP_SUB_BATCH)), model)
    program_cache.register(program, "mfpt_transitions", model, solver)
    return program


@functools.lru_cache(maxsize=None)
def _linearise_program(model: Walker, solver: SolverOptions):
    return compiling.jit(lambda p, v: linearise(model, p, v, solver=solver), model)


def _transitions(mesh: Mesh, v_next: np.ndarray, ok: np.ndarray, weights: np.ndarray, n_src: int | None = None):
    """Sparse ``Q`` (``n_src`` x states; default states x states) and, per source state, the
    fraction of its surviving mass that left the box.

    ``v_next`` holds ``len(weights)`` successors of each source state, in order."""
    n_e = len(weights)
    d, m = mesh.axes.shape[1], mesh.points
    n = m**d
    n_src = n if n_src is None else n_src
    xi = ((v_next - mesh.v_star) @ mesh.axes) / mesh.half_width  # (n * n_e, d) in [-1, 1] inside the box
    pos = (xi + 1.0) * 0.5 * (m - 1)
    outside = np.any((pos < 0) | (pos > m - 1), axis=-1)
    pos = np.clip(pos, 0.0, m - 1)
    lo = np.minimum(np.floor(pos).astype(np.int64), m - 2)
    frac = pos - lo
    src = np.repeat(np.arange(n_src), n_e)
    w = np.tile(weights, n_src) * ok
    rows, cols, vals = [], [], []
    strides = m ** np.arange(d - 1, -1, -1)
    for corner in np.ndindex(*([2] * d)):
        c = np.asarray(corner)
        wc = w * np.prod(np.where(c == 1, frac, 1.0 - frac), axis=-1)
        rows.append(src), cols.append((lo + c) @ strides), vals.append(wc)
    q = scipy.sparse.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(n_src, n))
    escaped = np.bincount(src, weights=w * outside, minlength=n_src) / np.maximum(np.bincount(src, weights=w, minlength=n_src), 1e-300)
    return q, escaped


#: A chain whose failure rate per step, ``1 - lambda_d``, is below this gives
#: ``mfpt = inf``: more than 1e10 expected steps is beyond what the chain
#: resolves (its terrain samples end at 5 sigma, whose tail holds 6e-7 of the
#: mass), and at ``1 - lambda_d`` near machine precision the solve for ``t``
#: returns rounding noise of either sign (seen: -5.7e16).
UNRESOLVED_FAILURE_RATE = 1e-10


class ChainPlan(NamedTuple):
    """One gait's two chains, meshed and ready to run (:func:`plan`).

    Attributes:
        params: the walker's parameters (scalars).
        v_star: ``(n_v,)`` the gait's fixed point.
        fine, coarse: the chain's mesh and the error estimate's, half as fine.
        samples: terrain samples per mesh point of each, ``(fine, coarse)``.
    """

    params: dict
    v_star: np.ndarray
    fine: Mesh
    coarse: Mesh
    samples: tuple[int, int]

    @property
    def steps(self) -> int:
        """Step maps the two chains take (the work of :func:`run`)."""
        return sum(m.points ** m.axes.shape[1] * s for m, s in zip((self.fine, self.coarse), self.samples))


def plan(model: Walker, params, v_star, options: MFPTOptions, solver: SolverOptions = SolverOptions()) -> ChainPlan:
    """The meshes of the gait at ``v_star`` (``sigma > 0``): the linearised chain's principal axes.

    Raises :class:`~jaxwalk.errors.ConfigError` for a model that cannot walk up a step
    (:attr:`jaxwalk.walker.Walker.cannot_step_up`): half the chain's terrain steps up."""
    require(model, "step_up", "mfpt")
    v_star = np.asarray(v_star, np.float64)
    p = {k: jnp.asarray(v, jnp.float64) for k, v in params.items()}
    lin = _linearise_program(model, solver)(p, jnp.asarray(v_star))
    J, B = np.asarray(lin.J), np.asarray(lin.B)
    coarse_points, coarse_samples = (options.mesh + 1) // 2, max(2, options.samples // 2)
    return ChainPlan(p, v_star, principal_mesh(J, B, v_star, options, options.mesh),
                     principal_mesh(J, B, v_star, options, coarse_points), (options.samples, coarse_samples))


def _chain(model: Walker, params, v_star, mesh: Mesh, sigma: float, samples: int, solver, progress):
    """``(t at the gait, quasi-stationary MFPT, escaped, n_states)`` of one mesh;
    ``progress(n)`` after each call of ``n`` steps."""
    states = mesh_states(mesh)
    drops, weights = terrain_samples(sigma, samples)
    n = len(states) * len(drops)
    transitions = Transition(np.repeat(states, len(drops), axis=0), np.tile(drops, len(states)))
    steps = Rows({k: np.full(n, float(x)) for k, x in params.items()}, transitions)
    v_next, status = run_chunks(_step_program(model, solver), steps, CALL_ROWS, progress)
    q, escaped = _transitions(mesh, np.asarray(v_next), np.asarray(status) == Status.OK, weights)
    n = q.shape[0]
    t = scipy.sparse.linalg.spsolve((scipy.sparse.identity(n, format="csc") - q).tocsc(), q @ np.ones(n))
    start = np.argmin(np.linalg.norm(states - v_star, axis=-1))
    t_gait = float(t[start]) if np.linalg.norm(states[start] - v_star) < 1e-12 else _interpolate(mesh, t, v_star)
    lam, pi = _dominant_eigenvalue(q)
    if 1.0 - lam < UNRESOLVED_FAILURE_RATE:
        # I - Q is singular to working precision (no sampled step fails: Q is
        # stochastic), and the solve's t is rounding noise, of either sign.
        t_gait, lam = np.inf, 1.0
    # Escape weighted by the quasi-stationary distribution: the box's corners,
    # which a non-normal J maps far outside, are rarely visited.
    return t_gait, (np.inf if lam >= 1.0 else 1.0 / (1.0 - lam)), float(pi @ escaped), n


def _interpolate(mesh: Mesh, values: np.ndarray, v: np.ndarray) -> float:
    """Multilinear interpolation of mesh ``values`` at the state ``v``."""
    q, _ = _transitions(mesh, v[None, :], np.ones(1, bool), np.ones(1), n_src=1)
    return float(q.getrow(0).toarray()[0] @ values)


def _dominant_eigenvalue(q) -> tuple[float, np.ndarray]:
    """Largest eigenvalue of the non-negative ``q`` (Perron: real, non-negative) and its left
    eigenvector normalised to a distribution (the quasi-stationary distribution)."""
    n = q.shape[0]
    if q.count_nonzero() == 0:
        # Every sampled step from every mesh state fails (met: the coarse chain
        # of an unstable shoe-walker gait, lambda_max 1.49, at sigma 0.005):
        # no mass stays in the chain, lambda_d = 0, and no distribution is
        # quasi-stationary; the escape is weighted uniformly. (ARPACK stops on
        # it: q^T maps its start vector to zero.)
        return 0.0, np.full(n, 1.0 / n)
    # A fixed, positive start vector (ARPACK's default is random): reruns give
    # the same numbers bit for bit, and a Perron vector is positive anyway.
    vals, vecs = scipy.sparse.linalg.eigs(q.T.tocsr(), k=1, which="LM", tol=1e-12, maxiter=100_000, v0=np.full(n, 1.0 / n))
    pi = np.abs(np.real(vecs[:, 0]))
    return float(np.abs(vals[0])), pi / pi.sum()


def mfpt(model: Walker, params, v_star, options: MFPTOptions, solver: SolverOptions = SolverOptions(),
         progress: Callable[[int], None] | None = None) -> MFPTResult:
    """The MFPT of the gait at ``v_star`` (module docstring). Host-side linear algebra; not differentiable.

    ``progress(n)``: called as each call of ``n`` step maps finishes (``plan(...).steps`` in all).
    Raises :class:`~jaxwalk.errors.ConfigError` as :func:`plan`, for any ``sigma``."""
    require(model, "step_up", "mfpt")
    if options.sigma == 0.0:
        return MFPTResult(np.inf, 0.0, np.inf, 0.0, 1)
    return run(model, plan(model, params, v_star, options, solver), options.sigma, solver, progress)


def run(model: Walker, chains: ChainPlan, sigma: float, solver: SolverOptions = SolverOptions(),
        progress: Callable[[int], None] | None = None) -> MFPTResult:
    """The MFPT from a :func:`plan`'s two chains (``sigma`` as planned); ``progress`` as :func:`mfpt`."""
    fine, coarse = (_chain(model, chains.params, chains.v_star, mesh, sigma, samples, solver, progress)
                    for mesh, samples in zip((chains.fine, chains.coarse), chains.samples))
    error = 0.0 if fine[0] == coarse[0] == np.inf else abs(fine[0] - coarse[0])
    return MFPTResult(fine[0], error, fine[1], fine[2], fine[3])
