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
import json
import math
from pathlib import Path
from typing import Any, Mapping

import numpy as np

from jaxwalk.optimize.engine import OPTIMIZERS, OWNERS, QUANTITIES, Problem
from jaxwalk.analyses import did_you_mean as _did_you_mean
from jaxwalk.configs import Solver, TopLevel, check_axis, check_name, check_params, failing, field, kind, model_of, parse_toml, read_config_text
from jaxwalk.sweep.config import GridAxis, grid_axis
from jaxwalk.walker import check_supported



class Document(TopLevel):
    """An optimisation file's top level."""

    optimize: dict[str, Any] = field({}, "what to optimise")
    starts: dict[str, Any] = field({}, "where to start")
    heatmap: dict[str, Any] = field({}, "the background grid")
    analysis: dict[str, Any] = field({}, "solver settings")


TOP_LEVEL_KEYS = Document.keys()
OPTIMIZE_KEYS = ("objective", "bounds", "iterations", "learning_rate", "optimizer", "hold", "penalty", "dual_every", "max_retries")
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
                       **{k: v.tolist() for k, v in self.start_fixed.items()}},
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
    problem = _problem(table, specs, params, model_name, fail)
    _check_capabilities(problem, model, fail)
    starts, start_fixed = _starts(data.get("starts", {}), problem, specs, params, model_name, fail)
    heatmap, continuation = _heatmap(data.get("heatmap", {}), specs, model_name, fail)
    solver = Solver.check(data.get("analysis", {}), fail).model_dump(exclude_none=True)
    fixed = {k: float(s.default) for k, s in specs.items() if k not in problem.names}
    fixed.update(params)
    return OptimizeConfig(
        name=name, model=model_name, fixed=fixed, problem=problem, starts=starts, start_fixed=start_fixed,
        heatmap=heatmap, heatmap_continuation=continuation, solver=solver, source=source, text=text,
    )


def _number(value) -> bool:
    return not isinstance(value, bool) and isinstance(value, (int, float)) and math.isfinite(value)


def _problem(table, specs, params, model_name, fail) -> Problem:
    where = "[optimize]"
    for key in table:
        if key not in OPTIMIZE_KEYS:
            raise fail(f"{where}: unknown key '{key}'{_did_you_mean(key, OPTIMIZE_KEYS)} (allowed: {', '.join(OPTIMIZE_KEYS)})")
    objective = table.get("objective", "lambda_max")
    if not isinstance(objective, str) or objective.lstrip("-") not in QUANTITIES or objective.startswith("--"):
        raise fail(f"{where}: objective must be one of {', '.join(QUANTITIES)} (a leading '-' maximises), got {objective!r}")
    bounds = table.get("bounds")
    if not isinstance(bounds, Mapping) or not bounds:
        raise fail(f"{where}: bounds must be a table of the optimised parameters, e.g. bounds = {{ r = [0.3, 0.6] }}")
    names, lower, upper = [], [], []
    for pname, box in bounds.items():
        if pname not in specs:
            raise fail(f"{where} bounds: unknown parameter '{pname}' for model '{model_name}'{_did_you_mean(pname, specs)} (known: {', '.join(specs)})")
        if pname in params:
            raise fail(f"parameter '{pname}' is both fixed in [params] and optimised in [optimize] bounds; remove one")
        if not isinstance(box, list) or len(box) != 2 or not all(_number(b) for b in box):
            raise fail(f"{where} bounds: '{pname}' must be [lower, upper] (two numbers), got {box!r}")
        lo, hi = float(box[0]), float(box[1])
        if not lo < hi:
            raise fail(f"{where} bounds: '{pname}' needs lower < upper, got [{lo}, {hi}]")
        for b in (lo, hi):
            try:
                specs[pname].check(b)
            except ValueError as err:
                raise fail(f"{where} bounds: {err}") from None
        names.append(pname), lower.append(lo), upper.append(hi)
    hold = table.get("hold", {})
    if not isinstance(hold, Mapping):
        raise fail(f"{where}: hold must be a table, e.g. hold = {{ speed = 0.09 }}, got {kind(hold)}")
    for q, target in hold.items():
        if q not in QUANTITIES or q == "lambda_max":
            allowed = ", ".join(x for x in QUANTITIES if x != "lambda_max")
            raise fail(f"{where} hold: unknown quantity '{q}'{_did_you_mean(q, QUANTITIES)} (allowed: {allowed})")
        if not _number(target) or target == 0:
            raise fail(f"{where} hold: {q} must be a non-zero number (the target), got {target!r}")
        if q == objective.lstrip("-"):
            raise fail(f"{where}: the objective '{q}' cannot also be held")
    settings = {}
    for key, kind, default in (
        ("iterations", int, 30), ("learning_rate", float, 0.02), ("penalty", float, 10.0), ("dual_every", int, 10), ("max_retries", int, 4)
    ):
        value = table.get(key, default)
        bad = (not isinstance(value, int) or isinstance(value, bool) or value < (0 if key == "max_retries" else 1)) if kind is int else (not _number(value) or value <= 0)
        if bad:
            what = "a non-negative integer" if key == "max_retries" else ("a positive integer" if kind is int else "a positive number")
            raise fail(f"{where}: {key} must be {what}, got {value!r}")
        settings[key] = kind(value)
    optimizer = table.get("optimizer", "normalized")
    if optimizer not in OPTIMIZERS:
        raise fail(f"{where}: optimizer must be one of {', '.join(OPTIMIZERS)}, got {optimizer!r}")
    settings["optimizer"] = optimizer
    if settings["iterations"] > 10_000:
        raise fail(f"{where}: iterations = {settings['iterations']} is more than 10,000")
    return Problem(
        names=tuple(names), lower=tuple(lower), upper=tuple(upper), objective=objective.lstrip("-"),
        sign=-1.0 if objective.startswith("-") else 1.0, hold={q: float(t) for q, t in hold.items()}, **settings,
    )


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
    columns: dict[str, Any] = {}
    for key, value in table.items():
        if key not in specs:
            raise fail(f"{where}: unknown parameter '{key}' for model '{model_name}'{_did_you_mean(key, specs)} (known: {', '.join(specs)})")
        if key in params:
            raise fail(f"{where}: '{key}' is fixed in [params]; give it in one place")
        values = value if isinstance(value, list) else [value]
        if not values or not all(_number(v) for v in values):
            raise fail(f"{where}: '{key}' must be a number or a non-empty array of numbers, got {value!r}")
        for v in values:
            try:
                specs[key].check(v)
            except ValueError as err:
                raise fail(f"{where}: {err}") from None
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
