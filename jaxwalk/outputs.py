"""The result schema: every per-point output of a sweep, declared once.

An :class:`Output` says what an analysis returns at each grid point: its name,
dtype, trailing axes, units, short name and sentence, plot label, whether it
must be finite where its status is ``OK`` and whether it is differentiable in
the parameters. The gait's outputs are :mod:`jaxwalk.analyses.gait`'s; every
analysis beside the gait declares its own (:mod:`jaxwalk.analyses`). From
the declarations come:

* the checks of an analysis's arrays (:func:`take`, :func:`nonfinite`,
  :func:`blank`; :func:`jaxwalk.sweep.runner.check_results`),
* a store's template and the disk estimate (:func:`template`, :func:`bytes_per_point`),
* the dataset variables and their attributes (:func:`variables`),
* the plot labels and the variables drawn by default (:mod:`jaxwalk.plot.labels`,
  :mod:`jaxwalk.plot.source`),
* the quantities an optimisation may name (``differentiable``; :mod:`jaxwalk.optimize.engine`).

Units are written as a template over the model's unit system
(:func:`jaxwalk.sweep.dataset.output_units`): ``"{length}"``, ``"{time}"``,
``"{speed}"``, ``"{energy}"`` or a literal such as ``"1"``.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any, Callable, Iterable, Mapping

import numpy as np

from jaxwalk.status import RESULT_STATUSES, Status, flag_attributes

#: Attributes an output adds that depend on the config (``(resolved, units) -> dict``).
Attrs = Callable[[Any, Mapping[str, str]], Mapping[str, Any]]


@dataclasses.dataclass(frozen=True)
class Output:
    """One per-point result of an analysis.

    Attributes:
        name: the result key, and the dataset variable (complex outputs are
            written as ``<name>_real`` and ``<name>_imag``).
        dtype: ``"float64"``, ``"complex128"``, ``"int32"`` or ``"int8"``.
        description: one sentence on what it is (the dataset's ``description``,
            or its ``long_name`` when there is no short one).
        long_name: the short name xarray's plots label an axis with
            (``"step length"``); ``None``: the sentence is the ``long_name``.
        units: a template over the model's units (module docstring), or
            ``(units) -> str`` for a rule a template cannot say; ``None``: no
            ``units`` attribute.
        trailing: names of the axes after the grid's (``"section"``, ``"eigen"``,
            ``"cycle"``); their sizes come from the analysis (:meth:`Analysis.sizes`).
        label: short symbol in figures (matplotlib mathtext); default the name.
        meaning: one phrase for a figure's title; default the dataset's ``long_name``.
        finite_where_ok: a point whose status is ``OK`` must have it finite
            (else its status becomes ``NONFINITE``).
        inf_is_a_value: with ``finite_where_ok``, an infinity is a result (the
            gait sensitivity norm of an unstable gait) and only NaN is not.
        differentiable: an optimisation may name it (an objective or a held quantity).
        flags: a status variable: int8 :class:`~jaxwalk.status.Status` codes with
            CF flag attributes, ``NOT_COMPUTED`` in a store's unwritten chunks.
        plot: drawn by default (``jaxwalk plot`` without ``--vars``) when it has
            values, figures in ascending ``plot`` (stability measures first); ``None``: on request only.
        always: keeps its value where the status is not ``OK`` (``newton_iterations``:
            how hard Newton tried); otherwise it is :meth:`missing` there.
        log_scale: figures draw it on a logarithmic scale where its values are
            positive and span more than a decade (``mfpt``: 8 to 40,000 steps on
            one line); written as the dataset attribute ``plot_scale = "log"``.
        attrs: further attributes: a mapping, or ``(resolved, units) -> mapping``
            for those that depend on the analysis's settings.
        source: the field of the analysis's own result it is read from (the
            gait's: an attribute of :class:`jaxwalk.gait.Gait`, ``"v"`` for
            ``fixed_point``); default (``None``) its name.
    """

    name: str
    dtype: str
    description: str
    long_name: str | None = None
    units: str | Callable[[Mapping[str, str]], str] | None = "1"
    trailing: tuple[str, ...] = ()
    label: str | None = None
    meaning: str | None = None
    finite_where_ok: bool = False
    inf_is_a_value: bool = False
    differentiable: bool = False
    flags: bool = False
    plot: int | None = None
    always: bool = False
    log_scale: bool = False
    attrs: Mapping[str, Any] | Attrs = dataclasses.field(default_factory=dict)
    source: str | None = None

    def __post_init__(self):
        if self.source is None:
            object.__setattr__(self, "source", self.name)

    @property
    def is_complex(self) -> bool:
        return self.dtype == "complex128"

    @property
    def is_float(self) -> bool:
        return self.dtype in ("float64", "complex128")

    def shape(self, grid: tuple[int, ...], sizes: Mapping[str, int]) -> tuple[int, ...]:
        """The array's shape for grid shape ``grid``: ``grid`` plus the trailing sizes."""
        return grid + tuple(int(sizes[d]) for d in self.trailing)

    def missing(self):
        """Its value where there is no result: NaN (floats), 0 (counts)."""
        return complex(math.nan, math.nan) if self.is_complex else math.nan if self.is_float else 0


# ---------------------------------------------------------------- checks


