"""The sweep outputs of :mod:`jaxwalk.global_stability`: computed per block, checked, laid out.

Hooks: :func:`jaxwalk.grid.analyse_chunk` calls :func:`grid_outputs`;
:mod:`jaxwalk.sweep.runner` takes :func:`result_keys` and :func:`check`;
:mod:`jaxwalk.sweep.dataset` takes :func:`dataset_variables`.

Outputs (grid shape ``S``, NaN where no gait was found, ``status != 0``):

* ``gait_sensitivity_norm``: :mod:`~jaxwalk.global_stability.sensitivity_norm`;
  ``inf`` where the gait is unstable (``lambda_max >= 1``);
* ``mfpt``, ``mfpt_error``, ``mfpt_quasi_stationary``, ``mfpt_escaped``:
  :mod:`~jaxwalk.global_stability.mfpt`; ``mfpt`` is ``inf`` for ``sigma = 0``.
"""

from __future__ import annotations

import functools
from typing import Any, Mapping

import jax
import jax.numpy as jnp
import numpy as np

from jaxwalk.global_stability.options import GlobalOptions
from jaxwalk.global_stability.sensitivity_norm import gait_sensitivity_norm
from jaxwalk.step import SolverOptions
from jaxwalk.walker import Walker

GSN_KEYS = ("gait_sensitivity_norm",)
MFPT_KEYS = ("mfpt", "mfpt_error", "mfpt_quasi_stationary", "mfpt_escaped")


@functools.lru_cache(maxsize=None)
def _gsn_program(model: Walker, indicators: tuple[str, ...], solver: SolverOptions):
    return jax.jit(jax.vmap(lambda p, v: gait_sensitivity_norm(model, p, v, indicators, solver)))


def grid_outputs(
    model: Walker, params: Mapping[str, np.ndarray], gaits, status: np.ndarray, solver: SolverOptions, options: GlobalOptions
) -> dict[str, np.ndarray]:
    """The outputs ``options`` asks for, shaped like ``status`` (``S``).

    Args:
        params: every parameter as an ``S`` array; ``gaits.v``: ``S + (n_v,)`` fixed points.
    """
    shape = status.shape
    rows = {k: jnp.asarray(np.asarray(v).reshape(-1)) for k, v in params.items()}
    v = np.asarray(gaits.v).reshape(-1, np.asarray(gaits.v).shape[-1])
    ok = status.reshape(-1) == 0
    out = {}
    if options.gait_sensitivity is not None:
        gsn = np.asarray(_gsn_program(model, options.gait_sensitivity, solver)(rows, jnp.asarray(np.where(ok[:, None], v, 0.0))))
        out["gait_sensitivity_norm"] = np.where(ok, gsn, np.nan).reshape(shape)
    if options.mfpt is not None:
        from jaxwalk.global_stability.mfpt import MFPTOptions, mfpt

        mo = MFPTOptions(**dict(options.mfpt))
        values = np.full((len(ok), 4), np.nan)
        for i in np.flatnonzero(ok):
            r = mfpt(model, {k: float(x[i]) for k, x in rows.items()}, v[i], mo, solver)
            values[i] = (r.mfpt, r.error, r.quasi_stationary, r.escaped)
        for j, key in enumerate(MFPT_KEYS):
            out[key] = values[:, j].reshape(shape)
    return out


def result_keys(resolved: Mapping[str, Any]) -> dict[str, bool]:
    """The result keys a config's resolved global-stability settings add (none has a section axis)."""
    keys = GSN_KEYS * ("gait_sensitivity" in resolved) + MFPT_KEYS * ("mfpt" in resolved)
    return {k: False for k in keys}


def check(results: Mapping[str, np.ndarray], status: np.ndarray, resolved: Mapping[str, Any]) -> dict[str, np.ndarray]:
    """The checked outputs: float64 of ``status``'s shape, NaN where ``status != 0``.

    Raises:
        ValueError: a key is missing or has another shape.
    """
    out = {}
    for key in result_keys(resolved):
        if key not in results:
            raise ValueError(f"the analysis returned no {key}")
        value = np.asarray(results[key], np.float64)
        if value.shape != status.shape:
            raise ValueError(f"the analysis returned '{key}' of shape {value.shape}, expected {status.shape}")
        out[key] = np.where(status == 0, value, np.nan)
    return out


def dataset_variables(resolved: Mapping[str, Any], dims: tuple[str, ...], results: Mapping[str, np.ndarray], units: Mapping[str, str]) -> dict[str, tuple]:
    """The dataset variables of the outputs, with their attributes."""
    out = {}
    if "gait_sensitivity" in resolved:
        names = resolved["gait_sensitivity"]["indicators"]
        out["gait_sensitivity_norm"] = (
            dims,
            results["gait_sensitivity_norm"],
            {
                "long_name": "gait sensitivity norm: H2 norm of the step-to-step response of the gait indicators to a floor-height disturbance",
                "units": "1" if (units["length"], units["time"]) == ("1", "1") else f"indicator units per {units['length']}",
                "indicators": " ".join(names),
                "comment": (
                    "Hobbelen & Wisse (2007): sqrt(D^2 + sum_k |C J^k B|^2) for x+ = J x + B e, y = C x + D e, "
                    "e the drop of the ground at a step's touchdown, y the indicators (model units, unscaled); "
                    "exact forward-mode Jacobians, Lyapunov equation by Smith's doubling; inf where lambda_max >= 1"
                ),
            },
        )
    if "mfpt" in resolved:
        m = resolved["mfpt"]
        common = {f"mfpt_{k}": v for k, v in m.items()}
        out["mfpt"] = (
            dims,
            results["mfpt"],
            {
                "long_name": "mean first-passage time: expected completed steps before a failure, from the gait",
                "units": "steps",
                "comment": (
                    f"every step's ground height change i.i.d. N(0, {m['sigma']:g}^2) {units['length']}; discretised "
                    "step-to-step Markov chain with an absorbing failure state (jaxwalk.global_stability.mfpt); inf for sigma = 0"
                ),
                **common,
            },
        )
        out["mfpt_error"] = (dims, results["mfpt_error"], {"long_name": "discretisation error estimate of mfpt: |mfpt - mfpt on a mesh and terrain grid half as fine|", "units": "steps"})
        out["mfpt_quasi_stationary"] = (dims, results["mfpt_quasi_stationary"], {"long_name": "1 / (1 - lambda_d), lambda_d the chain's dominant eigenvalue (Byl & Tedrake)", "units": "steps"})
        out["mfpt_escaped"] = (dims, results["mfpt_escaped"], {"long_name": "fraction of the chain's transition mass that left the mesh box (moved onto its surface)", "units": "1"})
    return out
