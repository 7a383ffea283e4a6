"""Event times by Newton's method kept inside a bracket (safeguarded Newton).

diffrax locates an event on the dense interpolant of the step on which a guard
changed sign, so the root is bracketed by the step's ends. Plain Newton from
the step's end can leave that bracket when the guard is not monotone on it
(a swing foot that dips through the ground and rises again within one solver
step) and then fails; bisection never fails but converges slowly. This finder
takes the Newton step when it lands strictly inside the current bracket or is
within the tolerance (converged) and bisects otherwise, shrinking the bracket
with every evaluation: quadratic convergence on smooth guards, guaranteed
convergence on all of them. A converged step may land outside the bracket by
less than the tolerance (1e-13 in time); the dense interpolant is evaluated
there, a negligible extrapolation.

The event time's derivative does not depend on the root finder: optimistix
differentiates the root implicitly, ``dt/dp = -(dg/dp) / (dg/dt)``.
"""

from __future__ import annotations

from typing import Any, ClassVar

import equinox as eqx
import jax
import jax.numpy as jnp
import optimistix as optx
from jaxtyping import Array, Bool, Float, Scalar


class _State(eqx.Module):
    lower: Scalar
    upper: Scalar
    lower_negative: Bool[Array, ""]  # sign of the guard at ``lower``
    width: Float[Array, ""]
    step: Float[Array, ""]


class BracketedNewton(optx.AbstractRootFinder):
    """Safeguarded Newton for scalar roots; needs ``options=dict(lower=..., upper=...)``.

    Attributes:
        rtol, atol: stop when the last step or the bracket is below ``atol + rtol |t|``.
    """

    rtol: float
    atol: float
    norm: ClassVar = jnp.abs

    def init(self, fn, y, args, options: dict[str, Any], f_struct, aux_struct, tags) -> _State:
        lower = jnp.asarray(options["lower"], f_struct.dtype)
        upper = jnp.asarray(options["upper"], f_struct.dtype)
        f_lower, _ = fn(lower, args)
        inf = jnp.asarray(jnp.inf, f_struct.dtype)
        return _State(lower, upper, f_lower < 0, inf, inf)

    def step(self, fn, y, args, options, state: _State, tags):
        (f, aux), (df, _) = jax.jvp(lambda t: fn(t, args), (y,), (jnp.ones_like(y),))
        same_as_lower = (f < 0) == state.lower_negative
        lower = jnp.where(same_as_lower, y, state.lower)
        upper = jnp.where(same_as_lower, state.upper, y)
        step = f / jnp.where(df == 0, 1.0, df)
        newton = y - step
        inside = (df != 0) & (newton > jnp.minimum(lower, upper)) & (newton < jnp.maximum(lower, upper))
        # A step within the tolerance is convergence wherever it lands: below
        # one ulp it lands on the iterate, itself a bracket end, and bisecting
        # it would throw the root away and halve the bracket down to the
        # tolerance (38 extra guard evaluations for one event of the paper
        # walker's step).
        converged = (df != 0) & (jnp.abs(step) < self.atol + self.rtol * jnp.abs(y))
        new_y = jnp.where(f == 0, y, jnp.where(inside | converged, newton, 0.5 * (lower + upper)))
        new_state = _State(lower, upper, state.lower_negative, jnp.abs(upper - lower), jnp.abs(new_y - y))
        return new_y, new_state, aux

    def terminate(self, fn, y, args, options, state: _State, tags):
        scale = self.atol + self.rtol * jnp.abs(y)
        done = (state.step < scale) | (state.width < scale)
        return done, optx.RESULTS.successful

    def postprocess(self, fn, y, aux, args, options, state, tags, result):
        return y, aux, {}
