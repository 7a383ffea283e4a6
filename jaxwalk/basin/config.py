"""The ``jaxwalk basin`` config: a model, fixed ``[params]`` and a ``[basin]`` table.

Checked as the sweep's is (:mod:`jaxwalk.sweep.config`): every error is one
line, prefixed by the file, with a "did you mean" hint for a misspelt key.

``[basin]`` keys (``span`` required, the rest optional):

* ``x``, ``y``: the two section coordinates varied (default: the model's first
  two); every other coordinate stays at the fixed point;
* ``span``: ``[sx, sy]``, half-widths of the image about the fixed point, in
  each coordinate's own units (rad, rad per model time unit, ...);
* ``points``: ``[nx, ny]`` starts along x and y (default ``[101, 101]``);
* ``steps``, ``tol``, ``scale``: as ``[analysis] basin`` (:mod:`jaxwalk.analyses.basin`):
  most steps walked, return tolerance and per-coordinate scales of the norm.
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path
from typing import Any, Mapping

from jaxwalk.analyses.base import did_you_mean
from jaxwalk.analyses.basin import DEFAULTS, check_section
from jaxwalk.sweep.config import ConfigError, _kind, _name, _params, model_of, parse_toml, read_config_text

TOP_LEVEL_KEYS = ("name", "model", "params", "basin")
BASIN_KEYS = ("x", "y", "span", "points", "steps", "tol", "scale")
#: Largest image: starts are walked at once (one array of them).
MAX_STARTS = 1_000_000


@dataclasses.dataclass(frozen=True, eq=False)
class BasinConfig:
    """A checked basin image.

    Attributes:
        name, model: the outputs' name, the model's registered name.
        fixed: every model parameter's value (``[params]`` over the defaults).
        x, y: indices of the varied section coordinates.
        span: ``(sx, sy)`` half-widths, the coordinates' own units.
        points: ``(nx, ny)``.
        steps, tol: walk limit and return tolerance (scaled norm).
        scale: ``(n_v,)`` the norm's per-coordinate scales.
        source, text: the file and its text (kept in the dataset).
    """

    name: str
    model: str
    fixed: dict[str, float]
    x: int
    y: int
    span: tuple[float, float]
    points: tuple[int, int]
    steps: int
    tol: float
    scale: tuple[float, ...]
    source: str
    text: str | None


def load_basin_config(path: str | Path) -> BasinConfig:
    """Read and check ``path``. Raises :class:`~jaxwalk.errors.ConfigError` (one line)."""
    text = read_config_text(path)
    return parse_basin_config(parse_toml(text, source=str(path)), source=str(path), text=text)


def parse_basin_config(data: Mapping[str, Any], *, source: str = "<config>", text: str | None = None) -> BasinConfig:
    """Check a parsed config and resolve it."""

    def fail(message: str) -> ConfigError:
        return ConfigError(f"{source}: {message}")

    for key in data:
        if key not in TOP_LEVEL_KEYS:
            raise fail(f"unknown top-level key '{key}'{did_you_mean(key, TOP_LEVEL_KEYS)} (allowed: {', '.join(TOP_LEVEL_KEYS)})")
    name = _name(data, fail)
    model_name, model = model_of(data, fail, example="simplest")
    if not isinstance(data.get("params", {}), Mapping):
        raise fail(f"'params' must be a table ([params]), got {_kind(data['params'])}")
    fixed = {p: float(spec.default) for p, spec in model.param_specs.items()}
    fixed.update(_params(data.get("params", {}), model.param_specs, model_name, fail))
    table = data.get("basin")
    if not isinstance(table, Mapping):
        raise fail("[basin] is missing (e.g. x = \"alpha_1\", y = \"alpha_1_dot\", span = [0.03, 0.03])")
    for key in table:
        if key not in BASIN_KEYS:
            raise fail(f"[basin]: unknown key '{key}'{did_you_mean(key, BASIN_KEYS)} (allowed: {', '.join(BASIN_KEYS)})")
    names = tuple(model.section_names)
    x, y = table.get("x", names[0]), table.get("y", names[1])
    for axis, value in (("x", x), ("y", y)):
        if not isinstance(value, str):
            raise fail(f"[basin] {axis} must be a section coordinate's name ({', '.join(names)}), got {_kind(value)}")
    check_section({"coordinates": [x, y], "scale": table.get("scale")}, model, lambda m: fail(m.replace("[analysis] basin", "[basin]")))
    if x == y:
        raise fail(f"[basin] x and y must be different section coordinates, both are '{x}'")
    span = _pair(table, "span", None, fail, float)
    points = _pair(table, "points", [101, 101], fail, int)
    if any(n < 2 for n in points) or points[0] * points[1] > MAX_STARTS:
        raise fail(f"[basin] points must be two integers >= 2 with at most {MAX_STARTS} starts in all, got {list(points)}")
    steps, tol = table.get("steps", DEFAULTS["steps"]), table.get("tol", DEFAULTS["tol"])
    if isinstance(steps, bool) or not isinstance(steps, int) or steps < 1:
        raise fail(f"[basin] steps must be a positive integer, got {steps!r}")
    if isinstance(tol, bool) or not isinstance(tol, (int, float)) or not 0 < tol < math.inf:
        raise fail(f"[basin] tol must be a positive number (scaled section norm), got {tol!r}")
    scale = table.get("scale", [1.0] * len(names))
    if any(isinstance(s, bool) or not isinstance(s, (int, float)) or not 0 < s < math.inf for s in scale):
        raise fail(f"[basin] scale must be positive numbers, got {scale!r}")
    return BasinConfig(name=name, model=model_name, fixed=fixed, x=names.index(x), y=names.index(y), span=span,
                       points=points, steps=int(steps), tol=float(tol), scale=tuple(float(s) for s in scale),
                       source=source, text=text)


def _pair(table, key: str, default, fail, kind) -> tuple:
    value = table.get(key, default)
    if value is None:
        raise fail(f"[basin]: missing '{key}' (half-widths about the fixed point in the coordinates' own units, e.g. {key} = [0.03, 0.03])")
    ok = isinstance(value, list) and len(value) == 2 and all(not isinstance(v, bool) and isinstance(v, (int, float) if kind is float else int) for v in value)
    if not ok or (kind is float and not all(0 < v < math.inf for v in value)):
        what = "two positive numbers" if kind is float else "two integers"
        raise fail(f"[basin] {key} must be {what} [x, y], got {value!r}")
    return tuple(kind(v) for v in value)
