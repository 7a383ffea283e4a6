"""Where a continuation line's gait is lost: the edge located by bisection (:func:`shrink_edges`).

Part of :func:`jaxwalk.bifurcation.locate`. The re-solve is given as
``solve(at, line, i, guess) -> (status, v, multipliers, sequences)`` (the
batched Newton of :mod:`jaxwalk.bifurcation` at parameter values ``at`` on
lines ``line``, the other parameters of grid point ``i``, each from
``guess``), so this module needs no program of its own.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from jaxwalk.status import Status

#: Steps in which :func:`approach` follows a cycle to where a direct solve failed.
APPROACH_STEPS = 4
#: A cycle solved at ``at`` from the one found at ``x`` that moved more than this
#: many times what the line's slope there allows (plus :data:`MIN_MOVE`) is
#: suspected of being another gait's, and checked (:meth:`_Edges.followed`).
JUMP_FACTOR = 4.0
#: ... plus this (section units): Newton's own tolerance is 1e-8.
MIN_MOVE = 1e-6
#: Times :func:`approach` halves a step whose cycle jumped before it gives up.
JUMP_HALVINGS = 8
#: Most solves one :func:`approach` makes (each a batched Newton call).
APPROACH_SOLVES = 32


def shrink_edges(solve, rows, x: np.ndarray, status, v, multipliers, sequences, tol: float, rounds,
                 same_gait: float = 1e-4):
    """Bisection on "the cycle is followed there" at each edge of a line's gaits.

    ``rows``: ``(line, found, lost)`` grid indices of each edge; ``x`` the
    continuation parameter ``(n_lines, n)``; ``sequences`` ``(n_lines, n, k)``
    the grid's sequence codes; ``rounds`` counts the rounds of solves.

    A Newton solve that fails from the last found cycle does not show that the
    cycle is gone: far from the bracket's found end its start can lie where a
    step fails although the cycle exists (the flat-foot walker's unstable
    gaits, whose steps diverge from an offset start). Such a failure is checked
    by following the cycle in :data:`APPROACH_STEPS` steps (:func:`approach`);
    the bracket becomes the last step reached and the first that failed. The
    same holds for the grid point beyond the edge, whose failure the line's own
    continuation found from its other side or from far away: once the bracket
    has closed on it, it is solved from the cycle next to it, and where the
    cycle is found there the edge moves on to the next interval; past the
    line's last point, or onto a grid point that has a gait, there is none
    (the grid's own brackets and edges take the line on from there).

    A solve may converge to another gait (the heel-rise walker's stable and
    unstable twins lie 0.08 apart at one ``k``). A cycle that moved farther
    from the last one than the line's slope allows is solved back where the
    last one was found, from itself; unless that returns to the last cycle
    (within ``same_gait``), it is another gait's (:meth:`_Edges.followed`):
    the solve counts as failed with ``NOT_LOCATED``, and the cycle is followed
    towards it in shorter steps, so the edge ends where the line's own cycle is
    lost. Near a fold the cycle moves faster than the grid's slope, and the
    solve back is what tells it from a jump.

    Returns ``(edges, segments)``. ``edges``: one dict per edge still inside
    its line: ``parameter`` (the bracket's midpoint), ``line``, ``v``,
    ``multipliers`` and ``sequences`` of the last cycle found, ``beyond`` (the
    failure's status); ``kind`` is the caller's to decide. ``segments``:
    ``(line, i, a, b, edge)`` for each stretch of a line between two of the cycles
    followed that no two found grid gaits bracket (from the last found grid
    point, or a grid point the edge moved through, to the next one or to the
    last cycle found; ``a``, ``b`` gaits as dicts ``x``, ``v``, ``mu``, ``s``
    in the order walked; ``i`` a grid index of the line, for its other
    parameters; ``edge``: the index in ``edges`` of the edge it ends at, or
    ``None``): a bifurcation there has no grid bracket of its own.
    """
    if not rows:
        rounds.edges_done()
        return [], []
    e = _Edges.start(rows, x, status, v, multipliers, sequences, same_gait)
    walk = lambda at_, which, guess, x_from: e.followed(solve, at_, which, guess, x_from)  # noqa: E731
    while True:
        narrow = np.abs(e.bad - e.good) <= 2 * tol
        probe = narrow & e.untested & ~e.ended
        idx = np.flatnonzero((~narrow | probe) & ~e.ended)
        if idx.size == 0:
            break
        rounds.edge_round()
        at = np.where(probe, e.bad, 0.5 * (e.good + e.bad))[idx]
        st, v_at, mu_at, s_at = walk(at, idx, e.v_good[idx], e.good[idx])
        lost = np.flatnonzero(st != Status.OK)
        reached, v_r, mu_r, s_r, failed, why = approach(walk, idx[lost], e.good[idx[lost]], at[lost], e.v_good[idx[lost]],
                                                        e.mu_good[idx[lost]], e.s_good[idx[lost]])
        found = st == Status.OK
        found[lost] = ~np.isfinite(failed)
        v_at[lost], mu_at[lost], s_at[lost] = v_r, mu_r, s_r
        e.found_at(idx[found], at[found], v_at[found], mu_at[found], s_at[found], probe[idx[found]])
        k = np.flatnonzero(~found)
        which = np.searchsorted(lost, k)  # rows of `lost` that the approach confirmed
        e.lost_at(idx[k], reached[which], v_r[which], mu_r[which], s_r[which], failed[which], why[which])
    rounds.edges_done()
    edges, segments = [], list(e.crossed)
    for r in range(len(rows)):
        last = {"x": e.good[r], "v": e.v_good[r], "mu": e.mu_good[r], "s": e.s_good[r]}
        edge = None
        if not e.ended[r]:
            edge = len(edges)
            edges.append({"parameter": 0.5 * (e.good[r] + e.bad[r]), "line": e.line[r], "v": e.v_good[r],
                          "multipliers": e.mu_good[r], "sequences": e.s_good[r], "beyond": e.beyond[r]})
        if not e.ended[r] and e.anchor[r]["x"] != last["x"]:  # an ended edge's stretches are all in `crossed`
            segments.append((e.line[r], e.ok_i[r], e.anchor[r], last, edge))
    return edges, segments


@dataclasses.dataclass
class _Edges:
    """The brackets of :func:`shrink_edges`, one row per edge: ``good`` (the
    cycle found there: ``v_good``, ``mu_good``, its sequence codes ``s_good``)
    and ``bad`` (the failure ``beyond``; ``untested`` while it is the grid point
    as the line's continuation left it), on line ``line`` between grid points
    ``ok_i`` and ``bad_i``; ``ended``: the cycle was followed past the line's
    last point. ``anchor``: the last grid point where the cycle is known (the
    line's last found one, then each one the edge moved through, as a gait
    dict); ``crossed``: segments between anchors that the grid's gaits do not
    bracket (:func:`shrink_edges`)."""

    line: np.ndarray
    ok_i: np.ndarray
    bad_i: np.ndarray
    x: np.ndarray
    status: np.ndarray
    good: np.ndarray
    bad: np.ndarray
    v_good: np.ndarray
    mu_good: np.ndarray
    s_good: np.ndarray
    beyond: np.ndarray
    untested: np.ndarray
    ended: np.ndarray
    anchor: list
    crossed: list
    grid: tuple  # the grid's (v, multipliers, sequences)
    slope: np.ndarray  # the cycle's largest |dv/dx| seen near the edge (NaN: not known)
    same_gait: float

    @classmethod
    def start(cls, rows, x, status, v, multipliers, sequences, same_gait: float) -> "_Edges":
        line, ok_i, bad_i = (np.array([r[k] for r in rows]) for k in range(3))
        mu, seq = np.asarray(multipliers), np.asarray(sequences)
        anchor = [{"x": x[l_, i_], "v": v[l_, i_], "mu": mu[l_, i_], "s": seq[l_, i_]} for l_, i_ in zip(line, ok_i)]
        return cls(line, ok_i, bad_i, x, status, x[line, ok_i].copy(), x[line, bad_i].copy(), v[line, ok_i].copy(),
                   mu[line, ok_i].copy(), seq[line, ok_i].copy(), status[line, bad_i].astype(np.int8),
                   np.ones(len(rows), bool), np.zeros(len(rows), bool), anchor, [], (v, mu, seq),
                   grid_slope(x, status, v, line, ok_i, bad_i), same_gait)

    def followed(self, solve, at, which, guess, x_from):
        """``solve`` at ``at`` for edge rows ``which`` from cycles ``guess`` found at
        ``x_from``, with ``NOT_LOCATED`` where the cycle found is another gait's: it
        moved more than :func:`within_slope` allows, and solved back at ``x_from``
        from itself it does not return to ``guess`` (within ``same_gait``)."""
        st, v, mu, s = solve(at, self.line[which], self.ok_i[which], guess)
        suspect = np.flatnonzero((st == Status.OK) & ~within_slope(v, guess, at, x_from, self.slope[which]))
        if suspect.size:
            rows = which[suspect]
            st_back, v_back, _, _ = solve(x_from[suspect], self.line[rows], self.ok_i[rows], v[suspect])
            back = (st_back == Status.OK) & (np.max(np.abs(v_back - guess[suspect]), axis=-1) <= self.same_gait)
            st = st.copy()
            st[suspect[~back]] = Status.NOT_LOCATED
        return st, v, mu, s

    def found_at(self, r, at, v, mu, s, probed) -> None:
        """The cycle was found at ``at``; a probed grid point moves the edge on one interval."""
        moved = np.max(np.abs(v - self.v_good[r]), axis=-1) / np.maximum(np.abs(at - self.good[r]), 1e-300)
        self.slope[r] = np.maximum(self.slope[r], moved)  # steeper towards a fold
        self.good[r], self.v_good[r], self.mu_good[r], self.s_good[r] = at, v, mu, s
        for j in np.flatnonzero(probed):  # the grid point (one the line lost) is the new anchor; the stretch to it
            row = r[j]
            gait = {"x": at[j], "v": v[j], "mu": mu[j], "s": s[j]}
            self.crossed.append((self.line[row], self.ok_i[row], self.anchor[row], gait, None))
            self.anchor[row] = gait
        moved = r[probed]
        self.bad_i[moved] += np.sign(self.bad_i[moved] - self.ok_i[moved])
        past = (self.bad_i[moved] < 0) | (self.bad_i[moved] >= self.x.shape[1])
        self.ended[moved[past]] = True
        on = moved[~past]
        self.bad[on], self.beyond[on] = self.x[self.line[on], self.bad_i[on]], self.status[self.line[on], self.bad_i[on]]
        v, mu, seq = self.grid
        for row in on[self.beyond[on] == Status.OK]:  # onto a grid gait: the edge ends, its stretch is searched
            line, j = self.line[row], self.bad_i[row]
            self.crossed.append((line, self.ok_i[row], self.anchor[row], {"x": self.x[line, j], "v": v[line, j],
                                                                           "mu": mu[line, j], "s": seq[line, j]}, None))
            self.ended[row] = True

    def lost_at(self, r, reached, v, mu, s, failed, why) -> None:
        """The cycle, followed, was found up to ``reached`` and lost at ``failed`` (status ``why``)."""
        self.good[r], self.v_good[r], self.mu_good[r], self.s_good[r] = reached, v, mu, s
        self.bad[r], self.beyond[r], self.untested[r] = failed, why, False


def grid_slope(x, status, v, line, ok_i, bad_i) -> np.ndarray:
    """``(edges,)`` the largest ``|dv/dx|`` between each edge's found grid gait and the
    grid gait next to it on the other side (NaN where there is none: every move
    is then checked, :meth:`_Edges.followed`)."""
    inner = ok_i - np.sign(bad_i - ok_i)
    inside = (inner >= 0) & (inner < x.shape[1])
    inner = np.clip(inner, 0, x.shape[1] - 1)
    known = inside & (status[line, inner] == Status.OK)
    dx = np.abs(x[line, ok_i] - x[line, inner])
    dv = np.max(np.abs(v[line, ok_i] - v[line, inner]), axis=-1)
    return np.where(known & (dx > 0), dv / np.where(dx > 0, dx, 1.0), np.nan)


def within_slope(v_at, v_from, at, x_from, slope) -> np.ndarray:
    """Whether cycles ``v_at`` (solved at ``at``) moved from ``v_from`` (at ``x_from``) at
    most :data:`JUMP_FACTOR` times ``slope |at - x_from|`` plus :data:`MIN_MOVE`, in
    the largest section coordinate (False where ``slope`` is NaN: not known)."""
    move = np.max(np.abs(np.asarray(v_at) - np.asarray(v_from)), axis=-1)
    return move <= JUMP_FACTOR * np.asarray(slope) * np.abs(np.asarray(at) - np.asarray(x_from)) + MIN_MOVE


def approach(solve, which: np.ndarray, good: np.ndarray, target: np.ndarray, v_good: np.ndarray, mu_good: np.ndarray,
             s_good: np.ndarray):
    """Follow the cycles of rows ``which`` from ``good`` towards ``target`` in
    :data:`APPROACH_STEPS` equal steps, each solve from the last found cycle
    (``solve(at, which, guess, x_guess)``, ``x_guess`` where that cycle was found).
    A step whose cycle jumped to another gait (``NOT_LOCATED``, from
    :meth:`_Edges.followed`) is tried again at half its length, at most
    :data:`JUMP_HALVINGS` times in a row (a jump depends on how far the start
    was; a guard's failure on the point), and the step doubles back after each
    success; at most :data:`APPROACH_SOLVES` solves in all, after which a row
    still on its way fails ``NOT_LOCATED`` at its next step.

    Returns ``(reached, v_reached, mu_reached, s_reached, failed, status)`` per
    row: the last value where the cycle was found, its point, multipliers and
    sequence codes, the first value where it was not (NaN if the target itself
    was reached) and that failure's status.
    """
    reached, v_reached, mu_reached, s_reached = good.copy(), v_good.copy(), mu_good.copy(), s_good.copy()
    failed = target.copy()
    why = np.full(len(which), Status.NO_CONVERGENCE, np.int8)
    full = (target - good) / APPROACH_STEPS
    step, halvings = full.copy(), np.zeros(len(which), int)
    going, arrived = np.ones(len(which), bool), np.zeros(len(which), bool)
    for _ in range(APPROACH_SOLVES):
        idx = np.flatnonzero(going)
        if idx.size == 0:
            break
        last = np.abs(target[idx] - reached[idx]) <= np.abs(step[idx]) * (1 + 1e-12)
        at = np.where(last, target[idx], reached[idx] + step[idx])
        st, v_at, mu_at, s_at = solve(at, which[idx], v_reached[idx], reached[idx])
        ok = st == Status.OK
        reached[idx[ok]], v_reached[idx[ok]], mu_reached[idx[ok]], s_reached[idx[ok]] = at[ok], v_at[ok], mu_at[ok], s_at[ok]
        arrived[idx[ok & last]] = True
        step[idx[ok]] = np.where(np.abs(2 * step[idx[ok]]) <= np.abs(full[idx[ok]]), 2 * step[idx[ok]], full[idx[ok]])
        halvings[idx[ok]] = 0
        retry = ~ok & (st == Status.NOT_LOCATED) & (halvings[idx] < JUMP_HALVINGS) & (at != reached[idx])
        step[idx[retry]] *= 0.5
        halvings[idx[retry]] += 1
        stop = ~ok & ~retry
        failed[idx[stop]], why[idx[stop]] = at[stop], st[stop]
        going[idx[stop]] = False
        going[idx[arrived[idx]]] = False
    out = going & ~arrived  # out of solves on the way: not followed further
    failed[out] = np.where(np.abs(target[out] - reached[out]) <= np.abs(step[out]), target[out], reached[out] + step[out])
    why[out] = Status.NOT_LOCATED
    failed[arrived] = np.nan  # every step found, the target too: no failure on this side
    return reached, v_reached, mu_reached, s_reached, failed, why
