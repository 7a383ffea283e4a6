"""Continuation lines run in fixed-length segments, so every line length shares one program.

A continuation line (:mod:`jaxwalk.continuation`) visits its points in an
order set by its seed (:func:`~jaxwalk.continuation.visiting_order`). Here the
visits are cut into segments of :data:`SEGMENT_LENGTH`; one jitted program
advances a call of lines by one segment, taking the lines' carry
(:class:`~jaxwalk.continuation.LineCarry`) in and handing it out, and a line
of any length is its segments run one after the other. The last segment's
padding visits are skipped (a real branch of the program), so a line costs
its own points only, and grids of every size, seed lines included, run the
same compiled program: after a model's first run no sweep of it compiles again.
"""

from __future__ import annotations

import functools
from typing import Callable, Mapping, NamedTuple

import jax
import numpy as np
from jaxtyping import Array, Bool, Float

from jaxwalk import compiling, program_cache
from jaxwalk.batching import Rows, in_sub_batches, run_chunks, sub_batch_size
from jaxwalk.continuation import LineCarry, continue_segment, fresh_carry, visiting_order
from jaxwalk.gait import Gait, NewtonOptions
from jaxwalk.status import Status
from jaxwalk.step import SolverOptions
from jaxwalk.walker import Walker

#: Visits per segment: one program call advances every line of a call by this many.
SEGMENT_LENGTH = 64
#: Continuation lines are heavier than independent rows: a call of lines is
#: split over the threads when each gets two.
MIN_LINES_PER_THREAD = 2

class SegmentInputs(NamedTuple):
    """A line's input to :func:`segment_program` beside its parameters (``(L,)``
    arrays over the segment's ``L`` visits, one row per line in a call)."""

    position: Float[Array, " L"]  # the continuation parameter's value at the visit
    restart: Bool[Array, " L"]  # the visit starts again from the line's seed
    first: Bool[Array, " L"]  # the line's first visit (its seed point)
    visit_valid: Bool[Array, " L"]  # a real visit, not padding; the same on every line
    carry: LineCarry  # the line's state before the segment's first visit


@functools.lru_cache(maxsize=None)
def segment_program(model: Walker, solver: SolverOptions, newton: NewtonOptions):
    """One jitted program for every continuation line of a model and settings.

    Its input is :class:`~jaxwalk.batching.Rows`, one row per line: each
    parameter as an ``(n_lines, L)`` array over the segment's visits, and
    :class:`SegmentInputs` (the program reads ``visit_valid`` of row 0, so
    padding visits are skipped, not masked). It returns ``(carry, gaits)`` with
    the same leading axis."""

    chord = chord_steps(model, solver)

    def line(params, inputs: SegmentInputs, valid):
        return continue_segment(model, params, inputs.position, inputs.restart, inputs.first, valid, inputs.carry, solver,
                                newton, chord)

    def program(rows: Rows):
        valid = rows.inputs.visit_valid[0]
        # Lines in sub-batches of sub_batch_size(): a line waits at every visit for
        # the slowest line of its sub-batch (the flat-foot walker's hardest map
        # quarter ran 6x faster at 2 lines per sub-batch than at 8, 13x at 1:
        # benchmarks/README.md).
        return in_sub_batches(lambda r: line(*r, valid), (rows.params, rows.inputs), sub_batch_size(model, solver), rows.valid)

    program = compiling.jit(program, model)
    program_cache.register(program, "continuation", model, solver, newton)
    return program


def chord_steps(model: Walker, solver: SolverOptions) -> bool:
    """Whether ``model``'s continuation lines start each search with chord steps
    (:func:`~jaxwalk.continuation.continue_segment`'s ``chord``).

    They pay only where a line's program is not vmapped (one line per sub-batch:
    under ``vmap`` the ``lax.cond`` choosing the evaluation runs both), and need
    a section whose every point is a state: an iterate moved into the section
    measures no contraction, which would end every chord at once."""
    return sub_batch_size(model, solver) == 1 and type(model).into_section is Walker.into_section


