"""The periodic gait's outputs: what every sweep computes at every grid point.

Its program is the grid's own (:func:`jaxwalk.grid.analyse_chunk`, which reads
each output from the :class:`jaxwalk.gait.Gait` field its ``source`` names); its one
setting is ``[analysis] stability`` (without it ``lambda_max`` and the
eigenvalues need not be finite and are written as NaN).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from jaxwalk import outputs as schema
from jaxwalk.analyses.base import Analysis
from jaxwalk.outputs import Output

_FINITE = dict(finite_where_ok=True)
OUTPUTS = (
    Output("status", "int8", "outcome at this grid point (0: periodic gait found)", "status", units=None, flags=True),
    Output(
        "lambda_max", "float64", "largest eigenvalue modulus of the step-to-step Jacobian (stable below 1)",
        "largest eigenvalue modulus", label=r"$\lambda_{\max}$",
        meaning="local stability: largest eigenvalue modulus (stable below 1)", differentiable=True, plot=10, **_FINITE,
    ),
    Output("eigenvalues", "complex128", "the eigenvalues of the step-to-step Jacobian", "eigenvalue",
           trailing=("eigen",), **_FINITE),
    Output("fixed_point", "float64", "fixed point of the step map in section coordinates (names in 'section')",
           "fixed point", units=None, trailing=("section",), source="v", **_FINITE),
    Output("period", "float64", "duration of one step", "step period", units="{time}", label="step period",
           meaning="duration of one step", differentiable=True, **_FINITE),
    Output("step_length", "float64", "distance the stance foot advances in one step, along the slope", "step length",
           units="{length}", label="step length", meaning="distance the stance foot advances per step",
           differentiable=True, **_FINITE),
    Output("speed", "float64", "mean speed along the slope, step_length / period", "speed", units="{speed}",
           label="speed", meaning="mean walking speed", differentiable=True, plot=50, **_FINITE),
    Output("work", "float64", "work done by the actuators in one step (0 for a passive walker)",
           "actuator work per step", units="{energy}", **_FINITE),
    Output(
        "cost_of_transport", "float64", "actuator work per unit weight per unit distance, work / (weight * step_length)",
        "cost of transport", label="cost of transport", meaning="actuator work per weight and distance",
        differentiable=True, plot=60, **_FINITE,
        attrs={"comment": (
            "mechanical cost of transport of the actuators only; a passive walker's is 0 (gravity "
            "supplies its energy: sin(gamma) per unit weight and distance)"
        )},
    ),
    Output("newton_iterations", "int32", "Newton iterations used to find the fixed point (both searches where continuation's fallback start ran)", "Newton iterations",
           always=True, source="iterations"),
)
#: Without stability these are neither required nor written.
_STABILITY = ("lambda_max", "eigenvalues")


class Gait(Analysis):
    name = "gait"
    order = 0

    def outputs(self, stability=True) -> tuple[Output, ...]:
        if stability:
            return OUTPUTS
        return tuple(dataclasses.replace(o, finite_where_ok=False) if o.name in _STABILITY else o for o in OUTPUTS)

    def finalise(self, arrays, status, stability=True) -> dict[str, np.ndarray]:
        arrays = dict(arrays)
        if not stability:  # not asked for: absent, whatever the analysis computed
            for o in OUTPUTS:
                if o.name in _STABILITY:
                    arrays[o.name] = np.broadcast_to(np.asarray(o.missing(), o.dtype), arrays[o.name].shape)
        out = schema.blank(arrays, OUTPUTS, status != 0)
        out["status"] = status
        out["newton_iterations"] = arrays["newton_iterations"]
        return out


ANALYSIS = Gait()
