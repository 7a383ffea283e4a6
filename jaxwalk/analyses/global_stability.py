"""``[analysis] gait_sensitivity`` and ``mfpt``: the global-stability measures of :mod:`jaxwalk.global_stability`.

Outputs (grid shape ``S``, NaN where no gait was found, ``status != 0``):

* ``gait_sensitivity_norm``: :mod:`~jaxwalk.global_stability.sensitivity_norm`;
  ``inf`` where the gait is unstable (``lambda_max >= 1``);
* ``mfpt``, ``mfpt_error``, ``mfpt_quasi_stationary``, ``mfpt_escaped``:
  :mod:`~jaxwalk.global_stability.mfpt`; ``mfpt`` is ``inf`` for ``sigma = 0``.

Their settings are declared here (:class:`GaitSensitivity`, :class:`Mfpt`) and
become a :class:`jaxwalk.global_stability.options.GlobalOptions` for the grid.
"""

from __future__ import annotations

import functools
from typing import Annotated, Any, ClassVar, Mapping

import numpy as np

from jaxwalk.analyses.base import Analysis, AtGait, Block, did_you_mean, row_program, switch
from jaxwalk.configs import Distinct, Table, field
from jaxwalk.outputs import Output


class GaitSensitivity(Table):
    """``[analysis] gait_sensitivity = { .. }`` (``true``: the default indicators)."""

    where: ClassVar[str] = "[analysis] gait_sensitivity"

    #: The gait indicators whose response the norm measures (names of
    #: :data:`jaxwalk.global_stability.sensitivity_norm.INDICATORS`; checked when resolved).
    indicators: Annotated[list[Any], Distinct] | None = field(None, "a non-empty array of distinct names", min_length=1, message=(
        "{where}: indicators must be {what} (known: {known}), got {value!r}"))


class Mfpt(Table):
    """``[analysis] mfpt = { sigma = .. }``: the terrain and the chain's discretisation; an
    absent key but ``sigma`` takes :class:`jaxwalk.global_stability.mfpt.MFPTOptions`' default."""

    where: ClassVar[str] = "[analysis] mfpt"

    sigma: float = field(what="a number >= 0 (model length units)", ge=0, allow_inf_nan=False, missing=(
        "{where}: needs sigma (the standard deviation of each step's ground height change, model length units)"))
    mesh: int | None = field(None, "an integer >= 3", ge=3)  # mesh points per principal axis
    span: float | None = field(None, "a positive number (standard deviations)", gt=0, allow_inf_nan=False)
    samples: int | None = field(None, "an integer >= 4", ge=4)  # terrain samples per mesh point
    max_axes: int | None = field(None, "an integer >= 1", ge=1)  # principal axes meshed, at most


def _gait_sensitivity(table, fail) -> dict[str, Any] | None:
    if table.get("gait_sensitivity", False) is False:
        return None  # off: the indicators' module (JAX) is not imported
    from jaxwalk.global_stability.sensitivity_norm import DEFAULT_INDICATORS, INDICATORS

    known = ", ".join(INDICATORS)
    given = switch(table, "gait_sensitivity", GaitSensitivity, fail, "{ indicators = [..] }", known=known)
    names = list(DEFAULT_INDICATORS) if given.indicators is None else given.indicators
    for name in names:
        if name not in INDICATORS:
            raise fail(f"{GaitSensitivity.where}: unknown indicator {name!r}{did_you_mean(name, INDICATORS)} (known: {known})")
    return {"indicators": list(names)}


def _mfpt(table, fail) -> dict[str, Any] | None:
    given = switch(table, "mfpt", Mfpt, fail, "{ sigma = .. }", true_is_defaults=False)
    if given is None:
        return None
    from jaxwalk.global_stability.mfpt import MFPTOptions

    value = {k: getattr(MFPTOptions, k) if v is None else v for k, v in given.model_dump().items()}
    # In this order: the resolved config's fingerprint.
    return {"sigma": float(value["sigma"]), "span": float(value["span"]),
            **{k: value[k] for k in ("mesh", "samples", "max_axes")}}

