"""Would a probe with tangents after one chord step end the shoe map's searches?

On three lines of the shoe walker's map (l_f 0.2937, 0.2524, 0.2048; the map's 64
ratios, each gait found from the one before), at every gait with three found
gaits before it: the start from the secant through two of them and from the
parabola through three (their errors), one chord step from each with the gait
before's Jacobian (its update ``d1`` and the error it leaves), and the Newton
update of an evaluation with tangents at the chord's iterate (the probe of
:func:`jaxwalk.gait._newton_iteration`, which ends the search where it is below
``tol``). Also the gate :data:`jaxwalk.gait.CHORD_EXPECTED_THETA` would set
(probe where ``d1`` times it is below ``tol``): how many probes, and how many of
them end the search. Then the same searches as the loop runs them
(:func:`jaxwalk.gait._newton_iteration`, from the parabola with the gait
before's Jacobian, driven one iteration at a time): the evaluations each
took, ``c`` a chord (primal) step and ``t`` one with tangents, in order.

    PYTHONPATH=. taskset -c 0 python benchmarks/profile_chord_probe.py

Writes ``benchmarks/results/chord_probe.json``.
"""

from __future__ import annotations

import os
import sys

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import jaxwalk  # noqa: E402,F401  (float64 and the device count before jax starts)
import jax  # noqa: E402
import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402

from _record import write_stamped  # noqa: E402
from jaxwalk.gait import (CHORD_EXPECTED_THETA, NewtonOptions, _Newton, _newton_iteration, find_gait,  # noqa: E402
                          step_residual, value_and_jacfwd)
from jaxwalk.status import Status  # noqa: E402
from jaxwalk.models import get_model  # noqa: E402
from jaxwalk.step import SolverOptions, step_map  # noqa: E402

MODEL = get_model("flatfoot")
SOLVER = SolverOptions()
R_GRID = np.linspace(0.1, 1.0, 64)
LINES = np.linspace(0.1, 0.3, 64)[[61, 48, 33]]


def _params(l_f: float, r: float) -> dict:
    return {**MODEL.default_params(), "l_f": jnp.asarray(l_f), "r": jnp.asarray(r)}


def line_gaits(search, l_f: float) -> dict[int, tuple[np.ndarray, np.ndarray]]:
    """``{index in R_GRID: (v*, J)}`` of one line, each search from the gait before."""
    found, v = {}, None
    for k, r in enumerate(R_GRID):
        p = _params(l_f, r)
        gait = search(p, v if v is not None else MODEL.initial_guess(p))
        if int(gait.status) != 0:
            gait = search(p, MODEL.initial_guess(p))
        if int(gait.status) == 0:
            found[k], v = (np.asarray(gait.v), np.asarray(gait.jacobian)), gait.v
    return found


def _iteration(carry: _Newton, params: dict, v0, jacobian) -> _Newton:
    """One iteration of ``find_gait``'s loop body with chord steps on ``jacobian`` (no fallback)."""
    body = _newton_iteration(step_residual(MODEL, params, SOLVER), NewtonOptions(), jnp.eye(2), lambda v: v, jacobian, v0)
    return body(carry)


def evaluations(iteration, params: dict, v0: np.ndarray, jacobian: np.ndarray) -> tuple[str, np.ndarray]:
    """The kinds of evaluation one search took (``c`` chord, ``t`` tangents) and where it ended."""
    nan, i0 = jnp.full((), jnp.nan, jnp.float64), jnp.zeros((), jnp.int32)  # not weak-typed: one compile
    # Shapes only: an eager call would compile its fori_loop anew on every search
    # (a fresh body each time), and every such executable stays mapped in memory.
    y, _, ctx = jax.eval_shape(MODEL.section_to_state, jnp.asarray(v0), params)
    carry = _Newton(jnp.asarray(v0), i0, jnp.int8(Status.IN_PROGRESS), jnp.asarray(False), jnp.full((2, 2), nan), nan,
                    nan, nan, i0, i0, i0 - 1, i0 - 1, jnp.full(y.shape, nan), jnp.full(ctx.shape, nan), jnp.asarray(False),
                    i0, jnp.full((), jnp.inf, jnp.float64), jnp.asarray(True), jnp.asarray(True))
    kinds = ""
    while int(carry.status) == Status.IN_PROGRESS and len(kinds) < 30:
        probe = float(carry.last_update) * CHORD_EXPECTED_THETA < NewtonOptions().tol
        kinds += "c" if bool(carry.chord) and not bool(carry.converged) and not probe else "t"
        carry = iteration(carry, params, jnp.asarray(v0), jnp.asarray(jacobian))
    return kinds + ("" if int(carry.status) == Status.OK else f" ({Status(int(carry.status)).name})"), np.asarray(carry.v)


