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
when the failure beyond it is a guard's (:data:`GUARD_FAILURES`: scuffing, a
fall, ...: the event sequence changes), else **fold** when a real multiplier is
within ``fold_window`` of +1 at the edge (the gait turns back: a natural-parameter
line cannot follow it), and **lost** otherwise.

Where neighbouring gaits' steps take different event sequences (models that
log their events: :mod:`jaxwalk.event_log`), the map is piecewise smooth and
its multipliers may jump: that point is located as a **border collision**
(:mod:`jaxwalk.border_collision`), and the test functions' sign changes are
sought only between gaits of one sequence; a sign that changes across the
collision is reported with it (``jumps``), not as a fold, flip or
Neimark-Sacker point. A sign change whose bracket closes with nothing near
the unit circle's crossing at one of its two ends (the multipliers jump with
no order change found) is a **jump** row (:func:`_crosses`), not a bifurcation.

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
from jaxwalk.bifurcation_edges import shrink_edges
from jaxwalk.bifurcation_rounds import Rounds as _Rounds
from jaxwalk.border_collision import jumps, locate_changes
from jaxwalk.errors import ConfigError
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
    BORDER_COLLISION = 7
    JUMP = 8
    SWITCH = 9


KIND_MEANINGS = {
    Kind.FOLD: "fold: a real multiplier through +1 (or the gait turns back at the edge where it is lost)",
    Kind.FLIP: "flip (period doubling): a real multiplier through -1",
    Kind.NEIMARK_SACKER: "Neimark-Sacker: a complex pair of multipliers through the unit circle",
    Kind.GRAZING: ("grazing: the gait is lost where a step starts to fail at a guard or an impact's check "
                   "(scuffing, a fall, a slip, a pulling contact, ...)"),
    Kind.LOST: ("the gait is lost (Newton from it fails beyond) with no multiplier near +1 and no guard failing the "
                "step (beyond: no convergence, a time limit, the solver, too many events, a non-finite state, or "
                "not_located: Newton converged to another gait)"),
    Kind.BRANCH_POINT: "branch point: a real multiplier through +1 where the branch does not turn (branches cross)",
    Kind.BORDER_COLLISION: ("border collision: the gait goes on but its step's event sequence changes (checked: the "
                            "logged sequences differ on the two sides, and re-solved there from each side's gait, "
                            "one fixed point); the multipliers may jump there"),
    Kind.JUMP: ("jump: a fold, flip or Neimark-Sacker test function changes sign between two gaits 2 tol apart, at "
                "one of which no multiplier (pair) is near the unit circle's crossing, with no event-order change "
                "found on the two sides (or none logged), and one gait there (re-solved at the located parameter "
                "from either end: one fixed point): the multipliers jump (the step map is not smooth there); "
                "no bifurcation is named"),
    Kind.SWITCH: ("switch: a test function's sign or the event sequence changes because the line passes from one "
                  "gait to another that coexists with it: re-solved at the located parameter from the two ends of "
                  "the closed bracket, Newton finds two fixed points (farther apart than same_gait); no bifurcation, "
                  "jump or border collision is named"),
}
#: Where a multiplier crosses the unit circle at a fold and at a flip.
_CROSSING_AT = {Kind.FOLD: 1.0, Kind.FLIP: -1.0}


@dataclasses.dataclass(frozen=True)
class BifurcationOptions:
    """Settings of the location.

    Attributes:
        tol: half-width of the final bracket (parameter units): the located value's accuracy.
        max_iter: root-finder iterations per bracket before ``NOT_LOCATED``.
        fold_window: at a lost gait's edge where no guard failed beyond, a real multiplier
            within this of +1 makes it a fold;
            a located fold, flip or Neimark-Sacker point needs a multiplier within it of
            +1 or -1 (a pair whose product is within it of 1) at both ends of its
            closed bracket, else it is a :attr:`Kind.JUMP`.
        same_gait: a closed sign-change bracket is re-solved at its midpoint from each
            of its two ends; fixed points farther apart than this (max norm, section
            units: rad, rad per time unit) are two gaits, a :attr:`Kind.SWITCH`. Far
            above Newton's agreement with itself (``tol`` 1e-8, amplified near a fold
            by ``1 / sigma_min(J - I)``) and below the distance of two distinct gaits.
    """

    tol: float = 1e-6
    max_iter: int = 80
    fold_window: float = 0.05
    same_gait: float = 1e-4


