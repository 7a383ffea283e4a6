"""The grid options of ``[analysis] gait_sensitivity`` and ``[analysis] mfpt``.

Their keys are declared and checked by the sweep plug-in
:mod:`jaxwalk.analyses.global_stability`, which calls :func:`global_options`
on its resolved settings.
"""

from __future__ import annotations

import dataclasses
from typing import Any, Mapping


@dataclasses.dataclass(frozen=True)
class GlobalOptions:
    """What a sweep computes beyond the gait (hashable: part of program cache keys).

    Attributes:
        gait_sensitivity: the indicators of the gait sensitivity norm, or ``None`` (off).
        mfpt: :class:`~jaxwalk.global_stability.mfpt.MFPTOptions` as a tuple of
            ``(key, value)`` pairs, or ``None`` (off).
    """

    gait_sensitivity: tuple[str, ...] | None = None
    mfpt: tuple[tuple[str, Any], ...] | None = None


def global_options(resolved: Mapping[str, Any]) -> GlobalOptions | None:
    """The :class:`GlobalOptions` of a config's resolved keys (``None`` when none is set)."""
    if not resolved:
        return None
    gs = resolved.get("gait_sensitivity")
    m = resolved.get("mfpt")
    return GlobalOptions(
        gait_sensitivity=None if gs is None else tuple(gs["indicators"]),
        mfpt=None if m is None else tuple(sorted(m.items())),
    )