MFPT_KEYS = ("mfpt", "mfpt_error", "mfpt_quasi_stationary", "mfpt_escaped")


def _gsn_units(units: Mapping[str, str]) -> str:
    return "1" if (units["length"], units["time"]) == ("1", "1") else f"indicator units per {units['length']}"


def _gsn_attrs(resolved: Mapping[str, Any], units: Mapping[str, str]) -> dict[str, Any]:
    return {
        "indicators": " ".join(resolved["gait_sensitivity"]["indicators"]),
        "comment": (
            "Hobbelen & Wisse (2007): sqrt(D^2 + sum_k |C J^k B|^2) for x+ = J x + B e, y = C x + D e, "
            "e the drop of the ground at a step's touchdown, y the indicators (model units, unscaled); "
            "exact forward-mode Jacobians, Lyapunov equation by Smith's doubling; inf where lambda_max >= 1"
        ),
    }


def _mfpt_attrs(resolved: Mapping[str, Any], units: Mapping[str, str]) -> dict[str, Any]:
    m = resolved["mfpt"]
    return {
        "comment": (
            f"every step's ground height change i.i.d. N(0, {m['sigma']:g}^2) {units['length']}; discretised "
            "step-to-step Markov chain with an absorbing failure state (jaxwalk.global_stability.mfpt); "
            "inf for sigma = 0 and where its failure rate per step is below 1e-10"
        ),
        **{f"mfpt_{k}": v for k, v in m.items()},
    }


GSN = Output(
    "gait_sensitivity_norm", "float64",
    "gait sensitivity norm: H2 norm of the step-to-step response of the gait indicators to a floor-height disturbance",
    units=_gsn_units, label="gait sensitivity norm", meaning="response of step time and length to floor height (H2 norm)",
    differentiable=True, plot=30, attrs=_gsn_attrs, finite_where_ok=True, inf_is_a_value=True,
)
MFPT = (
    Output("mfpt", "float64", "mean first-passage time: expected completed steps before a failure, from the gait",
           units="steps", label="MFPT", meaning="mean steps before a fall on random terrain", plot=40, log_scale=True,
           attrs=_mfpt_attrs),
    Output("mfpt_error", "float64",
           "discretisation error estimate of mfpt: |mfpt - mfpt on a mesh and terrain grid half as fine|", units="steps",
           log_scale=True),
    Output("mfpt_quasi_stationary", "float64", "1 / (1 - lambda_d), lambda_d the chain's dominant eigenvalue (Byl & Tedrake)",
           units="steps", log_scale=True),
    Output("mfpt_escaped", "float64", "fraction of the chain's transition mass that left the mesh box (moved onto its surface)"),
)


@functools.lru_cache(maxsize=None)
def _gsn_program(model, indicators: tuple[str, ...], solver, sub_batch: int):
    """Rows (parameters, inputs :class:`~jaxwalk.analyses.base.AtGait`) -> the gait
    sensitivity norm; one compiled shape for every grid (:func:`jaxwalk.batching.run_chunks`)."""
    from jaxwalk.global_stability.sensitivity_norm import gait_sensitivity_norm

    def one(p, at):
        return gait_sensitivity_norm(model, p, at.v_star, indicators, solver)

    return row_program(one, sub_batch, "gait_sensitivity_norm", model, indicators, solver)


