"""Gait searches over parameter grids, with natural-parameter continuation.

From one fixed initial guess Newton's method loses a gait far from where the
guess was made (for the simplest walker, above a slope of about 0.0135). Along
the *continuation axis* we instead start each grid point from its converged
neighbour: the sweep begins at the grid point nearest the value of that parameter at
which the model's initial guess was made (its default, or that of the
documented gait the guess is: :meth:`jaxwalk.walker.Walker.seed_value`), walks up
the axis, then walks down from the same seed. A point whose search fails starts
the next one from the last converged gait (or from the model's guess if there
is none yet). All other axes are batched with ``vmap``.

Newton starts at the next point on the secant through the gaits of the two
points before (``NewtonOptions.predictor = "secant"``, the default): its error
is of second order in the grid step where the neighbour's gait is of first, which
saves a Newton iteration of about four step evaluations on a smooth branch
(benchmarks/README.md). Where that search fails, has not converged after
:data:`SECANT_MAX_ITER` iterations, or converges farther from its start than
the branch moved over the last two steps (a sign of another branch's gait),
the same search starts again from the neighbour's gait
(:func:`jaxwalk.gait.find_gait`'s :class:`~jaxwalk.gait.Fallback`): at that
visit a gait the order-zero start finds is not lost, and where both fail the
order-zero start's failure is reported. Later visits of the line start from
what this one found, so once a visit differs from the order-zero walk, later
ones may too (measured: one point of 4096 on a 64 x 64 map, docs/engine.md
section 5). The secant is used only after two converged consecutive visits of
the walk (the seed counts as the visit before the first one of the walk
down), for a next step in the walk's direction at most :data:`MAX_STEP_RATIO`
times the last. A line that takes chord steps (:func:`continue_segment`'s
``chord``) starts them on the parabola through its last three gaits where
three consecutive converged visits allow it (:func:`parabola_start`): a chord
converges linearly, so a start closer by an order in the grid step saves it a
step, where Newton's quadratic convergence gains nothing from it.
"""

from __future__ import annotations

from typing import Mapping, NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from jaxwalk.errors import ConfigError
from jaxwalk.gait import Fallback, Gait, NewtonOptions, find_gait
from jaxwalk.status import Status
from jaxwalk.step import SolverOptions
from jaxwalk.walker import Walker

Array = jax.Array


def seed_index(values: np.ndarray, default: float) -> int:
    """Index of the grid value nearest ``default`` (where continuation starts: :meth:`jaxwalk.walker.Walker.seed_value`)."""
    return int(np.argmin(np.abs(np.asarray(values) - default)))


def start_value(model: Walker, axis: str, fixed: Mapping[str, float], values: np.ndarray,
                guess_at: Mapping[str, float] | None = None) -> float:
    """Where lines along ``axis`` (grid ``values``) start: the grid value nearest
    ``guess_at[axis]`` where the user's gait guess says where its gait is
    (``[analysis] gait_guess_at`` of a sweep), else the model's own
    :meth:`~jaxwalk.walker.Walker.seed_value`."""
    if guess_at and axis in guess_at:
        values = np.asarray(values, np.float64).reshape(-1)
        return float(values[seed_index(values, float(guess_at[axis]))])
    return model.seed_value(axis, fixed, values)


def checked_guess(model: Walker, options) -> np.ndarray | None:
    """``options.gait_guess`` (:class:`jaxwalk.grid.AnalysisOptions`) as ``(n_v,)``
    float64, or ``None``. Raises :class:`~jaxwalk.errors.ConfigError` unless it is
    the model's number of finite section coordinates."""
    if options.gait_guess is None:
        return None
    guess = np.asarray(options.gait_guess, np.float64).reshape(-1)
    n_v = len(model.section_names)
    if guess.shape != (n_v,) or not np.isfinite(guess).all():
        raise ConfigError(f"gait_guess must be {n_v} finite numbers ({', '.join(model.section_names)}), "
                          f"got {list(options.gait_guess)!r}")
    return guess