def take(results: Mapping[str, np.ndarray], outputs: Iterable[Output], grid: tuple[int, ...],
         sizes: Mapping[str, int]) -> dict[str, np.ndarray]:
    """The arrays of ``outputs`` from an analysis's ``results``, checked and cast to their dtype.

    Raises:
        ValueError: an output is missing (all missing ones named), has the wrong
            shape, or is a status whose dtype is not an integer or whose codes
            are not dataset statuses.
    """
    outputs = tuple(outputs)
    missing = [o.name for o in outputs if o.name not in results]
    if missing:
        raise ValueError(f"the analysis returned no {', '.join(missing)}")
    out = {}
    for o in outputs:
        value = np.asarray(results[o.name])
        expected = o.shape(grid, sizes)
        if value.shape != expected:
            raise ValueError(f"the analysis returned '{o.name}' of shape {value.shape}, expected {expected}")
        out[o.name] = value
    for o in outputs:
        if o.flags:
            codes = out[o.name]
            if not np.issubdtype(codes.dtype, np.integer):
                raise ValueError(f"the analysis returned '{o.name}' of dtype {codes.dtype}, expected an integer type")
            bad = ~np.isin(codes, [int(s) for s in RESULT_STATUSES])
            if bad.any():
                raise ValueError(f"the analysis returned {o.name} codes {sorted(set(codes[bad].tolist()))}, not dataset statuses")
    return {o.name: out[o.name].astype(o.dtype) for o in outputs}


def nonfinite(status: np.ndarray, arrays: Mapping[str, np.ndarray], outputs: Iterable[Output]) -> np.ndarray:
    """``status`` with ``NONFINITE`` where it is ``OK`` but an output declared
    ``finite_where_ok`` is not finite (any of its trailing entries; NaN only, for
    one whose ``inf_is_a_value``)."""
    finite = np.ones(status.shape, bool)
    for o in outputs:
        if o.finite_where_ok:
            ok = ~np.isnan(arrays[o.name]) if o.inf_is_a_value else np.isfinite(arrays[o.name])
            finite &= ok.reshape(status.shape + (-1,)).all(axis=-1)
    return np.where((status == Status.OK) & ~finite, np.int8(Status.NONFINITE), status).astype(np.int8)


def blank(arrays: Mapping[str, np.ndarray], outputs: Iterable[Output], failed: np.ndarray) -> dict[str, np.ndarray]:
    """The numbers of ``outputs`` with :meth:`Output.missing` where ``failed`` (statuses untouched)."""
    out = {}
    for o in outputs:
        if o.flags or o.always:
            continue
        value = arrays[o.name]
        mask = failed.reshape(failed.shape + (1,) * (value.ndim - failed.ndim))
        out[o.name] = np.where(mask, o.missing(), value).astype(o.dtype)
    return out


# ---------------------------------------------------------------- layout


def template(outputs: Iterable[Output], grid: tuple[int, ...], sizes: Mapping[str, int]) -> dict[str, np.ndarray]:
    """Results of the grid's shape as zero-stride views of one fill value (no memory):
    ``NOT_COMPUTED`` for statuses, :meth:`Output.missing` otherwise."""
    out = {}
    for o in outputs:
        value = Status.NOT_COMPUTED if o.flags else o.missing()
        out[o.name] = np.broadcast_to(np.asarray(value, o.dtype), o.shape(grid, sizes))
    return out


def bytes_per_point(outputs: Iterable[Output], sizes: Mapping[str, int]) -> int:
    """Bytes one grid point takes in the dataset."""
    return sum(np.dtype(o.dtype).itemsize * math.prod(int(sizes[d]) for d in o.trailing) for o in outputs)


def units_text(output: Output, units: Mapping[str, str]) -> str | None:
    """The units of ``output`` in a model's unit system (:func:`jaxwalk.sweep.dataset.output_units`)."""
    if output.units is None:
        return None
    return output.units(units) if callable(output.units) else output.units.format(**units)


def attributes(output: Output, resolved: Any, units: Mapping[str, str]) -> dict[str, Any]:
    """The dataset attributes of ``output`` for an analysis's resolved settings and a model's units."""
    attrs: dict[str, Any] = {"long_name": output.long_name or output.description}
    if output.flags:
        attrs.update(flag_attributes())
    if output.units is not None:
        attrs["units"] = units_text(output, units)
    if output.log_scale:
        attrs["plot_scale"] = "log"
    extra = output.attrs(resolved, units) if callable(output.attrs) else output.attrs
    attrs.update(extra)
    if output.long_name:
        attrs["description"] = output.description
    return attrs


def variables(outputs: Iterable[Output], dims: tuple[str, ...], results: Mapping[str, np.ndarray], resolved: Any,
              units: Mapping[str, str]) -> dict[str, tuple]:
    """``{name: (dims, values, attrs)}`` of ``outputs`` for an ``xarray.Dataset``;
    a complex output is two real variables, ``<name>_real`` and ``<name>_imag``."""
    out = {}
    for o in outputs:
        var_dims = dims + o.trailing
        if not o.is_complex:
            out[o.name] = (var_dims, results[o.name], attributes(o, resolved, units))
            continue
        values = np.asarray(results[o.name])
        for part, take_part in (("real", np.real), ("imaginary", np.imag)):
            attrs = attributes(o, resolved, units)
            short = f"{o.long_name}, {part} part" if o.long_name else None
            attrs["long_name"] = short or f"{part} part of {o.description}"
            if short:
                attrs["description"] = f"{part} part of {o.description}"
            # no copy: a sweep's template passes zero-stride views
            out[f"{o.name}_{part[:4]}"] = (var_dims, take_part(values).astype(np.float64, copy=False), attrs)
    return out
