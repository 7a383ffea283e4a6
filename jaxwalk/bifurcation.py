"""Bifurcations along a continuation line, located to ``tol`` in the parameter.

Along a line of gaits (period 1, or period-k cycles: fixed points of the
k-step map) the multipliers ``mu`` (eigenvalues of the map's Jacobian) move
with the parameter. A bifurcation is where a test function changes sign:

* **fold**: a real multiplier through +1, ``prod(mu - 1)``;
* **flip** (period doubling): a real multiplier through -1, ``prod(mu + 1)``;
* **Neimark-Sacker**: a complex pair through the unit circle, the bialternate
  product ``prod_(i<j) (mu_i mu_j - 1)`` (which also vanishes at a real pair
  with ``mu_i mu_j = 1``, a neutral saddle: kept only where the pair nearest
  ``mu_i mu_j = 1`` is complex).

Where the line goes on but its gait is lost (Newton fails on one side), the
edge is located by bisection on "the gait is followed there" (a failure is
confirmed by following the gait to it in steps, and the grid point beyond is
itself re-solved from the gait next to it) and labelled **grazing**
when the failure beyond it is a step's (a guard reached: scuffing, a fall,
...: the event sequence changes), **fold** when a real multiplier is within
``fold_window`` of +1 at the edge (the gait turns back: a natural-parameter
line cannot follow it), and **lost** otherwise.

Each test-function bracket (two neighbouring grid points with opposite signs)
is shrunk by the Illinois variant of regula falsi, one Newton re-solve of the
cycle per trial parameter (started from the bracket's ends interpolated), all
brackets of all lines batched in one ``vmap`` per iteration, until it is
narrower than ``2 tol``; its midpoint is then within ``tol`` of the root of the
test function of the computed map (the map's own accuracy, ~1e-10 in the
section, sets how well that root is the true one).
"""

from __future__ import annotations

import dataclasses
import enum
import functools
from typing import Mapping, NamedTuple

import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Complex, Float, Int, Int8

from jaxwalk import compiling
from jaxwalk.attractor import AttractorOptions, find_cycle, minimal_period, spectrum
from jaxwalk.batching import Rows, over_rows, run_chunks, sub_batch_size
from jaxwalk.gait import NewtonOptions
from jaxwalk.status import Status
from jaxwalk.step import SolverOptions
from jaxwalk.walker import Walker


class Kind(enum.IntEnum):
    """Bifurcation labels (values are file format: append, never renumber)."""

    FOLD = 1
    FLIP = 2
    NEIMARK_SACKER = 3
    GRAZING = 4
    LOST = 5
    BRANCH_POINT = 6


KIND_MEANINGS = {
    Kind.FOLD: "fold: a real multiplier through +1 (or the gait turns back at the edge where it is lost)",
    Kind.FLIP: "flip (period doubling): a real multiplier through -1",
    Kind.NEIMARK_SACKER: "Neimark-Sacker: a complex pair of multipliers through the unit circle",
    Kind.GRAZING: "grazing: the gait is lost where a step starts to fail (a guard reaches zero: scuffing, a fall, ...)",
    Kind.LOST: "the gait is lost (Newton fails beyond) with no multiplier near +1 and no failing step",
    Kind.BRANCH_POINT: "branch point: a real multiplier through +1 where the branch does not turn (branches cross)",
}


@dataclasses.dataclass(frozen=True)
class BifurcationOptions:
    """Settings of the location.

    Attributes:
        tol: half-width of the final bracket (parameter units): the located value's accuracy.
        max_iter: root-finder iterations per bracket before ``NO_CONVERGENCE``.
        fold_window: at a lost gait's edge, a real multiplier within this of +1 makes it a fold.
    """

    tol: float = 1e-6
    max_iter: int = 80
    fold_window: float = 0.05


