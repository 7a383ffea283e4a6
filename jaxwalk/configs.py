"""Config files: read them, and check each table against a declared shape.

Every command's config is a TOML file of tables. Each table's shape (its keys,
their types, ranges and defaults) is declared once, as a :class:`Table`: a
frozen pydantic model that refuses unknown keys and converts nothing (a string
is not a number, ``true`` is not ``1``). A violation becomes the project's
one-line :class:`~jaxwalk.errors.ConfigError` naming the file, the table and
the key, with a "did you mean" hint for a misspelt key (:meth:`Table.check`).

What depends on the model (parameter names and bounds, section coordinates,
capabilities) or on the analysis plug-ins (:mod:`jaxwalk.analyses`) is checked
after the shape, against those registries, by the command's parser; the
helpers every parser shares are here (:func:`check_name`, :func:`model_of`,
:func:`check_params`).
"""

from __future__ import annotations

import difflib
import re
import tomllib
from pathlib import Path
from typing import Any, Callable, ClassVar, Literal, Mapping

from pydantic import AfterValidator, BaseModel, ConfigDict, Field, ValidationError
from pydantic_core import PydanticUndefined

from jaxwalk.errors import ConfigError

#: ``fail(message)`` returns the :class:`ConfigError` to raise (the file's name in front).
Fail = Callable[[str], ConfigError]

_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9_.-]*\Z")


# ---------------------------------------------------------------- files


def did_you_mean(key: str, choices) -> str:
    """``" (did you mean 'step'?)"`` for the closest of ``choices``, or ``""``."""
    close = difflib.get_close_matches(str(key), list(choices), n=1)
    return f" (did you mean '{close[0]}'?)" if close else ""


def read_config_text(path: str | Path) -> str:
    """The text of the config file at ``path`` (UTF-8). Raises :class:`ConfigError`."""
    try:
        raw = Path(path).read_bytes()
    except FileNotFoundError:
        raise ConfigError(f"config file '{path}' not found") from None
    except IsADirectoryError:
        raise ConfigError(f"config file '{path}' is a directory") from None
    except OSError as err:
        raise ConfigError(f"cannot read config file '{path}': {err.strerror or err}") from None
    try:
        return raw.decode("utf-8")
    except UnicodeDecodeError:
        raise ConfigError(f"{path}: not a UTF-8 text file") from None


def parse_toml(text: str, *, source: str = "<config>") -> dict[str, Any]:
    """TOML text as a dict. Raises :class:`ConfigError` (one line, with the position)."""
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as err:
        # tomllib's message carries "(at line L, column C)".
        raise ConfigError(f"{source}: invalid TOML: {one_line(err)}") from None


def failing(source: str) -> Fail:
    """``fail(message)``: the error a parser raises, ``source`` in front."""
    return lambda message: ConfigError(f"{source}: {message}")


# ---------------------------------------------------------------- declared shapes


def field(default: Any = PydanticUndefined, what: str = "", *, message: str | None = None,
          missing: str | None = None, messages: Mapping[str, str] | None = None, **constraints) -> Any:
    """A :class:`Table` key: its default (none: required), ``what`` it must be (its
    documentation and the error's words), pydantic ``constraints`` (``ge``,
    ``gt``, ``min_length``, ``allow_inf_nan``, ...) and, where a key's message
    is not the table's, its own ``message`` (a :meth:`str.format` template, as
    :attr:`Table.must`), ``missing`` text and ``messages`` by pydantic error
    type (``{"greater_than_equal": ...}``: a range and a type fault told apart)."""
    pairs = (("message", message), ("missing", missing), ("messages", dict(messages) if messages else None))
    extra = {k: v for k, v in pairs if v is not None}
    return Field(default, description=what, json_schema_extra=extra or None, **constraints)


def _distinct(values: list) -> list:
    if len(set(map(str, values))) != len(values):
        raise ValueError("entries repeat")
    return values


