"""The sweep dataset: its layout, its attributes, and an atomic zarr write.

Layout (see ``docs/sweeps.md``), for grid shape ``S`` (one dimension per swept
parameter, in config order) and ``n_v = len(model.section_names)``:

* ``status`` ``S``, int8 :class:`~jaxwalk.status.Status` with CF flag attributes;
* ``lambda_max`` ``S``, the largest eigenvalue modulus of the step-to-step Jacobian;
* ``eigenvalues_real``, ``eigenvalues_imag`` ``S + (eigen,)``;
* ``fixed_point`` ``S + (section,)``, in section coordinates;
* ``period``, ``step_length``, ``speed`` ``S``, in the model's units;
* ``work`` ``S``, actuator work per step, and ``cost_of_transport`` ``S``, that
  work per unit weight and distance (both 0 for passive walkers);
* ``newton_iterations`` ``S``, int32;
* with ``[analysis] h_max`` (global stability, :mod:`jaxwalk.stepdown`): ``h_max``
  ``S``, the largest survived step-down, in model length units;
  ``step_down_status`` ``S``, int8 with CF flag attributes; ``h_failed`` ``S``.

Where ``status != 0`` every float variable is NaN; a NaN never comes with status 0
(``h_failed`` excepted: it is NaN where no drop failed up to the limit).
"""

from __future__ import annotations

import datetime as _dt
import importlib.metadata
import json
import os
import platform
import shutil
import tempfile
import warnings
from pathlib import Path
from typing import Mapping

import numpy as np
import xarray as xr

import jaxwalk
from jaxwalk.status import flag_attributes
from jaxwalk.sweep import attractors
from jaxwalk.sweep.config import SweepConfig
from jaxwalk.walker import Walker

#: Packages whose versions are written to every dataset.
VERSIONED = ("jax", "jaxlib", "diffrax", "equinox", "optimistix", "numpy", "xarray", "zarr")


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


def units_note(model: Walker) -> str:
    """One sentence on the unit system of a model's numbers."""
    declared = getattr(model, "units_note", None)
    if declared:
        return declared
    u = output_units(model)
    if u["length"] == "1":
        return (
            "dimensionless: leg length 1, g 1, so lengths are in leg lengths, times in "
            "sqrt(leg length / g), speeds in sqrt(g leg length); angles in rad"
        )
    return f"lengths in {u['length']}, times in {u['time']}, angles in rad; other parameters as their units say"


def package_versions() -> dict[str, str]:
    """``{"jaxwalk": ..., "jax": ..., ..., "python": ...}`` without importing the packages."""
    out = {"jaxwalk": jaxwalk.__version__}
    for name in VERSIONED:
        try:
            out[name] = importlib.metadata.version(name)
        except importlib.metadata.PackageNotFoundError:
            out[name] = "not installed"
    out["python"] = platform.python_version()
    return out


