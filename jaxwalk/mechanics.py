"""Constrained Lagrangian mechanics of planar point-mass systems, by autodiff.

A walker is described by where its point masses are, ``points(q) -> (n_points, 2)``,
and by holonomic constraints ``constraints(q) -> (n_c,)`` (feet on the ground,
locked knees). Everything else, the paper's eqs. 3-7 and 11-16, follows here by
automatic differentiation rather than by hand-typed matrices:

* ``T = dpoints/dq`` (the paper's T, shape ``(n_points, 2, n_q)``),
* ``M_r = T^T M T`` (eq. 6) and ``F_r = T^T (F - M * Tdot qdot)`` (eq. 7),
* ``Sigma = dxi/dq`` (eq. 3) and ``Psi = (d(Sigma qdot)/dq) qdot`` (eq. 4),
* the equations of motion (eq. 5) as one KKT system,
* inelastic impacts (eqs. 13, 16) as the same KKT system on velocities.

Coordinates live in the *slope frame*: x along the ground (downhill positive),
y normal to it; gravity is ``g (sin gamma, -cos gamma)``. All quantities are in the
model's units (dimensionless for the flat-foot walker: M = L = g = 1).

Constraints that are not active in a phase are switched off by a 0/1 mask rather
than removed, so every phase has the same array shapes (a requirement for
``vmap``): an inactive row of the KKT system reads ``lambda_i = 0``. A mask whose
value is known while tracing (the same in every phase) instead drops those rows
from the linear system; the solution is the same.

Small linear systems (order 8 or less) are solved by an unrolled Gaussian
elimination with partial pivoting (see :func:`solve`): on CPU under ``vmap`` it is
several times cheaper than LAPACK called per batch element. Larger ones (the
kneed and flat-foot walkers' KKT systems) by LAPACK, one matrix per call, with NaN
for a singular system (dependent active constraints) so that a step ends
``nonfinite`` rather than carrying on with accelerations made of rounding.
"""

from __future__ import annotations

import math
from typing import Callable

import jax
import jax.numpy as jnp
import numpy as np
from jax.custom_batching import custom_vmap
from jaxtyping import ArrayLike, Float

Array = jax.Array

#: Largest linear system (KKT matrix order) solved by the unrolled elimination
#: below; larger ones by LAPACK one matrix at a time (:func:`_lapack_one`).
UNROLLED_SOLVE_MAX = 8


def second_derivative_along(fn: Callable[[Float[Array, "n_q"]], Float[Array, "*m"]], q: Float[Array, "n_q"],
                            qd: Float[Array, "n_q"]) -> Float[Array, "*m"]:
    """``(d/ds)^2 fn(q + s qd)`` at ``s = 0``: the convective term ``Jdot(q, qd) qd``.

    This is the paper's Psi (eq. 4) for a constraint function and the
    velocity-product part of the points' accelerations for ``points``.
    """
    first = lambda q_: jax.jvp(fn, (q_,), (qd,))[1]
    return jax.jvp(first, (q,), (qd,))[1]


#: Largest ``n_q`` times the point masses' coordinates (``2 n_points``) for
#: which the mass matrix, the forces and the constraint Jacobian are written
#: entry by entry. The two forms trade program size against batched speed, both
#: measured on 2 CPU cores (benchmarks/README.md, "Dynamics by size"):
#: entry by entry, each entry a scalar (under ``vmap`` a vector over the batch),
#: the simplest and compass walkers' gait searches run 2-3x faster at batch
#: 64 than from stacked Jacobians, but the program grows as ``n_q^2 n_points``;
#: the flat-foot walker (6 x 22 = 132, run one configuration at a time) then
#: took 200 s to trace and compile its gait search, against 64 s stacked, and
#: ran 1.35x slower.
ENTRYWISE_MAX = 64


def entrywise(n_q: int, n_coordinates: int) -> bool:
    """Whether a system of ``n_q`` coordinates and ``n_coordinates`` point-mass
    coordinates builds its dynamics entry by entry (:data:`ENTRYWISE_MAX`)."""
    return n_q * n_coordinates <= ENTRYWISE_MAX


