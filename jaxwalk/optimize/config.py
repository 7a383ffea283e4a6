"""Optimisation configs: read a TOML file, check it against its model.

A config names a model, fixes some of its parameters, and says what to
optimise over which parameters, from which starts (see ``docs/optimize.md``)::

    name = "foot_ratio"
    model = "flatfoot"
    [params]                       # held fixed (the model's defaults otherwise)
    k = 0.03
    [optimize]
    objective = "lambda_max"       # or any of engine.QUANTITIES (speed, ...); "-speed" maximises
    bounds = { r = [0.3, 0.6] }    # the optimised parameters and their boxes
    iterations = 30
    learning_rate = 0.02           # fraction of each box per step, cosine-decayed
    optimizer = "normalized"       # or "adam", "sgd"
    hold = { speed = 0.09 }        # optional: augmented Lagrangian
    [starts]                       # equal-length arrays (or one number for all)
    r = [0.40, 0.45]
    l_f = [0.21, 0.22]             # a fixed parameter may vary per start
    # gait_guess = [[0.33, -0.37], [0.32, -0.37]]   # optional: Newton's first start per start (section coordinates)
    [heatmap]                      # optional lambda_max background (a sweep's [grid] axes)
    r = { start = 0.3, stop = 0.6, num = 13 }
    continuation = "r"
    [analysis]                     # solver settings, as in sweeps
    rtol = 1e-10

As for sweeps, every problem is a :class:`~jaxwalk.errors.ConfigError`
with a one-line message naming the file, the section and the key.
"""

from __future__ import annotations

import dataclasses
import functools
import json
import math
from pathlib import Path
from typing import Annotated, Any, ClassVar, Literal, Mapping

import numpy as np
from pydantic import Field, create_model

from jaxwalk.optimize.engine import OPTIMIZERS, OWNERS, QUANTITIES, Problem
from jaxwalk.configs import (Solver, Table, TopLevel, check_axis, check_name, check_params, did_you_mean, failing, field, model_of,
                             parse_toml, read_config_text, unknown_param)
from jaxwalk.sweep.config import GridAxis, grid_axis
from jaxwalk.walker import check_supported



class Document(TopLevel):
    """An optimisation file's top level."""

    optimize: dict[str, Any] = field({}, "what to optimise")
    starts: dict[str, Any] = field({}, "where to start")
    heatmap: dict[str, Any] = field({}, "the background grid")
    analysis: dict[str, Any] = field({}, "solver settings")


TOP_LEVEL_KEYS = Document.keys()
#: Most starts and heatmap points accepted (each start is a gait search with derivatives per iteration).
MAX_STARTS = 4096
MAX_HEATMAP_POINTS = 100_000


@dataclasses.dataclass(frozen=True, eq=False)
class OptimizeConfig:
    """A checked optimisation.

    Attributes:
        name: output name (``<name>.zarr``, ``<name>.png``).
        model: registry name.
        fixed: every parameter not optimised: defaults updated by ``[params]``.
        problem: the :class:`~jaxwalk.optimize.engine.Problem`.
        starts: ``(S, n_p)`` initial values of the optimised parameters.
        start_fixed: ``{name: (S,)}`` fixed parameters that vary per start.
        guesses: ``(S, n_v)`` where each start's first gait search begins (the
            model's section coordinates), or ``None``: the model's initial guess.
        heatmap: the background grid's axes (``GridAxis``), empty when not asked for.
        heatmap_continuation: axis to continue along in the background grid, or ``None``.
        solver: the ``[analysis]`` solver settings given.
        source, text: where the config came from, and its TOML.
    """

    name: str
    model: str
    fixed: dict[str, float]
    problem: Problem
    starts: np.ndarray
    start_fixed: dict[str, np.ndarray]
    heatmap: tuple[GridAxis, ...] = ()
    heatmap_continuation: str | None = None
    solver: dict[str, float | int] = dataclasses.field(default_factory=dict)
    guesses: np.ndarray | None = None
    source: str = "<config>"
    text: str | None = None

    def fixed_per_start(self) -> dict[str, np.ndarray]:
        """Every non-optimised parameter as an ``(S,)`` array."""
        n = self.starts.shape[0]
        out = {k: np.full(n, v) for k, v in self.fixed.items()}
        out.update({k: np.asarray(v, np.float64) for k, v in self.start_fixed.items()})
        return out

    def to_dict(self) -> dict[str, Any]:
        """The resolved config (JSON-ready), itself a valid config."""
        p = self.problem
        opt = {
            "objective": ("-" if p.sign < 0 else "") + p.objective,
            "bounds": {n: [lo, hi] for n, lo, hi in zip(p.names, p.lower, p.upper)},
            "iterations": p.iterations,
            "learning_rate": p.learning_rate,
            "penalty": p.penalty,
            "max_retries": p.max_retries,
            "optimizer": p.optimizer,
            "dual_every": p.dual_every,
        }
        if p.hold:
            opt["hold"] = dict(p.hold)
        out = {
            "name": self.name,
            "model": self.model,
            "params": {k: v for k, v in self.fixed.items() if k not in self.start_fixed},
            "optimize": opt,
            "starts": {**{n: self.starts[:, i].tolist() for i, n in enumerate(p.names)},
                       **{k: v.tolist() for k, v in self.start_fixed.items()},
                       **({} if self.guesses is None else {GUESS_KEY: self.guesses.tolist()})},
            "analysis": dict(self.solver),
        }
        if self.heatmap:
            out["heatmap"] = {a.name: dict(a.spec) for a in self.heatmap}
            out["heatmap"]["continuation"] = self.heatmap_continuation or False
        return out

    def to_json(self) -> str:
        return json.dumps(self.to_dict())


