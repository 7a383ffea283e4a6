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
from pathlib import Path
from typing import Annotated, Any, ClassVar, Mapping

from pydantic import Field

import numpy as np

from jaxwalk.configs import Table, TopLevel, check_name, check_params, failing, field, model_of, parse_toml, read_config_text
from jaxwalk.walker import NEEDS, Walker, missing

#: Most steps one walk may take (the trajectory is held in memory).
MAX_STEPS = 1000
#: Allowed output sampling interval, in units of the model's time scale sqrt(L/g).
DT_RANGE = (1e-4, 1.0)
#: Default sampling interval, in time scales (rounded to one significant digit).
DEFAULT_DT_SCALES = 0.02
#: The table the command reads, as messages name it.
_WHERE = "[simulate]"


class Document(TopLevel):
    """A simulation file's top level."""

    sections_named: ClassVar[bool] = True

    simulate: dict[str, Any] = field({}, "the walk")


class Simulate(Table):
    """``[simulate]``; ranges that depend on the model (``dt``, ``drop``) are checked after.

    The command line's ``--steps`` and ``--drop`` are checked as these keys
    (:func:`parse_simulate_config`), their messages naming the option.
    """

    where: ClassVar[str] = _WHERE
    must: ClassVar[str] = "{name} must be {what}, got {value!r}"

    #: Steps to walk (``--steps`` overrides it; one of the two is needed).
    steps: int | None = field(None, "a positive integer", ge=1, le=MAX_STEPS, messages={
        "less_than_equal": "{name} = {value} is more than the limit of %d steps" % MAX_STEPS})
    #: A vertical step-down of the ground at the first touchdown, model length units (``--drop`` overrides it).
    drop: float = field(0.0, "a number >= 0", ge=0, allow_inf_nan=False, message=(
        "{name} must be a number >= 0 (a vertical step-down at the first touchdown, in {length}), got {value!r}"))
    #: Output sampling interval, model time units (default: a fiftieth of the time scale sqrt(L/g)).
    dt: float | None = field(None, "the output sampling interval", allow_inf_nan=False, message="{dt_range}, got {value!r}")
    #: Start here (section coordinates) instead of at the periodic gait.
    v0: list[Annotated[float, Field(allow_inf_nan=False)]] | None = field(
        None, "the start", message="{where} v0 must be an array of {n_v} finite numbers ({names}), got {value!r}")


SIMULATE_KEYS = Simulate.keys()
TOP_LEVEL_KEYS = Document.keys()


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

    fail = failing(source)
    if not isinstance(data, Mapping):
        raise fail("a config must be a TOML table")
    if "grid" in data:
        raise fail("[grid] is for sweeps (jaxwalk sweep); a simulation runs one parameter set: put fixed values in [params]")
    Document.check(data, fail)
    name = check_name(data, fail)
    model_name, model = model_of(data, fail, example="kneed")
    specs = model.param_specs
    params = check_params(data.get("params", {}), specs, model_name, fail)
    fixed = {p: float(spec.default) for p, spec in specs.items()}
    fixed.update(params)
    scale = float(model.time_scale({k: np.float64(v) for k, v in fixed.items()}))
    names = model.section_names
    words = dict(length=model.units["length"], n_v=len(names), names=", ".join(names), dt_range=_dt_range(model, scale))
    table = Simulate.check(data.get("simulate", {}), fail, **words)
    # The command line's values, checked as the file's (the file's are checked even where overridden).
    override = {}
    for key, value in (("steps", steps), ("drop", drop)):
        if value is not None:
            override[key] = getattr(Simulate.check({key: value}, fail, name=f"--{key}", **words), key)
    if table.steps is None and "steps" not in override:
        raise fail("no step count: give --steps N or [simulate] steps = N")
    _capable(table.drop, model, f"{_WHERE} drop", fail)
    if "drop" in override:
        _capable(override["drop"], model, "--drop", fail)
    return SimulateConfig(
        name=name, model=model_name, params=params, fixed=fixed, steps=int(override.get("steps", table.steps)),
        drop=float(override.get("drop", table.drop)), dt=_dt(table.dt, model, scale, fail), v0=_v0(table.v0, model, fail),
        source=source, text=text,
    )


def _capable(h: float, model: Walker, what: str, fail) -> None:
    """A step-down ``h > 0`` needs the model's step-down capability (:data:`jaxwalk.walker.NEEDS`)."""
    reason = missing(model, NEEDS["drop"]) if h > 0 else None
    if reason:
        raise fail(f"{what}: model '{model.name}' {reason}")


def _dt_range(model: Walker, scale: float) -> str:
    """The message of a bad ``dt``, without the value: the interval in the model's time units."""
    lo, hi = DT_RANGE[0] * scale, DT_RANGE[1] * scale
    return (f"{_WHERE} dt (output sampling interval) must be a number from {lo:.3g} to {hi:.3g} "
            f"{_time_unit(model)} ({DT_RANGE[0]:g} to {DT_RANGE[1]:g} times the time scale sqrt(L/g) = {scale:.4g})")


def _dt(dt: float | None, model: Walker, scale: float, fail) -> float:
    """The sampling interval: within :data:`DT_RANGE` time scales (``scale``: the
    model's sqrt(L/g)); default :data:`DEFAULT_DT_SCALES` of them, to one significant digit."""
    if dt is None:
        return float(f"{DEFAULT_DT_SCALES * scale:.1g}")
    if not DT_RANGE[0] * scale <= dt <= DT_RANGE[1] * scale:
        raise fail(f"{_dt_range(model, scale)}, got {dt!r}")
    return float(dt)


def _v0(v0: list[float] | None, model: Walker, fail) -> tuple[float, ...] | None:
    """``[simulate] v0``: as many finite numbers as the model has section coordinates, or ``None``."""
    names = model.section_names
    if v0 is not None and len(v0) != len(names):
        raise fail(f"{_WHERE} v0 must be an array of {len(names)} finite numbers ({', '.join(names)}), got {v0!r}")
    return None if v0 is None else tuple(float(x) for x in v0)


def _time_unit(model: Walker) -> str:
    unit = model.units["time"]
    return "(model time units)" if unit == "1" else unit
