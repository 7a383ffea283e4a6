"""The attractor variables of a sweep (``[analysis] attractors``): config, checks, layout.

With ``[analysis] attractors`` on, every grid point also says what the walker
settles on from its period-1 gait's neighbourhood (:mod:`jaxwalk.attractor`):

* ``attractor_status`` ``S``, int8 with CF flag attributes: 0 where an attractor
  was found; the gait's status where there is no period-1 gait; the failing
  step's (``fell``, ``scuffing``, ...), ``no_periodic_attractor`` (15) or
  ``cycle_not_found`` (16) where the walk from an unstable gait found none;
* ``attractor_period`` ``S``, int32: its number of steps k (0 where none);
* ``attractor_lambda_max`` ``S``: spectral radius of the k-step map's Jacobian;
* ``attractor_rate`` ``S``: the per-step contraction ``attractor_lambda_max ** (1/k)``;
* ``attractor_multipliers_real`` / ``_imag`` ``S + (eigen,)``: the k-step map's eigenvalues;
* ``attractor_points`` ``S + (cycle, section)``: the cycle's k points (fixed
  points of the k-step map) in the order walked, NaN rows beyond k.

The period-1 variables (``status``, ``lambda_max``, ...) keep their meaning.
"""

from __future__ import annotations

import math
from typing import Mapping

import numpy as np

from jaxwalk.status import RESULT_STATUSES, Status, flag_attributes

#: ``[analysis] attractors`` keys and the :class:`jaxwalk.attractor.AttractorOptions` fields they set.
KEYS = {"max_period": "max_period", "steps": "steps"}
#: The attractor's float variables, NaN where ``attractor_status != 0``.
FLOATS = ("attractor_lambda_max", "attractor_rate", "attractor_multipliers", "attractor_points")


def parse(value, fail) -> dict[str, int] | None:
    """``[analysis] attractors``: ``false``/absent (off), ``true`` (the defaults) or a
    table of ``max_period`` (a power of two) and ``steps``; resolved with the defaults."""
    where = "[analysis] attractors"
    if value is False:
        return None
    if value is not True and not isinstance(value, Mapping):
        raise fail(f"{where} must be true, false or a table {{ max_period = .., steps = .. }}, got {value!r}")
    table = {} if value is True else value
    for key in table:
        if key not in KEYS:
            raise fail(f"{where}: unknown key '{key}' (allowed: {', '.join(KEYS)})")
    from jaxwalk.attractor import AttractorOptions

    defaults = AttractorOptions()
    out = {"max_period": table.get("max_period", defaults.max_period), "steps": table.get("steps", defaults.steps)}
    for key, n in out.items():
        if isinstance(n, bool) or not isinstance(n, int) or n < 1:
            raise fail(f"{where}: {key} must be a positive integer, got {n!r}")
    if out["max_period"] & (out["max_period"] - 1):
        raise fail(f"{where}: max_period must be a power of two (periods 1, 2, 4, ... are tested), got {out['max_period']}")
    return out


def options(table: Mapping[str, int] | None):
    """The :class:`jaxwalk.attractor.AttractorOptions` of a resolved table, or ``None``."""
    if table is None:
        return None
    from jaxwalk.attractor import AttractorOptions

    return AttractorOptions(**{KEYS[k]: v for k, v in table.items()})


def result_keys(table: Mapping[str, int], n_v: int) -> dict[str, tuple[int, ...]]:
    """The attractor's result arrays and their trailing shapes."""
    return {
        "attractor_status": (), "attractor_period": (), "attractor_lambda_max": (), "attractor_rate": (),
        "attractor_multipliers": (n_v,), "attractor_points": (int(table["max_period"]), n_v),
    }


def template_value(key: str):
    """The fill value of a result array in a store's template (dtype included)."""
    return {"attractor_status": np.int8(0), "attractor_period": np.int32(0),
            "attractor_multipliers": np.complex128(complex(math.nan, math.nan))}.get(key, np.float64(math.nan))