def load_optimize_config(path: str | Path) -> OptimizeConfig:
    """Read and check the optimisation config at ``path``. Raises ``ConfigError``."""
    text = read_config_text(path)
    return parse_optimize_config(parse_toml(text, source=str(path)), source=str(path), text=text)


def parse_optimize_config(data: Mapping[str, Any], *, source: str = "<config>", text: str | None = None) -> OptimizeConfig:
    """Check a parsed TOML table and resolve it. Raises ``ConfigError`` (one line)."""

    fail = failing(source)
    if not isinstance(data, Mapping):
        raise fail("a config must be a TOML table")
    Document.check(data, fail)
    name = check_name(data, fail)
    model_name, model = model_of(data, fail, example="flatfoot")
    specs = model.param_specs
    params = check_params(data.get("params", {}), specs, model_name, fail)
    table = data.get("optimize")
    if not table:
        raise fail("[optimize] is missing or empty: give at least bounds = { <parameter> = [lower, upper] }")
    problem = Optimize.check(table, fail).problem(specs, params, model_name, fail)
    _check_capabilities(problem, model, fail)
    starts_raw = dict(data.get("starts", {})) if isinstance(data.get("starts", {}), Mapping) else data.get("starts")
    guess = starts_raw.pop(GUESS_KEY, None) if isinstance(starts_raw, dict) else None
    for key in starts_raw if isinstance(starts_raw, dict) else ():
        if key not in specs and did_you_mean(key, [GUESS_KEY]):
            raise fail(f"[starts]: unknown key '{key}'{did_you_mean(key, [GUESS_KEY])}")
    starts, start_fixed = _starts(starts_raw, problem, specs, params, model_name, fail)
    guesses = None if guess is None else _guesses(guess, starts.shape[0], len(model.section_names), fail)
    heatmap, continuation = _heatmap(data.get("heatmap", {}), specs, model_name, fail)
    solver = Solver.check(data.get("analysis", {}), fail).model_dump(exclude_none=True)
    fixed = {k: float(s.default) for k, s in specs.items() if k not in problem.names}
    fixed.update(params)
    return OptimizeConfig(
        name=name, model=model_name, fixed=fixed, problem=problem, starts=starts, start_fixed=start_fixed,
        heatmap=heatmap, heatmap_continuation=continuation, solver=solver, source=source, text=text, guesses=guesses,
    )


#: The ``[starts]`` key of Newton's first start points (not a parameter).
GUESS_KEY = "gait_guess"


def _guesses(value, n_start: int, n_v: int, fail) -> np.ndarray:
    """``(S, n_v)`` from ``gait_guess``: one point of ``n_v`` numbers for every start, or one per start."""
    where, shape = f"[starts] {GUESS_KEY}", f"{n_v} numbers (the model's section coordinates)"
    seq = (list, tuple)
    rows = value if isinstance(value, seq) and value and all(isinstance(r, seq) for r in value) else [value]
    for row in rows:
        if not isinstance(row, seq) or len(row) != n_v or not all(_number(x) for x in row):
            raise fail(f"{where}: each point must be {shape}, got {row!r}")
    if len(rows) not in (1, n_start):
        raise fail(f"{where}: {len(rows)} points for {n_start} start{'s' if n_start > 1 else ''}; "
                   "give one point, or one per start")
    return np.broadcast_to(np.asarray(rows, np.float64), (n_start, n_v)).copy()