def jacobian(fn: Callable[[Float[Array, "n_q"]], Float[Array, "*m"]], q: Float[Array, "n_q"],
             by_entries: bool) -> Float[Array, "n_q *m"]:
    """``d fn / d q_k`` stacked on a leading axis ``k``: ``n_q`` separate ``jvp`` calls
    (``by_entries``, :func:`jacobian_columns`) or one ``jvp`` vmapped over the
    basis (the program holds ``fn``'s derivative once, whatever ``n_q``)."""
    if by_entries:
        return jnp.stack(jacobian_columns(fn, q))
    basis = jnp.eye(q.shape[0], dtype=q.dtype)
    return jax.vmap(lambda e: jax.jvp(fn, (q,), (e,))[1])(basis)


def jacobian_columns(fn: Callable[[Float[Array, "n_q"]], Float[Array, "*m"]], q: Float[Array, "n_q"]) -> list[Float[Array, "*m"]]:
    """``[d fn / d q_k for k in range(n_q)]``, each shaped like ``fn(q)``.

    One ``jvp`` per coordinate, kept as separate arrays: ``jax.jacfwd`` would
    stack them on a new last axis, and under ``vmap`` the transposes and small
    batched ``dot``s that follow cost more on CPU than the arithmetic itself.
    """
    basis = np.eye(q.shape[0])
    return [jax.jvp(fn, (q,), (jnp.asarray(basis[k], q.dtype),))[1] for k in range(q.shape[0])]


def _weighted_products(cols: list[Array], masses: Array) -> tuple[list, list]:
    """Per-point-coordinate entries of the columns of ``T`` and their masses, as scalars."""
    n_p = masses.shape[0]
    flat = [c.reshape(n_p, -1) for c in cols]
    dim = flat[0].shape[1]
    entries = [[c[i, a] for i in range(n_p) for a in range(dim)] for c in flat]
    weights = [masses[i] for i in range(n_p) for _ in range(dim)]
    return entries, weights


def _mass_from_columns(entries: list, weights: list) -> Array:
    n = len(entries)
    mass = [[None] * n for _ in range(n)]
    for k in range(n):
        for l in range(k, n):
            value = 0.0
            for e in range(len(weights)):
                value = value + weights[e] * entries[k][e] * entries[l][e]
            mass[k][l] = mass[l][k] = value
    return jnp.stack([jnp.stack(row) for row in mass])


def mass_matrix(points: Callable[[Float[Array, "n_q"]], Float[Array, "n_points 2"]], masses: Float[Array, "n_points"], q: Float[Array, "n_q"]) -> Float[Array, "n_q n_q"]:
    """Reduced mass matrix ``M_r = sum_i m_i T_i^T T_i``, shape ``(n_q, n_q)``.

    Args:
        points: ``q -> (n_points, 2)`` positions of the point masses.
        masses: ``(n_points,)`` masses.
        q: ``(n_q,)`` generalized coordinates.
    """
    n_coordinates = math.prod(jax.eval_shape(points, q).shape)
    if not entrywise(q.shape[0], n_coordinates):
        return _stacked_mass(jacobian(points, q, False), masses)
    entries, weights = _weighted_products(jacobian_columns(points, q), masses)
    return _mass_from_columns(entries, weights)


def _stacked_mass(t: Float[Array, "n_q n_points 2"], masses: Float[Array, "n_points"]) -> Float[Array, "n_q n_q"]:
    """``sum_i m_i T_i^T T_i`` from the stacked Jacobian, as one product and sum
    (no ``dot``: under ``vmap`` on CPU a broadcast product fuses into one loop)."""
    weighted = t * masses[None, :, None]
    return jnp.sum(weighted[:, None] * t[None, :], axis=(-2, -1))


