"""``[analysis] basin``: the basin of attraction of each gait on the Poincare section.

The measure is :mod:`jaxwalk.global_stability.basin` (its docstring defines the
fate of a start, the scaled norm, the ball and the rays); this plug-in reads its
settings, runs it on a block's gaits and declares its outputs (grid shape ``S``):

* ``basin_status`` ``S``, int8 with CF flag attributes: 0 where measured; the
  gait's status where there is no gait; ``unstable_gait`` (18) where the gait is
  unstable and no attractor of it is known (``[analysis] attractors`` off), or the
  attractor search's status where it found none; ``not_a_state`` (20) where no
  start of the ball is a state of the walker;
* ``basin_fraction``, ``basin_fraction_error`` ``S``: share of the ball's random
  starts that are states of the walker which returned to the gait's cycle within
  ``steps`` steps, and its binomial standard error;
* ``basin_radius`` ``S`` and ``basin_ray_radius`` ``S + (direction,)``: the
  smallest ray radius, and each ray's (scaled norm, dimensionless).

The target cycle is the gait where it is stable; with ``[analysis] attractors``
on, the attractor cycle it settles on (so an unstable gait past a flip has the
period-2 cycle's basin, measured from a ball about the unstable fixed point).
"""

from __future__ import annotations

import functools
from typing import Annotated, Any, ClassVar

import numpy as np
from pydantic import Field

from jaxwalk import outputs as schema
from jaxwalk.analyses.base import Analysis, Block, did_you_mean, run_with_bar, switch
from jaxwalk.configs import Distinct, Table, field
from jaxwalk.outputs import Output
from jaxwalk.status import Status

_Positive = Annotated[float, Field(gt=0, allow_inf_nan=False)]


class Settings(Table):
    """``[analysis] basin = { .. }``: the measure's settings, the fields of
    :class:`jaxwalk.global_stability.basin.BasinOptions` (its docstring defines them;
    these defaults are its defaults, which a test holds equal)."""

    where: ClassVar[str] = "[analysis] basin"
    must: ClassVar[str] = "{where}: {key} must be {what}, got {value!r}"

    radius: float | None = field(None, "a positive number (scaled section norm)", gt=0, allow_inf_nan=False)  # of the ball of starts
    # Caps as the basin command's starts (jaxwalk.basin.config.MAX_STARTS) and a walk's steps
    # (jaxwalk.simulate.config.MAX_STEPS): a typo's 1e9 is refused, not run for a year.
    samples: int = field(256, "an integer >= 2", ge=2, le=1_000_000, messages={  # random starts in the ball
        "less_than_equal": "{where}: {key} = {value} is more than the limit of 1000000"})
    steps: int = field(60, "an integer >= 1", ge=1, le=1000, messages={  # most steps walked from a start
        "less_than_equal": "{where}: {key} = {value} is more than the limit of 1000"})
    tol: float = field(1e-4, "a positive number (scaled section norm)", gt=0, allow_inf_nan=False)  # "returned" within this
    directions: int = field(16, "an integer >= 1", ge=1)  # rays from the fixed point
    scan: int = field(8, "an integer >= 1", ge=1)  # radii scanned along a ray before bisecting
    bisections: int = field(10, "an integer >= 0", ge=0)  # halvings of a ray's failing interval
    scale: list[_Positive] | None = field(None, "an array of positive numbers, one per section coordinate", min_length=1)
    coordinates: Annotated[list[str], Distinct] | None = field(None, "a non-empty array of distinct section coordinate names", min_length=1)
    seed: int = field(0, "an integer >= 0", ge=0)  # of the random starts


#: ``[analysis] basin`` keys and their defaults (``radius``, ``scale``: ``None``, the model's;
#: ``coordinates``: ``None``, every coordinate).
DEFAULTS: dict[str, Any] = {k: info.default for k, info in Settings.model_fields.items()}


def _attrs(resolved, units) -> dict[str, Any]:
    settings = {"scale": "1 for every coordinate", "coordinates": "all", **resolved}
    return {
        **{"basin_" + k: " ".join(map(str, v)) if isinstance(v, list) else v for k, v in settings.items()},
        "norm": "sqrt(sum_i ((v_i - v*_i) / scale_i)^2) over the perturbed section coordinates (jaxwalk.global_stability.basin)",
    }