class Bifurcations(NamedTuple):
    """A table of located points (one row each).

    Attributes:
        kind: int8 :class:`Kind`.
        parameter: the continuation parameter's value there.
        line: index of the line (row of the lines given).
        period: k of the map whose multipliers cross (1: the period-1 gait).
        status: int8 ``OK``, or why the location failed (its bracket is then the row's ``parameter``
            midpoint, not to ``tol``).
        v: ``(n_v,)`` the cycle's point at the located parameter (on the gait's side for edges).
        multipliers: ``(n_v,)`` complex, there.
        beyond: int8 status of the failure beyond an edge (``OK`` for sign changes).
    """

    kind: Int8[np.ndarray, "rows"]
    parameter: Float[np.ndarray, "rows"]
    line: Int[np.ndarray, "rows"]
    period: Int[np.ndarray, "rows"]
    status: Int8[np.ndarray, "rows"]
    v: Float[np.ndarray, "rows n_v"]
    multipliers: Complex[np.ndarray, "rows n_v"]
    beyond: Int8[np.ndarray, "rows"]


def indicators(mu: np.ndarray) -> np.ndarray:
    """``(..., 3)``: the fold, flip and Neimark-Sacker test functions of multipliers ``(..., n_v)``."""
    mu = np.asarray(mu, np.complex128)
    fold = np.prod(mu - 1.0, axis=-1).real
    flip = np.prod(mu + 1.0, axis=-1).real
    i, j = np.triu_indices(mu.shape[-1], 1)
    ns = np.prod(mu[..., i] * mu[..., j] - 1.0, axis=-1).real
    return np.stack([fold, flip, ns], axis=-1)


def _complex_pair_on_circle(mu: np.ndarray) -> bool:
    i, j = np.triu_indices(mu.shape[-1], 1)
    nearest = int(np.argmin(np.abs(mu[i] * mu[j] - 1.0)))
    return abs(mu[i[nearest]].imag) > 1e-6 and abs(mu[i[nearest]] - np.conj(mu[j[nearest]])) < 1e-6


#: Re-solves per program call: every call has this shape whatever the batch
#: (padding skipped: jaxwalk.batching), so a model compiles its re-solve once.
CALL_ROWS = 64


class CycleGuess(NamedTuple):
    """The re-solve's input beside the parameters: where Newton starts."""

    v0: Array  # (n_v,) a point of the cycle, on the section


@functools.lru_cache(maxsize=None)
def _solver(model: Walker, k: int, solver: SolverOptions, newton: NewtonOptions):
    """Batched Newton re-solve of the period-k cycle: :class:`~jaxwalk.batching.Rows`
    (parameters, inputs :class:`CycleGuess`) -> ``(status, v, multipliers)``."""

    k_ = jnp.asarray(k, jnp.int32)

    def one(p, guess: CycleGuess):
        v0 = guess.v0
        _, jac, points, status = find_cycle(model, p, v0, k_, k, solver, newton)
        eig, _ = spectrum(jnp.where(jnp.isfinite(jac).all(), jac, jnp.eye(v0.shape[0], dtype=v0.dtype)))
        # A fixed point of f^k that closes after fewer steps is a shorter cycle, not this branch's.
        shorter = minimal_period(points, k_, AttractorOptions(max_period=k)) < k_
        status = jnp.where((status == Status.OK) & shorter, jnp.int8(Status.CYCLE_NOT_FOUND), status)
        return status, points[0], eig

    return compiling.jit(over_rows(one, sub_batch_size(model, solver)), model)


def _evaluate(model, k, solver, newton, params: Mapping[str, np.ndarray], v0: np.ndarray):
    """Re-solve at a batch of parameter sets, :data:`CALL_ROWS` per call (one compiled shape)."""
    rows = Rows({k_: np.asarray(x, np.float64) for k_, x in params.items()}, CycleGuess(np.asarray(v0, np.float64)))
    status, v, eig = run_chunks(_solver(model, k, solver, newton), rows, CALL_ROWS, None)
    return np.asarray(status), np.asarray(v), np.asarray(eig)


