"""Gradient-based optimisation of gait metrics (``jaxwalk optimize``; docs/optimize.md)."""

from jaxwalk.optimize.config import (
    OptimizeConfig as OptimizeConfig,
    load_optimize_config as load_optimize_config,
    parse_optimize_config as parse_optimize_config,
)
from jaxwalk.optimize.engine import (
    QUANTITIES as QUANTITIES,
    Path as Path,
    Problem as Problem,
    optimise as optimise,
    sensitivity_program as sensitivity_program,
)
from jaxwalk.optimize.output import build_dataset as build_dataset, run_optimize as run_optimize, summary as summary

# jaxwalk.optimize(config, out=None, ...) runs it from a notebook (jaxwalk.api.optimize).
from jaxwalk._callable import make_callable as _make_callable  # noqa: E402

_make_callable(__name__, "optimize")
