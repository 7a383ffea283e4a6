"""Sweep configs: read a TOML file, check it against its model, resolve the grid.

A config names a model, fixes some of its parameters and sweeps others over a
Cartesian grid (see ``docs/sweeps.md``)::

    name = "slope_scan"
    model = "simplest"
    [params]
    [grid]
    gamma = { start = 0.002, stop = 0.015, num = 64 }   # or { values = [...] }
    [analysis]
    stability = true
    continuation = "gamma"
    h_max = { step = 0.0005, count = 40, steps = 10 }   # global stability; optional

Everything is checked here, before anything is computed or written: every
problem is a :class:`ConfigError` whose message is one line naming the file,
the section and the key at fault.
"""

from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path
from typing import Any, ClassVar, Mapping

import numpy as np

from jaxwalk import analyses
from jaxwalk.analyses import did_you_mean as _did_you_mean
from jaxwalk.configs import Axis, Solver, Table, TopLevel, check_axis, check_name, check_params, failing, field, human_bytes, model_of
from jaxwalk.configs import parse_toml as parse_toml, read_config_text as read_config_text  # the sweep API's names
from jaxwalk.errors import ConfigError as ConfigError  # the error root, re-exported where it was
from jaxwalk.parameters import ParamSpec
from jaxwalk.walker import check_supported

#: Largest grid accepted by default (points); callers may pass their own ``max_points``.
DEFAULT_MAX_POINTS = 10_000_000

#: Keys of a ``[grid]`` axis (:class:`jaxwalk.configs.Axis`).
AXIS_KEYS = Axis.keys()


class Gait(Table):
    """The gait's keys of ``[analysis]``."""

    where: ClassVar[str] = "[analysis]"

    stability: bool = field(True, "true or false")
    continuation: bool | str = field(True, "a grid axis name or false")
    seed_axis: bool | str = field(False, "a grid axis name or false")
    gait_guess: bool | list[Any] = field(False, "a list of the model's section coordinates, or false")
    gait_guess_at: dict[str, Any] = field({}, "a table {grid axis = value} of where the guessed gait is")


#: Solver settings passed through to the analysis when set (absent: its defaults).
SOLVER_KEYS = Solver.keys()
#: ``[analysis]`` keys: the gait's, the plug-ins' (:mod:`jaxwalk.analyses`), the solver's.
ANALYSIS_KEYS = (*Gait.keys(), *analyses.keys(), *SOLVER_KEYS)


class Document(TopLevel):
    """A sweep file's top level."""

    sections_named: ClassVar[bool] = True

    grid: dict[str, Any] = field({}, "the swept parameters")
    analysis: dict[str, Any] = field({}, "what to compute")


TOP_LEVEL_KEYS = Document.keys()


@dataclasses.dataclass(frozen=True)
class GridAxis:
    """One swept parameter.

    Attributes:
        name: the parameter.
        values: ``(num,)`` float64, read-only, in sweep order.
        spec: the axis as written, numbers as floats: ``{"start", "stop", "num"}``
            or ``{"values"}``.
    """

    name: str
    values: np.ndarray
    spec: dict[str, Any]