OUTPUTS = (
    Output("basin_status", "int8", (
        "outcome of the basin measure (0: measured; the gait's status where there is no gait; unstable_gait where "
        "the gait is unstable and no attractor of it is known; the attractor search's status where it found none; "
        "not_a_state where no start of the ball is a state of the walker)"
    ), units=None, flags=True),
    Output("basin_fraction", "float64", (
        "share of random starts uniform in a ball about the fixed point (scaled section norm), of those that are "
        "states of the walker, that return to within tol of the gait's cycle in at most steps steps"
    ), label="basin fraction", meaning="share of perturbed starts that return to the gait", plot=45,
        finite_where_ok=True, attrs=_attrs),
    Output("basin_fraction_error", "float64", "binomial standard error of basin_fraction, sqrt(f (1 - f) / n), n the starts that are states",
           finite_where_ok=True),
    Output("basin_radius", "float64", (
        "radius of the largest ball about the fixed point inside the basin as the rays see it: the smallest "
        "basin_ray_radius (scaled section norm)"
    ), label="basin radius", meaning="distance to the basin's nearest edge along the rays", plot=46,
        finite_where_ok=True, attrs=_attrs),
    Output("basin_ray_radius", "float64", (
        "along each ray from the fixed point, the largest radius confirmed to return before the first failing "
        "one (scaled section norm; radius itself where no scanned start failed, a lower bound; a start that is "
        "not a state of the walker is no failure: a ray with none on it reads radius, nothing walked)"
    ), trailing=("direction",), finite_where_ok=True),
)


@functools.lru_cache(maxsize=None)
def _program(model, items: tuple, solver):
    from jaxwalk.global_stability.basin import BasinOptions, basin_program

    return basin_program(model, BasinOptions(**options_of_items(model, items)), solver)


def options_of_items(model, items: tuple) -> dict[str, Any]:
    """:class:`~jaxwalk.global_stability.basin.BasinOptions` fields from resolved ``(key, value)`` pairs
    (coordinate names -> indices of ``model.section_names``)."""
    fields = dict(items)
    names = fields.pop("coordinates", None)
    fields["coordinates"] = None if names is None else tuple(model.section_names.index(n) for n in names)
    fields["scale"] = None if fields.get("scale") is None else tuple(fields["scale"])
    return fields


def resolve(given: Settings, written) -> dict[str, Any]:
    """The settings (TOML/JSON-ready) of a checked table and the keys ``written``:
    every default but ``radius``, ``scale`` and ``coordinates``, which appear only
    when given (after the others, in the order written) until :func:`with_model`."""
    values = given.model_dump()
    out = {k: v for k, v in DEFAULTS.items() if v is not None}
    out.update((k, values[k]) for k in written)
    return out


def with_model(resolved: dict[str, Any], model) -> dict[str, Any]:
    """``resolved`` with the model's ball where none is given: ``radius`` first (where
    it always stood), ``scale`` after the others (:attr:`Walker.basin_radius`,
    :attr:`Walker.basin_scale`; no ``scale`` where the model has none)."""
    out = {"radius": model.basin_radius, **resolved}
    if "scale" not in out and model.basin_scale is not None:
        out["scale"] = list(model.basin_scale)
    return out


def check_section(resolved, model, fail, where: str = "[analysis] basin") -> None:
    """``coordinates`` name section coordinates of ``model`` and ``scale`` has one entry per coordinate."""
    names = tuple(model.section_names)
    for n in resolved.get("coordinates") or ():
        if n not in names:
            raise fail(f"{where}: unknown section coordinate '{n}'{did_you_mean(n, names)} of the {model.name} model "
                       f"(its section: {', '.join(names)})")
    scale = resolved.get("scale")
    if scale is not None and len(scale) != len(names):
        raise fail(f"{where}: scale has {len(scale)} entries, the {model.name} model's section {len(names)} ({', '.join(names)})")


