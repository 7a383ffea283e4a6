"""A step's event sequence, as one integer: what a gait does, comparable between gaits.

A model that logs the events of its step (:attr:`jaxwalk.walker.Walker.event_log`
names the two context entries) appends each event's guard index, as one
base-:data:`BASE` digit, to a history held in a float64 context entry (exact
for the last :data:`DEPTH` events: ``16**13 = 2**52``) and counts the events in
another. Both start at 0 on the section. The *sequence code* packs them into one
int64, ``count * 2**52 + history``, so two steps with the same code took the
same events in the same order (up to the last 13; a leading guard 0, which adds
no digit, is told apart by the count).

Two gaits of one continuation line whose codes differ walk different hybrid
step maps: between them the event order changes (a border collision of the
step map, whose Jacobian, and with it the multipliers, may jump there:
:mod:`jaxwalk.bifurcation` locates it).
"""

from __future__ import annotations

import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float, Int

#: Digits of the history: guard indices must be below it.
BASE = 16
#: Events the history keeps exactly (``BASE**DEPTH = 2**52``).
DEPTH = 13
#: The code where there is no sequence (no gait, a model that logs none): no step has no event.
NONE = 0
_COUNT_UNIT = 2**52


def append(history: Float[Array, ""], guard) -> Float[Array, ""]:
    """The history after one more event, guard index ``guard`` (its last :data:`DEPTH` kept)."""
    # The oldest digit goes first: the product stays below 2**52, exact in float64.
    return jnp.mod(history, float(BASE ** (DEPTH - 1))) * BASE + guard


def sequence_code(model, ctx: Float[Array, "*batch n_ctx"]) -> Int[Array, "*batch"]:
    """The step's sequence code from its end context ``ctx`` (:data:`NONE` if the model logs nothing)."""
    if model.event_log is None:
        return jnp.full(ctx.shape[:-1], NONE, jnp.int64)
    history, count = (ctx[..., model.ctx_index(name)] for name in model.event_log)
    return jnp.round(count).astype(jnp.int64) * _COUNT_UNIT + jnp.round(history).astype(jnp.int64)


def decode(code: int, guards: tuple[str, ...]) -> tuple[str, ...]:
    """The events of sequence code ``code``, oldest first, by their guards' names
    (``guards``: the model's :attr:`~jaxwalk.walker.Walker.guards`); ``()`` for :data:`NONE`.
    A step of more than :data:`DEPTH` events starts with ``"..."``."""
    code = int(code)
    if code <= 0:
        return ()
    count, history = divmod(code, _COUNT_UNIT)
    names = []
    for _ in range(min(count, DEPTH)):
        history, digit = divmod(history, BASE)
        names.append(guards[digit] if digit < len(guards) else f"guard {digit}")
    return (("...",) if count > DEPTH else ()) + tuple(reversed(names))


def describe(code: int, guards: tuple[str, ...]) -> str:
    """``decode`` as one line, ``"unlock > knee_flex > ..."`` (``"none"`` for :data:`NONE`)."""
    names = decode(code, guards)
    return " > ".join(names) if names else "none"


def codes(model, ctx: np.ndarray) -> np.ndarray:
    """:func:`sequence_code` of host arrays (NumPy in, NumPy out)."""
    return np.asarray(sequence_code(model, jnp.asarray(ctx)))