class Bifurcations(NamedTuple):
    """A table of located points (one row each).

    Attributes:
        kind: int8 :class:`Kind`.
        parameter: the continuation parameter's value there.
        line: index of the line (row of the lines given).
        period: k of the map whose multipliers cross (1: the period-1 gait).
        status: int8 ``OK``, or why the location failed (its bracket is then the row's ``parameter``
            midpoint, not to ``tol``): ``NOT_LOCATED`` where its bracket was not closed, also where a sign change's
            bracket met a third event sequence inside (two collisions between grid points).
        v: ``(n_v,)`` the cycle's point at the located parameter (on the gait's side for
            edges, on the lower parameter's side for border collisions and jumps).
        multipliers: ``(n_v,)`` complex, there.
        beyond: int8 status of the failure beyond an edge (``OK`` for sign changes).
        sequence: int64 sequence code of the cycle's first step there (:mod:`jaxwalk.event_log`;
            0 where the model logs none).
        sequence_beyond: int64, a border collision's sequence on its higher parameter's side (0 for the others).
        multipliers_beyond: ``(n_v,)`` complex, a border collision's or a jump's multipliers on its
            higher parameter's side (NaN for the others).
        jumps: int8 bit mask of the test functions whose sign changes across a border
            collision or a jump (fold 1, flip 2, Neimark-Sacker 4; 0 for the others).
    """

    kind: Int8[np.ndarray, "rows"]
    parameter: Float[np.ndarray, "rows"]
    line: Int[np.ndarray, "rows"]
    period: Int[np.ndarray, "rows"]
    status: Int8[np.ndarray, "rows"]
    v: Float[np.ndarray, "rows n_v"]
    multipliers: Complex[np.ndarray, "rows n_v"]
    beyond: Int8[np.ndarray, "rows"]
    sequence: Int[np.ndarray, "rows"]
    sequence_beyond: Int[np.ndarray, "rows"]
    multipliers_beyond: Complex[np.ndarray, "rows n_v"]
    jumps: Int8[np.ndarray, "rows"]


