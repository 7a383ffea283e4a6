"""Gradient-based optimisation of gait metrics (``jaxwalk optimize``; docs/optimize.md)."""

from jaxwalk.optimize.config import OptimizeConfig, load_optimize_config, parse_optimize_config
from jaxwalk.optimize.engine import QUANTITIES, Path, Problem, optimise, sensitivity_program
from jaxwalk.optimize.output import build_dataset, run_optimize, summary

__all__ = [
    "OptimizeConfig",
    "Path",
    "Problem",
    "QUANTITIES",
    "build_dataset",
    "load_optimize_config",
    "optimise",
    "parse_optimize_config",
    "run_optimize",
    "sensitivity_program",
    "summary",
]

# jaxwalk.optimize(config, out=None, ...) runs it from a notebook (jaxwalk.api.optimize).
from jaxwalk._callable import make_callable as _make_callable  # noqa: E402

_make_callable(__name__, "optimize")