def build_dataset(
    config: SweepConfig,
    model: Walker,
    results: Mapping[str, np.ndarray],
    *,
    command: str | None = None,
    created: _dt.datetime | None = None,
    options: Mapping | None = None,
) -> xr.Dataset:
    """The dataset of a finished sweep.

    Args:
        config: the resolved config.
        model: its model (units, section names, parameter specs).
        results: checked analysis output (:func:`jaxwalk.sweep.runner.check_results`).
        command: the command line that made it.
        created: creation time (default: now, UTC).
        options: every setting the analysis ran with, defaults included (JSON-able).
    """
    dims = config.dims
    specs = model.param_specs
    units = output_units(model)
    n_v = len(model.section_names)
    created = created or _dt.datetime.now(_dt.timezone.utc)
    created_s = created.isoformat(timespec="seconds")

    coords = {
        axis.name: (
            axis.name,
            np.asarray(axis.values, np.float64),
            {"units": specs[axis.name].units, "long_name": specs[axis.name].description},
        )
        for axis in config.axes
    }
    coords["section"] = (
        "section",
        np.array(model.section_names, dtype=object),
        {"long_name": "section coordinates: the independent coordinates at the start of a step"},
    )
    coords["eigen"] = ("eigen", np.arange(n_v), {"long_name": "eigenvalue index, in the order the analysis returns them"})

    eig = np.asarray(results["eigenvalues"])
    data_vars = {
        "status": (dims, results["status"], {"long_name": "outcome at this grid point (0: periodic gait found)", **flag_attributes()}),
        "lambda_max": (
            dims,
            results["lambda_max"],
            {"long_name": "largest eigenvalue modulus of the step-to-step Jacobian (stable below 1)", "units": "1"},
        ),
        "eigenvalues_real": (
            dims + ("eigen",),
            eig.real.astype(np.float64, copy=False),  # no copy: a sweep's template passes zero-stride views
            {"long_name": "real part of the eigenvalues of the step-to-step Jacobian", "units": "1"},
        ),
        "eigenvalues_imag": (
            dims + ("eigen",),
            eig.imag.astype(np.float64, copy=False),
            {"long_name": "imaginary part of the eigenvalues of the step-to-step Jacobian", "units": "1"},
        ),
        "fixed_point": (
            dims + ("section",),
            results["fixed_point"],
            {"long_name": "fixed point of the step map in section coordinates (names in 'section')"},
        ),
        "period": (dims, results["period"], {"long_name": "duration of one step", "units": units["time"]}),
        "step_length": (
            dims,
            results["step_length"],
            {"long_name": "distance the stance foot advances in one step, along the slope", "units": units["length"]},
        ),
        "speed": (dims, results["speed"], {"long_name": "mean speed along the slope, step_length / period", "units": units["speed"]}),
        "work": (
            dims,
            results["work"],
            {"long_name": "work done by the actuators in one step (0 for a passive walker)", "units": units["energy"]},
        ),
        "cost_of_transport": (
            dims,
            results["cost_of_transport"],
            {
                "long_name": "actuator work per unit weight per unit distance, work / (weight * step_length)",
                "units": "1",
                "comment": (
                    "mechanical cost of transport of the actuators only; a passive walker's is 0 (gravity "
                    "supplies its energy: sin(gamma) per unit weight and distance)"
                ),
            },
        ),
        "newton_iterations": (
            dims,
            results["newton_iterations"],
            {"long_name": "Newton iterations used to find the fixed point", "units": "1"},
        ),
    }
    if config.h_max is not None:
        data_vars.update(step_down_variables(config.h_max, dims, results, units["length"]))
    if config.attractors is not None:
        data_vars.update(attractors.variables(dims, results))
    if config.global_stability:
        from jaxwalk.global_stability.sweep import dataset_variables

        data_vars.update(dataset_variables(config.global_stability, dims, results, units))

    versions = package_versions()
    attrs = {
        "title": f"jaxwalk sweep '{config.name}' of the {model.name} model",
        "Conventions": "CF-1.10",
        "name": config.name,
        "model": model.name,
        "model_description": model.description,
        "swept_parameters": " ".join(dims),
        "fixed_parameters": json.dumps(config.fixed),
        "parameter_units": json.dumps({p.name: p.units for p in model.parameters}),
        "units_note": units_note(model),
        "continuation_axis": config.continuation or "none",
        "seed_axis": config.seed_axis or "none",
        "stability": int(config.stability),
        "config": config.to_json(),
        "analysis_options": json.dumps(options or {}, default=str),
        "config_source": config.source,
        "config_toml": config.text if config.text is not None else "",
        "created": created_s,
        "command": command or "",
        "history": f"{created_s}: {command or 'jaxwalk.sweep.run_sweep'}",
        **{f"{name}_version": v for name, v in versions.items()},
    }
    return xr.Dataset(short_names(data_vars), coords=short_names(coords), attrs=attrs)


#: Short ``long_name`` of each variable, as xarray's own plots label an axis
#: ("step length [m]"); the sentence it replaces is the variable's ``description``.
SHORT_NAMES = {
    "section": "section coordinate",
    "eigen": "eigenvalue index",
    "status": "status",
    "lambda_max": "largest eigenvalue modulus",
    "eigenvalues_real": "eigenvalue, real part",
    "eigenvalues_imag": "eigenvalue, imaginary part",
    "fixed_point": "fixed point",
    "period": "step period",
    "step_length": "step length",
    "speed": "speed",
    "work": "actuator work per step",
    "cost_of_transport": "cost of transport",
    "newton_iterations": "Newton iterations",
    "h_max": "largest survived step-down",
    "step_down_status": "step-down status",
    "h_failed": "first failed drop",
}