def _crosses(kind: Kind, mu: np.ndarray, options: "BifurcationOptions") -> bool:
    """Whether multipliers ``mu`` located at a ``kind`` sign change are near where
    that kind crosses the unit circle, within ``fold_window``: one near +1 (fold),
    -1 (flip), a pair whose product is near 1 (Neimark-Sacker).

    Where the test function changed sign by a jump of the multipliers (the step
    map not smooth, with the event order unchanged: a border collision is
    caught before), the regula falsi still closes on the jump, and nothing is
    near the circle there. (Two multipliers meeting at +1 are complex on one
    side, so no realness is asked.)
    """
    mu = np.asarray(mu, np.complex128)
    if kind == Kind.NEIMARK_SACKER:
        i, j = np.triu_indices(mu.shape[-1], 1)
        return bool(i.size) and float(np.min(np.abs(mu[i] * mu[j] - 1.0))) < options.fold_window
    return float(np.min(np.abs(mu - _CROSSING_AT[kind]), initial=np.inf)) < options.fold_window


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
    (parameters, inputs :class:`CycleGuess`) -> ``(status, v, multipliers, sequences)``
    (``sequences``: ``(k,)`` int64, the sequence codes of the cycle's steps)."""

    k_ = jnp.asarray(k, jnp.int32)

    def one(p, guess: CycleGuess):
        v0 = guess.v0
        _, jac, points, status, sequences = find_cycle(model, p, v0, k_, k, solver, newton)
        eig, _ = spectrum(jnp.where(jnp.isfinite(jac).all(), jac, jnp.eye(v0.shape[0], dtype=v0.dtype)))
        # A fixed point of f^k that closes after fewer steps is a shorter cycle, not this branch's.
        shorter = minimal_period(points, k_, AttractorOptions(max_period=k)) < k_
        status = jnp.where((status == Status.OK) & shorter, jnp.int8(Status.CYCLE_NOT_FOUND), status)
        return status, points[0], eig, sequences[:k]

    return compiling.jit(over_rows(one, sub_batch_size(model, solver)), model)


def _evaluate(model, k, solver, newton, params: Mapping[str, np.ndarray], v0: np.ndarray):
    """Re-solve at a batch of parameter sets, :data:`CALL_ROWS` per call (one compiled shape):
    ``(status, v, multipliers, sequences)``, ``sequences`` ``(rows, k)`` int64."""
    rows = Rows({k_: np.asarray(x, np.float64) for k_, x in params.items()}, CycleGuess(np.asarray(v0, np.float64)))
    status, v, eig, sequences = run_chunks(_solver(model, k, solver, newton), rows, CALL_ROWS, None)
    return np.asarray(status), np.asarray(v), np.asarray(eig), np.asarray(sequences).reshape(len(status), k)


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
            st, v_i, mu_i, _ = _evaluate(model, period, solver, newton, _params_at(lines, None, rows, None, np.full(n_lines, i)), prev)
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
    sequences: np.ndarray | None = None,
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
            planned (the grid's edges' and collisions' bisections, the sign
            changes' regula falsi at most ``options.max_iter``; lowered when
            they end sooner, raised for what is found between a line's last
            grid gait and its edge) and advanced by one per round.
        sequences: ``(n_lines, n)`` int64 sequence codes of the period-1 gaits'
            steps (:mod:`jaxwalk.event_log`; ``period`` 1 only), or ``None``
            (not known: no border collision is located, and every sign change
            is taken to be a continuous crossing).

    Lines may run either way in the continuation parameter (rows report its values).

    Returns:
        :class:`Bifurcations`, rows ordered by line then parameter.

    Raises:
        ConfigError: ``sequences`` given for ``period`` above 1, or not integers.
    """
    status, v, multipliers, lines, sequences, known = _increasing(status, v, multipliers, lines, axis, sequences, period)
    n_lines, n = status.shape
    x = lines[axis]

    def solve(at, line, i, guess):
        st, v_, mu_, s_ = _evaluate(model, period, solver, newton, _params_at(lines, axis, line, at, i), guess)
        return st, v_, mu_, (s_ if known else np.zeros_like(s_))  # codes not known: every gait one sequence

    gait = lambda line, j: {"x": x[line, j], "v": v[line, j], "mu": multipliers[line, j], "s": sequences[line, j]}
    smooth, edge_rows, changes = [], [], []  # (line, i, lo, hi, skip), (line, found, lost), (line, i, lo, hi, skip)
    for line, i in ((line, i) for line in range(n_lines) for i in range(n - 1)):
        ok_a, ok_b = status[line, i] == Status.OK, status[line, i + 1] == Status.OK
        if ok_a and ok_b:
            (changes if np.any(sequences[line, i] != sequences[line, i + 1]) else smooth).append(
                (line, i, gait(line, i), gait(line, i + 1), ()))
        elif ok_a != ok_b:
            edge_rows.append((line, i, i + 1) if ok_a else (line, i + 1, i))  # (line, found, lost)
    rounds = _Rounds(progress, smooth or changes or edge_rows, edge_rows, changes, x, options)
    edges, segments = shrink_edges(solve, edge_rows, x, status, v, multipliers, sequences, options.tol, rounds,
                                   options.same_gait)
    edges = [_edge_row(e, options) for e in edges]
    seen = set()
    for line, i, a, b, edge in segments:  # stretches the grid does not bracket: more to locate there
        lo, hi = (a, b) if a["x"] <= b["x"] else (b, a)
        if (line, lo["x"], hi["x"]) in seen:  # walked from both sides of a grid point the line lost
            continue
        seen.add((line, lo["x"], hi["x"]))
        # Next to a fold edge the gait turns back: the fold is the edge itself, not a crossing to locate again.
        skip = (Kind.FOLD,) if edge is not None and edges[edge]["kind"] == Kind.FOLD else ()
        (changes if np.any(lo["s"] != hi["s"]) else smooth).append((line, i, lo, hi, skip))
    collisions, between = locate_changes(solve, changes, options.tol, rounds)
    brackets = [b for seg in smooth + between for b in _sign_brackets(*seg)]
    rows = _shrink_signs(solve, brackets, options, rounds) + _collision_rows(solve, collisions, options, rounds) + edges
    rows.sort(key=lambda r: (r["line"], r["parameter"]))
    return _table(rows, v.shape[-1], period)


def _increasing(status, v, multipliers, lines, axis, sequences, period):
    """The inputs with every line's points in increasing order of the continuation
    parameter (a line given decreasing is reversed; rows report parameters, not
    indices), as float arrays; the sequence codes ``(n_lines, n, k)`` (0 where no
    gait, all 0 where not ``known``)."""
    status = np.asarray(status)
    x = np.asarray(lines[axis], np.float64)
    flip = (x[:, -1] < x[:, 0])[:, None]
    order = lambda a: np.where(flip.reshape(flip.shape + (1,) * (np.ndim(a) - 2)), np.asarray(a)[:, ::-1], np.asarray(a))
    known = sequences is not None
    if known:
        if period != 1:
            raise ConfigError("sequence codes are compared for period-1 gaits only (period %d given)" % period)
        if not np.issubdtype(np.asarray(sequences).dtype, np.integer):
            raise ConfigError(f"sequence codes must be integers (int64), got {np.asarray(sequences).dtype}")
        seq = np.asarray(sequences, np.int64).reshape(status.shape + (1,))
    else:
        seq = np.zeros(status.shape + (period,), np.int64)
    status = order(status)
    seq = np.where((status == Status.OK)[..., None], order(seq), 0)
    lines = {k: order(np.asarray(val, np.float64)) for k, val in lines.items()}
    return status, order(v), order(multipliers), lines, seq, known


def _table(rows: list[dict], n_v: int, period: int) -> Bifurcations:
    nan = np.full(n_v, np.nan + 0j)
    col = lambda key, dtype, default=0: np.array([r.get(key, default) for r in rows], dtype)
    return Bifurcations(
        kind=col("kind", np.int8), parameter=col("parameter", np.float64), line=col("line", np.int32),
        period=np.full(len(rows), period, np.int32), status=col("status", np.int8),
        v=np.array([r["v"] for r in rows], np.float64).reshape(-1, n_v),
        multipliers=np.array([r["multipliers"] for r in rows], np.complex128).reshape(-1, n_v),
        beyond=col("beyond", np.int8),
        sequence=np.array([r["sequences"][0] for r in rows], np.int64),
        sequence_beyond=col("sequence_beyond", np.int64),
        multipliers_beyond=np.array([r.get("multipliers_beyond", nan) for r in rows], np.complex128).reshape(-1, n_v),
        jumps=col("jumps", np.int8),
    )


def _collision_row(c: dict) -> dict:
    return {"kind": Kind.BORDER_COLLISION, "parameter": c["parameter"], "line": c["line"], "status": c["status"],
            "v": c["v_lo"], "multipliers": c["multipliers_lo"], "beyond": Status.OK, "sequences": c["sequences_lo"],
            "sequence_beyond": c["sequences_hi"][0], "multipliers_beyond": c["multipliers_hi"],
            "jumps": jumps(indicators(c["multipliers_lo"])[None], indicators(c["multipliers_hi"])[None])[0]}


def _collision_rows(solve, collisions: list[dict], options: BifurcationOptions, rounds) -> list[dict]:
    """The located sequence changes' rows: each re-solved at its parameter from each side's
    gait alone (one batched round). One fixed point: a border collision; two farther apart
    than ``same_gait``: a :attr:`Kind.SWITCH` (the line passed to a coexisting gait of
    another sequence; both sequences kept); a failed re-solve: not located, its status."""
    rows = [_collision_row(c) for c in collisions]
    closed = [r for r, c in enumerate(collisions) if c["status"] == Status.OK]
    if not closed:
        return rows
    rounds.collision_round()
    get = lambda key: np.array([collisions[r][key] for r in closed])
    n = len(closed)
    st, v, mu, _ = solve(np.tile(get("parameter"), 2), np.tile(get("line"), 2), np.tile(get("i"), 2),
                         np.concatenate([get("v_lo"), get("v_hi")]))
    for j, r in enumerate(closed):
        a, b = j, n + j
        if st[a] != Status.OK or st[b] != Status.OK:
            rows[r]["status"] = st[a] if st[a] != Status.OK else st[b]
        elif np.max(np.abs(v[a] - v[b])) > options.same_gait:
            rows[r].update(kind=Kind.SWITCH, v=v[a], multipliers=mu[a], multipliers_beyond=mu[b],
                           jumps=jumps(indicators(mu[a])[None], indicators(mu[b])[None])[0])
    return rows


#: The failures of a step that a guard reaching zero or an impact's check names
#: (:mod:`jaxwalk.status`): beyond an edge, one of these makes it grazing. The others (a phase's time limit, the solver, too many
#: events, Newton, a non-finite state, a shorter cycle) name no guard: lost.
GUARD_FAILURES = frozenset({Status.FELL, Status.STALLED, Status.RUNNING, Status.SHANK_RELEASING, Status.SCUFFING,
                            Status.KNEE_BUCKLED, Status.SLIPPING, Status.FOOT_ROLLING})


def _edge_row(r: dict, options: BifurcationOptions) -> dict:
    """An edge's kind: grazing where a guard failed the step beyond (:data:`GUARD_FAILURES`:
    seen), else a fold where a real multiplier is near +1, else lost. A guard seen
    failing outranks the multiplier: near a grazing the map is not smooth, and a
    multiplier that jumped near +1 there is not a branch turning back."""
    mu = r["multipliers"]
    real = mu[np.abs(mu.imag) < 1e-9].real
    near_one = real.size and np.min(np.abs(real - 1.0)) < options.fold_window
    kind = Kind.GRAZING if int(r["beyond"]) in GUARD_FAILURES else Kind.FOLD if near_one else Kind.LOST
    return {**r, "kind": kind, "status": Status.OK}


def _sign_brackets(line, i, lo: dict, hi: dict, skip: tuple = ()) -> list[dict]:
    """The test functions whose sign differs between two gaits of one sequence
    (``lo``, ``hi``: ``x``, ``v``, ``mu``, ``s``): one bracket each (none of the kinds in ``skip``)."""
    t_lo, t_hi = indicators(lo["mu"]), indicators(hi["mu"])
    out = []
    for kind, column in ((Kind.FOLD, 0), (Kind.FLIP, 1), (Kind.NEIMARK_SACKER, 2)):
        if kind not in skip and np.sign(t_lo[column]) * np.sign(t_hi[column]) < 0:
            out.append({"kind": kind, "column": column, "line": line, "i": i, "lo": lo["x"], "hi": hi["x"],
                        "f_lo": t_lo[column], "f_hi": t_hi[column], "v_lo": lo["v"], "v_hi": hi["v"],
                        "mu_lo": lo["mu"], "mu_hi": hi["mu"], "sequences": lo["s"]})
    return out


def _params_at(lines, axis, line_index: np.ndarray, x: np.ndarray, i: np.ndarray) -> dict[str, np.ndarray]:
    """Parameters of the lines at continuation values ``x`` (other parameters of point ``i``)."""
    out = {k: np.asarray(val)[line_index, i] for k, val in lines.items()}
    if axis is not None:
        out[axis] = x
    return out


def _shrink_signs(solve, brackets: list[dict], options: BifurcationOptions, rounds: _Rounds) -> list[dict]:
    """Illinois regula falsi on each sign-change bracket (:func:`_sign_brackets`), all batched.

    Every trial's gait must take the bracket's event sequence: one that does
    not lies beyond a border collision inside the bracket (two between
    neighbouring grid points), where the test function need not be
    continuous; that bracket ends ``NOT_LOCATED``.
    """
    if not brackets:
        rounds.no_signs()
        return []
    get = lambda key: np.array([b[key] for b in brackets])
    column, line, i = get("column"), get("line"), get("i")
    lo, hi, f_lo, f_hi = get("lo").astype(float), get("hi").astype(float), get("f_lo"), get("f_hi")
    v_lo, v_hi, seq = get("v_lo"), get("v_hi"), get("sequences")
    mu_lo, mu_hi = get("mu_lo").astype(np.complex128), get("mu_hi").astype(np.complex128)
    state = np.full(len(brackets), Status.IN_PROGRESS, np.int8)
    side = np.zeros(len(brackets), np.int8)  # which end was kept last (Illinois halves its value when kept twice)
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
        st, v_t, mu, s_t = solve(trial[idx], line[idx], i[idx], ((1 - w) * v_lo + w * v_hi)[idx])
        other = np.any((s_t != seq[idx]) & (seq[idx] != 0), axis=-1)  # 0: the bracket's sequence is not known
        st = np.where((st == Status.OK) & other, np.int8(Status.NOT_LOCATED), st)
        failed = st != Status.OK
        state[idx[failed]] = st[failed]
        good = idx[~failed]
        f_t = indicators(mu[~failed])[np.arange(len(good)), column[good]]
        same_lo = np.sign(f_t) == np.sign(f_lo[good])
        for j, g in enumerate(good):
            if same_lo[j]:
                lo[g], f_lo[g], v_lo[g], mu_lo[g] = trial[g], f_t[j], v_t[~failed][j], mu[~failed][j]
                f_hi[g] *= 0.5 if side[g] == 1 else 1.0
                side[g] = 1
            else:
                hi[g], f_hi[g], v_hi[g], mu_hi[g] = trial[g], f_t[j], v_t[~failed][j], mu[~failed][j]
                f_lo[g] *= 0.5 if side[g] == -1 else 1.0
                side[g] = -1
    state[(state == Status.IN_PROGRESS) & (np.abs(hi - lo) <= 2 * options.tol)] = Status.OK  # closed by the last trial
    state[state == Status.IN_PROGRESS] = Status.NOT_LOCATED
    rounds.signs_done()
    rounds.advance(signs=True)
    mid = 0.5 * (lo + hi)
    n = len(brackets)
    # The midpoint from the ends interpolated (the row's gait), and from each end alone: the same gait or two.
    st, v_m, mu_m, _ = solve(np.tile(mid, 3), np.tile(line, 3), np.tile(i, 3), np.concatenate([0.5 * (v_lo + v_hi), v_lo, v_hi]))
    from_lo, from_hi = slice(n, 2 * n), slice(2 * n, 3 * n)
    ends = {"v_lo": v_lo, "mu_lo": mu_lo, "mu_hi": mu_hi, "st_lo": st[from_lo], "v_from_lo": v_m[from_lo],
            "mu_from_lo": mu_m[from_lo], "st_hi": st[from_hi], "v_from_hi": v_m[from_hi], "mu_from_hi": mu_m[from_hi]}
    return _sign_rows(brackets, state, mid, st[:n], v_m[:n], mu_m[:n], ends, options)


def _two_gaits(r: int, ends: dict, options: BifurcationOptions) -> bool:
    """Whether bracket ``r``'s midpoint, re-solved from each end alone, gave two fixed points."""
    both = ends["st_lo"][r] == Status.OK and ends["st_hi"][r] == Status.OK
    return bool(both and np.max(np.abs(ends["v_from_lo"][r] - ends["v_from_hi"][r])) > options.same_gait)


