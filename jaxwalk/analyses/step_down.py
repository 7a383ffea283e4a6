"""``[analysis] h_max``: the largest step-down each gait survives (the paper's h_m).

The physics is :func:`jaxwalk.stepdown.h_max`; this plug-in reads its settings,
runs it on a block's gaits and declares its outputs:

* ``h_max`` ``S``, the largest survived step-down, in model length units (NaN
  where no gait; must be finite where there is one);
* ``step_down_status`` ``S``, int8 with CF flag attributes: the first failed
  drop's status, ``OK`` if none failed up to the limit, the gait's status
  where there is no gait;
* ``h_failed`` ``S``, the first failed drop's height (NaN if none failed).
"""

from __future__ import annotations

import functools
from typing import Any, ClassVar, Mapping

import numpy as np

from jaxwalk.analyses.base import Analysis, Block, row_program, run_with_bar, switch
from jaxwalk.configs import Table, field
from jaxwalk.outputs import Output
from jaxwalk.status import Status


class Settings(Table):
    """``[analysis] h_max = { .. }``: the step-down test. An absent key takes the
    default of :class:`jaxwalk.stepdown.StepDownOptions` (read when resolved: that
    module needs JAX, a config check does not)."""

    where: ClassVar[str] = "[analysis] h_max"

    step: float | None = field(None, "a positive number (the resolution, in model length units)",
                               gt=0, allow_inf_nan=False)
    # Caps: a typo's 1e9 is refused, not run for a year.
    count: int | None = field(None, "a positive integer (drops tried: step, 2 step, ..., count * step)", ge=1,
                              le=100_000, messages={"less_than_equal": "{where}: {key} = {value} is more than the limit of 100000"})
    steps: int | None = field(None, "a positive integer (steps to survive after the drop)", ge=1, le=1000,
                              messages={"less_than_equal": "{where}: {key} = {value} is more than the limit of 1000"})


def _h_max_attrs(resolved: Mapping[str, Any], units) -> dict[str, Any]:
    step, count, steps = float(resolved["step"]), int(resolved["count"]), int(resolved["steps"])
    limit = count * step
    comment = (
        f"From the periodic gait, the ground is lowered by h (a vertical drop, slope unchanged) at the "
        f"next touchdown and the walker must then complete {steps} more steps. Drops h = k * {step:g} "
        f"(k = 1, ..., {count}) are tried in increasing order until one fails; h_max is the largest "
        f"tried drop survived together with every smaller one: 0 if the smallest drop ({step:g}) "
        f"already fails, {limit:g} (the limit) if none failed up to it (a lower bound, not "
        "extrapolated). Survival need not be monotone in h, so a drop larger than h_failed might "
        "be survived; the search does not look past it. NaN where no gait was found (status != 0)."
    )
    return {"resolution": step, "limit": limit, "steps_after_drop": steps, "comment": comment}


OUTPUTS = (
    Output("h_max", "float64", "largest survived step-down (every smaller tested drop survived)",
           "largest survived step-down", units="{length}", label=r"$h_{\max}$",
           meaning="global stability: largest survived step-down", finite_where_ok=True, plot=20, attrs=_h_max_attrs),
    Output("step_down_status", "int8", (
        "outcome of the step-down search: status of the first failed drop (0: no drop failed "
        "up to the limit; where no gait was found, the gait's status)"
    ), "step-down status", units=None, flags=True),
    Output("h_failed", "float64", "height of the first failed drop, h_max + resolution (NaN if none failed up to the limit)",
           "first failed drop", units="{length}"),
)


@functools.lru_cache(maxsize=None)
def _program(model, solver, step_down, sub_batch: int):
    from jaxwalk.stepdown import h_max

    def one(p, at):
        return h_max(model, p, at.v_star, step_down, solver)

    # Every drop of every step in lockstep across a sub-batch.
    return row_program(one, sub_batch, "step_down", model, solver, step_down)


class StepDown(Analysis):
    name = "h_max"
    keys = ("h_max",)
    order = 10
    options_field = "step_down"

    def parse(self, table, fail, *, continuation) -> dict[str, float | int] | None:
        """``false`` (off), ``true`` (the defaults) or a table of ``step``/``count``/``steps``,
        each optional; resolved with the defaults of :class:`jaxwalk.stepdown.StepDownOptions`."""
        given = switch(table, "h_max", Settings, fail, "{ step = .., count = .., steps = .. }")
        if given is None:
            return None
        from jaxwalk.stepdown import StepDownOptions

        defaults = StepDownOptions()
        pick = lambda value, default: default if value is None else value  # noqa: E731
        return {
            "step": float(pick(given.step, defaults.dh)),
            "count": int(pick(given.count, defaults.count)),
            "steps": int(pick(given.steps, defaults.n_steps)),
        }

    def to_dict(self, resolved) -> dict[str, Any]:
        return {"h_max": dict(resolved) if resolved is not None else False}  # written when off too

    def grid_options(self, resolved):
        if resolved is None:
            return None
        from jaxwalk.stepdown import StepDownOptions

        return StepDownOptions(dh=resolved["step"], count=resolved["count"], n_steps=resolved["steps"])

    def compute(self, block: Block) -> dict[str, np.ndarray]:
        status = block.results["status"]
        options = block.options
        program = _program(block.model, options.solver, options.step_down, block.sub_batch)
        # Up to count drops of steps + 1 steps each per gait: seconds a flat-foot gait,
        # and 30x more for one that survives every drop than for one that fails the
        # first: 8 sub-batches a thread per call, so a call rarely waits on one row.
        drops = run_with_bar(block, program, block.rows_at_gaits(), "h_max", "point", block.sub_batch, per_call=8)
        no_gait = status != 0  # no h_max without a gait: carry the gait's status
        return {
            "h_max": drops.h_max.reshape(status.shape),
            "step_down_status": np.where(no_gait, status, drops.first_failure.astype(np.int8).reshape(status.shape)),
            "h_failed": drops.failed_at.reshape(status.shape),
        }

    def outputs(self, resolved=None) -> tuple[Output, ...]:
        return OUTPUTS

    def finalise(self, arrays, status, resolved=None) -> dict[str, np.ndarray]:
        """``h_max`` NaN exactly where there is no gait; there ``step_down_status`` is the
        gait's status and ``h_failed`` NaN, as it is wherever no drop failed."""
        if (arrays["h_max"] < 0).any():
            raise ValueError("the analysis returned a negative 'h_max'")
        failed = status != Status.OK
        drop_status = np.where(failed, status, arrays["step_down_status"]).astype(np.int8)
        return {
            "h_max": np.where(failed, np.nan, arrays["h_max"]),
            "step_down_status": drop_status,
            "h_failed": np.where(failed | (drop_status == Status.OK), np.nan, arrays["h_failed"]),
        }


ANALYSIS = StepDown()
