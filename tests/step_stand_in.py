"""What Newton's loop body (:func:`jaxwalk.gait._newton_iteration`) reads of a step,
for tests that drive it with a stand-in residual instead of a walker's step."""

from __future__ import annotations

from typing import NamedTuple

import jax


class StepStandIn(NamedTuple):
    """The fields of :class:`~jaxwalk.stepbase.StepResult` the loop body reads."""

    status: jax.Array
    time: jax.Array
    length: jax.Array
    work: jax.Array
    n_events: jax.Array
    ode_steps: jax.Array
    phase: jax.Array
    guard: jax.Array
    y: jax.Array
    ctx: jax.Array
