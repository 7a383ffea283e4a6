"""``[analysis] event_sequence``: which events each gait's step takes, in which order.

On by default for models that log their step's events
(:attr:`jaxwalk.walker.Walker.event_log`: the flat-foot walkers); nothing is
written for the others. Read, not walked again, from the end context of each
gait's step (the gait search's last evaluation, :attr:`jaxwalk.gait.Gait.context`):

* ``event_sequence`` ``S`` int64: the step's sequence code
  (:mod:`jaxwalk.event_log`: ``count * 2**52 + history``, the history's base-16
  digits the guard indices of the events, oldest first); its attribute
  ``event_names`` names the guards, and ``jaxwalk.event_log.describe(code,
  names)`` spells a code out (``"unlock > knee_flex > ... > toe_strike"``). 0
  where there is no gait.

Neighbouring gaits with different codes walk different hybrid step maps: the
bifurcation table (``[analysis] bifurcations``) locates where the order changes.
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

    event_sequence: bool = field(True, "true or false")  # write each gait's event sequence (models that log it)


OUTPUT = Output(
    "event_sequence", "int64",
    "the gait's step's events in order, as a sequence code (count * 2**52 + history; the history's base-16 digits "
    "are the events' indices in event_names, oldest first; 0: no gait)",
    "event sequence", units=None, always=True,
)


class EventSequence(Analysis):
    name = "event_sequence"
    keys = Settings.keys()
    order = 6  # beside the failure cause: it reads the gait search only
    off = False

    def parse(self, table, fail, *, continuation) -> bool:
        return Settings.pick(table, fail).event_sequence

    def to_dict(self, resolved) -> dict:
        return {} if resolved is not False else {self.name: False}  # on by default: written only when switched off

    def for_model(self, resolved, model):
        """On only where the model logs its events (``None``: nothing to write)."""
        return True if resolved and model.event_log is not None else None

    def grid_options(self, resolved):
        return True if resolved else None

    def compute(self, block: Block) -> dict[str, np.ndarray]:
        from jaxwalk.event_log import codes

        return {"event_sequence": codes(block.model, np.asarray(block.gaits.context)).reshape(block.shape)}

    def outputs(self, resolved=True) -> tuple[Output, ...]:
        return (OUTPUT,) if resolved else ()

    def finalise(self, arrays, status, resolved=True) -> dict[str, np.ndarray]:
        """0 where no gait was found (the failed step's events are not a gait's)."""
        return {OUTPUT.name: np.where(status == 0, arrays[OUTPUT.name], 0).astype(np.int64)} if resolved else {}

    def variables(self, dims, results, resolved, units, model=None) -> dict[str, tuple]:
        out = super().variables(dims, results, resolved, units, model)
        if model is not None and OUTPUT.name in out:  # the names behind the digits are the model's
            out[OUTPUT.name][2]["event_names"] = " ".join(model.guards)
        return out


ANALYSIS = EventSequence()