def _default(name: str) -> Any:
    """The :class:`~jaxwalk.optimize.engine.Problem` default of a setting: one place for it."""
    return Problem.__dataclass_fields__[name].default


_Finite = Annotated[float, Field(allow_inf_nan=False)]
#: What a held quantity may be: every optimisable quantity but ``lambda_max`` (no target for it).
HOLDABLE = tuple(q for q in QUANTITIES if q != "lambda_max")


class Optimize(Table):
    """``[optimize]``: the objective, the optimised parameters' boxes, the optimiser's settings."""

    where: ClassVar[str] = "[optimize]"

    objective: Literal[(*QUANTITIES, *(f"-{q}" for q in QUANTITIES))] = field(
        "lambda_max", f"one of {', '.join(QUANTITIES)} (a leading '-' maximises)")
    bounds: dict[str, Any] = field(
        what="a table {parameter = [lower, upper]} of the optimised parameters (the model's units)", min_length=1,
        message="{where}: bounds must be a table of the optimised parameters, e.g. bounds = {{ r = [0.3, 0.6] }}",
        missing="{where}: bounds must be a table of the optimised parameters, e.g. bounds = {{ r = [0.3, 0.6] }}")
    iterations: int = field(_default("iterations"), "a positive integer", ge=1, le=10_000, messages={
        "less_than_equal": "{where}: iterations = {value} is more than 10,000"})
    learning_rate: float = field(_default("learning_rate"), "a positive number", gt=0, allow_inf_nan=False)
    optimizer: Literal[OPTIMIZERS] = field(_default("optimizer"), f"one of {', '.join(OPTIMIZERS)}")
    hold: dict[str, Any] = field({}, "a table {quantity = target}, held by the augmented Lagrangian", message=(
        "{where}: hold must be a table, e.g. hold = {{ speed = 0.09 }}, got {kind}"))
    penalty: float = field(_default("penalty"), "a positive number", gt=0, allow_inf_nan=False)
    dual_every: int = field(_default("dual_every"), "a positive integer", ge=1)
    max_retries: int = field(_default("max_retries"), "a non-negative integer", ge=0)

    def problem(self, specs, params, model_name, fail) -> Problem:
        """The :class:`~jaxwalk.optimize.engine.Problem`: the boxes and held targets checked against the model."""
        where = self.where
        names, lower, upper = [], [], []
        for pname, box in self.bounds.items():
            if pname not in specs:
                raise fail(f"{where} bounds: {unknown_param(pname, specs, model_name)}")
            if pname in params:
                raise fail(f"parameter '{pname}' is both fixed in [params] and optimised in [optimize] bounds; remove one")
            if not isinstance(box, list) or len(box) != 2 or not all(_number(b) for b in box):
                raise fail(f"{where} bounds: '{pname}' must be [lower, upper] (two numbers), got {box!r}")
            lo, hi = float(box[0]), float(box[1])
            if not lo < hi:
                raise fail(f"{where} bounds: '{pname}' needs lower < upper, got [{lo}, {hi}]")
            for b in (lo, hi):
                _within(specs[pname], b, f"{where} bounds", fail)
            names.append(pname), lower.append(lo), upper.append(hi)
        objective = self.objective.lstrip("-")
        for q, target in self.hold.items():
            if q not in HOLDABLE:
                raise fail(f"{where} hold: unknown quantity '{q}'{did_you_mean(q, QUANTITIES)} (allowed: {', '.join(HOLDABLE)})")
            if not _number(target) or target == 0:
                raise fail(f"{where} hold: {q} must be a non-zero number (the target), got {target!r}")
            if q == objective:
                raise fail(f"{where}: the objective '{q}' cannot also be held")
        settings = self.model_dump(include={"iterations", "learning_rate", "optimizer", "penalty", "dual_every", "max_retries"})
        return Problem(names=tuple(names), lower=tuple(lower), upper=tuple(upper), objective=objective,
                       sign=-1.0 if self.objective.startswith("-") else 1.0,
                       hold={q: float(t) for q, t in self.hold.items()}, **settings)


def _number(value) -> bool:
    return not isinstance(value, bool) and isinstance(value, (int, float)) and math.isfinite(value)


def _within(spec, value: float, where: str, fail) -> None:
    """``value`` within the parameter's bounds (a :class:`~jaxwalk.parameters.ParamSpec`)."""
    try:
        spec.check(value)
    except ValueError as err:
        raise fail(f"{where}: {err}") from None