#: Annotate a list key with it (``Annotated[list[str], Distinct]``): a repeated entry is
#: refused with the key's message, as a value of the wrong type is.
Distinct = AfterValidator(_distinct)


class Table(BaseModel):
    """The declared shape of one config table; subclasses declare keys as fields.

    Class attributes: ``where`` names the table in messages (``"[basin]"``);
    ``must`` is the message of a value of the wrong type or range, a template
    with ``{where}``, ``{key}``, ``{name}`` (``"{where} {key}"`` unless the
    context names it otherwise: a command-line option), ``{what}`` (the field's description),
    ``{value!r}``, ``{kind}`` (:func:`kind` of the value) and any context
    :meth:`check` is given.
    """

    model_config = ConfigDict(extra="forbid", frozen=True, strict=True)

    where: ClassVar[str] = ""
    must: ClassVar[str] = "{where}: {key} must be {what}, got {value!r}"

    @classmethod
    def keys(cls) -> tuple[str, ...]:
        """The table's keys, in declaration order (the "allowed" list of messages)."""
        return tuple(cls.model_fields)

    @classmethod
    def unknown(cls, key: str, value: Any, where: str | None = None) -> str:
        """The message for a key the table does not declare."""
        allowed = cls.keys()
        return f"{where or cls.where}: unknown key '{key}'{did_you_mean(key, allowed)} (allowed: {', '.join(allowed)})"

    @classmethod
    def check(cls, data: Mapping[str, Any], fail: Fail, *, where: str | None = None, **context: Any):
        """``data`` validated as this table; ``fail(message)`` raised for its first fault
        (an unknown key before a bad value, as a reader would fix them). ``where``
        names the table in messages when it is not :attr:`where` (one declared
        shape read in several places: each grid axis, each switchable analysis)."""
        try:
            return cls.model_validate(dict(data))
        except ValidationError as err:
            errors = sorted(err.errors(include_url=False), key=lambda e: e["type"] != "extra_forbidden")
            raise fail(cls.message(errors[0], data, dict(context, where=where or cls.where))) from None

    @classmethod
    def pick(cls, table: Mapping[str, Any], fail: Fail, **context: Any):
        """This table's keys of a larger ``table`` (``[analysis]``, shared by several
        declared shapes) validated; its other keys are not looked at."""
        return cls.check({k: table[k] for k in cls.keys() if k in table}, fail, **context)

    @classmethod
    def message(cls, error: Mapping[str, Any], data: Mapping[str, Any], context: Mapping[str, Any]) -> str:
        """One pydantic error as the project's one-line message (``context["where"]``: the table's name)."""
        key = str(error["loc"][0]) if error["loc"] else ""
        if error["type"] == "extra_forbidden":
            return cls.unknown(key, data[key], context.get("where"))
        info = cls.model_fields[key]
        extra = info.json_schema_extra or {}
        words = dict(context, key=key, what=info.description)
        words.setdefault("where", cls.where)
        words.setdefault("name", f"{words['where']} {key}")  # the key as a reader names it
        if error["type"] == "missing":
            return extra.get("missing", "{where}: missing '{key}'").format(**words)
        value = data.get(key)
        template = extra.get("messages", {}).get(error["type"]) or extra.get("message", cls.must)
        # The whole value, not the element pydantic stopped at: the reader sees what they wrote.
        return template.format(value=value, kind=kind(value), **words)


class TopLevel(Table):
    """The top level of a config: ``name``, ``model``, ``[params]``; commands add their tables.

    ``name`` and ``model`` are checked by :func:`check_name` and :func:`model_of`
    (their messages show an example); tables must be tables.
    """

    where: ClassVar[str] = ""
    must: ClassVar[str] = "'{key}' must be a table ([{key}]), got {kind}"
    #: Whether an unknown table is called a "section" (else every unknown entry is a "key").
    sections_named: ClassVar[bool] = False

    name: Any = None
    model: Any = None
    params: dict[str, Any] = field({}, "the fixed parameters")

    @classmethod
    def unknown(cls, key: str, value: Any, where: str | None = None) -> str:
        what = "section" if cls.sections_named and isinstance(value, Mapping) else "key"
        allowed = cls.keys()
        return f"unknown top-level {what} '{key}'{did_you_mean(key, allowed)} (allowed: {', '.join(allowed)})"


