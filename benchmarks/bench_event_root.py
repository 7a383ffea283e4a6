"""Benchmark: the nested engine's event root finder with a converged Newton step
taken, against the same finder bisecting it (the form before 2026-12-06).

``jaxwalk.rootfind.BracketedNewton`` takes a Newton step that lands strictly
inside the bracket, or is within the tolerance, and bisects otherwise. The old
form (``Bisecting``, below) bisected a converged step too: once Newton has
converged the iterate is itself a bracket end and the next Newton step (below
one ulp) lands on it or just past it; that step was bisected, the root thrown
away, and the bracket then halved down to the tolerance (1e-13): on the paper
walker's flat-foot step two of the 11 events took 38 and 17 extra iterations,
each a guard evaluation under ``jvp``. The flat engine's ``locate_event``
always took such a step as convergence.

The forms (``bisecting``: the old; ``converged``: today's) are installed in
turn as ``jaxwalk.step.BracketedNewton`` (``jax.clear_caches()`` between, so
every solve traces again). Per walker and batch size, ``jit(vmap(...))`` on one
CPU device, compile apart; both forms compiled first, then run in turn (A B A B)
and the best of ``--repeat`` kept, for one step map from the stored guess and
the gait search, on ``bench_first_step.py``'s configurations. The largest
differences of the values between the forms are reported.

    JAXWALK_CACHE_DIR= PYTHONPATH=. python benchmarks/bench_event_root.py [--models flatfoot kneed simplest] [--batches 1 64]

Writes ``benchmarks/results/event_root.json``.
"""

from __future__ import annotations

import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

import jaxwalk  # noqa: E402,F401  (before jax: the device-count flag)
import jax  # noqa: E402
import jax.numpy as jnp  # noqa: E402

from bench_first_step import cli, compare, compile_programs  # noqa: E402
from jaxwalk import rootfind, step  # noqa: E402
from jaxwalk.step import SolverOptions  # noqa: E402


class Bisecting(rootfind.BracketedNewton):
    """The old form: a Newton step is taken only where it lands strictly inside the bracket."""

    def step(self, fn, y, args, options, state, tags):
        (f, aux), (df, _) = jax.jvp(lambda t: fn(t, args), (y,), (jnp.ones_like(y),))
        same_as_lower = (f < 0) == state.lower_negative
        lower = jnp.where(same_as_lower, y, state.lower)
        upper = jnp.where(same_as_lower, state.upper, y)
        newton = y - f / jnp.where(df == 0, 1.0, df)
        inside = (df != 0) & (newton > jnp.minimum(lower, upper)) & (newton < jnp.maximum(lower, upper))
        new_y = jnp.where(f == 0, y, jnp.where(inside, newton, 0.5 * (lower + upper)))
        new_state = rootfind._State(lower, upper, state.lower_negative, jnp.abs(upper - lower), jnp.abs(new_y - y))
        return new_y, new_state, aux


FORMS = {"bisecting": Bisecting, "converged": rootfind.BracketedNewton}


def measure(model, n: int, repeat: int) -> list[dict]:
    """Both forms compiled (each installed in turn), then compared (``bench_first_step.compare``)."""
    compiled = {}
    for form, finder in FORMS.items():
        step.BracketedNewton = finder
        jax.clear_caches()
        compile_programs(model, n, SolverOptions(), form, compiled)
    step.BracketedNewton = rootfind.BracketedNewton
    return compare(model, n, compiled, tuple(FORMS), repeat)


if __name__ == "__main__":
    cli(__doc__.splitlines()[0], measure, "event_root")
