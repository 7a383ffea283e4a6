"""The ``jaxwalk continue`` config: a model, fixed ``[params]`` and a ``[continuation]`` table.

The tables' shapes are declared below (:class:`~jaxwalk.configs.Table`); the
parameter, its bounds and the arclength options are then checked against the
model. Every error is one line, prefixed by the file, with a "did you mean"
hint for a misspelt key.
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path
from typing import Annotated, Any, ClassVar, Mapping

from pydantic import Field

from jaxwalk.arclength import ArclengthOptions
from jaxwalk.configs import (Table, TopLevel, check_name, check_params, failing, field, model_of, parse_toml,
                             read_config_text, unknown_param)


class Document(TopLevel):
    """The file's top level."""

    continuation: Any = None


#: Most points a branch may have (its arrays are allocated at that size before it runs).
MAX_POINTS = 10_000
_FINITE = dict(allow_inf_nan=False, message="{where} {key} must be {what}, got {value!r}")
_POSITIVE = dict(gt=0, **_FINITE)
_POINTS = dict(ge=1, le=MAX_POINTS, message="{where} {key} must be {what}, got {value!r}")


class Continuation(Table):
    """``[continuation]``: the parameter, its range and starts, the arclength steps, branch switching."""

    where: ClassVar[str] = "[continuation]"
    must: ClassVar[str] = "{where} {key} must be {what}, got {kind}"

    parameter: str = field(what="a string")
    start: float | Annotated[list[float], Field(min_length=1)] = field(
        what="a number", message="{where} start must be a number or a non-empty array of numbers, got {kind}")
    min: float = field(what="a finite number", **_FINITE)
    max: float = field(what="a finite number", **_FINITE)
    direction: int = field(1, "an integer")
    period: int = field(1, "an integer")
    ds: float = field(ArclengthOptions.ds, "a finite number", **_FINITE)
    ds_min: float = field(ArclengthOptions.ds_min, "a finite number", **_FINITE)
    ds_max: float = field(ArclengthOptions.ds_max, "a finite number", **_FINITE)
    max_steps: int = field(ArclengthOptions.max_steps, f"an integer from 1 to {MAX_POINTS}", **_POINTS)
    switch_branches: bool = field(False, "true or false")
    switch_eps: float = field(1e-2, "a finite number > 0 (the first step off a flip, section units)", **_POSITIVE)
    switch_max_steps: int = field(ArclengthOptions.max_steps, f"an integer from 1 to {MAX_POINTS}", **_POINTS)
    tol: float = field(1e-6, "a finite number > 0", **_POSITIVE)


TOP_LEVEL_KEYS = Document.keys()
CONTINUATION_KEYS = Continuation.keys()


@dataclasses.dataclass(frozen=True, eq=False)
class ContinueConfig:
    """A checked continuation run.

    Attributes:
        name, model: the dataset's name, the model's registered name.
        fixed: every model parameter's value (``[params]`` over the defaults); the
            continuation parameter's entry is its first start.
        parameter: the continuation parameter.
        starts: the start values of ``parameter``, one branch each (from the model's initial guess there).
        bounds: ``(min, max)`` of the parameter.
        direction: +1 / -1: the branches start towards increasing / decreasing ``parameter``.
        period: k of the branches' map.
        options: the continuation's :class:`~jaxwalk.arclength.ArclengthOptions`.
        switch_branches, switch_eps, switch_max_steps: at each located flip, continue the
            period-2k branch from ``eps`` along its eigenvector, for at most this many points.
        tol: location accuracy of the labelled points (arclength, so parameter units at most).
        source, text: the file and its TOML text (the dataset keeps both, beside
            the resolved config, :meth:`to_json`).
    """

    name: str
    model: str
    fixed: dict[str, float]
    parameter: str
    starts: tuple[float, ...]
    bounds: tuple[float, float]
    direction: int
    period: int
    options: ArclengthOptions
    switch_branches: bool
    switch_eps: float
    switch_max_steps: int
    tol: float
    source: str
    text: str | None

    def to_dict(self) -> dict[str, Any]:
        """The resolved config, itself a valid config (TOML/JSON-ready): every fixed
        parameter, every ``[continuation]`` key with its value in force."""
        o = self.options
        lo, hi = self.bounds
        table = {"parameter": self.parameter, "start": list(self.starts), "min": lo, "max": hi,
                 "direction": self.direction, "period": self.period, "ds": o.ds, "ds_min": o.ds_min, "ds_max": o.ds_max,
                 "max_steps": o.max_steps, "switch_branches": self.switch_branches, "switch_eps": self.switch_eps,
                 "switch_max_steps": self.switch_max_steps, "tol": self.tol}
        params = {k: v for k, v in self.fixed.items() if k != self.parameter}  # its values are the starts
        return {"name": self.name, "model": self.model, "params": params, "continuation": table}

    def to_json(self) -> str:
        return json.dumps(self.to_dict())