def follow(model: Walker, lines: Mapping[str, np.ndarray], v0: np.ndarray, start: int, period: int = 1,
           solver: SolverOptions = SolverOptions(), newton: NewtonOptions = NewtonOptions()):
    """Natural-parameter continuation of period-k cycles along ``n_lines`` lines of ``n`` points.

    Each line starts at point ``start`` from ``v0[line]`` and walks up the line,
    then down from ``start``, each point from its neighbour's cycle (the last
    found one after a failure), all lines batched.

    Returns ``(status, v, multipliers)``, ``(n_lines, n)``, ``(n_lines, n, n_v)`` twice.
    """
    n_lines, n = next(iter(lines.values())).shape
    v0 = np.asarray(v0, np.float64).reshape(n_lines, -1)
    status = np.full((n_lines, n), Status.NO_CONVERGENCE, np.int8)
    v = np.full((n_lines, n, v0.shape[-1]), np.nan)
    mu = np.full(v.shape, np.nan, np.complex128)
    rows = np.arange(n_lines)
    for order in (range(start, n), range(start - 1, -1, -1)):
        prev = v0.copy() if order.start == start else v[:, start].copy()
        prev = np.where(np.isfinite(prev), prev, v0)
        for i in order:
            st, v_i, mu_i = _evaluate(model, period, solver, newton, _params_at(lines, None, rows, None, np.full(n_lines, i)), prev)
            status[:, i], v[:, i], mu[:, i] = st, np.where((st == 0)[:, None], v_i, np.nan), np.where((st == 0)[:, None], mu_i, np.nan)
            prev = np.where((st == 0)[:, None], v_i, prev)
    return status, v, mu


def locate(
    model: Walker,
    lines: Mapping[str, np.ndarray],
    axis: str,
    status: np.ndarray,
    v: np.ndarray,
    multipliers: np.ndarray,
    period: int = 1,
    options: BifurcationOptions = BifurcationOptions(),
    solver: SolverOptions = SolverOptions(),
    newton: NewtonOptions = NewtonOptions(),
    progress=None,
) -> Bifurcations:
    """Every bifurcation between neighbouring points of ``n_lines`` lines of ``n`` points.

    Args:
        lines: every model parameter as an ``(n_lines, n)`` array; ``lines[axis]``
            is the continuation parameter (monotone along each line).
        status: ``(n_lines, n)`` status of each point's cycle (0: found).
        v: ``(n_lines, n, n_v)`` a point of each cycle (the period-1 fixed point for ``period = 1``).
        multipliers: ``(n_lines, n, n_v)`` complex eigenvalues of the k-step map's Jacobian there.
        period: k, the map's number of steps.
        progress: ``None``, or a progress bar with tqdm's ``total``, ``update(n)``
            and ``refresh()``: its total is set to the rounds of batched solves
            planned (the edges' bisections exactly, the sign changes' regula
            falsi at most ``options.max_iter``, lowered when they end sooner)
            and advanced by one per round.

    Returns:
        :class:`Bifurcations`, rows ordered by line then parameter.
    """
    status = np.asarray(status)
    tests = indicators(multipliers)
    sign_rows, edge_rows = [], []
    n_lines, n = status.shape
    for line, i in ((line, i) for line in range(n_lines) for i in range(n - 1)):
        a, b = (line, i), (line, i + 1)
        ok_a, ok_b = status[a] == Status.OK, status[b] == Status.OK
        if ok_a and ok_b:
            for kind, column in ((Kind.FOLD, 0), (Kind.FLIP, 1), (Kind.NEIMARK_SACKER, 2)):
                if np.sign(tests[a][column]) * np.sign(tests[b][column]) < 0:
                    sign_rows.append((kind, column, line, i))
        elif ok_a != ok_b:
            edge_rows.append((line, i, i + 1) if ok_a else (line, i + 1, i))  # (line, found, lost)
    rounds = _Rounds(progress, sign_rows, edge_rows, np.asarray(lines[axis], np.float64), options)
    rows = _shrink_signs(model, lines, axis, v, tests, sign_rows, period, options, solver, newton, rounds)
    rows += _shrink_edges(model, lines, axis, status, v, multipliers, edge_rows, period, options, solver, newton, rounds)
    rows.sort(key=lambda r: (r["line"], r["parameter"]))
    n_v = v.shape[-1]
    col = lambda key, dtype: np.array([r[key] for r in rows], dtype)
    return Bifurcations(
        kind=col("kind", np.int8), parameter=col("parameter", np.float64), line=col("line", np.int32),
        period=np.full(len(rows), period, np.int32), status=col("status", np.int8),
        v=np.array([r["v"] for r in rows], np.float64).reshape(-1, n_v),
        multipliers=np.array([r["multipliers"] for r in rows], np.complex128).reshape(-1, n_v),
        beyond=col("beyond", np.int8),
    )


