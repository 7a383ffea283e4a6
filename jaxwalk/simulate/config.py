"""The config of ``jaxwalk simulate``: read, check and resolve it.

The TOML shape of a sweep without ``[grid]``, plus an optional ``[simulate]``
table::

    name = "kneed_walk"
    model = "kneed"
    [params]
    [simulate]
    steps = 4          # or --steps N
    drop = 0.0         # step-down at the first touchdown (model length units, vertical); or --drop H
    dt = 0.005         # output sampling interval (model time units)
    # v0 = [0.2385, -1.1095, -0.0577]   # start here (section coordinates) instead of the gait
"""

from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path
from typing import Any, Mapping

import numpy as np

from jaxwalk.sweep.config import (
    ConfigError,
    _did_you_mean,
    _kind,
    _name,
    _params,
    model_of,
    parse_toml,
    read_config_text,
)
from jaxwalk.walker import NEEDS, Walker, missing

SIMULATE_KEYS = ("steps", "drop", "dt", "v0")
TOP_LEVEL_KEYS = ("name", "model", "params", "simulate")
#: Most steps one walk may take (the trajectory is held in memory).
MAX_STEPS = 1000
#: Allowed output sampling interval, in units of the model's time scale sqrt(L/g).
DT_RANGE = (1e-4, 1.0)
#: Default sampling interval, in time scales (rounded to one significant digit).
DEFAULT_DT_SCALES = 0.02


@dataclasses.dataclass(frozen=True, eq=False)
class SimulateConfig:
    """A checked, resolved simulation.

    Attributes:
        name: output name (``<name>_trajectory.zarr``, ``<name>_stick.png``, ...).
        model: registry name of the model.
        params: the ``[params]`` table as written (floats).
        fixed: every parameter: the model's defaults updated by ``params``.
        steps: steps to take.
        drop: step-down at the first touchdown (model length units, vertical; 0 for none).
        dt: output sampling interval (model time units).
        v0: start from these section coordinates, or ``None`` for the periodic gait.
        source, text: where the config came from, and its TOML source.
    """

    name: str
    model: str
    params: dict[str, float]
    fixed: dict[str, float]
    steps: int
    drop: float = 0.0
    dt: float = 0.01
    v0: tuple[float, ...] | None = None
    source: str = "<config>"
    text: str | None = None

    def to_dict(self) -> dict[str, Any]:
        """The resolved config, itself a valid config (TOML/JSON-ready)."""
        sim: dict[str, Any] = {"steps": self.steps, "drop": self.drop, "dt": self.dt}
        if self.v0 is not None:
            sim["v0"] = list(self.v0)
        return {"name": self.name, "model": self.model, "params": dict(self.fixed), "simulate": sim}

    def to_json(self) -> str:
        return json.dumps(self.to_dict())


def load_simulate_config(path: str | Path, *, steps: int | None = None, drop: float | None = None) -> SimulateConfig:
    """Read and check the TOML config at ``path``; ``steps``/``drop`` (the command
    line's ``--steps``/``--drop``) override ``[simulate]``. Raises :class:`ConfigError`."""
    text = read_config_text(path)
    return loads_simulate_config(text, source=str(path), steps=steps, drop=drop)


def loads_simulate_config(
    text: str, *, source: str = "<config>", steps: int | None = None, drop: float | None = None
) -> SimulateConfig:
    """Parse and check a config from TOML text. Raises :class:`ConfigError`."""
    return parse_simulate_config(parse_toml(text, source=source), source=source, text=text, steps=steps, drop=drop)


def parse_simulate_config(
    data: Mapping[str, Any],
    *,
    source: str = "<config>",
    text: str | None = None,
    steps: int | None = None,
    drop: float | None = None,
) -> SimulateConfig:
    """Check a config given as a mapping and resolve it (``steps``/``drop`` override
    ``[simulate]``). Raises :class:`ConfigError` with a one-line message."""

    def fail(message: str) -> ConfigError:
        return ConfigError(f"{source}: {message}")

    _check_layout(data, fail)
    name = _name(data, fail)
    model_name, model = model_of(data, fail, example="kneed")
    specs = model.param_specs
    params = _params(data.get("params", {}), specs, model_name, fail)
    fixed = {p: float(spec.default) for p, spec in specs.items()}
    fixed.update(params)

    table = data.get("simulate", {})
    for key in table:
        if key not in SIMULATE_KEYS:
            raise fail(f"{_WHERE}: unknown key '{key}'{_did_you_mean(key, SIMULATE_KEYS)} (allowed: {', '.join(SIMULATE_KEYS)})")
    return SimulateConfig(
        name=name, model=model_name, params=params, fixed=fixed, steps=_steps(table, steps, fail),
        drop=_drop(table, drop, model, fail), dt=_dt(table, model, fixed, fail), v0=_v0(table, model, fail),
        source=source, text=text,
    )