@dataclasses.dataclass(frozen=True, eq=False)
class SweepConfig:
    """A checked, resolved sweep.

    Attributes:
        name: dataset name (also its file name, ``<name>.zarr``).
        model: registry name of the model.
        params: the ``[params]`` table as written (floats).
        fixed: every parameter that is not swept: the model's defaults updated by ``params``.
        axes: the swept parameters, in the order written; the grid is their Cartesian product.
        stability: whether to compute the Jacobian, its eigenvalues and ``lambda_max``.
        continuation: the axis along which Newton warm-starts from its converged
            neighbour, or ``None`` for independent points.
        seed_axis: another axis along which seed lines give every continuation
            line its start (:mod:`jaxwalk.seedline`), or ``None`` (each line
            starts from the model's initial guess).
        gait_guess: with continuation, Newton's first start at the lines' (or the
            seed lines') seed points, ``(n_v,)`` section coordinates, in place of
            the model's initial guess; ``None``: the model's.
        gait_guess_at: ``{axis: value}``, where the guessed gait is: lines along
            a named axis start at its grid value nearest there (else where the
            model's guess was made, :meth:`jaxwalk.walker.Walker.seed_value`).
        solver: the solver settings of ``[analysis]`` that were given.
        analyses: the resolved settings of the analyses beside the gait that are
            on, by name (:mod:`jaxwalk.analyses`); each is also an attribute,
            its ``off`` value when it is off: ``config.h_max`` (the step-down
            test, ``{"step": float, "count": int, "steps": int}`` or ``None``),
            ``config.attractors`` (``{"max_period": int, "steps": int}`` or
            ``None``), ``config.global_stability`` (the resolved
            ``gait_sensitivity`` and ``mfpt`` that are set, ``{}`` when neither
            is), ``config.bifurcations`` (bool), ...
        source: where the config came from (a path, or a label).
        text: the TOML source, when read from text.
    """

    name: str
    model: str
    params: dict[str, float]
    fixed: dict[str, float]
    axes: tuple[GridAxis, ...]
    stability: bool = True
    continuation: str | None = None
    seed_axis: str | None = None
    gait_guess: tuple[float, ...] | None = None
    gait_guess_at: dict[str, float] = dataclasses.field(default_factory=dict)
    solver: dict[str, float | int] = dataclasses.field(default_factory=dict)
    analyses: dict[str, Any] = dataclasses.field(default_factory=dict)
    source: str = "<config>"
    text: str | None = None

    def __getattr__(self, name: str) -> Any:
        # Only reached for names that are not fields: an analysis's setting by its name.
        if name.startswith("_"):
            raise AttributeError(name)
        for analysis in analyses.plugins():
            if analysis.name == name:
                return self.__dict__.get("analyses", {}).get(name, analysis.off)
        raise AttributeError(f"'SweepConfig' has no attribute '{name}'")

    @property
    def dims(self) -> tuple[str, ...]:
        return tuple(a.name for a in self.axes)

    @property
    def grid(self) -> dict[str, np.ndarray]:
        """Swept values by parameter, in grid order."""
        return {a.name: a.values for a in self.axes}

    @property
    def shape(self) -> tuple[int, ...]:
        return tuple(len(a.values) for a in self.axes)

    @property
    def n_points(self) -> int:
        return math.prod(self.shape)

    def to_dict(self) -> dict[str, Any]:
        """The resolved config, itself a valid config (TOML/JSON-ready).

        ``params`` holds every fixed value, defaults included; ``continuation`` is
        the axis used, or ``False``; ``seed_axis``, ``gait_guess`` and
        ``gait_guess_at`` appear only when set (so configs without them keep
        their fingerprint); then each analysis's
        entries (:meth:`jaxwalk.analyses.base.Analysis.to_dict`: ``h_max`` the
        step-down settings with their defaults, or ``False``; the others only when on).
        """
        entries = {}
        for analysis in analyses.plugins():
            entries.update(analysis.to_dict(self.analyses.get(analysis.name, analysis.off)))
        return {
            "name": self.name,
            "model": self.model,
            "params": dict(self.fixed),
            "grid": {a.name: dict(a.spec) for a in self.axes},
            "analysis": {
                "stability": self.stability,
                "continuation": self.continuation if self.continuation is not None else False,
                **({"seed_axis": self.seed_axis} if self.seed_axis is not None else {}),
                **({"gait_guess": list(self.gait_guess)} if self.gait_guess is not None else {}),
                **({"gait_guess_at": dict(self.gait_guess_at)} if self.gait_guess_at else {}),
                **entries,
                **self.solver,
            },
        }

    def to_json(self) -> str:
        return json.dumps(self.to_dict())


# ---------------------------------------------------------------- loading


def load_config(path: str | Path, *, max_points: int = DEFAULT_MAX_POINTS) -> SweepConfig:
    """Read and check the TOML config at ``path``. Raises :class:`ConfigError`."""
    return loads_config(read_config_text(path), source=str(path), max_points=max_points)


def loads_config(text: str, *, source: str = "<config>", max_points: int = DEFAULT_MAX_POINTS) -> SweepConfig:
    """Parse and check a config from TOML text. Raises :class:`ConfigError`."""
    return parse_config(parse_toml(text, source=source), source=source, text=text, max_points=max_points)