class _Rounds:
    """Counts :func:`locate`'s rounds of batched solves on a progress bar (or nowhere)."""

    def __init__(self, bar, sign_rows, edge_rows, x: np.ndarray, options: BifurcationOptions):
        self.bar = bar
        self.sign_left = (options.max_iter + 1) if sign_rows else 0  # the last +1: the midpoints' solve
        if edge_rows:
            width = max(abs(x[r[0], r[2]] - x[r[0], r[1]]) for r in edge_rows)
            edge = int(np.ceil(np.log2(max(width / (2 * options.tol), 1.0)))) + 1
        else:
            edge = 0
        self.edge_left = edge  # bisection rounds planned, and one to solve at the failed grid point
        if bar is not None:
            bar.total = self.sign_left + edge
            bar.refresh()

    def advance(self, signs: bool = False) -> None:
        if signs:
            self.sign_left -= 1
        if self.bar is not None:
            self.bar.update(1)

    def signs_done(self) -> None:
        """The regula falsi ended before ``max_iter``: its unused rounds leave the total."""
        if self.bar is not None and self.sign_left > 1:
            self.bar.total -= self.sign_left - 1
            self.bar.refresh()
        self.sign_left = min(self.sign_left, 1)

    def edge_round(self) -> None:
        """One round of the edges' location; past the plan (a grid point found to
        hold the gait moves the edge on to the next interval) the total grows."""
        if self.edge_left > 0:
            self.edge_left -= 1
        elif self.bar is not None:
            self.bar.total += 1
        self.advance()

    def edges_done(self) -> None:
        """The edges are located; rounds planned but not needed leave the total."""
        if self.bar is not None and self.edge_left > 0:
            self.bar.total -= self.edge_left
            self.bar.refresh()
        self.edge_left = 0


def _params_at(lines, axis, line_index: np.ndarray, x: np.ndarray, i: np.ndarray) -> dict[str, np.ndarray]:
    """Parameters of the lines at continuation values ``x`` (other parameters of point ``i``)."""
    out = {k: np.asarray(val)[line_index, i] for k, val in lines.items()}
    if axis is not None:
        out[axis] = x
    return out


def _shrink_signs(model, lines, axis, v, tests, rows, period, options, solver, newton, rounds: _Rounds) -> list[dict]:
    """Illinois regula falsi on each sign-change bracket, all brackets batched."""
    if not rows:
        return []
    kind = np.array([r[0] for r in rows]); column = np.array([r[1] for r in rows])
    line = np.array([r[2] for r in rows]); i = np.array([r[3] for r in rows])
    x = np.asarray(lines[axis], np.float64)
    lo, hi = x[line, i], x[line, i + 1]
    f_lo, f_hi = tests[line, i, column], tests[line, i + 1, column]
    v_lo, v_hi = v[line, i], v[line, i + 1]
    state = np.full(len(rows), Status.IN_PROGRESS, np.int8)
    side = np.zeros(len(rows), np.int8)  # which end was kept last (Illinois halves its value when kept twice)
    for it in range(options.max_iter):
        active = (state == Status.IN_PROGRESS) & (np.abs(hi - lo) > 2 * options.tol)
        state[(state == Status.IN_PROGRESS) & ~active] = Status.OK
        if not active.any():
            break
        rounds.advance(signs=True)
        secant = hi - f_hi * (hi - lo) / (f_hi - f_lo)
        # Every fourth trial a bisection, and never within 1% of an end: the bracket must shrink from both sides.
        width = hi - lo
        trial = np.where((it % 4 == 3) | ~np.isfinite(secant), 0.5 * (lo + hi), np.clip(secant, lo + 0.01 * width, hi - 0.01 * width))
        w = ((trial - lo) / np.where(width == 0, 1, width))[:, None]
        idx = np.flatnonzero(active)
        st, v_t, mu = _evaluate(model, period, solver, newton, _params_at(lines, axis, line[idx], trial[idx], i[idx]),
                                ((1 - w) * v_lo + w * v_hi)[idx])
        failed = st != Status.OK
        state[idx[failed]] = st[failed]
        good = idx[~failed]
        f_t = indicators(mu[~failed])[np.arange(len(good)), column[good]]
        same_lo = np.sign(f_t) == np.sign(f_lo[good])
        for j, g in enumerate(good):
            if same_lo[j]:
                lo[g], f_lo[g], v_lo[g] = trial[g], f_t[j], v_t[~failed][j]
                f_hi[g] *= 0.5 if side[g] == 1 else 1.0
                side[g] = 1
            else:
                hi[g], f_hi[g], v_hi[g] = trial[g], f_t[j], v_t[~failed][j]
                f_lo[g] *= 0.5 if side[g] == -1 else 1.0
                side[g] = -1
    state[state == Status.IN_PROGRESS] = Status.NO_CONVERGENCE
    rounds.signs_done()
    rounds.advance(signs=True)
    mid = 0.5 * (lo + hi)
    st, v_m, mu_m = _evaluate(model, period, solver, newton, _params_at(lines, axis, line, mid, i), 0.5 * (v_lo + v_hi))
    out = []
    for r in range(len(rows)):
        status = state[r] if state[r] != Status.OK else st[r]
        if kind[r] == Kind.NEIMARK_SACKER and not _complex_pair_on_circle(mu_m[r]):
            continue  # a neutral saddle (real mu_i mu_j = 1), not a bifurcation of the cycle
        out.append({"kind": kind[r], "parameter": mid[r], "line": line[r], "status": status, "v": v_m[r],
                    "multipliers": mu_m[r], "beyond": Status.OK})
    return out