#: The table the command reads, as messages name it.
_WHERE = "[simulate]"


def _check_layout(data, fail) -> None:
    """A TOML table of the known top-level keys, ``[params]`` and ``[simulate]`` tables."""
    if not isinstance(data, Mapping):
        raise fail("a config must be a TOML table")
    for key in data:
        if key == "grid":
            raise fail("[grid] is for sweeps (jaxwalk sweep); a simulation runs one parameter set: put fixed values in [params]")
        if key not in TOP_LEVEL_KEYS:
            kind = "section" if isinstance(data[key], Mapping) else "key"
            raise fail(f"unknown top-level {kind} '{key}'{_did_you_mean(key, TOP_LEVEL_KEYS)} (allowed: {', '.join(TOP_LEVEL_KEYS)})")
    for key in ("params", "simulate"):
        if key in data and not isinstance(data[key], Mapping):
            raise fail(f"'{key}' must be a table ([{key}]), got {_kind(data[key])}")


def _steps(table, override: int | None, fail) -> int:
    """The step count: ``--steps`` over ``[simulate] steps``; the file's value is
    checked even where the command line overrides it."""

    def check(n, what):
        if isinstance(n, bool) or not isinstance(n, int) or n < 1:
            raise fail(f"{what} must be a positive integer, got {n!r}")
        if n > MAX_STEPS:
            raise fail(f"{what} = {n} is more than the limit of {MAX_STEPS} steps")
        return n

    n = check(table["steps"], f"{_WHERE} steps") if "steps" in table else None
    if override is not None:
        n = check(override, "--steps")
    if n is None:
        raise fail("no step count: give --steps N or [simulate] steps = N")
    return int(n)


def _drop(table, override: float | None, model: Walker, fail) -> float:
    """The step-down at the first touchdown: ``--drop`` over ``[simulate] drop`` (both checked)."""

    def check(h, what):
        if isinstance(h, bool) or not isinstance(h, (int, float)) or not math.isfinite(h) or h < 0:
            raise fail(f"{what} must be a number >= 0 (a vertical step-down at the first touchdown, in {model.units['length']}), got {h!r}")
        reason = missing(model, NEEDS["drop"]) if h > 0 else None
        if reason:
            raise fail(f"{what}: model '{model.name}' {reason}")
        return h

    h = check(table.get("drop", 0.0), f"{_WHERE} drop")
    if override is not None:
        h = check(override, "--drop")
    return float(h)


def _dt(table, model: Walker, fixed: Mapping[str, float], fail) -> float:
    """The sampling interval: within :data:`DT_RANGE` time scales; default
    :data:`DEFAULT_DT_SCALES` of them, to one significant digit."""
    scale = float(model.time_scale({k: np.float64(v) for k, v in fixed.items()}))
    lo, hi = DT_RANGE[0] * scale, DT_RANGE[1] * scale
    if "dt" not in table:
        return float(f"{DEFAULT_DT_SCALES * scale:.1g}")
    dt = table["dt"]
    if isinstance(dt, bool) or not isinstance(dt, (int, float)) or not math.isfinite(dt) or not (lo <= dt <= hi):
        raise fail(
            f"{_WHERE} dt (output sampling interval) must be a number from {lo:.3g} to {hi:.3g} "
            f"{_time_unit(model)} ({DT_RANGE[0]:g} to {DT_RANGE[1]:g} times the time scale sqrt(L/g) = {scale:.4g}), got {dt!r}"
        )
    return float(dt)


def _v0(table, model: Walker, fail) -> tuple[float, ...] | None:
    """``[simulate] v0``: as many finite numbers as the model has section coordinates, or ``None``."""
    if "v0" not in table:
        return None
    v0 = table["v0"]
    names = model.section_names
    ok = isinstance(v0, list) and len(v0) == len(names) and all(
        not isinstance(x, bool) and isinstance(x, (int, float)) and math.isfinite(x) for x in v0
    )
    if not ok:
        raise fail(f"{_WHERE} v0 must be an array of {len(names)} finite numbers ({', '.join(names)}), got {v0!r}")
    return tuple(float(x) for x in v0)


def _time_unit(model: Walker) -> str:
    unit = model.units["time"]
    return "(model time units)" if unit == "1" else unit
