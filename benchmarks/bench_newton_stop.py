"""Benchmark: Newton's rate test (``NewtonOptions.rate_test``), against the update test alone.

The gait search stopped when an update fell below ``tol`` (1e-8), so every
search spent one evaluation of the step map and its Jacobian only to confirm
the update before it, and on the simplest walker's flattest slopes, where the
update's integration noise (~2.5e-8) exceeds ``tol``, it waited for a lucky
draw. With the rate test (the default since 2026-12-06) it also stops when
``theta / (1 - theta) * |update| < tol``, ``theta`` the observed contraction.

Per walker and batch size, ``jit(vmap(...))`` on one CPU device, compile apart;
both settings compiled first, then run in turn (A B A B) and the best of
``--repeat`` kept (``bench_first_step.compare``), on ``bench_first_step.py``'s
configurations: the gait search's time, Newton iterations and the largest
differences of fixed point and ``lambda_max`` (the step map is the same
program under both: a control).

    JAXWALK_CACHE_DIR= PYTHONPATH=. python benchmarks/bench_newton_stop.py [--models flatfoot kneed simplest] [--batches 1 64]

Writes ``benchmarks/results/newton_stop.json``.
"""

from __future__ import annotations

import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

import jaxwalk  # noqa: E402,F401  (before jax: the device-count flag)

from bench_first_step import cli, compare, compile_programs  # noqa: E402
from jaxwalk.gait import NewtonOptions  # noqa: E402
from jaxwalk.step import SolverOptions  # noqa: E402

SETTINGS = {"update": False, "rate": True}


def measure(model, n: int, repeat: int) -> list[dict]:
    """Both settings compiled, then compared (``bench_first_step.compare``)."""
    compiled = {}
    for setting, rate_test in SETTINGS.items():
        compile_programs(model, n, SolverOptions(), setting, compiled, NewtonOptions(rate_test=rate_test))
    return compare(model, n, compiled, tuple(SETTINGS), repeat)


if __name__ == "__main__":
    cli(__doc__.splitlines()[0], measure, "newton_stop")