#: ``[analysis]`` solver keys and the ``SolverOptions`` / ``NewtonOptions`` fields
#: they set (sweeps and optimisations alike).
SOLVER_FIELDS = {"rtol": "rtol", "atol": "atol"}
NEWTON_FIELDS = {"newton_tol": "tol", "max_newton_iter": "max_iter", "predictor": "predictor"}
#: The values of :attr:`jaxwalk.gait.NewtonOptions.predictor` (that module imports
#: JAX, which parsing a config must not; tests/test_continuation.py holds the two equal).
PREDICTORS = ("secant", "previous")


class Solver(Table):
    """The solver settings of ``[analysis]`` (sweeps, optimisation): each passed to
    the analysis when set, its default otherwise."""

    where: ClassVar[str] = "[analysis]"

    rtol: float | None = field(None, "a positive number", gt=0, allow_inf_nan=False)
    atol: float | None = field(None, "a positive number", gt=0, allow_inf_nan=False)
    newton_tol: float | None = field(None, "a positive number", gt=0, allow_inf_nan=False)
    max_newton_iter: int | None = field(None, "a positive integer", ge=1, le=1000, messages={
        "less_than_equal": "{where}: {key} = {value} is more than the limit of 1000"})
    predictor: Literal[PREDICTORS] | None = field(None, f"one of {', '.join(PREDICTORS)}")

    @classmethod
    def settings(cls, table: Mapping[str, Any], fail: Fail) -> dict[str, float | int]:
        """The settings of ``table`` that are given (its other keys are not looked at)."""
        return cls.pick(table, fail).model_dump(exclude_none=True)


class Axis(Table):
    """One axis of a grid (``[grid]`` of a sweep, ``[heatmap]`` of an optimisation):
    ``num`` values evenly spaced from ``start`` to ``stop``, both included, or the
    ``values`` listed, in the swept parameter's own units.

    The numbers are checked against the parameter's bounds after the shape
    (:meth:`resolve`): the bounds are the model's.
    """

    where: ClassVar[str] = "[grid] axis"
    must: ClassVar[str] = "{where}: {key} must be {what}, got {value!r}"

    start: Any = field(None, "the first value (the parameter's units)")
    stop: Any = field(None, "the last value (the parameter's units)")
    num: int | None = field(None, "an integer", ge=1, messages={
        "greater_than_equal": "{where}: num must be at least 1, got {value!r}"})
    values: list[Any] | None = field(None, "an array of numbers", min_length=1, message=(
        "{where}: values must be an array of numbers, got {kind}"), messages={"too_short": "{where}: values is empty"})

    def resolve(self, spec, where: str, fail: Fail) -> dict[str, Any]:
        """The axis as written, numbers as floats (``{"start", "stop", "num"}`` or
        ``{"values"}``), each value within ``spec``'s bounds (a :class:`~jaxwalk.parameters.ParamSpec`)."""

        def check(value, what):
            try:
                spec.check(value)
            except ValueError as err:
                raise fail(f"{where}: {what}: {err}") from None
            return float(value)

        if self.values is not None:
            if self.model_fields_set != {"values"}:
                raise fail(f"{where}: give either values or start/stop/num, not both")
            values = [check(v, f"value {i}") for i, v in enumerate(self.values)]
            if len(set(values)) != len(values):
                dup = next(v for v in values if values.count(v) > 1)
                raise fail(f"{where}: value {dup} appears more than once")
            return {"values": values}
        missing = [k for k in ("start", "stop", "num") if k not in self.model_fields_set]
        if missing:
            raise fail(f"{where}: needs start, stop and num, or values (missing: {', '.join(missing)})")
        # Bounds are intervals and linspace's endpoints are exactly start and stop,
        # so checking the two endpoints checks every value of the axis.
        start, stop, num = check(self.start, "start"), check(self.stop, "stop"), self.num
        if num > 1 and start == stop:
            raise fail(f"{where}: start equals stop with num = {num} (every value the same)")
        if num == 1 and start != stop:
            raise fail(f"{where}: num = 1 with start != stop; for one value write values = [{start}]")
        return {"start": start, "stop": stop, "num": num}