def check(results: Mapping[str, np.ndarray], status: np.ndarray, keys: Mapping[str, tuple[int, ...]]) -> dict[str, np.ndarray]:
    """Check the attractor arrays of a block whose gait ``status`` is final.

    ``ValueError`` on a wrong shape or a code that is not a dataset status. Where
    there is no period-1 gait the attractor's status is the gait's; where
    ``attractor_status == 0`` a non-finite lambda_max, rate or first cycle point
    makes it ``NONFINITE``; wherever it is not 0 the floats are NaN and the period 0.
    """
    shape = status.shape
    out = {}
    for key, trailing in keys.items():
        if key not in results:
            raise ValueError(f"the analysis returned no {key}")
        value = np.asarray(results[key])
        if value.shape != shape + tuple(trailing):
            raise ValueError(f"the analysis returned '{key}' of shape {value.shape}, expected {shape + tuple(trailing)}")
        out[key] = value
    codes = out["attractor_status"]
    if not np.issubdtype(codes.dtype, np.integer) or not np.isin(codes, [int(s) for s in RESULT_STATUSES]).all():
        raise ValueError("the analysis returned attractor_status codes that are not dataset statuses")
    codes = np.where(status != Status.OK, status, codes).astype(np.int8)
    finite = np.isfinite(out["attractor_lambda_max"]) & np.isfinite(out["attractor_rate"])
    finite &= np.isfinite(out["attractor_points"][..., 0, :]).all(axis=-1)
    codes = np.where((codes == Status.OK) & ~finite, np.int8(Status.NONFINITE), codes).astype(np.int8)
    failed = codes != Status.OK
    out["attractor_status"] = codes
    out["attractor_period"] = np.where(failed, 0, out["attractor_period"]).astype(np.int32)
    for key in FLOATS:
        value = out[key]
        dtype = np.complex128 if key == "attractor_multipliers" else np.float64
        nan = complex(math.nan, math.nan) if key == "attractor_multipliers" else math.nan
        out[key] = np.where(failed.reshape(shape + (1,) * (value.ndim - len(shape))), nan, value).astype(dtype)
    return out


def variables(dims: tuple[str, ...], results: Mapping[str, np.ndarray]) -> dict[str, tuple]:
    """The attractor's data variables (``xarray`` tuples) for :func:`jaxwalk.sweep.dataset.build_dataset`."""
    mult = np.asarray(results["attractor_multipliers"])
    return {
        "attractor_status": (dims, results["attractor_status"], {
            "long_name": (
                "outcome of the attractor search from the period-1 gait's neighbourhood (0: an attractor was "
                "found; the gait's status where there is no period-1 gait)"
            ),
            **flag_attributes(),
        }),
        "attractor_period": (dims, results["attractor_period"], {
            "long_name": "number of steps k of the attractor's cycle (1: the period-1 gait; 0: no attractor)", "units": "1",
        }),
        "attractor_lambda_max": (dims, results["attractor_lambda_max"], {
            "long_name": "spectral radius of the attractor's k-step map Jacobian (below 1: stable)", "units": "1",
        }),
        "attractor_rate": (dims, results["attractor_rate"], {
            "long_name": "per-step contraction of the attractor, attractor_lambda_max ** (1 / attractor_period)",
            "units": "1",
        }),
        "attractor_multipliers_real": (dims + ("eigen",), mult.real.astype(np.float64, copy=False), {
            "long_name": "real part of the eigenvalues of the attractor's k-step map Jacobian", "units": "1",
        }),
        "attractor_multipliers_imag": (dims + ("eigen",), mult.imag.astype(np.float64, copy=False), {
            "long_name": "imaginary part of the eigenvalues of the attractor's k-step map Jacobian", "units": "1",
        }),
        "attractor_points": (dims + ("cycle", "section"), results["attractor_points"], {
            "long_name": (
                "the attractor's cycle: its k points (fixed points of the k-step map) in section coordinates, "
                "in the order walked; NaN beyond k"
            ),
        }),
    }