class Starts(Table):
    """``[starts]``: each optimised parameter's start values, and fixed parameters that
    vary per start, by the model's parameter names; equal-length arrays, or one
    number for every start. The keys are the model's (:func:`starts_table`)."""

    where: ClassVar[str] = "[starts]"
    must: ClassVar[str] = "{where}: '{key}' must be a number or a non-empty array of numbers, got {value!r}"
    model_name: ClassVar[str] = ""

    @classmethod
    def unknown(cls, key: str, value: Any, where: str | None = None) -> str:
        return f"{where or cls.where}: {unknown_param(key, cls.keys(), cls.model_name)}"


@functools.lru_cache(maxsize=None)
def starts_table(model_name: str, names: tuple[str, ...]) -> type[Starts]:
    """The :class:`Starts` of a model whose parameters are ``names``: one optional key each."""
    column = Annotated[list[_Finite], Field(min_length=1)] | _Finite | None
    keys = {n: (column, field(None, "its start values (the parameter's units)")) for n in names}
    table = create_model(f"Starts_{model_name}", __base__=Starts, **keys)
    table.model_name = model_name
    return table


def _check_capabilities(problem: Problem, model, fail) -> None:
    """Refuse, in one line, an objective or held quantity whose analysis needs a
    capability the model lacks (the gait sensitivity norm: a step-down), as a
    sweep asking for that analysis is refused (:func:`jaxwalk.walker.check_supported`)."""
    named = [("objective", problem.objective)] + [("hold", q) for q in problem.hold]
    for field, q in named:
        if q in OWNERS:
            check_supported(model, {OWNERS[q].key_of(q): True}, fail, where=f"[optimize] {field} '{q}' needs")


def _starts(table, problem: Problem, specs, params, model_name, fail):
    """``(S, n_p)`` starts and ``{fixed name: (S,)}``; without [starts], one start at the box's centre."""
    where = "[starts]"
    starts_table(model_name, tuple(specs)).check(table, fail)
    columns: dict[str, Any] = {}
    for key, value in table.items():
        if key in params:
            raise fail(f"{where}: '{key}' is fixed in [params]; give it in one place")
        values = value if isinstance(value, list) else [value]
        for v in values:  # as written: the message shows the reader's number
            _within(specs[key], v, where, fail)
        columns[key] = [float(v) for v in values]
    lengths = {len(v) for v in columns.values() if len(v) > 1}
    if len(lengths) > 1:
        raise fail(f"{where}: arrays have different lengths ({', '.join(f'{k}: {len(v)}' for k, v in columns.items())})")
    n = lengths.pop() if lengths else 1
    if n > MAX_STARTS:
        raise fail(f"{where}: {n} starts, more than the limit of {MAX_STARTS}")
    starts = np.empty((n, len(problem.names)))
    for i, (pname, lo, hi) in enumerate(zip(problem.names, problem.lower, problem.upper)):
        col = np.broadcast_to(np.asarray(columns.get(pname, [0.5 * (lo + hi)])), (n,))
        if np.any(col < lo) or np.any(col > hi):
            bad = float(col[(col < lo) | (col > hi)][0])
            raise fail(f"{where}: start {pname} = {bad} is outside its bounds [{lo}, {hi}]")
        starts[:, i] = col
    start_fixed = {k: np.broadcast_to(np.asarray(v), (n,)).copy() for k, v in columns.items() if k not in problem.names}
    return starts, start_fixed


def _heatmap(table, specs, model_name, fail):
    axes_raw = {k: v for k, v in table.items() if k != "continuation"}
    if len(axes_raw) > 2:
        raise fail(f"[heatmap]: at most two axes (a map over two parameters), got {len(axes_raw)}: {', '.join(axes_raw)}")
    specs_out = {a: check_axis("[heatmap]", a, s, specs, {}, model_name, fail) for a, s in axes_raw.items()}
    axes = tuple(grid_axis(a, s) for a, s in specs_out.items())
    if math.prod(len(a.values) for a in axes) > MAX_HEATMAP_POINTS:
        raise fail(f"[heatmap]: more than {MAX_HEATMAP_POINTS:,} points")
    continuation = table.get("continuation", bool(axes))
    if continuation is True:
        continuation = axes[0].name if axes else None
    elif continuation is False:
        continuation = None
    elif not isinstance(continuation, str) or continuation not in specs_out:
        raise fail(f"[heatmap]: continuation must be one of its axes ({', '.join(specs_out) or 'none given'}) or false, got {continuation!r}")
    return axes, continuation


#: Keys of ``[optimize]``, in the order messages list them.
OPTIMIZE_KEYS = Optimize.keys()
