"""Where each failed gait search's step failed: on by default (``[analysis] failure_cause``).

A status says what ended a point's gait search (``slipping``, ``foot_rolling``,
``scuffing``, ...); these say where, from the step that failed
(:class:`jaxwalk.gait.GaitStats`, kept by every search at no extra step):

* ``failure_phase`` ``S``: the phase in which that step stopped;
* ``failure_event`` ``S``: the event (guard) that ended it: a failure guard
  (``slip``, ``foot_roll``, ``fall``, ...) or a transition whose reset failed
  (``heel_strike`` for an impact impulse outside its friction cone; ``unlock``
  or ``toe_off`` for a phase entered already beyond one of its limits: the
  shoe walker at r = 0.755 re-enters push-off with its knee released beyond
  the stance foot's cone);
* ``failure_limit`` ``S``: for the flat-foot walker's ``slip`` and ``foot_roll``
  events, the contact limit at its edge there (``stance_friction``,
  ``heel_friction``, ``cop_toe``, ``cop_heel``; :meth:`jaxwalk.walker.Walker.limit_use`).

Each is an int8 CF flag variable whose ``flag_meanings`` are ``none`` (0) and
the model's names in order (1, 2, ...): ``none`` where a gait was found, where
the search failed without a failed step (``no_convergence``), where no event
ended the step (a time limit, a solver failure) and, for the limit, where the
event is not a limit's.
"""

from __future__ import annotations

from typing import Any, ClassVar

import numpy as np

from jaxwalk.analyses.base import Analysis, Block
from jaxwalk.configs import Table, field
from jaxwalk.outputs import Output


class Settings(Table):
    """Its ``[analysis]`` key."""

    where: ClassVar[str] = "[analysis]"

    failure_cause: bool = field(True, "true or false")  # write where each failed search's step failed


#: ``(output, GaitStats field, Walker attribute naming its values)``.
_FIELDS = (("failure_phase", "failure_phase", "phases"), ("failure_event", "failure_guard", "guards"),
           ("failure_limit", "failure_limit", "limits"))

OUTPUTS = (
    Output("failure_phase", "int8", "phase in which the step that ended the gait search failed (flag values; 0: none)",
           "failure phase", units=None, always=True),
    Output("failure_event", "int8", "event (guard) that ended the failed step: a failure guard, or a transition whose "
           "reset failed (flag values; 0: none)", "failure event", units=None, always=True),
    Output("failure_limit", "int8", "contact limit at its edge where a limit's event ended the failed step "
           "(flag values; 0: none)", "failure limit", units=None, always=True),
)


def flag_attributes(names: tuple[str, ...]) -> dict[str, Any]:
    """CF flag attributes of a variable holding ``0`` (none) or ``1 + index`` into ``names``."""
    return {"flag_values": list(range(len(names) + 1)), "flag_meanings": " ".join(("none", *names))}


class FailureCause(Analysis):
    name = "failure_cause"
    keys = Settings.keys()
    order = 5  # right after the gait: it reads the gait search only
    off = False

    def parse(self, table, fail, *, continuation) -> bool:
        return Settings.pick(table, fail).failure_cause

    def to_dict(self, resolved) -> dict[str, Any]:
        return {} if resolved else {self.name: False}  # on by default: written only when switched off

    def grid_options(self, resolved):
        return True if resolved else None

    def compute(self, block: Block) -> dict[str, np.ndarray]:
        stats = block.gaits.stats
        return {out: (np.asarray(getattr(stats, source)) + 1).astype(np.int8).reshape(block.shape)
                for out, source, _ in _FIELDS}

    def outputs(self, resolved=True) -> tuple[Output, ...]:
        return OUTPUTS

    def finalise(self, arrays, status, resolved=True) -> dict[str, np.ndarray]:
        """Kept where the gait search failed (they say where), ``none`` where it did not."""
        return {o.name: np.where(status == 0, 0, arrays[o.name]).astype(np.int8) for o in OUTPUTS}

    def variables(self, dims, results, resolved, units, model=None) -> dict[str, tuple]:
        out = super().variables(dims, results, resolved, units, model)
        if model is not None:  # the names behind the flag values are the model's
            for name, _, names in _FIELDS:
                out[name][2].update(flag_attributes(getattr(model, names)))
        return out


ANALYSIS = FailureCause()
