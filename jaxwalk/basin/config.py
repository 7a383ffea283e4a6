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
  most steps walked, return tolerance and per-coordinate scales of the norm;
  unlike the sweep's, ``scale`` defaults to 1 for every coordinate, not the
  model's (the image's window is its ``span``).
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path
from typing import Annotated, Any, ClassVar, Mapping

from pydantic import Field

from jaxwalk.analyses.basin import DEFAULTS, check_section  # [analysis] basin's defaults: the measure's
from jaxwalk.configs import Table, TopLevel, check_name, check_params, failing, field, model_of, parse_toml, read_config_text

#: Largest image: starts are walked at once (one array of them).
MAX_STARTS = 1_000_000

_Positive = Annotated[float, Field(gt=0, allow_inf_nan=False)]


class Document(TopLevel):
    """The file's top level."""

    basin: Any = None


class Basin(Table):
    """``[basin]``: the image's coordinates, extent and resolution, the walk's limits."""

    where: ClassVar[str] = "[basin]"
    must: ClassVar[str] = "{where} {key} must be {what}, got {value!r}"

    x: str | None = field(None, "a section coordinate's name", message="{where} {key} must be {what} ({names}), got {kind}")
    y: str | None = field(None, "a section coordinate's name", message="{where} {key} must be {what} ({names}), got {kind}")
    span: Annotated[list[_Positive], Field(min_length=2, max_length=2)] = field(
        what="two positive numbers [x, y]",
        missing="[basin]: missing 'span' (half-widths about the fixed point in the coordinates' own units, e.g. span = [0.03, 0.03])")
    points: Annotated[list[int], Field(min_length=2, max_length=2)] = field([101, 101], "two integers [x, y]")
    steps: int = field(DEFAULTS["steps"], "a positive integer", ge=1)
    tol: float = field(DEFAULTS["tol"], "a positive number (scaled section norm)", gt=0, allow_inf_nan=False)
    scale: list[_Positive] | None = field(None, "positive numbers")


TOP_LEVEL_KEYS = Document.keys()
BASIN_KEYS = Basin.keys()


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
        source, text: the file and its TOML text (the dataset keeps both, beside
            the resolved config, :meth:`to_json`).
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

    def to_dict(self) -> dict[str, Any]:
        """The resolved config, itself a valid config (TOML/JSON-ready): every parameter,
        the coordinates by name, every ``[basin]`` key with its value in force."""
        from jaxwalk.models import get_model

        names = get_model(self.model).section_names
        basin = {"x": names[self.x], "y": names[self.y], "span": list(self.span), "points": list(self.points),
                 "steps": self.steps, "tol": self.tol, "scale": list(self.scale)}
        return {"name": self.name, "model": self.model, "params": dict(self.fixed), "basin": basin}

    def to_json(self) -> str:
        return json.dumps(self.to_dict())


def load_basin_config(path: str | Path) -> BasinConfig:
    """Read and check ``path``. Raises :class:`~jaxwalk.errors.ConfigError` (one line)."""
    text = read_config_text(path)
    return parse_basin_config(parse_toml(text, source=str(path)), source=str(path), text=text)


def parse_basin_config(data: Mapping[str, Any], *, source: str = "<config>", text: str | None = None) -> BasinConfig:
    """Check a parsed config and resolve it."""
    fail = failing(source)
    Document.check(data, fail)
    name = check_name(data, fail)
    model_name, model = model_of(data, fail, example="simplest")
    fixed = {p: float(spec.default) for p, spec in model.param_specs.items()}
    fixed.update(check_params(data.get("params", {}), model.param_specs, model_name, fail))
    if not isinstance(data.get("basin"), Mapping):
        raise fail("[basin] is missing (e.g. x = \"alpha_1\", y = \"alpha_1_dot\", span = [0.03, 0.03])")
    names = tuple(model.section_names)
    table = Basin.check(data["basin"], fail, names=", ".join(names))
    x, y = table.x or names[0], table.y or names[1]
    check_section({"coordinates": [x, y], "scale": table.scale}, model, fail, where="[basin]")
    if x == y:
        raise fail(f"[basin] x and y must be different section coordinates, both are '{x}'")
    if any(n < 2 for n in table.points) or table.points[0] * table.points[1] > MAX_STARTS:
        raise fail(f"[basin] points must be two integers >= 2 with at most {MAX_STARTS} starts in all, got {table.points}")
    return BasinConfig(name=name, model=model_name, fixed=fixed, x=names.index(x), y=names.index(y), span=tuple(table.span),
                       points=tuple(table.points), steps=table.steps, tol=table.tol,
                       scale=tuple(table.scale or [1.0] * len(names)), source=source, text=text)