def _sign_rows(brackets, state, mid, st, v_m, mu_m, ends: dict, options: BifurcationOptions) -> list[dict]:
    """The table rows of the shrunk sign-change brackets: each located at its
    midpoint ``mid`` (re-solved there: ``st``, ``v_m``, ``mu_m``), except where
    the bracket closed and either

    * its two ends are two gaits (re-solved at ``mid`` from each end alone:
      ``ends["v_from_lo"]``, ``ends["v_from_hi"]`` farther apart than
      ``same_gait``): a :attr:`Kind.SWITCH` row, the lower end's gait and
      multipliers there, the upper's as ``multipliers_beyond``; or
    * the multipliers at either of its ends (``ends["mu_lo"]``, ``["mu_hi"]``)
      are not near the crossing (:func:`_crosses`): a :attr:`Kind.JUMP` row,
      its lower end's gait (``ends["v_lo"]``) and multipliers, its upper end's
      as ``multipliers_beyond``.

    Both carry ``jumps``: the test functions whose sign differs between the two
    (one jump or switch may change two or three: one row). Where a re-solve
    from either end failed, one gait or two is not known: the row keeps the
    test's kind with that failure as its status (not located)."""
    out = []
    for r, b in enumerate(brackets):
        kind = b["kind"]
        status = state[r] if state[r] != Status.OK else st[r]
        found = st[r] == Status.OK  # a failed midpoint solve's point and multipliers are not a gait's
        # Checked only where the bracket closed (both ends solved gaits within 2 tol): an unlocated
        # row's ends need not be near anything. Both ends, not the midpoint alone: a jump from just
        # inside the window to far outside it has one side near the crossing.
        mu_lo, mu_hi = ends["mu_lo"][r], ends["mu_hi"][r]
        row = None
        # A re-solve from one end failed: one gait or two is not known, so neither a crossing nor a
        # jump is confirmed. The row keeps its kind, with that failure as its status (not located).
        unconfirmed = next((int(ends[k][r]) for k in ("st_lo", "st_hi") if ends[k][r] != Status.OK), None)
        if state[r] == Status.OK and unconfirmed is not None:
            status = unconfirmed
        elif state[r] == Status.OK and _two_gaits(r, ends, options):
            row = {"kind": Kind.SWITCH, "v": ends["v_from_lo"][r], "multipliers": ends["mu_from_lo"][r],
                   "multipliers_beyond": ends["mu_from_hi"][r]}
        elif state[r] == Status.OK and not (_crosses(kind, mu_lo, options) and _crosses(kind, mu_hi, options)):
            row = {"kind": Kind.JUMP, "v": ends["v_lo"][r], "multipliers": mu_lo, "multipliers_beyond": mu_hi}
        if row is not None:
            bits = jumps(indicators(row["multipliers"])[None], indicators(row["multipliers_beyond"])[None])[0]
            twin = next((o for o in out if o["kind"] == row["kind"] and o["line"] == b["line"]
                         and abs(o["parameter"] - mid[r]) <= 2 * options.tol), None)
            if twin is not None:  # the fold and the flip test both change sign by the one jump
                twin["jumps"] |= bits
                continue
            out.append({**row, "parameter": mid[r], "line": b["line"], "status": state[r], "beyond": Status.OK,
                        "sequences": b["sequences"], "jumps": bits})
            continue
        if found and kind == Kind.NEIMARK_SACKER and not _complex_pair_on_circle(mu_m[r]):
            continue  # a neutral saddle (real mu_i mu_j = 1), not a bifurcation of the cycle
        out.append({"kind": kind, "parameter": mid[r], "line": b["line"], "status": status,
                    "v": v_m[r] if found else np.full_like(v_m[r], np.nan),
                    "multipliers": mu_m[r] if found else np.full_like(mu_m[r], np.nan), "beyond": Status.OK,
                    "sequences": b["sequences"]})
    return out
