"""How long sweeps of a model took, kept in the cache directory, for ``jaxwalk sweep --dry-run``.

One record per kind of sweep (model, stability, continuation, seed lines, the
analyses beside the gait): the seconds per grid point of the last run that compiled nothing, and
of the last that did (its programs compiled in it). A dry run scales the one
that applies to the new grid's size. Best effort: an unreadable or unwritable
file means no estimate, never an error.
"""

from __future__ import annotations

import json
from pathlib import Path

from jaxwalk import cache
from jaxwalk.files import write_atomically

FILE = "sweep-timings.json"


def kind(config) -> str:
    """What a sweep's cost per point depends on, beyond its size: the model, the
    gait's settings, and each analysis beside it that is on (``h_max`` always named)."""
    others = "".join(f"|{name}" for name in config.analyses if name != "h_max")
    return (
        f"{config.model}|stability={int(config.stability)}|h_max={config.h_max is not None}"
        f"|continuation={config.continuation is not None}|seed={config.seed_axis is not None}{others}"
    )


def _path() -> Path | None:
    root = cache.directory()
    return None if root is None else root / FILE


def _read() -> dict:
    path = _path()
    try:
        return json.loads(path.read_text()) if path is not None else {}
    except (OSError, ValueError):
        return {}


def record(config, seconds: float, points: int, compiled: bool) -> None:
    """Keep ``seconds`` for ``points`` points of a sweep like ``config``."""
    path = _path()
    if path is None or points <= 0:
        return
    data = _read()
    entry = data.setdefault(kind(config), {})
    entry["compiling" if compiled else "warm"] = {"seconds_per_point": seconds / points, "points": points}
    try:
        write_atomically(path, lambda tmp: tmp.write_text(json.dumps(data, indent=1)))
    except OSError:
        pass


def estimate(config, points: int) -> str | None:
    """``"about 12 s (a previous run: 0.02 s per point, programs cached)"``, or ``None``."""
    entry = _read().get(kind(config))
    if not entry:
        return None
    which = "warm" if "warm" in entry else "compiling"
    per_point = entry[which]["seconds_per_point"]
    note = "programs cached" if which == "warm" else "its programs compiled in it"
    return f"about {_seconds(per_point * points)} (a previous {config.model} run: {per_point:.3g} s per point, {note})"


def _seconds(s: float) -> str:
    if s < 90:
        return f"{s:.0f} s"
    if s < 5400:
        return f"{s / 60:.0f} min"
    return f"{s / 3600:.1f} h"
