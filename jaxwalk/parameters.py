"""Declared model parameters: defaults, units, meaning and physical bounds.

A model's parameters are one flat ``dict[str, scalar]`` pytree at run time (so
``vmap`` over any of them is free); this module holds what is known about each
name before any number is computed, so that configs can be checked up front
with one-line messages.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Mapping

import numpy as np


@dataclasses.dataclass(frozen=True)
class ParamSpec:
    """One model parameter.

    Attributes:
        name: identifier used in configs and datasets.
        default: default value, in ``units``.
        units: unit string written to datasets (``"1"`` for dimensionless).
        description: one line, written as the dataset's ``long_name``.
        lower, upper: physical bounds (``None`` = unbounded).
        lower_open, upper_open: whether the bound itself is excluded.
    """

    name: str
    default: float
    units: str
    description: str
    lower: float | None = None
    upper: float | None = None
    lower_open: bool = False
    upper_open: bool = False

    def check(self, value: float) -> None:
        """Raise ``ValueError`` with a one-line message if ``value`` is not physical."""
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise ValueError(f"parameter '{self.name}' must be a number, got {value!r}")
        if not math.isfinite(value):
            raise ValueError(f"parameter '{self.name}' must be finite, got {value}")
        if self.lower is not None:
            bad = value <= self.lower if self.lower_open else value < self.lower
            if bad:
                op = ">" if self.lower_open else ">="
                raise ValueError(
                    f"parameter '{self.name}' ({self.description}) must be {op} {self.lower}, got {value}"
                )
        if self.upper is not None:
            bad = value >= self.upper if self.upper_open else value > self.upper
            if bad:
                op = "<" if self.upper_open else "<="
                raise ValueError(
                    f"parameter '{self.name}' ({self.description}) must be {op} {self.upper}, got {value}"
                )


def positive(name: str, default: float, units: str, description: str) -> ParamSpec:
    """A strictly positive parameter (masses, lengths, stiffnesses)."""
    return ParamSpec(name, default, units, description, lower=0.0, lower_open=True)


def nonnegative(name: str, default: float, units: str, description: str) -> ParamSpec:
    """A parameter that may be zero but not negative."""
    return ParamSpec(name, default, units, description, lower=0.0)


def resolve(specs: Mapping[str, ParamSpec], overrides: Mapping[str, float], model: str) -> dict[str, float]:
    """Defaults updated by ``overrides``, every value checked.

    Raises:
        KeyError: an override names no parameter of ``model`` (message lists the known ones).
        ValueError: a value is not physical.
    """
    unknown = sorted(set(overrides) - set(specs))
    if unknown:
        raise KeyError(
            f"unknown parameter '{unknown[0]}' for model '{model}' (known: {', '.join(specs)})"
        )
    values = {name: spec.default for name, spec in specs.items()}
    values.update(overrides)
    for name, value in values.items():
        specs[name].check(value)
    return values


def parameter_grid(model, fixed: Mapping[str, float], grid: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
    """Every parameter of ``model`` (a :class:`jaxwalk.walker.Walker`) as a
    float64 array of the grid's shape ``S``.

    Swept names vary along their axis (axes in ``grid``'s order); fixed names
    and defaults are constant.
    """
    axes = list(grid)
    shape = tuple(len(np.atleast_1d(grid[a])) for a in axes)
    out = {}
    for spec in model.parameters:
        if spec.name in grid:
            k = axes.index(spec.name)
            line = np.asarray(grid[spec.name], np.float64)
            view = [1] * len(shape)
            view[k] = len(line)
            out[spec.name] = np.broadcast_to(line.reshape(view), shape).copy()
        else:
            value = float(fixed.get(spec.name, spec.default))
            out[spec.name] = np.full(shape, value)
    return out
