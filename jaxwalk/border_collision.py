"""Where a gait's event sequence changes along a continuation line: located by bisection.

Part of :func:`jaxwalk.bifurcation.locate`. Two neighbouring gaits of a line
whose steps take different events, or the same events in another order
(:mod:`jaxwalk.event_log`'s sequence codes differ), are fixed points of two
different smooth pieces of a piecewise-smooth step map. Between them lies a
*border collision*: the gait where two events coincide (the heel-rise
walker's stance heel rising exactly at toe-strike), or where an event is met
with zero margin. The fixed point moves continuously through it, but the
map's Jacobian, and the multipliers with it, may jump there, so a stability
test function (:func:`jaxwalk.bifurcation.indicators`) can change sign by a
jump: no multiplier passes through +1 or -1, and a root finder on the test
function would converge onto the jump and name a fold or a flip that is not
there. So a sign change is located only between gaits of one sequence, and
the jump is reported as what it is.

:func:`shrink_collisions` bisects on "the gait's sequence is the one at the
bracket's lower end", re-solving the gait at each midpoint (from the bracket's
ends interpolated; where Newton fails from there, again from the lower end's
gait and then from the upper end's, since Newton on a piecewise-smooth map
can cycle across the border). Its result: the collision's parameter to ``tol``, the gaits and
multipliers on both sides, and which test functions jump in sign across it.
"""

from __future__ import annotations

import numpy as np

from jaxwalk.status import Status


#: Sequence changes located one after the other inside one bracket (A, then B, then C, ...).
MAX_PASSES = 8


def locate_changes(solve, changes: list[tuple], tol: float, rounds) -> tuple[list[dict], list[tuple]]:
    """Every sequence change inside the brackets ``changes``, ``(line, i, lo, hi, skip)``
    (gait dicts ``x``, ``v``, ``mu``, ``s`` at the ends, ``lo["x"] < hi["x"]``,
    their sequences different; ``skip``: bifurcation kinds not to seek in the bracket).

    Each pass locates, in every bracket, where the lower end's sequence ends
    (:func:`shrink_collisions`); the stretch from there to the upper end is a
    new bracket if its two ends still differ (a third sequence), up to
    :data:`MAX_PASSES` passes; a bracket still open after them is reported as
    an unlocated collision (status ``NOT_LOCATED``). Returns ``(collisions,
    smooth)``: the collisions (:func:`shrink_collisions`'s dicts) and the
    stretches of one sequence between them, ``(line, i, lo, hi, skip)``, where a
    test function's sign change is a multiplier's continuous crossing.
    """
    collisions, smooth, pending = [], [], list(changes)
    for _ in range(MAX_PASSES):
        if not pending:
            break
        found = shrink_collisions(solve, [{"line": c[0], "i": c[1], "lo": c[2], "hi": c[3]} for c in pending], tol, rounds)
        following = []
        for (line, i, lo, hi, skip), c in zip(pending, found):
            collisions.append(c)
            below = {"x": c["lo"], "v": c["v_lo"], "mu": c["multipliers_lo"], "s": c["sequences_lo"]}
            above = {"x": c["hi"], "v": c["v_hi"], "mu": c["multipliers_hi"], "s": c["sequences_hi"]}
            if below["x"] > lo["x"]:
                smooth.append((line, i, lo, below, skip))
            if above["x"] < hi["x"]:
                (following if np.any(above["s"] != hi["s"]) else smooth).append((line, i, above, hi, skip))
        pending = following
    collisions += [_unlocated(*c[:4]) for c in pending]
    return collisions, smooth


def _unlocated(line, i, lo: dict, hi: dict) -> dict:
    """A sequence-change bracket left open (more changes in it than :data:`MAX_PASSES`)."""
    return {"line": line, "i": i, "parameter": 0.5 * (lo["x"] + hi["x"]), "status": Status.NOT_LOCATED,
            "lo": lo["x"], "hi": hi["x"], "v_lo": lo["v"], "multipliers_lo": lo["mu"], "sequences_lo": lo["s"],
            "v_hi": hi["v"], "multipliers_hi": hi["mu"], "sequences_hi": hi["s"]}