def fill_starts(starts: np.ndarray | None, n_lines: int, guess: np.ndarray | None) -> np.ndarray | None:
    """Start points of ``n_lines`` lines (``(n_lines, n_v)``, NaN rows: none) with the
    user's ``guess`` (``(n_v,)``) in every row that has none; ``starts`` itself when
    there is no guess."""
    if guess is None:
        return starts
    guess = np.asarray(guess, np.float64)
    if starts is None:
        return np.broadcast_to(guess, (n_lines, guess.shape[-1])).copy()
    starts = np.asarray(starts, np.float64).reshape(n_lines, -1)
    return np.where(np.isfinite(starts).all(axis=-1, keepdims=True), starts, guess)


def visiting_order(n: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Order in which a continuation axis of length ``n`` is visited from ``seed``.

    Returns ``order`` (every index once: seed, up to the end, then down from
    ``seed - 1``) and ``restart`` (True where the walk restarts from the seed's
    gait instead of the previous point's).
    """
    order = np.concatenate([np.arange(seed, n), np.arange(seed - 1, -1, -1)]).astype(np.int32)
    restart = np.zeros(n, bool)
    if seed > 0:
        restart[n - seed] = True
    return order, restart


class LineCarry(NamedTuple):
    """What a continuation line hands from one visit to the next (one line; vmap it).

    Attributes:
        v_prev, have_prev: ``(n_v,)`` start for the next visit (the last
            converged gait, or the last start where a search failed) and whether it holds one.
        v_seed, have_seed: ``(n_v,)`` the seed point's gait (or the line's given
            start before the seed is visited), where the walk down restarts.
        s_prev: the continuation parameter's value at the last converged visit
            (pairs with ``v_prev`` only where ``last_ok``).
        last_ok: the last visit's search converged (``v_prev`` is its gait).
        v_prev2, s_prev2, have_prev2: ``(n_v,)`` the gait before ``v_prev`` and
            its parameter value, and whether both are converged gaits of
            consecutive visits of the walk (the secant predictor's second point).
        v_prev3, s_prev3, have_prev3: the gait before ``v_prev2``, its
            parameter value, and whether all three are converged gaits of
            consecutive visits of the walk (the parabola's third point,
            :func:`parabola_start`).
        s_seed, seed_ok: the seed point's parameter value and whether its search converged.
        jac_prev, jac_seed: ``(n_v, n_v)`` the Jacobians of the gaits in
            ``v_prev`` (where ``last_ok``) and ``v_seed`` (where ``seed_ok``),
            NaN elsewhere: the chord iterations' matrix of the next search
            (:func:`continue_segment`'s ``chord``).
    """

    v_prev: Array
    have_prev: Array
    v_seed: Array
    have_seed: Array
    s_prev: Array
    last_ok: Array
    v_prev2: Array
    s_prev2: Array
    have_prev2: Array
    s_seed: Array
    seed_ok: Array
    jac_prev: Array
    jac_seed: Array
    v_prev3: Array
    s_prev3: Array
    have_prev3: Array


def fresh_carry(v0, have) -> LineCarry:
    """A :class:`LineCarry` that holds only a start ``v0`` (``(..., n_v)``) where ``have`` (``(...)``)."""
    no = jnp.zeros_like(have, dtype=bool) if isinstance(have, jax.Array) else np.zeros_like(have, dtype=bool)
    zero = no.astype(v0.dtype)
    no_jac = v0[..., :, None] * v0[..., None, :] * np.nan  # (..., n_v, n_v), no Jacobian known
    return LineCarry(v0, have, v0, have, zero, no, v0 * 0, zero, no, zero, no, no_jac, no_jac, v0 * 0, zero, no)


#: Iterations after which a search from the secant that has not converged is
#: abandoned for the neighbour's gait (from a second-order start Newton needs 2-3).
SECANT_MAX_ITER = 8
#: Largest ratio of the next parameter step to the last one at which the secant
#: extrapolates (its error grows with the ratio's square); beyond it the visit
#: starts from the neighbour's gait.
MAX_STEP_RATIO = 2.0
#: Least ``max_jump`` (section units): below it a converged gait is never
#: taken for another branch's (the step map's noise is about 1e-10).
MIN_JUMP = 1e-6


def secant_start(carry: LineCarry, s: Array, from_seed: Array) -> tuple[Array, Array, Array]:
    """``(v, usable, max_jump)``: the point at parameter ``s`` on the line through
    the carry's last two gaits; whether they allow it (two consecutive converged
    visits of the walk, not a restart from the seed, the step to ``s`` in the
    walk's direction and at most :data:`MAX_STEP_RATIO` times the last one);
    and how far from it the gait found may lie before it is taken for
    another branch's (the prediction's move plus the last step's, at least
    :data:`MIN_JUMP`)."""
    last = carry.s_prev - carry.s_prev2
    ratio = (s - carry.s_prev) / jnp.where(last != 0.0, last, 1.0)
    usable = carry.have_prev2 & carry.last_ok & ~from_seed & (last != 0.0) & (ratio > 0.0) & (ratio <= MAX_STEP_RATIO)
    move = carry.v_prev - carry.v_prev2
    v = carry.v_prev + ratio * move
    max_jump = jnp.maximum((1.0 + ratio) * jnp.max(jnp.abs(move)), MIN_JUMP)
    return v, usable, max_jump


def parabola_start(carry: LineCarry, s: Array, from_seed: Array) -> tuple[Array, Array]:
    """``(v, usable)``: the point at parameter ``s`` on the parabola through the
    carry's last three gaits (Lagrange extrapolation), and whether they allow it:
    the secant's conditions (:func:`secant_start`) and three consecutive
    converged visits of the walk, the step between the first two in the walk's
    direction too and the last at most :data:`MAX_STEP_RATIO` times it (the
    weights grow as the ratio's square). Its error is of third order in the grid step where the
    secant's is of second: the start of a line's chord iterations
    (:func:`continue_segment`)."""
    s1, s2, s3 = carry.s_prev, carry.s_prev2, carry.s_prev3
    _, secant_ok, _ = secant_start(carry, s, from_seed)
    before = s2 - s3
    # The last step at most MAX_STEP_RATIO times the one before, as the secant's next one.
    ratio = (s1 - s2) / jnp.where(before != 0.0, before, 1.0)
    usable = secant_ok & carry.have_prev3 & (before != 0.0) & (ratio > 0.0) & (ratio <= MAX_STEP_RATIO)
    d12, d13, d23 = [jnp.where(usable, d, 1.0) for d in (s1 - s2, s1 - s3, s2 - s3)]
    w1 = (s - s2) * (s - s3) / (d12 * d13)
    w2 = -(s - s1) * (s - s3) / (d12 * d23)
    w3 = (s - s1) * (s - s2) / (d13 * d23)
    return w1 * carry.v_prev + w2 * carry.v_prev2 + w3 * carry.v_prev3, usable


def after_visit(carry: LineCarry, v: Array, ok: Array, s: Array, from_seed: Array, is_first: Array,
                start_v: Array, start_ok: Array, jac: Array) -> LineCarry:
    """The carry after a visit at parameter ``s`` whose search from ``start_v``
    (``start_ok``: a real start) ended with gait ``v`` (``ok``: converged) and
    Jacobian ``jac``."""
    # The gait before this one in the walk: the seed's on the first visit down.
    before_v = jnp.where(from_seed, carry.v_seed, carry.v_prev)
    before_s = jnp.where(from_seed, carry.s_seed, carry.s_prev)
    before_ok = jnp.where(from_seed, carry.seed_ok, carry.last_ok)
    seeded = is_first & ok
    return LineCarry(
        v_prev=jnp.where(ok, v, start_v),
        have_prev=ok | start_ok,
        v_seed=jnp.where(seeded, v, carry.v_seed),
        have_seed=carry.have_seed | seeded,
        s_prev=jnp.where(ok, s, carry.s_prev),
        last_ok=ok,
        v_prev2=jnp.where(ok, before_v, carry.v_prev2),
        s_prev2=jnp.where(ok, before_s, carry.s_prev2),
        have_prev2=ok & before_ok,
        s_seed=jnp.where(seeded, s, carry.s_seed),
        seed_ok=carry.seed_ok | seeded,
        jac_prev=jnp.where(ok, jac, jnp.nan),
        jac_seed=jnp.where(seeded, jac, carry.jac_seed),
        # The walk down has no gait beyond the seed's: its parabola waits for the seed's and two more.
        v_prev3=jnp.where(ok, carry.v_prev2, carry.v_prev3),
        s_prev3=jnp.where(ok, carry.s_prev2, carry.s_prev3),
        have_prev3=ok & before_ok & ~from_seed & carry.have_prev2,
    )


def continue_segment(
    model: Walker,
    visits: Mapping[str, Array],
    position: Array,
    restart: Array,
    first: Array,
    valid: Array,
    carry: LineCarry,
    solver: SolverOptions,
    newton: NewtonOptions,
    chord: bool = False,
) -> tuple[LineCarry, Gait]:
    """Gaits at ``L`` consecutive visits of one continuation line, in visiting order.

    Args:
        visits: dict of ``(L,)`` parameter arrays, one entry per visit.
        position: ``(L,)`` the continuation parameter's value at each visit
            (the secant predictor's abscissa).
        restart: ``(L,)`` True where the visit starts from the seed's gait
            instead of the previous visit's (:func:`visiting_order`).
        first: ``(L,)`` True at the line's seed point (its first visit).
        valid: ``(L,)`` False at padding visits: skipped (a real branch, not
            a masked one, as long as ``valid`` is not batched: every line of a
            call shares it), their gaits zeros and the carry unchanged.
        carry: from the visit before (:func:`fresh_carry` before the first).
        chord: start each search with chord iterations on the Jacobian of the
            gait it starts from (:func:`~jaxwalk.gait.find_gait`'s
            ``jacobian_guess``), from the parabola through the last three
            gaits where there are three (:func:`parabola_start`): the shoe
            walker's map 1.31x faster than full Newton with chord steps from
            the secant, 1.18x faster again from the parabola with the probe
            that ends them (benchmarks/README.md). Only where the line's
            program is not vmapped: under ``vmap`` it would be a ``select`` of
            both evaluations.

    Returns:
        The carry after the last visit, and a :class:`Gait` of ``(L,)`` leaves.
    """
    guess_fn = model.initial_guess

    def search(carry: LineCarry, p, s, from_seed, is_first):
        start_v = jnp.where(from_seed, carry.v_seed, carry.v_prev)
        start_ok = jnp.where(from_seed, carry.have_seed, carry.have_prev)
        v0 = jnp.where(start_ok, start_v, guess_fn(p))
        # The Jacobian of the gait the search starts from (NaN where it starts
        # from a failed search's start or the model's guess: full Newton).
        jac = jnp.where(from_seed, carry.jac_seed, carry.jac_prev) if chord else None
        if newton.predictor == "secant":
            v_secant, use, max_jump = secant_start(carry, s, from_seed)
            if chord:  # a chord contracts linearly: it starts on the parabola where there is one
                v_parabola, on_parabola = parabola_start(carry, s, from_seed)
                v_secant = jnp.where(on_parabola, v_parabola, v_secant)
            fallback = Fallback(v0, use, SECANT_MAX_ITER, max_jump)
            gait = find_gait(model, p, jnp.where(use, v_secant, v0), solver, newton, fallback, jac)
        else:
            gait = find_gait(model, p, v0, solver, newton, None, jac)
        ok = gait.status == Status.OK
        return after_visit(carry, gait.v, ok, s, from_seed, is_first, start_v, start_ok, gait.jacobian), gait

    # One trace serves both the shape of a skipped visit's output and the branch
    # that runs (jit caches the trace of one function object at one signature).
    search = jax.jit(search)

    def visit(carry, xs):
        p, s, from_seed, is_first, real = xs
        shapes = jax.eval_shape(search, carry, p, s, from_seed, is_first)
        skipped = lambda c, *_: (c, jax.tree_util.tree_map(lambda x: jnp.zeros(x.shape, x.dtype), shapes[1]))
        return jax.lax.cond(real, search, skipped, carry, p, s, from_seed, is_first)

    return jax.lax.scan(visit, carry, (dict(visits), position, restart, first, valid))
