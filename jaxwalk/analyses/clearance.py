"""``[analysis] min_clearance``: the lowest swing-foot clearance of each gait's step.

Models whose context tracks it (a ``min_clearance`` entry, kept exact by
events at the swing foot's height extrema: the flat-foot walker,
:mod:`jaxwalk.models.flatfoot.clearance`) report it for any step; this
plug-in reads it from the end context of each gait's step (the gait search's
last evaluation, :attr:`jaxwalk.gait.Gait.context`) and writes:

* ``min_clearance`` ``S``: the lowest height of the swing heel or toe above
  the ground at an interior minimum of the step, model length units (negative
  below it); NaN where no gait was found or the step passes no minimum.
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np

from jaxwalk.analyses.base import Analysis, Block
from jaxwalk.configs import Table, field
from jaxwalk.outputs import Output


class Settings(Table):
    """Its ``[analysis]`` key."""

    where: ClassVar[str] = "[analysis]"

    min_clearance: bool = field(False, "true or false")  # write the step's lowest swing-foot clearance

OUTPUT = Output(
    "min_clearance", "float64",
    "lowest height of the swing foot's heel or toe above the ground over the gait's step (negative: below it)",
    "minimum swing clearance", units="{length}", label="min. swing clearance",
    meaning="lowest swing-foot height above the ground in a step",
)


class Clearance(Analysis):
    name = "min_clearance"
    keys = Settings.keys()
    order = 50
    off = False

    def parse(self, table, fail, *, continuation) -> bool:
        return Settings.pick(table, fail).min_clearance

    def check_model(self, resolved, model, fail) -> None:
        if resolved and "min_clearance" not in model.context:
            raise fail(f"[analysis]: min_clearance = true: the {model.name} model does not track its swing foot's "
                       "clearance (no 'min_clearance' context entry; the flatfoot model does)")

    def grid_options(self, resolved):
        return True if resolved else None

    def compute(self, block: Block) -> dict[str, np.ndarray]:
        from jaxwalk.models.flatfoot.clearance import min_clearance

        # Read, not walked again: the step from the fixed point is the gait
        # search's last evaluation, whose end context the gait keeps; a
        # program of its own would take ~20 s to trace and compile, and one
        # more step per gait to run.
        return {"min_clearance": np.asarray(min_clearance(np.asarray(block.gaits.context)), np.float64)}

    def outputs(self, resolved=True) -> tuple[Output, ...]:
        return (OUTPUT,)


ANALYSIS = Clearance()