def _shrink_edges(model, lines, axis, status, v, multipliers, rows, period, options, solver, newton,
                  rounds: _Rounds) -> list[dict]:
    """Bisection on "the cycle is followed there" at each edge of a line's gaits.

    A Newton solve that fails from the last found cycle does not show that the
    cycle is gone: far from the bracket's found end its start can lie where a
    step fails although the cycle exists (the flat-foot walker's unstable
    gaits, whose steps diverge from an offset start). Such a failure is checked
    by following the cycle in :data:`APPROACH_STEPS` steps (:func:`_approach`);
    the bracket becomes the last step reached and the first that failed. The
    same holds for the grid point beyond the edge, whose failure the line's own
    continuation found from its other side or from far away: once the bracket
    has closed on it, it is solved from the cycle next to it, and where the
    cycle is found there the edge moves on to the next interval (or, past the
    line's last point, there is none).
    """
    if not rows:
        return []
    e = _Edges.start(rows, np.asarray(lines[axis], np.float64), status, v, multipliers)
    solve = lambda at, which, guess: _evaluate(model, period, solver, newton, _params_at(lines, axis, e.line[which], at, e.ok_i[which]), guess)
    while True:
        narrow = np.abs(e.bad - e.good) <= 2 * options.tol
        probe = narrow & e.untested & ~e.ended
        idx = np.flatnonzero((~narrow | probe) & ~e.ended)
        if idx.size == 0:
            break
        rounds.edge_round()
        at = np.where(probe, e.bad, 0.5 * (e.good + e.bad))[idx]
        st, v_at, mu_at = solve(at, idx, e.v_good[idx])
        lost = np.flatnonzero(st != Status.OK)
        reached, v_r, mu_r, failed, why = _approach(solve, idx[lost], e.good[idx[lost]], at[lost], e.v_good[idx[lost]], e.mu_good[idx[lost]])
        found = st == Status.OK
        found[lost] = ~np.isfinite(failed)
        v_at[lost], mu_at[lost] = v_r, mu_r
        e.found_at(idx[found], at[found], v_at[found], mu_at[found], probe[idx[found]])
        k = np.flatnonzero(~found)
        which = np.searchsorted(lost, k)  # rows of `lost` that the approach confirmed
        e.lost_at(idx[k], reached[which], v_r[which], mu_r[which], failed[which], why[which])
    rounds.edges_done()
    out = []
    for r in np.flatnonzero(~e.ended):
        real = e.mu_good[r][np.abs(e.mu_good[r].imag) < 1e-9].real
        near_one = real.size and np.min(np.abs(real - 1.0)) < options.fold_window
        step_failed = e.beyond[r] not in (Status.NO_CONVERGENCE, Status.NONFINITE, Status.NOT_DIFFERENTIABLE)
        kind = Kind.FOLD if near_one else Kind.GRAZING if step_failed else Kind.LOST
        out.append({"kind": kind, "parameter": 0.5 * (e.good[r] + e.bad[r]), "line": e.line[r], "status": Status.OK,
                    "v": e.v_good[r], "multipliers": e.mu_good[r], "beyond": e.beyond[r]})
    return out


