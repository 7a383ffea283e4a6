"""``[analysis] attractors``: what the walker settles on from its period-1 gait's neighbourhood.

The search is :mod:`jaxwalk.attractor`; this plug-in reads its settings, runs
it on a block's gaits and declares its outputs (grid shape ``S``):

* ``attractor_status`` ``S``, int8 with CF flag attributes: 0 where an attractor
  was found; the gait's status where there is no period-1 gait; the failing
  step's (``fell``, ``scuffing``, ...), ``no_periodic_attractor`` (15) or
  ``cycle_not_found`` (16) where the walk from an unstable gait found none;
* ``attractor_period`` ``S``, int32: its number of steps k (0 where none);
* ``attractor_lambda_max`` ``S``: spectral radius of the k-step map's Jacobian;
* ``attractor_rate`` ``S``: the per-step contraction ``attractor_lambda_max ** (1/k)``;
* ``attractor_multipliers_real`` / ``_imag`` ``S + (eigen,)``: the k-step map's eigenvalues;
* ``attractor_points`` ``S + (cycle, section)``: the cycle's k points (fixed
  points of the k-step map) in the order walked, NaN rows beyond k.

The period-1 variables (``status``, ``lambda_max``, ...) keep their meaning.
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np

from jaxwalk import outputs as schema
from jaxwalk.analyses.base import Analysis, Block, switch
from jaxwalk.configs import Table, field
from jaxwalk.outputs import Output
from jaxwalk.status import Status


class Settings(Table):
    """``[analysis] attractors = { .. }``: the search's bounds, the
    :class:`jaxwalk.attractor.AttractorOptions` fields of the same names (an
    absent key takes its default, read when resolved: that module needs JAX)."""

    where: ClassVar[str] = "[analysis] attractors"

    max_period: int | None = field(None, "a positive integer", ge=1)  # longest period tested (steps)
    steps: int | None = field(None, "a positive integer", ge=1)  # most steps walked before giving up

OUTPUTS = (
    Output("attractor_status", "int8", (
        "outcome of the attractor search from the period-1 gait's neighbourhood (0: an attractor was "
        "found; the gait's status where there is no period-1 gait)"
    ), units=None, flags=True),
    Output("attractor_period", "int32", "number of steps k of the attractor's cycle (1: the period-1 gait; 0: no attractor)",
           label="attractor period k [steps]", meaning="steps per cycle of the gait the walker settles on", plot=70),
    Output("attractor_lambda_max", "float64", "spectral radius of the attractor's k-step map Jacobian (below 1: stable)",
           finite_where_ok=True),
    Output("attractor_rate", "float64",
           "per-step contraction of the attractor, attractor_lambda_max ** (1 / attractor_period)",
           label=r"attractor rate $\lambda_{\max,k}^{1/k}$", meaning="per-step contraction of the gait the walker settles on",
           finite_where_ok=True, plot=80),
    Output("attractor_multipliers", "complex128", "the eigenvalues of the attractor's k-step map Jacobian", trailing=("eigen",)),
    # Beyond k its rows are NaN: only the first point must be finite (finalise).
    Output("attractor_points", "float64", (
        "the attractor's cycle: its k points (fixed points of the k-step map) in section coordinates, "
        "in the order walked; NaN beyond k"
    ), units=None, trailing=("cycle", "section")),
)


class Attractors(Analysis):
    name = "attractors"
    keys = ("attractors",)
    order = 20
    options_field = "attractors"
    status_of_outputs = "attractor_status"

    def parse(self, table, fail, *, continuation) -> dict[str, int] | None:
        """``false``/absent (off), ``true`` (the defaults) or a table of ``max_period``
        (a power of two) and ``steps``; resolved with the defaults."""
        given = switch(table, "attractors", Settings, fail, "{ max_period = .., steps = .. }")
        if given is None:
            return None
        from jaxwalk.attractor import AttractorOptions

        defaults = AttractorOptions()
        out = {k: getattr(defaults, k) if v is None else v for k, v in given.model_dump().items()}
        where = Settings.where
        if out["max_period"] & (out["max_period"] - 1):
            raise fail(f"{where}: max_period must be a power of two (periods 1, 2, 4, ... are tested), got {out['max_period']}")
        return out

    def grid_options(self, resolved):
        if resolved is None:
            return None
        from jaxwalk.attractor import AttractorOptions

        return AttractorOptions(**resolved)

    def compute(self, block: Block) -> dict[str, np.ndarray]:
        from jaxwalk.attractor import grid_attractors

        return grid_attractors(block.model, block.params, block.results, block.options)

    def outputs(self, resolved=None) -> tuple[Output, ...]:
        return OUTPUTS

    def sizes(self, resolved, n_v: int) -> dict[str, int]:
        return {"section": n_v, "eigen": n_v, "cycle": int(resolved["max_period"])}

    def finalise(self, arrays, status, resolved) -> dict[str, np.ndarray]:
        """Where there is no period-1 gait the attractor's status is the gait's; where
        ``attractor_status == 0`` a non-finite lambda_max, rate or first cycle point
        makes it ``NONFINITE``; wherever it is not 0 the numbers are NaN and the period 0."""
        codes = np.where(status != Status.OK, status, arrays["attractor_status"]).astype(np.int8)
        codes = schema.nonfinite(codes, arrays, OUTPUTS)
        first = np.isfinite(arrays["attractor_points"][..., 0, :]).all(axis=-1)
        codes = np.where((codes == Status.OK) & ~first, np.int8(Status.NONFINITE), codes).astype(np.int8)
        return {"attractor_status": codes, **schema.blank(arrays, OUTPUTS, codes != Status.OK)}


ANALYSIS = Attractors()