def grid_outputs(model, params: Mapping[str, np.ndarray], gaits, status: np.ndarray, solver, options, run=None,
                 sub_batch: int = 64) -> dict[str, np.ndarray]:
    """The outputs ``options`` (a :class:`~jaxwalk.global_stability.options.GlobalOptions`)
    asks for, shaped like ``status`` (``S``).

    Args:
        params: every parameter as an ``S`` array; ``gaits.v``: ``S + (n_v,)`` fixed points.
        run: ``run(program, rows)``, the block's row runner (:class:`Block`; default:
            :func:`jaxwalk.batching.run_chunks` in calls of 256 rows).
        sub_batch: rows advancing together in the norm's program.
    """
    import jax.numpy as jnp

    from jaxwalk.batching import Rows

    shape = status.shape
    rows = {k: jnp.asarray(np.asarray(v).reshape(-1)) for k, v in params.items()}
    v = np.asarray(gaits.v).reshape(-1, np.asarray(gaits.v).shape[-1])
    ok = status.reshape(-1) == 0
    out = {}
    if options.gait_sensitivity is not None:
        if run is None:
            from jaxwalk.batching import run_chunks

            run = lambda program, rows_: run_chunks(program, rows_, 256, None)  # noqa: E731
        program = _gsn_program(model, tuple(options.gait_sensitivity), solver, sub_batch)
        at = AtGait(np.where(ok[:, None], v, 0.0))
        gsn = np.asarray(run(program, Rows({k: np.asarray(x) for k, x in rows.items()}, at)))
        out["gait_sensitivity_norm"] = np.where(ok, gsn, np.nan).reshape(shape)
    if options.mfpt is not None:
        values = _mfpt_values(model, rows, v, ok, options.mfpt, solver)
        for j, key in enumerate(MFPT_KEYS):
            out[key] = values[:, j].reshape(shape)
    return out


def _mfpt_values(model, rows, v: np.ndarray, ok: np.ndarray, settings, solver) -> np.ndarray:
    """``(n, 4)``: :data:`MFPT_KEYS` of each row's gait (NaN where ``ok`` is False), the
    gaits' chains planned first so that a :func:`jaxwalk.progress.stage` counts their step maps."""
    from jaxwalk.global_stability import mfpt
    from jaxwalk.progress import stage

    options = mfpt.MFPTOptions(**dict(settings))
    values = np.full((len(ok), 4), np.nan)
    if options.sigma == 0.0:  # nothing to plan: the walker never falls
        for i in np.flatnonzero(ok):
            values[i] = mfpt.mfpt(model, {}, v[i], options)[:4]
        return values
    plans = {int(i): mfpt.plan(model, {k: float(x[i]) for k, x in rows.items()}, v[i], options, solver) for i in np.flatnonzero(ok)}
    with stage(f"mfpt, {len(plans)} gaits", sum(p.steps for p in plans.values()), "step") as advance:
        for i, chains in plans.items():
            r = mfpt.run(model, chains, options.sigma, solver, advance)
            values[i] = (r.mfpt, r.error, r.quasi_stationary, r.escaped)
    return values


class GlobalStability(Analysis):
    name = "global_stability"
    keys = ("gait_sensitivity", "mfpt")
    order = 30
    off: Any = {}
    options_field = "global_stability"

    def parse(self, table, fail, *, continuation) -> dict[str, Any]:
        """The resolved keys that are set (``{}`` when neither is)."""
        found = {"gait_sensitivity": _gait_sensitivity(table, fail), "mfpt": _mfpt(table, fail)}
        return {k: v for k, v in found.items() if v is not None}

    def to_dict(self, resolved) -> dict[str, Any]:
        return dict(resolved)  # only the keys that are set: fingerprints unchanged without them

    def grid_options(self, resolved):
        from jaxwalk.global_stability.options import global_options

        return global_options(resolved) if resolved else None

    def compute(self, block: Block) -> dict[str, np.ndarray]:
        options = block.options
        return grid_outputs(block.model, block.params, block.gaits, block.results["status"], options.solver,
                            options.global_stability, block.run, block.sub_batch)

    def outputs(self, resolved) -> tuple[Output, ...]:
        return (GSN,) * ("gait_sensitivity" in resolved) + MFPT * ("mfpt" in resolved)

    def fullest(self):
        return {"gait_sensitivity": {}, "mfpt": {}}

    def key_of(self, output: str) -> str:
        return "gait_sensitivity" if output == GSN.name else "mfpt"

    def gradient(self, quantity: str, model, names: tuple[str, ...], solver, newton):
        from jaxwalk.global_stability.sensitivity_norm import norm_and_gradient

        return lambda p, v0: norm_and_gradient(model, p, v0, names, solver, newton)


ANALYSIS = GlobalStability()