def shrink_collisions(solve, brackets: list[dict], tol: float, rounds) -> list[dict]:
    """Bisection of each sequence-change bracket, all brackets batched per round.

    Args:
        solve: ``solve(at, line, i, guess) -> (status, v, multipliers, sequences)``
            (parameter values ``at`` on lines ``line``, other parameters of grid point ``i``).
        brackets: one dict per bracket: ``line``, ``i`` and, at its ends ``lo``
            and ``hi``, the gaits' ``x`` (the continuation parameter, ``lo``'s below
            ``hi``'s), ``v`` ``(n_v,)``, ``mu`` ``(n_v,)`` and ``s`` ``(k,)``
            (sequence codes, different at the two ends).
        tol: the half-width to reach.
        rounds: counts the rounds of solves (``collision_round()``, ``collisions_done()``).

    Returns one dict per bracket: ``line``, ``i``, ``parameter`` (the midpoint),
    ``status`` (``OK``, or the failure of a re-solve that lost the gait inside
    the bracket, which then ends unlocated), ``lo``/``hi`` (the final bracket),
    and on each side (``_lo``, ``_hi``) the gait's ``v``, ``multipliers`` and ``sequences``.
    """
    if not brackets:
        rounds.collisions_done()
        return []
    line = np.array([b["line"] for b in brackets])
    i = np.array([b["i"] for b in brackets])
    side = lambda end: {key: np.array([b[end][key] for b in brackets]) for key in ("x", "v", "mu", "s")}
    lo, hi = side("lo"), side("hi")
    lo["x"], hi["x"] = lo["x"].astype(np.float64), hi["x"].astype(np.float64)
    status = np.full(len(brackets), Status.IN_PROGRESS, np.int8)
    while True:
        active = np.flatnonzero((status == Status.IN_PROGRESS) & (hi["x"] - lo["x"] > 2 * tol))
        if active.size == 0:
            break
        rounds.collision_round()
        mid = 0.5 * (lo["x"][active] + hi["x"][active])
        st, v_m, mu_m, s_m = solve(mid, line[active], i[active], 0.5 * (lo["v"][active] + hi["v"][active]))
        st, v_m, mu_m, s_m = _retry_from_ends(solve, st, v_m, mu_m, s_m, mid, line[active], i[active], lo, hi, active)
        failed = st != Status.OK
        status[active[failed]] = st[failed]
        keep_lo = ~failed & np.all(s_m == lo["s"][active], axis=-1)
        for part, sel in ((lo, keep_lo), (hi, ~failed & ~keep_lo)):
            which = active[sel]
            part["x"][which], part["v"][which], part["mu"][which], part["s"][which] = mid[sel], v_m[sel], mu_m[sel], s_m[sel]
    rounds.collisions_done()
    status[status == Status.IN_PROGRESS] = Status.OK
    return [{"line": line[r], "i": i[r], "parameter": 0.5 * (lo["x"][r] + hi["x"][r]), "status": status[r],
             "lo": lo["x"][r], "hi": hi["x"][r],
             "v_lo": lo["v"][r], "multipliers_lo": lo["mu"][r], "sequences_lo": lo["s"][r],
             "v_hi": hi["v"][r], "multipliers_hi": hi["mu"][r], "sequences_hi": hi["s"][r]} for r in range(len(brackets))]


def _retry_from_ends(solve, st, v_m, mu_m, s_m, mid, line, i, lo, hi, active):
    """Re-solve the failed midpoints from the lower end's gait, then those still failing from the upper end's."""
    st, v_m, mu_m, s_m = st.copy(), v_m.copy(), mu_m.copy(), s_m.copy()
    for end in (lo, hi):
        again = np.flatnonzero(st != Status.OK)
        if again.size == 0:
            break
        st[again], v_m[again], mu_m[again], s_m[again] = solve(mid[again], line[again], i[again], end["v"][active[again]])
    return st, v_m, mu_m, s_m


def jumps(tests_lo: np.ndarray, tests_hi: np.ndarray) -> np.ndarray:
    """``(rows,)`` int8 bit mask of the test functions (fold 1, flip 2, Neimark-Sacker 4)
    whose sign differs across each collision (``tests_*``: ``(rows, 3)`` on either side)."""
    flips = np.sign(tests_lo) * np.sign(tests_hi) < 0
    return (flips * np.array([1, 2, 4])).sum(axis=-1).astype(np.int8)