def short_names(variables: dict) -> dict:
    """``variables`` (``{name: (dims, values, attrs)}``) with :data:`SHORT_NAMES` as
    ``long_name`` and the sentence moved to ``description``."""
    out = {}
    for name, (dims, values, attrs) in variables.items():
        if name in SHORT_NAMES and "long_name" in attrs:
            attrs = {**attrs, "long_name": SHORT_NAMES[name], "description": attrs["long_name"]}
        out[name] = (dims, values, attrs)
    return out


def step_down_variables(
    h_max: Mapping[str, float | int], dims: tuple[str, ...], results: Mapping[str, np.ndarray], length: str
) -> dict[str, tuple]:
    """``h_max``, ``step_down_status`` and ``h_failed`` with their attributes.

    Args:
        h_max: the resolved ``[analysis] h_max`` (``step``, ``count``, ``steps``).
        dims: the grid's dimensions.
        results: checked analysis output with the step-down keys.
        length: the model's length unit.
    """
    step, count, steps = float(h_max["step"]), int(h_max["count"]), int(h_max["steps"])
    limit = count * step
    comment = (
        f"From the periodic gait, the ground is lowered by h (a vertical drop, slope unchanged) at the "
        f"next touchdown and the walker must then complete {steps} more steps. Drops h = k * {step:g} "
        f"(k = 1, ..., {count}) are tried in increasing order until one fails; h_max is the largest "
        f"tried drop survived together with every smaller one: 0 if the smallest drop ({step:g}) "
        f"already fails, {limit:g} (the limit) if none failed up to it (a lower bound, not "
        "extrapolated). Survival need not be monotone in h, so a drop larger than h_failed might "
        "be survived; the search does not look past it. NaN where no gait was found (status != 0)."
    )
    return {
        "h_max": (
            dims,
            results["h_max"],
            {
                "long_name": "largest survived step-down (every smaller tested drop survived)",
                "units": length,
                "resolution": step,
                "limit": limit,
                "steps_after_drop": steps,
                "comment": comment,
            },
        ),
        "step_down_status": (
            dims,
            results["step_down_status"],
            {
                "long_name": (
                    "outcome of the step-down search: status of the first failed drop (0: no drop failed "
                    "up to the limit; where no gait was found, the gait's status)"
                ),
                **flag_attributes(),
            },
        ),
        "h_failed": (
            dims,
            results["h_failed"],
            {
                "long_name": "height of the first failed drop, h_max + resolution (NaN if none failed up to the limit)",
                "units": length,
            },
        ),
    }


def write_zarr(ds: xr.Dataset, target: str | Path, *, overwrite: bool = False) -> Path:
    """Write ``ds`` to the zarr v3 store ``target`` (consolidated metadata), atomically.

    The store is written to a hidden temporary directory beside ``target`` and
    renamed into place, so a failure leaves no half-written ``target``; an
    existing ``target`` is replaced only with ``overwrite``.

    Raises:
        FileExistsError: ``target`` exists and ``overwrite`` is false.
    """
    target = Path(target)
    target.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{target.name}.", suffix=".tmp", dir=target.parent))
    try:
        store = tmp / target.name
        with warnings.catch_warnings():
            # Consolidated metadata is a zarr-python extension to the v3 spec; xarray
            # reads it, and without it every open warns and lists the store.
            warnings.filterwarnings("ignore", message="Consolidated metadata is currently not part")
            ds.to_zarr(store, mode="w-", zarr_format=3, consolidated=True)
        if target.exists() or target.is_symlink():
            if not overwrite:
                raise FileExistsError(f"'{target}' already exists")
            old = tmp / "replaced"
            os.rename(target, old)
            try:
                os.rename(store, target)
            except BaseException:
                os.rename(old, target)
                raise
        else:
            os.rename(store, target)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return target
