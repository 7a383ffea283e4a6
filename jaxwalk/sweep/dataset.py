"""The sweep dataset: its layout and its attributes (written by :func:`jaxwalk.files.write_zarr`).

Layout (see ``docs/sweeps.md``), for grid shape ``S`` (one dimension per swept
parameter, in config order) and ``n_v = len(model.section_names)``: one variable
per output of every analysis the config turns on, as each declares it
(:mod:`jaxwalk.analyses`; the gait's always: ``status``, ``lambda_max``,
``eigenvalues_real`` / ``_imag`` ``S + (eigen,)``, ``fixed_point`` ``S + (section,)``,
``period``, ``step_length``, ``speed``, ``work``, ``cost_of_transport``,
``newton_iterations``), with its units in the model's unit system, a short
``long_name`` where it has one and its sentence as ``description``.

Where ``status != 0`` every float variable is NaN; a NaN never comes with status 0
(``h_failed`` excepted: it is NaN where no drop failed up to the limit).
"""

from __future__ import annotations

import datetime as _dt
import json
from typing import Mapping

import numpy as np
import xarray as xr

from jaxwalk import analyses
from jaxwalk.files import package_versions as package_versions, provenance
from jaxwalk.files import write_zarr as write_zarr  # where tests and callers have found it
from jaxwalk.sweep.config import SweepConfig
from jaxwalk.walker import Walker


def output_units(model: Walker) -> dict[str, str]:
    """Units of lengths, times, speeds and energies in a model's results.

    Every model declares ``units = {"length": ..., "time": ...}``
    (:attr:`jaxwalk.walker.Walker.units`), and may declare ``"energy"``; without
    it energies are dimensionless in a dimensionless model and ``kg m2 s-2``
    (masses in kg) otherwise.
    """
    length, time = model.units["length"], model.units["time"]
    speed = "1" if (length, time) == ("1", "1") else f"{length} {time}-1"
    energy = model.units.get("energy", "1" if (length, time) == ("1", "1") else f"kg {length}2 {time}-2")
    return {"length": length, "time": time, "speed": speed, "energy": energy}


def section_units(model: Walker) -> list[str]:
    """Units of the section coordinates, in ``model.section_names`` order: the model's
    :attr:`~jaxwalk.walker.Walker.section_units`, or by default an angle (rad) or,
    named ``*_dot``, an angle's rate (rad per time unit), as in every walker here."""
    if model.section_units is not None:
        if len(model.section_units) != len(model.section_names):
            raise ValueError(f"model '{model.name}' declares {len(model.section_units)} section_units for "
                             f"{len(model.section_names)} section_names")
        return list(model.section_units)
    time = output_units(model)["time"]
    rate = "rad" if time == "1" else f"rad {time}-1"
    return [rate if name.endswith("_dot") else "rad" for name in model.section_names]


def section_attrs(model: Walker) -> dict[str, str]:
    """Attributes of a variable over the ``section`` axis: its coordinates' units, one each."""
    units = section_units(model)
    # A default rate in a dimensionless model is "rad" per time unit: say so (a declared unit is as declared).
    derived = model.section_units is None and output_units(model)["time"] == "1"
    said = [f"{u} per time unit" if derived and n.endswith("_dot") else u for n, u in zip(model.section_names, units)]
    return {"section_units": json.dumps(units),
            "comment": "units differ along 'section': " + ", ".join(f"{n} in {u}" for n, u in zip(model.section_names, said))}


def units_note(model: Walker) -> str:
    """One sentence on the unit system of a model's numbers (:func:`output_units`)."""
    u = output_units(model)
    if u["length"] == "1":
        return (
            "dimensionless: leg length 1, g 1, so lengths are in leg lengths, times in "
            "sqrt(leg length / g), speeds in sqrt(g leg length); angles in rad"
        )
    return f"lengths in {u['length']}, times in {u['time']}, angles in rad; other parameters as their units say"


def build_dataset(
    config: SweepConfig,
    model: Walker,
    results: Mapping[str, np.ndarray],
    *,
    command: str | None = None,
    created: _dt.datetime | None = None,
    options: Mapping | None = None,
) -> xr.Dataset:
    """The dataset of a finished sweep: the grid's coordinates, every active
    analysis's variables (:func:`jaxwalk.analyses.variables`), the attributes.

    Args:
        config: the resolved config.
        model: its model (units, section names, parameter specs).
        results: checked analysis output (:func:`jaxwalk.analyses.check_block`).
        command: the command line that made it.
        created: creation time (default: now, UTC).
        options: every setting the analysis ran with, defaults included (JSON-able).
    """
    created = created or _dt.datetime.now(_dt.timezone.utc)
    data_vars = analyses.variables(config, config.dims, results, output_units(model), model)
    # Over the section axis units differ by coordinate: say which, on every such variable.
    data_vars = {k: (dims, values, {**attrs, **section_attrs(model)}) if "section" in dims else (dims, values, attrs)
                 for k, (dims, values, attrs) in data_vars.items()}
    attrs = dataset_attributes(config, model, command=command, created=created, options=options)
    return xr.Dataset(data_vars, coords=coordinates(config, model), attrs=attrs)


def coordinates(config: SweepConfig, model: Walker) -> dict[str, tuple]:
    """One coordinate per swept parameter (units and description from its spec), and
    the ``section`` and ``eigen`` axes of the outputs with a trailing axis."""
    specs = model.param_specs
    coords = {
        axis.name: (
            axis.name,
            np.asarray(axis.values, np.float64),
            {"units": specs[axis.name].units, "long_name": specs[axis.name].description},
        )
        for axis in config.axes
    }
    coords["section"] = ("section", np.array(model.section_names, dtype=object), {
        "long_name": "section coordinate",
        "description": "section coordinates: the independent coordinates at the start of a step",
        **section_attrs(model),
    })
    coords["eigen"] = ("eigen", np.arange(len(model.section_names)), {
        "long_name": "eigenvalue index", "description": "eigenvalue index, in the order the analysis returns them",
    })
    return coords


def _continuation_start(config: SweepConfig, model: Walker) -> float | str:
    """The continuation axis's value where every line starts (``[analysis] gait_guess_at``
    where it names the axis, else ``Walker.seed_value``), or ``"none"``."""
    if config.continuation is None:
        return "none"
    from jaxwalk.continuation import start_value

    return start_value(model, config.continuation, config.fixed, config.grid[config.continuation], config.gait_guess_at)


def dataset_attributes(config: SweepConfig, model: Walker, *, command: str | None, created: _dt.datetime,
                       options: Mapping | None) -> dict[str, object]:
    """The global attributes: what was swept and how, the config, provenance and package versions."""
    return {
        "title": f"jaxwalk sweep '{config.name}' of the {model.name} model",
        "Conventions": "CF-1.10",
        "name": config.name,
        "model": model.name,
        "model_description": model.description,
        "swept_parameters": " ".join(config.dims),
        "fixed_parameters": json.dumps(config.fixed),
        "parameter_units": json.dumps({p.name: p.units for p in model.parameters}),
        "units_note": units_note(model),
        "continuation_axis": config.continuation or "none",
        "continuation_start": _continuation_start(config, model),
        "seed_axis": config.seed_axis or "none",
        "stability": int(config.stability),
        "config": config.to_json(),
        "analysis_options": json.dumps(options or {}, default=str),
        "config_source": config.source,
        "config_toml": config.text if config.text is not None else "",
        **provenance(command, "jaxwalk.sweep.run_sweep", created=created),
    }