def targets_of(block: Block) -> tuple[np.ndarray, np.ndarray]:
    """``(codes, targets)``: per point ``OK`` where a stable cycle is known, else why not
    (``S``, int8), and the cycle ``S + (P, n_v)`` (NaN rows beyond its period)."""
    res = block.results
    status = np.asarray(res["status"])
    v = np.asarray(block.gaits.v)
    if "attractor_points" in res:
        codes = np.where(status != Status.OK, status, res["attractor_status"]).astype(np.int8)
        return codes, np.asarray(res["attractor_points"])
    stable = np.asarray(res["lambda_max"]) < 1.0
    codes = np.where(status != Status.OK, status, np.where(stable, Status.OK, Status.UNSTABLE_GAIT)).astype(np.int8)
    return codes, v[..., None, :]


class BasinAnalysis(Analysis):
    name = "basin"
    keys = ("basin",)
    order = 35
    status_of_outputs = "basin_status"

    def parse(self, table, fail, *, continuation):
        """``false``/absent (off), ``true`` (the defaults) or a table of :data:`DEFAULTS`' keys."""
        given = switch(table, "basin", Settings, fail, "{ radius = .., samples = .., steps = .. }")
        if given is None:
            return None
        written = table["basin"] if given.model_fields_set else ()  # true: nothing written
        return resolve(given, written)

    def check_model(self, resolved, model, fail) -> None:
        """The section's names and sizes, and ``tol`` below the ball's radius (the model's
        where none is given)."""
        if resolved is None:
            return
        check_section(resolved, model, fail)
        radius = resolved.get("radius", model.basin_radius)
        if resolved["tol"] >= radius:
            raise fail(f"{Settings.where}: tol ({resolved['tol']}) must be below radius ({radius})")

    def for_model(self, resolved, model):
        return None if resolved is None else with_model(resolved, model)

    def fullest(self):
        return dict(DEFAULTS)

    def grid_options(self, resolved):
        if resolved is None:
            return None
        return tuple((k, tuple(v) if isinstance(v, list) else v) for k, v in sorted(resolved.items()))

    def compute(self, block: Block) -> dict[str, np.ndarray]:
        items = self.options_of(block.options)
        fields = dict(items)
        codes, targets = targets_of(block)
        shape, n_dir = block.shape, int(fields["directions"])
        out = {"basin_status": codes.copy(), "basin_fraction": np.full(shape, np.nan),
               "basin_fraction_error": np.full(shape, np.nan), "basin_radius": np.full(shape, np.nan),
               "basin_ray_radius": np.full(shape + (n_dir,), np.nan)}
        where = np.flatnonzero(codes.reshape(-1) == Status.OK)
        if where.size:
            from jaxwalk.batching import Rows
            from jaxwalk.global_stability.basin import BasinStart

            at = block.rows_at_gaits()
            start = BasinStart(at.inputs.v_star[where], targets.reshape((-1,) + targets.shape[len(shape):])[where])
            rows = Rows({k: x[where] for k, x in at.params.items()}, start)
            # A flat-foot gait's basin is hundreds of walks, one at a time: minutes.
            found = run_with_bar(block, _program(block.model, items, block.options.solver), rows, "basin", "gait")
            for key, name in (("basin_fraction", "fraction"), ("basin_fraction_error", "fraction_error"),
                              ("basin_radius", "radius"), ("basin_ray_radius", "ray_radius")):
                flat = out[key].reshape((-1,) + out[key].shape[len(shape):])
                flat[where] = np.asarray(getattr(found, name))
            # No start of the ball is a state (only NaN fraction the measure gives): say so, not "nonfinite".
            no_states = where[np.all(np.asarray(found.sample_status) == Status.NOT_A_STATE, axis=-1)]
            out["basin_status"].reshape(-1)[no_states] = Status.NOT_A_STATE
        return out

    def outputs(self, resolved=None) -> tuple[Output, ...]:
        return OUTPUTS

    def sizes(self, resolved, n_v: int) -> dict[str, int]:
        return {"section": n_v, "eigen": n_v, "direction": int(resolved["directions"])}

    def finalise(self, arrays, status, resolved) -> dict[str, np.ndarray]:
        """The gait's status where it has none; ``NONFINITE`` where a measured number is not
        finite; every number NaN wherever ``basin_status != 0``."""
        codes = np.where(status != Status.OK, status, arrays["basin_status"]).astype(np.int8)
        codes = schema.nonfinite(codes, arrays, OUTPUTS)
        return {"basin_status": codes, **schema.blank(arrays, OUTPUTS, codes != Status.OK)}


ANALYSIS = BasinAnalysis()
