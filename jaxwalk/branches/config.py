"""The ``jaxwalk continue`` config: a model, fixed ``[params]`` and a ``[continuation]`` table.

Checked as the sweep's is (:mod:`jaxwalk.sweep.config`): every error is one
line, prefixed by the file, with a "did you mean" hint for a misspelt key.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any, Mapping

from jaxwalk.arclength import ArclengthOptions
from jaxwalk.sweep.config import (ConfigError, _did_you_mean, _kind, _name, _params, model_of, parse_toml,
                                  read_config_text)

TOP_LEVEL_KEYS = ("name", "model", "params", "continuation")
#: ``[continuation]`` keys with their defaults (None: required).
CONTINUATION_KEYS: dict[str, Any] = {
    "parameter": None, "start": None, "min": None, "max": None, "direction": 1, "period": 1,
    "ds": ArclengthOptions.ds, "ds_min": ArclengthOptions.ds_min, "ds_max": ArclengthOptions.ds_max,
    "max_steps": ArclengthOptions.max_steps, "switch_branches": False, "switch_eps": 1e-2,
    "switch_max_steps": ArclengthOptions.max_steps, "tol": 1e-6,
}
_INTEGERS = ("direction", "period", "max_steps", "switch_max_steps")


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
        source, text: the file and its text (kept in the dataset).
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


def load_continue_config(path: str | Path) -> ContinueConfig:
    """Read and check ``path``. Raises :class:`~jaxwalk.errors.ConfigError` (one line)."""
    text = read_config_text(path)
    return parse_continue_config(parse_toml(text, source=str(path)), source=str(path), text=text)


def parse_continue_config(data: Mapping[str, Any], *, source: str = "<config>", text: str | None = None) -> ContinueConfig:
    """Check a parsed config and resolve it."""

    def fail(message: str) -> ConfigError:
        return ConfigError(f"{source}: {message}")

    for key in data:
        if key not in TOP_LEVEL_KEYS:
            raise fail(f"unknown top-level key '{key}'{_did_you_mean(key, TOP_LEVEL_KEYS)} (allowed: {', '.join(TOP_LEVEL_KEYS)})")
    name = _name(data, fail)
    model_name, model = model_of(data, fail, example="simplest")
    specs = model.param_specs
    if not isinstance(data.get("params", {}), Mapping):
        raise fail(f"'params' must be a table ([params]), got {_kind(data['params'])}")
    params = _params(data.get("params", {}), specs, model_name, fail)
    table = data.get("continuation")
    if not isinstance(table, Mapping):
        raise fail("[continuation] is missing (e.g. parameter = \"gamma\", start = 0.010, min = 0.009, max = 0.026)")
    values = _continuation_values(table, fail)
    parameter = values["parameter"]
    if parameter not in specs:
        raise fail(f"[continuation] parameter: unknown parameter '{parameter}' for model '{model_name}'"
                   f"{_did_you_mean(str(parameter), specs)} (known: {', '.join(specs)})")
    starts = values["start"] if isinstance(values["start"], list) else [values["start"]]
    lo, hi = float(values["min"]), float(values["max"])
    if not lo < hi:
        raise fail(f"[continuation] needs min < max, got min = {lo}, max = {hi}")
    for s in starts:
        _check_number(s, "start", fail)
        if not lo <= s <= hi:
            raise fail(f"[continuation] start {s} is outside [min, max] = [{lo}, {hi}]")
        try:
            specs[parameter].check(s)
        except ValueError as err:
            raise fail(f"[continuation] start: {err}") from None
    if values["direction"] not in (1, -1):
        raise fail(f"[continuation] direction must be 1 or -1, got {values['direction']}")
    if values["period"] < 1:
        raise fail(f"[continuation] period must be >= 1, got {values['period']}")
    try:
        options = ArclengthOptions(ds=float(values["ds"]), ds_min=float(values["ds_min"]), ds_max=float(values["ds_max"]),
                                   max_steps=int(values["max_steps"]))
    except ValueError as err:
        raise fail(f"[continuation] {err}") from None
    fixed = {p: float(spec.default) for p, spec in specs.items()}
    fixed.update(params)
    fixed[parameter] = float(starts[0])
    return ContinueConfig(
        name=name, model=model_name, fixed=fixed, parameter=parameter, starts=tuple(float(s) for s in starts),
        bounds=(lo, hi), direction=int(values["direction"]), period=int(values["period"]), options=options,
        switch_branches=bool(values["switch_branches"]), switch_eps=float(values["switch_eps"]),
        switch_max_steps=int(values["switch_max_steps"]), tol=float(values["tol"]), source=source, text=text,
    )


def _continuation_values(table: Mapping[str, Any], fail) -> dict[str, Any]:
    """``[continuation]`` with defaults filled in, each value's type checked."""
    out = {}
    for key in table:
        if key not in CONTINUATION_KEYS:
            raise fail(f"[continuation]: unknown key '{key}'{_did_you_mean(key, CONTINUATION_KEYS)} (allowed: {', '.join(CONTINUATION_KEYS)})")
    for key, default in CONTINUATION_KEYS.items():
        value = table.get(key, default)
        if value is None:
            raise fail(f"[continuation]: missing '{key}'")
        if key == "parameter" and not isinstance(value, str):
            raise fail(f"[continuation] parameter must be a string, got {_kind(value)}")
        elif key == "switch_branches" and not isinstance(value, bool):
            raise fail(f"[continuation] switch_branches must be true or false, got {_kind(value)}")
        elif key in _INTEGERS and (isinstance(value, bool) or not isinstance(value, int)):
            raise fail(f"[continuation] {key} must be an integer, got {_kind(value)}")
        elif key == "start" and isinstance(value, list):
            if not value:
                raise fail("[continuation] start must be a number or a non-empty array of numbers")
        elif key not in ("parameter", "switch_branches", *_INTEGERS):
            _check_number(value, key, fail)
        out[key] = value
    return out


def _check_number(value, key: str, fail) -> None:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise fail(f"[continuation] {key} must be a number, got {_kind(value)}")