def main() -> None:
    search = jax.jit(lambda p, v0: find_gait(MODEL, p, v0))
    primal = jax.jit(lambda v, p: step_map(MODEL, v, p, SOLVER)[0])
    tangents = jax.jit(lambda v, p: value_and_jacfwd(step_residual(MODEL, p, SOLVER), v)[:2])
    rows, searches, lines = [], [], {}
    for l_f in LINES:
        found = lines[float(l_f)] = line_gaits(search, float(l_f))
        for k in sorted(found):
            if not all(j in found for j in (k - 1, k - 2, k - 3)):
                continue
            p, truth = _params(float(l_f), R_GRID[k]), found[k][0]
            (v1, jac1), (v2, _), (v3, _) = found[k - 1], found[k - 2], found[k - 3]
            # Equal steps: the secant 2 v1 - v2, the parabola 3 v1 - 3 v2 + v3.
            for name, start in (("secant", 2 * v1 - v2), ("parabola", 3 * v1 - 3 * v2 + v3)):
                residual = np.asarray(primal(jnp.asarray(start), p)) - start
                chord = start - np.linalg.solve(jac1 - np.eye(2), residual)
                r, jac_r = tangents(jnp.asarray(chord), p)
                probe_update = np.abs(np.linalg.solve(np.asarray(jac_r), np.asarray(r))).max()
                rows.append(dict(l_f=float(l_f), r=float(R_GRID[k]), start=name,
                                 start_error=float(np.abs(start - truth).max()),
                                 chord_update=float(np.abs(chord - start).max()),
                                 chord_error=float(np.abs(chord - truth).max()),
                                 probe_update=float(probe_update)))
        print(f"l_f {l_f:.4f}: {len(found)} gaits", flush=True)
    iteration = jax.jit(_iteration)
    for l_f, found in lines.items():
        for k in sorted(found):
            if not all(j in found for j in (k - 1, k - 2, k - 3)):
                continue
            (v1, jac1), (v2, _), (v3, _) = found[k - 1], found[k - 2], found[k - 3]
            kinds, v_end = evaluations(iteration, _params(l_f, R_GRID[k]), 3 * v1 - 3 * v2 + v3, jac1)
            searches.append(dict(l_f=l_f, r=float(R_GRID[k]), evaluations=kinds,
                                 error=float(np.abs(v_end - found[k][0]).max())))
    tol = NewtonOptions().tol
    summary = {}
    for name in ("secant", "parabola"):
        sel = [row for row in rows if row["start"] == name]
        err = np.array([row["start_error"] for row in sel])
        d1 = np.array([row["chord_update"] for row in sel])
        e1 = np.array([row["chord_error"] for row in sel])
        probe = np.array([row["probe_update"] for row in sel])
        gated = d1 * CHORD_EXPECTED_THETA < tol
        summary[name] = dict(
            gaits=len(sel), start_error_median=float(np.median(err)), start_error_max=float(err.max()),
            chord_error_median=float(np.median(e1)), chord_error_max=float(e1.max()),
            contraction_quantiles_50_90_99_100=np.quantile(e1 / d1, [0.5, 0.9, 0.99, 1.0]).tolist(),
            probe_ends_search=int((probe < tol).sum()), probes_at_the_gate=int(gated.sum()),
            probes_at_the_gate_that_end_the_search=int((gated & (probe < tol)).sum()))
        print(name, summary[name])
    kinds, counts = np.unique([row["evaluations"] for row in searches], return_counts=True)
    summary["searches_from_the_parabola"] = dict(zip(kinds.tolist(), counts.tolist()))
    summary["searches_largest_distance_to_newtons_gait"] = max(row["error"] for row in searches)
    print("searches:", summary["searches_from_the_parabola"], "largest distance to Newton's gait",
          summary["searches_largest_distance_to_newtons_gait"])
    write_stamped("chord_probe", dict(tol=tol, expected_theta=CHORD_EXPECTED_THETA, summary=summary, rows=rows,
                                      searches=searches))


if __name__ == "__main__":
    main()