def parse_config(
    data: Mapping[str, Any],
    *,
    source: str = "<config>",
    text: str | None = None,
    max_points: int = DEFAULT_MAX_POINTS,
) -> SweepConfig:
    """Check a config given as a mapping (parsed TOML) and resolve it.

    Raises:
        ConfigError: with a one-line message prefixed by ``source``.
    """

    fail = failing(source)
    if not isinstance(data, Mapping):
        raise fail("a config must be a TOML table")
    # Configs of the other commands, named by their own section.
    for key, command in (("continuation", "jaxwalk continue"), ("optimize", "jaxwalk optimize")):
        if isinstance(data.get(key), Mapping):
            raise fail(f"a [{key}] section makes this a '{command}' config, not a sweep: run {command} {source}")
    Document.check(data, fail)
    name = check_name(data, fail)
    model_name, model = model_of(data, fail, example="simplest")
    specs: dict[str, ParamSpec] = model.param_specs

    params = check_params(data.get("params", {}), specs, model_name, fail)
    axes_raw = data.get("grid")
    if not axes_raw:
        raise fail("[grid] is missing or empty: sweep at least one parameter (e.g. gamma = { start = 0.002, stop = 0.015, num = 64 })")
    axis_specs = {
        axis: check_axis("[grid]", axis, spec, specs, params, model_name, fail) for axis, spec in axes_raw.items()
    }
    table = data.get("analysis", {})
    gait, continuation, seed_axis, solver = _analysis(table, list(axis_specs), fail)
    axes = tuple(grid_axis(axis, spec) for axis, spec in axis_specs.items())
    guess, guess_at = _gait_guess(gait, continuation, seed_axis, len(model.section_names), axes, fail)
    settings = _analyses(table, continuation, model, fail)
    check_supported(model, _requested(settings), fail)  # the capabilities they need (jaxwalk.walker)
    _check_size(axis_specs, len(model.section_names), max_points, fail, settings)

    fixed = {p: spec.default for p, spec in specs.items() if p not in axis_specs}
    fixed.update(params)
    return SweepConfig(
        name=name,
        model=model_name,
        params=params,
        fixed={p: float(v) for p, v in fixed.items()},
        axes=axes,
        stability=gait.stability,
        continuation=continuation,
        seed_axis=seed_axis,
        gait_guess=guess,
        gait_guess_at=guess_at,
        solver=solver,
        analyses=settings,
        source=source,
        text=text,
    )


# ---------------------------------------------------------------- sections


def grid_axis(name: str, spec: dict[str, Any]) -> GridAxis:
    """The axis of a checked spec (:func:`jaxwalk.configs.check_axis`): its values, read-only float64."""
    if "values" in spec:
        values = np.asarray(spec["values"], dtype=np.float64)
    else:
        values = np.linspace(spec["start"], spec["stop"], spec["num"], dtype=np.float64)
    values.setflags(write=False)
    return GridAxis(name, values, spec)


def _check_size(axis_specs, n_v, max_points, fail, settings: Mapping[str, Any]) -> None:
    lengths = [len(s["values"]) if "values" in s else s["num"] for s in axis_specs.values()]
    n = math.prod(lengths)
    if n > max_points:
        shape = " x ".join(str(k) for k in lengths)
        raise fail(
            f"[grid] has {n:,} points ({shape}), more than the limit of {max_points:,}; "
            f"its results alone would take about {human_bytes(n * result_bytes_per_point(n_v, settings))} "
            "(shrink the grid or raise the limit, --max-points)"
        )


def _analysis(table, names, fail) -> tuple[Gait, str | None, str | None, dict[str, float | int]]:
    # [analysis] is shared: the gait's, the solver's and every plug-in's Table
    # each pick their own keys from it (Table.pick ignores the others), so a key
    # that none of them declares is refused here, against their union.
    for key in table:
        if key not in ANALYSIS_KEYS:
            raise fail(f"[analysis]: unknown key '{key}'{_did_you_mean(key, ANALYSIS_KEYS)} (allowed: {', '.join(ANALYSIS_KEYS)})")
    gait = Gait.pick(table, fail)
    continuation = gait.continuation
    if continuation is True:
        continuation = names[0]
    elif continuation is False:
        continuation = None
    elif continuation not in names:
        raise fail(f"[analysis]: continuation = '{continuation}' is not a grid axis (axes: {', '.join(names)})")
    seed_axis = _seed_axis(gait.seed_axis, continuation, names, fail)
    return gait, continuation, seed_axis, Solver.settings(table, fail)