def load_continue_config(path: str | Path) -> ContinueConfig:
    """Read and check ``path``. Raises :class:`~jaxwalk.errors.ConfigError` (one line)."""
    text = read_config_text(path)
    return parse_continue_config(parse_toml(text, source=str(path)), source=str(path), text=text)


def parse_continue_config(data: Mapping[str, Any], *, source: str = "<config>", text: str | None = None) -> ContinueConfig:
    """Check a parsed config and resolve it."""
    fail = failing(source)
    Document.check(data, fail)
    name = check_name(data, fail)
    model_name, model = model_of(data, fail, example="simplest")
    specs = model.param_specs
    params = check_params(data.get("params", {}), specs, model_name, fail)
    if "continuation" in data and not isinstance(data["continuation"], Mapping):
        raise fail(f"'continuation' must be a table ([continuation]), got {data['continuation']!r}")
    if not isinstance(data.get("continuation"), Mapping):
        raise fail("[continuation] is missing (e.g. parameter = \"gamma\", start = 0.010, min = 0.009, max = 0.026)")
    table = Continuation.check(data["continuation"], fail)
    if table.parameter not in specs:
        raise fail(f"[continuation] parameter: {unknown_param(table.parameter, specs, model_name)}")
    if table.parameter in params:
        raise fail(f"parameter '{table.parameter}' is both fixed in [params] and continued in [continuation]; remove one")
    starts = table.start if isinstance(table.start, list) else [table.start]
    lo, hi = table.min, table.max
    if not lo < hi:
        raise fail(f"[continuation] needs min < max, got min = {lo}, max = {hi}")
    for key, bound in (("min", lo), ("max", hi)):
        try:
            specs[table.parameter].check(bound)
        except ValueError as err:
            raise fail(f"[continuation] {key}: {err}") from None
    for s in starts:
        if not lo <= s <= hi:
            raise fail(f"[continuation] start {s} is outside [min, max] = [{lo}, {hi}]")
        try:
            specs[table.parameter].check(s)
        except ValueError as err:
            raise fail(f"[continuation] start: {err}") from None
    if table.direction not in (1, -1):
        raise fail(f"[continuation] direction must be 1 or -1, got {table.direction}")
    if table.period < 1:
        raise fail(f"[continuation] period must be >= 1, got {table.period}")
    try:
        options = ArclengthOptions(ds=table.ds, ds_min=table.ds_min, ds_max=table.ds_max, max_steps=table.max_steps)
    except ValueError as err:
        raise fail(f"[continuation] {err}") from None
    fixed = {p: float(spec.default) for p, spec in specs.items()}
    fixed.update(params)
    fixed[table.parameter] = float(starts[0])
    return ContinueConfig(
        name=name, model=model_name, fixed=fixed, parameter=table.parameter, starts=tuple(starts),
        bounds=(lo, hi), direction=table.direction, period=table.period, options=options,
        switch_branches=table.switch_branches, switch_eps=table.switch_eps,
        switch_max_steps=table.switch_max_steps, tol=table.tol, source=source, text=text,
    )
