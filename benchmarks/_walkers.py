"""The parameters the benchmarks run each walker at.

A model's defaults, except the flat-foot walker's: the paper's walker
(``PAPER_PARAMS``), the defaults the figures in benchmarks/README.md were first
recorded at, so they stay comparable now that the defaults are the shoe
walker's (docs/model.md, "Defaults and the paper's walker").
"""

from __future__ import annotations

from jaxwalk.models.flatfoot.model import PAPER_PARAMS
from jaxwalk.walker import as_params


def benchmark_params(model) -> dict:
    """``{name: float64 scalar}``: ``model``'s defaults, the paper's walker for the flat-foot one."""
    params = model.default_params()
    return {**params, **as_params(PAPER_PARAMS)} if model.name == "flatfoot" else params