def _gait_guess(gait: Gait, continuation, seed_axis, n_v: int, axes, fail) -> tuple[tuple[float, ...] | None, dict[str, float]]:
    """``[analysis] gait_guess`` (``n_v`` finite numbers, or false) and ``gait_guess_at``
    (grid axes the lines follow, each to a finite number within the axis's range);
    both need continuation."""
    where = "[analysis]"
    if gait.gait_guess is False:
        if gait.gait_guess_at:
            raise fail(f"{where}: gait_guess_at needs gait_guess (the section point whose gait it places)")
        return None, {}
    if gait.gait_guess is True:  # the shape allows a boolean; only false means something
        raise fail(f"{where}: gait_guess must be a list of {n_v} numbers (the model's section coordinates) or false, got true")
    values = gait.gait_guess
    if len(values) != n_v or not all(_finite(x) for x in values):
        raise fail(f"{where}: gait_guess must be {n_v} finite numbers (the model's section coordinates), got {values!r}")
    if continuation is None:
        raise fail(f"{where}: gait_guess needs continuation (the lines start from it; continuation is off)")
    lines = [continuation] + ([seed_axis] if seed_axis is not None else [])
    for axis, value in gait.gait_guess_at.items():
        if axis not in lines:
            raise fail(f"{where}: gait_guess_at names '{axis}', which no line follows "
                       f"(lines follow {' and '.join(repr(a) for a in lines)})")
        if not _finite(value):
            raise fail(f"{where}: gait_guess_at {axis} must be a finite number, got {value!r}")
        grid = next(a.values for a in axes if a.name == axis)
        if not grid.min() <= value <= grid.max():
            raise fail(f"{where}: gait_guess_at {axis} = {value!r} is outside the grid's {axis} "
                       f"[{grid.min():g}, {grid.max():g}] (the lines would start at its end, not at that gait)")
    return tuple(float(x) for x in values), {a: float(v) for a, v in gait.gait_guess_at.items()}


def _finite(value) -> bool:
    return not isinstance(value, bool) and isinstance(value, (int, float)) and math.isfinite(value)


def _analyses(table, continuation, model, fail) -> dict[str, Any]:
    """The resolved settings of the plug-ins that are on (:mod:`jaxwalk.analyses`), each checked against the model."""
    out = {}
    for analysis in analyses.plugins():
        resolved = analysis.parse(table, fail, continuation=continuation)
        if resolved != analysis.off:
            analysis.check_model(resolved, model, fail)
            out[analysis.name] = analysis.for_model(resolved, model)
    return out


def _requested(settings: Mapping[str, Any]) -> dict[str, Any]:
    """The plug-ins' settings by config key (global stability's keys are its table's)."""
    out = {}
    for name, value in settings.items():
        out.update(value if name == "global_stability" and isinstance(value, Mapping) else {name: value})
    return out


def _seed_axis(value, continuation, names, fail) -> str | None:
    """``[analysis] seed_axis``: ``false`` / absent (off) or a grid axis other than
    the continuation axis (there must be one)."""
    if value is False:
        return None
    if value is True:  # the shape allows a boolean; only false means something
        raise fail(f"[analysis]: seed_axis must be a grid axis name or false, got {value!r}")
    if value not in names:
        raise fail(f"[analysis]: seed_axis = '{value}' is not a grid axis{_did_you_mean(value, names)} (axes: {', '.join(names)})")
    if continuation is None:
        raise fail(f"[analysis]: seed_axis = '{value}' needs continuation along another grid axis (continuation is off)")
    if value == continuation:
        raise fail(f"[analysis]: seed_axis = '{value}' is the continuation axis; name another grid axis (axes: {', '.join(names)})")
    return value


# ---------------------------------------------------------------- helpers


def result_bytes_per_point(n_v: int, settings: Mapping[str, Any] | None = None) -> int:
    """Bytes one grid point takes in the dataset: the gait's outputs and those of
    the analyses ``settings`` turns on (``{name: resolved}``, as ``SweepConfig.analyses``)."""
    from jaxwalk import outputs

    act = analyses.active_settings({**(settings or {}), "gait": True})
    return outputs.bytes_per_point(analyses.outputs(act), analyses.sizes(act, n_v))