def lines_per_call(chunk_size: int) -> int:
    """Lines one program call advances: as many segments as ``chunk_size`` points allow, at least one."""
    return max(1, chunk_size // SEGMENT_LENGTH)


def run_lines(
    model: Walker,
    lines: Mapping[str, np.ndarray],
    positions: np.ndarray,
    seed: int,
    solver: SolverOptions,
    newton: NewtonOptions,
    chunk_size: int,
    starts: np.ndarray | None = None,
    progress: Callable[[int], None] | None = None,
) -> Gait:
    """Continuation along ``n_lines`` lines of ``n`` points, segment by segment.

    Args:
        lines: every parameter as an ``(n_lines, n)`` array, in grid order.
        positions: ``(n,)`` the continuation parameter's values along every line.
        seed: index along the lines where each walk starts
            (:func:`~jaxwalk.continuation.seed_index`).
        chunk_size: points per program call (:func:`lines_per_call` lines of a segment).
        starts: ``(n_lines, n_v)`` start points of the seed points, NaN rows
            where a line has none (it starts from the model's initial guess);
            ``None``: none has one.
        progress: called with the number of points finished after each call.

    Returns:
        A :class:`Gait` of ``(n_lines, n)`` leaves, in grid order.
    """
    n_lines, n = next(iter(lines.values())).shape
    segments, order = segment_inputs(model, lines, positions, seed, starts)
    program = segment_program(model, solver, newton)
    carry, pieces = None, []
    for rows in segments:
        if carry is not None:
            rows = rows._replace(inputs=rows.inputs._replace(carry=carry))
        real = int(rows.inputs.visit_valid[0].sum())
        done = None if progress is None else (lambda count, real=real: progress(count * real))
        carry, gaits = run_chunks(program, rows, lines_per_call(chunk_size), done, MIN_LINES_PER_THREAD)
        pieces.append(gaits)
    gaits = jax.tree_util.tree_map(lambda *xs: np.concatenate(xs, axis=1)[:, :n], *pieces)
    inverse = np.argsort(order)
    gaits = jax.tree_util.tree_map(lambda x: x[:, inverse], gaits)
    return fill_from_neighbours(model, lines, positions, gaits, program, chunk_size)


def fill_from_neighbours(model: Walker, lines: Mapping[str, np.ndarray], positions: np.ndarray, gaits: Gait, program,
                         chunk_size: int) -> Gait:
    """Solve again, from a found neighbour's gait, every point of a line whose
    search failed beside it, until no point changes.

    A line's walk reaches each point once, from one side: the walk up from the
    seed meets a band of gaits that lies wholly above the seed from below, and
    its points below the band's first found one were searched from a failed
    start, not from the band's gait (the paper walker's lines from l_f 0.26 on
    missed up to seven stable gaits each that way). Each round solves the
    candidates (a failed point with a found neighbour not yet tried from that
    side) as one-visit lines of the same ``program`` (no new compile); a found
    gait makes its other neighbour a candidate. Block-independent: a line's
    result depends on its own points only. Each search starts on the secant
    through the neighbour's gait and the one beyond it where that is found too
    (``NewtonOptions.predictor``; on lines that take chord steps, on the
    parabola through those and the next one beyond where all three are found),
    with the neighbour's gait as the fallback: as the walk did past its first
    points in that direction.

    Args:
        lines: the parameters, ``(n_lines, n)`` each; ``gaits``: their
            :class:`Gait` from the walk, ``(n_lines, n)`` leaves, in grid order.
        positions: ``(n,)`` the continuation parameter's values along the lines.
        program: :func:`segment_program` of the model and settings.

    Returns:
        ``gaits`` with the points found again replaced.
    """
    status = np.asarray(gaits.status).copy()
    gaits = jax.tree_util.tree_map(np.array, gaits)
    tried = np.zeros(status.shape + (2,), bool)  # tried from the left, from the right
    while True:
        found = status == Status.OK
        left = np.zeros_like(found)
        left[:, 1:] = found[:, :-1]
        right = np.zeros_like(found)
        right[:, :-1] = found[:, 1:]
        from_left = ~found & left & ~tried[..., 0]
        from_right = ~found & right & ~tried[..., 1] & ~from_left
        line, point = np.nonzero(from_left | from_right)
        if line.size == 0:
            return gaits
        side = np.where(from_left[line, point], -1, 1)
        tried[line, point, np.where(side < 0, 0, 1)] = True
        single = {k: np.asarray(v, np.float64)[line, point][:, None] for k, v in lines.items()}
        carry = _neighbour_carry(gaits, positions, line, point, side)
        (rows,), _ = segment_inputs(model, single, np.asarray(positions, np.float64)[point][:, None], 0, carry=carry)
        _, again = run_chunks(program, rows, lines_per_call(chunk_size), None, MIN_LINES_PER_THREAD)
        ok = np.asarray(again.status)[:, 0] == Status.OK
        for leaf, new in zip(jax.tree_util.tree_leaves(gaits), jax.tree_util.tree_leaves(again)):
            leaf[line[ok], point[ok]] = np.asarray(new)[ok, 0]
        status[line[ok], point[ok]] = Status.OK


def segment_inputs(
    model: Walker, lines: Mapping[str, np.ndarray], positions: np.ndarray, seed: int, starts: np.ndarray | None = None,
    carry: LineCarry | None = None,
) -> tuple[list[Rows], np.ndarray]:
    """The rows of :func:`segment_program` for each segment of ``n_lines`` lines
    (arguments as :func:`run_lines`; ``positions`` ``(n,)`` or one row per line,
    ``(n_lines, n)``), every one holding the carry before the line's first
    visit (``carry`` where given, else from ``starts``; a run replaces it by the
    carry the segment before handed out), and the visiting order (``(n,)``:
    visit ``k`` is point ``order[k]``)."""
    n_lines, n = next(iter(lines.values())).shape
    order, restart = visiting_order(n, seed)
    padded = -(-n // SEGMENT_LENGTH) * SEGMENT_LENGTH
    visit_order = np.concatenate([order, np.full(padded - n, order[-1], order.dtype)])
    visits = {k: np.asarray(v, np.float64)[:, visit_order] for k, v in lines.items()}
    restart = np.concatenate([restart, np.zeros(padded - n, bool)])
    position = np.broadcast_to(np.asarray(positions, np.float64), (n_lines, n))[:, visit_order]
    first, visit_valid = np.arange(padded) == 0, np.arange(padded) < n
    carry = _initial_carry(model, n_lines, starts) if carry is None else carry
    segments = []
    for start in range(0, padded, SEGMENT_LENGTH):
        part = slice(start, start + SEGMENT_LENGTH)
        per_line = lambda v: np.broadcast_to(v[part], (n_lines, SEGMENT_LENGTH)).copy()  # noqa: E731
        inputs = SegmentInputs(position[:, part].copy(), per_line(restart), per_line(first), per_line(visit_valid), carry)
        segments.append(Rows({name: v[:, part] for name, v in visits.items()}, inputs))
    return segments, order


def _initial_carry(model: Walker, n_lines: int, starts: np.ndarray | None) -> LineCarry:
    """:class:`LineCarry` rows before the first visit (``starts`` as in :func:`run_lines`)."""
    n_v = len(model.section_names)
    if starts is None:
        starts = np.full((n_lines, n_v), np.nan)
    starts = np.asarray(starts, np.float64).reshape(n_lines, n_v)
    have = np.isfinite(starts).all(axis=-1)
    return fresh_carry(np.where(have[:, None], starts, 0.0), have)


def _neighbour_carry(gaits: Gait, positions: np.ndarray, line: np.ndarray, point: np.ndarray, side: np.ndarray) -> LineCarry:
    """The carry of one-visit lines at ``(line, point)`` (each ``(m,)``) reached
    from their found neighbour at ``point + side``, with the gaits beyond it
    (``point + 2 side``, ``point + 3 side``) as the secant's second point and
    the parabola's third where they are found."""
    v, status = np.asarray(gaits.v), np.asarray(gaits.status)
    s = np.asarray(positions, np.float64)
    n = status.shape[1]
    beyond = np.clip(point + 2 * side, 0, n - 1)
    have2 = (point + 2 * side == beyond) & (status[line, beyond] == Status.OK)
    third = np.clip(point + 3 * side, 0, n - 1)
    have3 = have2 & (point + 3 * side == third) & (status[line, third] == Status.OK)
    v1, have = v[line, point + side], np.ones(line.shape, bool)
    carry = fresh_carry(v1, have)
    return carry._replace(s_prev=s[point + side], last_ok=have, v_prev2=np.where(have2[:, None], v[line, beyond], 0.0),
                          s_prev2=np.where(have2, s[beyond], 0.0), have_prev2=have2,
                          jac_prev=np.asarray(gaits.jacobian)[line, point + side],
                          v_prev3=np.where(have3[:, None], v[line, third], 0.0), s_prev3=np.where(have3, s[third], 0.0),
                          have_prev3=have3)