@dataclasses.dataclass
class _Edges:
    """The brackets of :func:`_shrink_edges`, one row per edge: ``good`` (the
    cycle found there: ``v_good``, ``mu_good``) and ``bad`` (the failure
    ``beyond``; ``untested`` while it is the grid point as the line's
    continuation left it), on line ``line`` between grid points ``ok_i`` and
    ``bad_i``; ``ended``: the cycle was followed past the line's last point."""

    line: np.ndarray
    ok_i: np.ndarray
    bad_i: np.ndarray
    x: np.ndarray
    status: np.ndarray
    good: np.ndarray
    bad: np.ndarray
    v_good: np.ndarray
    mu_good: np.ndarray
    beyond: np.ndarray
    untested: np.ndarray
    ended: np.ndarray

    @classmethod
    def start(cls, rows, x, status, v, multipliers) -> "_Edges":
        line, ok_i, bad_i = (np.array([r[k] for r in rows]) for k in range(3))
        return cls(line, ok_i, bad_i, x, status, x[line, ok_i].copy(), x[line, bad_i].copy(), v[line, ok_i].copy(),
                   np.asarray(multipliers)[line, ok_i].copy(), status[line, bad_i].astype(np.int8),
                   np.ones(len(rows), bool), np.zeros(len(rows), bool))

    def found_at(self, r, at, v, mu, probed) -> None:
        """The cycle was found at ``at``; a probed grid point moves the edge on one interval."""
        self.good[r], self.v_good[r], self.mu_good[r] = at, v, mu
        moved = r[probed]
        self.bad_i[moved] += np.sign(self.bad_i[moved] - self.ok_i[moved])
        past = (self.bad_i[moved] < 0) | (self.bad_i[moved] >= self.x.shape[1])
        self.ended[moved[past]] = True
        on = moved[~past]
        self.bad[on], self.beyond[on] = self.x[self.line[on], self.bad_i[on]], self.status[self.line[on], self.bad_i[on]]

    def lost_at(self, r, reached, v, mu, failed, why) -> None:
        """The cycle, followed, was found up to ``reached`` and lost at ``failed`` (status ``why``)."""
        self.good[r], self.v_good[r], self.mu_good[r] = reached, v, mu
        self.bad[r], self.beyond[r], self.untested[r] = failed, why, False


#: Steps in which :func:`_approach` follows a cycle to where a direct solve failed.
APPROACH_STEPS = 4


def _approach(solve, which: np.ndarray, good: np.ndarray, target: np.ndarray, v_good: np.ndarray, mu_good: np.ndarray):
    """Follow the cycles of rows ``which`` from ``good`` towards ``target`` in
    :data:`APPROACH_STEPS` equal steps, each solve from the last found cycle.

    Returns ``(reached, v_reached, mu_reached, failed, status)`` per row: the
    last value where the cycle was found, its point and multipliers, the first
    value where it was not (NaN if the target itself was reached) and that
    failure's status.
    """
    reached, v_reached, mu_reached = good.copy(), v_good.copy(), mu_good.copy()
    failed = target.copy()
    why = np.full(len(which), Status.NO_CONVERGENCE, np.int8)
    going = np.ones(len(which), bool)
    for j in range(1, APPROACH_STEPS + 1):
        idx = np.flatnonzero(going)
        if idx.size == 0:
            break
        at = good[idx] + (target[idx] - good[idx]) * j / APPROACH_STEPS
        st, v_at, mu_at = solve(at, which[idx], v_reached[idx])
        ok = st == Status.OK
        reached[idx[ok]], v_reached[idx[ok]], mu_reached[idx[ok]] = at[ok], v_at[ok], mu_at[ok]
        failed[idx[~ok]], why[idx[~ok]] = at[~ok], st[~ok]
        going[idx[~ok]] = False
    failed[going] = np.nan  # every step found, the target too: no failure on this side
    return reached, v_reached, mu_reached, failed, why