def check_axis(section: str, axis: str, value: Any, specs: Mapping, params: Mapping, model_name: str,
               fail: Fail) -> dict[str, Any]:
    """The axis ``axis`` of the grid table ``section`` (``"[grid]"``, ``"[heatmap]"``),
    checked against the model's parameters (``specs``; none of ``params``, the fixed
    ones): :meth:`Axis.resolve`'s dict."""
    where = f"{section} axis '{axis}'"
    if axis not in specs:
        raise fail(f"{section}: {unknown_param(axis, specs, model_name)}")
    if axis in params:
        raise fail(f"parameter '{axis}' is both fixed in [params] and swept in {section}; remove one")
    if not isinstance(value, Mapping):
        raise fail(f"{where} must be a table, {{ start = .., stop = .., num = .. }} or {{ values = [..] }}, got {kind(value)}")
    return Axis.check(value, fail, where=where).resolve(specs[axis], where, fail)


# ---------------------------------------------------------------- shared checks


def check_name(data: Mapping[str, Any], fail: Fail) -> str:
    """The config's ``name``: the outputs' file names start with it."""
    name = data.get("name")
    if name is None:
        raise fail("missing 'name' (the dataset name, e.g. name = \"slope_scan\")")
    if not isinstance(name, str) or not _NAME.match(name):
        raise fail(f"'name' must be a string of letters, digits, '_', '.', '-' (a file name), got {name!r}")
    return name


def model_of(data: Mapping[str, Any], fail: Fail, example: str):
    """``(name, model)`` named by a config's ``model`` key, from the registry."""
    from jaxwalk.models import get_model

    model_name = data.get("model")
    if model_name is None:
        raise fail(f"missing 'model' (e.g. model = \"{example}\")")
    if not isinstance(model_name, str):
        raise fail(f"'model' must be a string, got {kind(model_name)}")
    try:
        return model_name, get_model(model_name)
    except KeyError as err:
        raise fail(err.args[0]) from None


def check_params(table: Mapping[str, Any], specs: Mapping, model_name: str, fail: Fail) -> dict[str, float]:
    """``[params]`` as floats, each a parameter of the model within its bounds
    (:class:`~jaxwalk.parameters.ParamSpec`)."""
    out = {}
    for key, value in table.items():
        if key not in specs:
            raise fail(f"[params]: {unknown_param(key, specs, model_name)}")
        try:
            specs[key].check(value)
        except ValueError as err:
            raise fail(f"[params]: {err}") from None
        out[key] = float(value)
    return out


def unknown_param(key: str, specs: Mapping, model: str) -> str:
    return f"unknown parameter '{key}' for model '{model}'{did_you_mean(key, specs)} (known: {', '.join(specs)})"


def kind(value: Any) -> str:
    """What a TOML value is, in words (``"an integer"``, ``"a table"``)."""
    names = {bool: "a boolean", int: "an integer", float: "a number", str: "a string", list: "an array"}
    return names.get(type(value), "a table" if isinstance(value, Mapping) else type(value).__name__)


def human_bytes(n: float) -> str:
    """``n`` bytes to three significant digits in B, KB, MB, GB or TB (powers of 1000)."""
    for unit in ("B", "KB", "MB", "GB"):
        if n < 1000:
            return f"{n:.3g} {unit}"
        n /= 1000
    return f"{n:.3g} TB"


def one_line(err: Exception) -> str:
    return " ".join(str(err).split())