def mass_matrix_and_forces(
    points: Callable[[Float[Array, "n_q"]], Float[Array, "n_points 2"]], masses: Float[Array, "n_points"], gravity: Float[Array, "2"], q: Float[Array, "n_q"], qd: Float[Array, "n_q"]
) -> tuple[Float[Array, "n_q n_q"], Float[Array, "n_q"]]:
    """:func:`mass_matrix` and the generalized gravity and velocity-product forces
    ``F_r = sum_i T_i^T m_i (g - Tdot_i qd)`` (eq. 7), ``(n_q,)``, sharing one
    Jacobian of ``points``; joint torques are added by the caller.

    Small systems (:func:`entrywise`) are written entry by entry (each entry a
    scalar, a vector over the batch under ``vmap``: on CPU faster than products
    of the stacked Jacobian); larger ones from the stacked Jacobian, whose
    program does not grow with ``n_q``. The same sums up to their order.
    """
    convective = second_derivative_along(points, q, qd)
    if not entrywise(q.shape[0], convective.size):
        t = jacobian(points, q, False)
        per_point = masses[:, None] * (gravity[None, :] - convective)
        return _stacked_mass(t, masses), jnp.sum(t * per_point[None], axis=(-2, -1))
    entries, weights = _weighted_products(jacobian_columns(points, q), masses)
    n_p = masses.shape[0]
    convective = convective.reshape(n_p, -1)
    dim = convective.shape[1]
    g = [gravity[a] for a in range(dim)]
    per_point = [weights[e] * (g[e % dim] - convective[e // dim, e % dim]) for e in range(len(weights))]
    forces = []
    for k in range(len(entries)):
        value = 0.0
        for e in range(len(weights)):
            value = value + entries[k][e] * per_point[e]
        forces.append(value)
    return _mass_from_columns(entries, weights), jnp.stack(forces)


def kinetic_energy(points: Callable[[Float[Array, "n_q"]], Float[Array, "n_points 2"]], masses: Float[Array, "n_points"], q: Float[Array, "n_q"], qd: Float[Array, "n_q"]) -> Float[Array, ""]:
    """``sum_i m_i |v_i|^2 / 2`` for point masses, a scalar."""
    velocities = jax.jvp(points, (q,), (qd,))[1]
    return 0.5 * jnp.sum(masses * jnp.sum(velocities**2, axis=-1))


def gravity_potential(points: Callable[[Float[Array, "n_q"]], Float[Array, "n_points 2"]], masses: Float[Array, "n_points"], gravity: Float[Array, "2"], q: Float[Array, "n_q"]) -> Float[Array, ""]:
    """``-sum_i m_i g . p_i``, a scalar (zero at the slope-frame origin)."""
    return -jnp.sum(masses * (points(q) @ gravity))


def _kkt_matrix(mass: Array, sigma: Array, mask: Array) -> Array:
    """``[[M, -Sigma^T], [Sigma, I - diag(mask)]]`` with inactive rows masked out.

    With ``mask_i = 0`` row i of the lower block reads ``lambda_i = 0`` and column
    i of ``Sigma^T`` is zero, so an inactive constraint neither acts nor constrains.
    """
    sigma_active = sigma * mask[:, None]
    top = jnp.concatenate([mass, -sigma_active.T], axis=1)
    bottom = jnp.concatenate([sigma_active, jnp.diag(1.0 - mask)], axis=1)
    return jnp.concatenate([top, bottom], axis=0)


def static_mask(mask) -> np.ndarray | None:
    """``mask`` as a NumPy 0/1 array when its value is known while tracing, else ``None``.

    A model's ``constraint_mask`` is usually a constant of the phase; evaluated
    under ``jax.ensure_compile_time_eval`` it is concrete, and the KKT system can
    drop its inactive rows at trace time (see :func:`constrained_accelerations`).
    """
    try:
        values = np.asarray(mask, dtype=np.float64)
    except (jax.errors.TracerArrayConversionError, jax.errors.ConcretizationTypeError, TypeError):
        return None
    if values.ndim != 1 or not np.all((values == 0.0) | (values == 1.0)):
        return None
    return values


# ---------------------------------------------------------------------------
# Small dense solves: Gaussian elimination with partial pivoting, unrolled.
#
# Under ``vmap`` every entry below is a vector over the batch, so the whole
# elimination is a few hundred elementwise operations that XLA fuses, instead of
# one LAPACK ``getrf`` + two ``trsm`` calls (and a pivot-permutation loop) per
# batch element, which cost more than the rest of the vector field together.
# LAPACK's batched driver also splits the batch over the intra-op thread pool
# and blocks on it: with two CPU devices running at once on two cores, both
# were seen stuck there for good (the benchmark hung twice at N = 2048).
# The pivoting is LAPACK's (the first entry of largest modulus in the column),
# so results agree with ``jnp.linalg.solve`` to round-off; it is needed: the
# simplest walker's 1e-12 foot mass makes the mass matrix nearly singular.
#
# Forward mode: ``dx = A^-1 (db - dA x)`` reuses the factors. When the tangents
# are batched (``jacfwd``, ``vmap`` of ``jvp``), ``custom_vmap`` applies the
# factors to every tangent column as separate batch-shaped vectors instead of
# letting ``vmap`` add a small minor axis of size n_tangents to every operation
# (elementwise chains ran ~2.5x slower per element that way on CPU).


def _entries(a: Array) -> list[list[Array]]:
    return [[a[i, j] for j in range(a.shape[1])] for i in range(a.shape[0])]


def _lu_factor(a: list[list[Array]]):
    """Factors of the square matrix ``a`` (rows of scalars): pivots, multipliers, U."""
    n = len(a)
    rows = [list(r) for r in a]
    pivots, multipliers, upper = [], [], []
    for k in range(n):
        if k == n - 1:
            upper.append(rows[0])
            break
        # The pivot: the first entry of largest modulus (LAPACK's idamax). As a
        # reduction it is computed once; written as a chain of selects, XLA
        # copies the chain into every fusion that uses it (measured 1.7x slower).
        pivot = jnp.argmax(jnp.abs(jnp.stack([r[0] for r in rows]))).astype(jnp.int32)
        chosen = [pivot == i for i in range(len(rows))]
        top = []
        for c in range(len(rows[0])):
            value = rows[0][c]
            for i in range(1, len(rows)):
                value = jnp.where(chosen[i], rows[i][c], value)
            top.append(value)
        below, column = [], []
        for i in range(1, len(rows)):
            row = [jnp.where(chosen[i], rows[0][c], rows[i][c]) for c in range(len(rows[0]))]
            factor = row[0] / top[0]
            column.append(factor)
            below.append([row[c] - factor * top[c] for c in range(1, len(row))])
        pivots.append(pivot)
        multipliers.append(column)
        upper.append(top)
        rows = below
    return pivots, multipliers, upper


def _lu_apply(factors, b: list[Array]) -> list[Array]:
    """Solve with the factors of :func:`_lu_factor` for one right-hand side."""
    pivots, multipliers, upper = factors
    n = len(upper)
    b = list(b)
    for k, (pivot, column) in enumerate(zip(pivots, multipliers)):
        rest = b[k:]
        top = rest[0]
        for i in range(1, len(rest)):
            top = jnp.where(pivot == i, rest[i], top)
        new = [top]
        for i in range(1, len(rest)):
            value = jnp.where(pivot == i, rest[0], rest[i])
            new.append(value - column[i - 1] * top)
        b = b[:k] + new
    x = [None] * n
    for k in range(n - 1, -1, -1):
        row = upper[k]
        value = b[k]
        for j in range(k + 1, n):
            value = value - row[j - k] * x[j]
        x[k] = value / row[0]
    return x


@custom_vmap
def _apply_factors(factors, r: Array) -> Array:
    return jnp.stack(_lu_apply(factors, [r[i] for i in range(r.shape[0])]))


@_apply_factors.def_vmap
def _apply_factors_batched(axis_size, in_batched, factors, r):
    factors_batched, r_batched = in_batched
    if not r_batched:
        r = jnp.broadcast_to(r, (axis_size,) + r.shape)
    if not any(jax.tree_util.tree_leaves(factors_batched)):
        # Same factors for every column (the tangents of one primal): one
        # elimination sequence per column, each a vector over the outer batch.
        cols = [_lu_apply(factors, [r[t, i] for i in range(r.shape[1])]) for t in range(axis_size)]
        return jnp.stack([jnp.stack(col) for col in cols]), True
    factors = jax.tree_util.tree_map(
        lambda x, b: x if b else jnp.broadcast_to(x, (axis_size,) + jnp.shape(x)), factors, factors_batched
    )
    one = lambda f, rr: jnp.stack(_lu_apply(f, [rr[i] for i in range(rr.shape[0])]))
    return jax.vmap(one)(factors, r), True


@jax.custom_jvp
def _unrolled_solve(a: Array, b: Array) -> Array:
    factors = _lu_factor(_entries(a))
    return jnp.stack(_lu_apply(factors, [b[i] for i in range(b.shape[0])]))


@_unrolled_solve.defjvp
def _unrolled_solve_jvp(primals, tangents):
    a, b = primals
    da, db = tangents
    n = b.shape[0]
    factors = _lu_factor(_entries(a))
    x = _lu_apply(factors, [b[i] for i in range(n)])
    r = []
    for i in range(n):
        value = db[i]
        for j in range(n):
            value = value - da[i, j] * x[j]
        r.append(value)
    x = jnp.stack(x)
    # custom_linear_solve only to keep reverse mode: its transpose is a plain
    # solve with a^T (custom_vmap itself cannot be transposed).
    dx = jax.lax.custom_linear_solve(
        lambda v: a @ v,
        jnp.stack(r),
        solve=lambda _, rhs: _apply_factors(factors, rhs),
        transpose_solve=lambda _, rhs: _lapack_one(a.T, rhs),
    )
    return x, dx


def solve(a: Float[Array, "n n"], b: Float[Array, "n"]) -> Float[Array, "n"]:
    """``a^-1 b`` for a square ``a`` and a vector ``b``, with partial pivoting.

    Orders up to :data:`UNROLLED_SOLVE_MAX` use the unrolled elimination (forward
    and reverse differentiable; reverse mode solves with ``a^T`` by :func:`_lapack_one`);
    larger ones (the kneed and flat-foot walkers' KKT systems, 12 and 15, whose
    masks change with the phase) LAPACK (an LU factorisation and two triangular
    solves), one matrix per call (:func:`_lapack_one`), differentiated as a linear
    solve (tangents and cotangents solve with the same matrix or its transpose);
    NaN where ``a`` is singular (:data:`SINGULAR_PIVOT_RATIO`).
    """
    if a.shape[0] <= UNROLLED_SOLVE_MAX:
        return _unrolled_solve(a, b)
    return jax.lax.custom_linear_solve(
        lambda v: a @ v, b, solve=lambda _, r: _lapack_one(a, r), transpose_solve=lambda _, r: _lapack_one(a.T, r)
    )


# LAPACK one matrix at a time. jaxlib's batched LAPACK kernels split a batch of
# more than about 2e5 flops over XLA's intra-op thread pool and wait for the
# pieces on the thread that called them; when as many programs run at once as the
# pool has threads (the sweep runs one per core), every pool thread can be such a
# caller and nothing is left to run the pieces: both were seen asleep for good
# (benchmarks/README.md, "The KKT solve by LAPACK"). A call of one matrix is never
# split. Under ``vmap`` on the CPU the rule below keeps it so: a batch of matrices
# becomes a ``lax.map`` of single calls, and an enclosing ``vmap`` batches that
# map's body, which calls this function again. A single matrix with a batch of
# right-hand sides (the tangents of ``jacfwd``) is one call with a matrix
# right-hand side. Measured against the pivoted elimination in a ``fori_loop`` it
# replaced (benchmarks/README.md, both forms timed in turn): the paper's flat-foot
# step map 1.8x faster at batch 1 and 1.6x at 64, its gait search 3.0x and 1.8x;
# the kneed walker's gait search 3.4x and 2.5x. Factoring each matrix once for its
# solve and tangents gained nothing there (0.93-1.01x). Other backends have no
# such pool; there a batch is one batched call (not yet run on a GPU).


@custom_vmap
def _lapack_one(a: Array, b: Array) -> Array:
    """``a^-1 b`` by one LAPACK call: ``a`` ``(n, n)``, ``b`` ``(n,)`` or ``(n, k)``."""
    return _solve_or_nan(a, b)


#: A linear system is taken as singular when its LU's smallest pivot is at most
#: this fraction of the largest (partial pivoting). Dependent constraint rows give
#: 1e-18..3e-14 (rounding, up to about 150 eps at orders 10-12); the walkers'
#: KKT systems 3.6e-4 (kneed) and 1.7e-3 (flat-foot) at the least in a default
#: step, their impacts 0.025 and 2.1e-3, the simplest walker's impacts (order 8,
#: not tested) 9.6e-13 (``benchmarks/kkt_pivot_ratios.py``). Constraints
#: dependent to within this fraction count as dependent: a solve would amplify
#: rounding by about 1e10 or more.
SINGULAR_PIVOT_RATIO = 1e-10


def _singular(pivots: Array) -> Array:
    """Whether the pivots ``(..., n)`` of an LU belong to a singular matrix ``(...)``."""
    pivots = jnp.abs(pivots)
    return jnp.min(pivots, axis=-1) <= SINGULAR_PIVOT_RATIO * jnp.max(pivots, axis=-1)


def _solve_or_nan(a: Array, b: Array) -> Array:
    """``a^-1 b`` by LU (LAPACK ``getrf`` and two ``trsm``), NaN where ``a`` is
    singular (:data:`SINGULAR_PIVOT_RATIO`). ``a`` ``(..., n, n)``; ``b`` ``(..., n)``
    or ``(..., n, k)``.

    A KKT system whose active constraints are dependent has no unique
    multipliers (and no accelerations at all if the constraints contradict each
    other); its LU ends with a pivot of rounding size, and a plain solve returned
    finite values anywhere from plausible to 1e35 in 3 of 10 random cases
    (inf/NaN in the rest), which the integrator would carry on with until some
    guard named a cause that is not the real one. NaN instead makes the step end
    ``nonfinite``. Systems of order 8 or less have no such test (the unrolled
    elimination, and impacts' looped one): the simplest walker's, with its 1e-12
    foot mass, are meant to be nearly singular (the unrolled solve's reverse
    mode solves by this function, untested for that reason).
    """
    if a.ndim > 2:  # a batch: the same for each matrix (batched LAPACK calls)
        return jax.vmap(_solve_or_nan)(a, b)
    lu, _, permutation = jax.lax.linalg.lu(a)
    rhs = b if b.ndim == 2 else b[:, None]
    y = jax.lax.linalg.triangular_solve(lu, rhs[permutation], left_side=True, lower=True, unit_diagonal=True)
    x = jax.lax.linalg.triangular_solve(lu, y, left_side=True, lower=False)
    if a.shape[-1] > UNROLLED_SOLVE_MAX:  # see above: small systems are not tested
        x = jnp.where(_singular(jnp.diagonal(lu)), jnp.nan, x)
    return x if b.ndim == 2 else x[:, 0]


@_lapack_one.def_vmap
def _lapack_one_batched(axis_size, in_batched, a, b):
    """:func:`_lapack_one` of a batch: one call with a matrix right-hand side where
    ``a`` is shared, else :func:`_one_at_a_time` on the CPU and :func:`_batched`
    elsewhere (chosen when the program is lowered for its platform)."""
    a_batched, b_batched = in_batched
    if not b_batched:
        b = jnp.broadcast_to(b, (axis_size,) + b.shape)
    if not a_batched:
        rhs = jnp.moveaxis(b, 0, -1)  # (n, [k,] batch)
        x = _lapack_one(a, rhs.reshape(rhs.shape[0], -1)).reshape(rhs.shape)
        return jnp.moveaxis(x, -1, 0), True
    return jax.lax.platform_dependent(a, b, cpu=_one_at_a_time, default=_batched), True


def _one_at_a_time(a: Array, b: Array) -> Array:
    """``a[i]^-1 b[i]`` for a batch, one LAPACK call per matrix (``lax.map``)."""
    if a.shape[0] == 1:
        return _lapack_one(a[0], b[0])[None]
    return jax.lax.map(lambda ab: _lapack_one(*ab), (a, b))


def _batched(a: Array, b: Array) -> Array:
    """``a[i]^-1 b[i]`` for a batch by one batched call (backends without the CPU's
    intra-op pool; not yet run on one)."""
    return _solve_or_nan(a, b)


def _looped_solve(a: Array, b: Array) -> Array:
    """``a^-1 b`` by Gaussian elimination with partial pivoting in a ``fori_loop``.

    Compiles to a small program (unlike the unrolled elimination) but runs several
    times slower than LAPACK; for impacts, once per event. NaN where ``a`` is
    singular (:data:`SINGULAR_PIVOT_RATIO`) and of an order above
    :data:`UNROLLED_SOLVE_MAX`, as the solves of :func:`solve`.
    """
    n = a.shape[0]
    w = jnp.concatenate([a, b[:, None]], axis=1)
    rows = jnp.arange(n)

    def eliminate(k, w):
        column = jnp.where(rows >= k, jnp.abs(w[:, k]), -1.0)
        p = jnp.argmax(column)  # the first largest, as LAPACK
        row_k, row_p = w[k], w[p]
        w = jnp.where((rows == k)[:, None], row_p[None, :], jnp.where((rows == p)[:, None], row_k[None, :], w))
        factor = jnp.where(rows > k, w[:, k] / w[k, k], 0.0)
        return w - factor[:, None] * w[k][None, :]

    w = jax.lax.fori_loop(0, n - 1, eliminate, w)

    def substitute(i, x):
        k = n - 1 - i
        value = w[k, n] - jnp.sum(jnp.where(rows > k, w[k, :n], 0.0) * x)
        return x.at[k].set(value / w[k, k])

    x = jax.lax.fori_loop(0, n, substitute, jnp.zeros(n, w.dtype))
    if n <= UNROLLED_SOLVE_MAX:  # the simplest walker's impacts: nearly singular by design
        return x
    return jnp.where(_singular(jnp.diagonal(w[:, :n])), jnp.nan, x)


def _reduced_kkt(mass: Array, sigma: Array, active: np.ndarray) -> Array:
    """``[[M, -S^T], [S, 0]]`` with ``S`` the active rows of ``Sigma``."""
    s = sigma[active]
    m = len(active)
    top = jnp.concatenate([mass, -s.T], axis=1)
    bottom = jnp.concatenate([s, jnp.zeros((m, m), mass.dtype)], axis=1)
    return jnp.concatenate([top, bottom], axis=0)


def constrained_accelerations(
    mass: Float[Array, "n_q n_q"], forces: Float[Array, "n_q"], sigma: Float[Array, "n_c n_q"], psi: Float[Array, "n_c"], mask: Float[ArrayLike, "n_c"]
) -> tuple[Float[Array, "n_q"], Float[Array, "n_c"]]:
    """Solve the equations of motion with active constraints (paper eq. 5).

    ``M qdd = F + Sigma^T lambda`` and ``Sigma qdd + Psi = 0`` for active rows.

    Args:
        mass: ``(n_q, n_q)`` reduced mass matrix.
        forces: ``(n_q,)`` applied generalized forces.
        sigma: ``(n_c, n_q)`` constraint Jacobian.
        psi: ``(n_c,)`` convective constraint term ``Sigmadot qd``.
        mask: ``(n_c,)`` 1.0 for active constraints, 0.0 otherwise. When it is
            known while tracing (a NumPy array, or see :func:`static_mask`), the
            inactive rows are left out of the linear system instead of being
            masked: the same solution with a smaller solve.

    Returns:
        ``qdd`` of shape ``(n_q,)`` and the multipliers ``lambda`` of shape
        ``(n_c,)``: the generalized constraint forces (for a foot-height
        constraint, the ground's normal force on the foot, positive upward).
    """
    n_q = mass.shape[0]
    known = static_mask(mask)
    if known is not None:
        return _solve_on_active(mass, sigma, known, forces, -psi)
    kkt = _kkt_matrix(mass, sigma, mask)
    rhs = jnp.concatenate([forces, -psi * mask])
    sol = solve(kkt, rhs)
    return sol[:n_q], sol[n_q:]


def _solve_on_active(mass, sigma, known: np.ndarray, top: Array, bottom: Array) -> tuple[Array, Array]:
    """The KKT system ``[[M, -S_a^T], [S_a, 0]] (x, l_a) = (top, bottom_a)`` on the rows
    ``known`` (a mask known when tracing) holds: ``x`` ``(n_q,)`` and the multipliers
    ``(n_c,)``, zero at inactive rows."""
    n_q, n_c = mass.shape[0], sigma.shape[0]
    active = np.flatnonzero(known)
    sol = solve(_reduced_kkt(mass, sigma, active), jnp.concatenate([top, bottom[active]]))
    return sol[:n_q], jnp.zeros(n_c, sol.dtype).at[active].set(sol[n_q:])


def impact(mass: Float[Array, "n_q n_q"], qd_minus: Float[Array, "n_q"], sigma: Float[Array, "n_c n_q"], mask: Float[ArrayLike, "n_c"]) -> tuple[Float[Array, "n_q"], Float[Array, "n_c"]]:
    """Perfectly inelastic impact onto the active constraints (eqs. 13 and 16, e = 0).

    ``M (qd+ - qd-) = Sigma^T Lambda`` and ``Sigma qd+ = 0`` for active rows.

    Returns:
        ``qd_plus`` of shape ``(n_q,)`` and the impulses ``Lambda`` of shape ``(n_c,)``.
    """
    n_q = mass.shape[0]
    n_c = sigma.shape[0]
    known = static_mask(mask)
    if known is not None:
        return _solve_on_active(mass, sigma, known, mass @ qd_minus, jnp.zeros(n_c, qd_minus.dtype))
    kkt = _kkt_matrix(mass, sigma, mask)
    rhs = jnp.concatenate([mass @ qd_minus, jnp.zeros(n_c, qd_minus.dtype)])
    # Once per event, not per vector-field evaluation: the looped elimination
    # (no LAPACK, small program) at every order.
    sol = _looped_solve(kkt, rhs)
    return sol[:n_q], sol[n_q:]
