"""``[analysis] gait_sensitivity`` and ``[analysis] mfpt``: checked config, resolved options.

Read by the sweep plug-in :mod:`jaxwalk.analyses.global_stability` (which calls
:func:`parse` and :func:`global_options`).
"""

from __future__ import annotations

import dataclasses
import difflib
import math
from typing import Any, Mapping

from jaxwalk.global_stability.sensitivity_norm import DEFAULT_INDICATORS, INDICATORS

#: The ``[analysis]`` keys this package reads.
KEYS = ("gait_sensitivity", "mfpt")
MFPT_KEYS = ("sigma", "mesh", "span", "samples", "max_axes")


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


def parse(table: Mapping[str, Any], fail) -> dict[str, Any]:
    """The resolved keys of ``[analysis]`` that are set (``{}`` when none is): JSON-ready.

    ``fail(message)`` returns the exception to raise.
    """
    out: dict[str, Any] = {}
    gs = table.get("gait_sensitivity", False)
    if gs is not False:
        out["gait_sensitivity"] = _gait_sensitivity(gs, fail)
    m = table.get("mfpt", False)
    if m is not False:
        out["mfpt"] = _mfpt(m, fail)
    return out


def _gait_sensitivity(value, fail) -> dict[str, Any]:
    where = "[analysis] gait_sensitivity"
    if value is True:
        return {"indicators": list(DEFAULT_INDICATORS)}
    if not isinstance(value, Mapping):
        raise fail(f"{where} must be true, false or a table {{ indicators = [..] }}, got {value!r}")
    for key in value:
        if key != "indicators":
            raise fail(f"{where}: unknown key '{key}' (allowed: indicators)")
    names = value.get("indicators", list(DEFAULT_INDICATORS))
    if not isinstance(names, list) or not names or len(set(map(str, names))) != len(names):
        raise fail(f"{where}: indicators must be a non-empty array of distinct names (known: {', '.join(INDICATORS)}), got {names!r}")
    for name in names:
        if name not in INDICATORS:
            close = difflib.get_close_matches(str(name), list(INDICATORS), n=1)
            hint = f" (did you mean '{close[0]}'?)" if close else ""
            raise fail(f"{where}: unknown indicator {name!r}{hint} (known: {', '.join(INDICATORS)})")
    return {"indicators": list(names)}


def _mfpt(value, fail) -> dict[str, Any]:
    from jaxwalk.global_stability.mfpt import MFPTOptions

    where = "[analysis] mfpt"
    if not isinstance(value, Mapping):
        raise fail(f"{where} must be false or a table {{ sigma = .. }}, got {value!r}")
    for key in value:
        if key not in MFPT_KEYS:
            close = difflib.get_close_matches(str(key), MFPT_KEYS, n=1)
            hint = f" (did you mean '{close[0]}'?)" if close else ""
            raise fail(f"{where}: unknown key '{key}'{hint} (allowed: {', '.join(MFPT_KEYS)})")
    if "sigma" not in value:
        raise fail(f"{where}: needs sigma (the standard deviation of each step's ground height change, model length units)")
    sigma = value["sigma"]
    if isinstance(sigma, bool) or not isinstance(sigma, (int, float)) or not (0 <= sigma < math.inf):
        raise fail(f"{where}: sigma must be a number >= 0 (model length units), got {sigma!r}")
    span = value.get("span", MFPTOptions.span)
    if isinstance(span, bool) or not isinstance(span, (int, float)) or not (0 < span < math.inf):
        raise fail(f"{where}: span must be a positive number (standard deviations), got {span!r}")
    ints = {}
    for key, least in (("mesh", 3), ("samples", 4), ("max_axes", 1)):
        n = value.get(key, getattr(MFPTOptions, key))
        if isinstance(n, bool) or not isinstance(n, int) or n < least:
            raise fail(f"{where}: {key} must be an integer >= {least}, got {n!r}")
        ints[key] = n
    return {"sigma": float(sigma), "span": float(span), **ints}


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
