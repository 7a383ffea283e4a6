"""Run a :class:`~jaxwalk.branches.config.ContinueConfig`: every start's branch under
one ``vmap``, the labelled points located on them, optionally the period-2k
branch born at each flip, and one self-describing xarray/zarr dataset.

Dataset layout (dims ``branch``, ``point``, ``section``, ``multiplier``, ``label``):
per branch ``period``, ``stop`` (:class:`~jaxwalk.arclength.Stop`), ``failure``,
``n_points``, ``origin`` (-1 for a start's branch, else the label row of the flip
it was switched from); per point ``parameter`` (the continuation parameter),
``v``, ``multipliers_real/imag``, ``lambda_max``, ``stable``, ``ds``,
``iterations``, ``point_status``; per label ``label_kind``
(:class:`~jaxwalk.bifurcation.Kind`), ``label_parameter``, ``label_branch``,
``label_period``, ``label_status``, ``label_v``, ``label_multipliers_real/imag``.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np
import xarray as xr

from jaxwalk import compiling
from jaxwalk.arclength import ArclengthOptions, Branch, CycleProblem, STOP_MEANINGS, continue_branch, start_direction
from jaxwalk.bifurcation import KIND_MEANINGS, Kind
from jaxwalk.branches.config import ContinueConfig
from jaxwalk.branchpoints import BranchPoints, locate_on_branches, switch_at_flip
from jaxwalk.models import get_model
from jaxwalk.status import flag_attributes
from jaxwalk.files import check_output, provenance, write_zarr

#: The location's regula falsi iterations per labelled point (a progress bar's bound).
LOCATE_ITERATIONS = 80
from jaxwalk.sweep.dataset import section_attrs


def run_branches(config: ContinueConfig, progress: bool = False):
    """``(branches, labels, period, origin)``: NumPy :class:`Branch` leaves with a leading
    ``branch`` axis (start branches first, then switched ones, padded to one length), the
    :class:`BranchPoints` of all of them, each branch's period and origin. ``progress``:
    a line on stderr as each stage starts (a branch is one program call: no bar inside
    it) and a bar, with the time left, over the location's rounds of solves."""
    say = _Stages(progress)
    model = get_model(config.model)
    problem = CycleProblem(model, config.parameter, config.period)
    starts = np.asarray(config.starts)
    params = {k: jnp.full(len(starts), v) for k, v in config.fixed.items()}
    params[config.parameter] = jnp.asarray(starts)
    lo, hi = config.bounds

    def one(p):
        v0 = model.initial_guess(p)
        return continue_branch(problem, p, v0, p[config.parameter], start_direction(v0.shape[0], config.direction), 0.0, lo, hi, config.options)

    say(f"continuing {len(starts)} branch{'es' if len(starts) > 1 else ''} of the {model.name} model in "
        f"{config.parameter} (the first run of a model compiles, a minute or more; cached afterwards)")
    first = jax.tree_util.tree_map(np.asarray, compiling.jit(jax.vmap(one), model)(params))
    say.done(f"{int(first.n_points.sum())} points")
    with say.rounds("locating folds, flips and Neimark-Sacker points") as advance:
        labels = locate_on_branches(problem, params, first, tol=config.tol, max_iter=LOCATE_ITERATIONS,
                                    options=config.options, advance=advance)
    parts, periods, origins = [first], [config.period] * len(starts), [-1] * len(starts)
    flips = np.flatnonzero((labels.kind == Kind.FLIP) & (labels.status == 0)) if config.switch_branches else []
    if len(flips):
        opts = ArclengthOptions(**{**_fields(config.options), "max_steps": config.switch_max_steps})
        say(f"switching onto the period-{2 * config.period} branch at {len(flips)} flip{'s' if len(flips) > 1 else ''}")
        switched = _switch(problem, config, labels, flips, opts)
        say.done(f"{int(switched[2].n_points.sum())} points")
        with say.rounds("locating their folds, flips and Neimark-Sacker points") as advance:
            more = locate_on_branches(switched[0], switched[1], switched[2], tol=config.tol, max_iter=LOCATE_ITERATIONS,
                                      options=opts, advance=advance)
        more = more._replace(branch=more.branch + len(starts))
        parts.append(switched[2]); periods += [2 * config.period] * len(flips); origins += flips.tolist()
        labels = BranchPoints(*(np.concatenate([a, b]) for a, b in zip(labels, more)))
    return _concat(parts), labels, np.asarray(periods, np.int32), np.asarray(origins, np.int32)


def _switch(problem, config: ContinueConfig, labels: BranchPoints, flips: np.ndarray, opts: ArclengthOptions):
    """The period-2k branches from the flips ``flips`` (label rows), under one vmap."""
    lo, hi = config.bounds
    params = {k: jnp.full(len(flips), v) for k, v in config.fixed.items()}
    params[config.parameter] = jnp.asarray(labels.parameter[flips])
    run = jax.vmap(lambda p, v, w, x: switch_at_flip(problem, p, v, w, x, lo, hi, config.switch_eps, 1.0, opts))
    out = compiling.jit(run, problem.model)(params, jnp.asarray(labels.v[flips]), jnp.asarray(labels.eigenvector[flips]), jnp.asarray(labels.parameter[flips]))
    return dataclasses.replace(problem, k=2 * problem.k), params, jax.tree_util.tree_map(np.asarray, out)


class _Stages:
    """Stage lines and a rounds bar on stderr, or nothing."""

    def __init__(self, on: bool):
        self.on, self.started = on, None

    def __call__(self, line: str) -> None:
        import sys
        import time

        self.started = time.perf_counter()
        if self.on:
            print(line, file=sys.stderr, flush=True)

    def done(self, what: str) -> None:
        import sys
        import time

        if self.on:
            print(f"  {what} in {time.perf_counter() - self.started:.0f} s", file=sys.stderr, flush=True)

    def rounds(self, desc: str, most: int = LOCATE_ITERATIONS + 1):
        """A bar over the location's rounds: ``most`` at most (its total, so the time
        left shown is an upper bound; the regula falsi usually ends far sooner)."""
        import contextlib
        import sys

        if not self.on:
            return contextlib.nullcontext(lambda n: None)
        from tqdm.auto import tqdm

        @contextlib.contextmanager
        def bar():
            with tqdm(desc=desc, total=most, unit="round", file=sys.stderr, leave=False) as b:
                yield b.update
                b.total = b.n  # ended sooner: done
                b.refresh()

        return bar()


def _fields(options: ArclengthOptions) -> dict:
    return {f.name: getattr(options, f.name) for f in dataclasses.fields(options)}


def _concat(parts: list[Branch]) -> Branch:
    """Branches of different record lengths along one ``branch`` axis (NaN / fill padded)."""
    n = max(p.p.shape[1] for p in parts)

    def pad(x, fill):
        if x.ndim < 2 or x.shape[1] == n:
            return x
        width = [(0, 0), (0, n - x.shape[1])] + [(0, 0)] * (x.ndim - 2)
        return np.pad(x, width, constant_values=fill)

    fills = Branch(0, 0, 0, 0, np.nan, np.nan, np.nan, np.nan, np.nan, np.nan, 0, 13)
    return Branch(*(np.concatenate([pad(getattr(p, f), getattr(fills, f)) for p in parts]) for f in Branch._fields))


def build_dataset(config: ContinueConfig, branches: Branch, labels: BranchPoints, period: np.ndarray,
                  origin: np.ndarray, command: str | None = None) -> xr.Dataset:
    """The branches and their labelled points as one dataset (module docstring), attributes self-describing."""
    model = get_model(config.model)
    spec = model.param_specs[config.parameter]
    mu = branches.multipliers
    flags = flag_attributes()
    bp, bps, bpsm, lab = ("branch", "point"), ("branch", "point", "section"), ("branch", "point", "multiplier"), ("label",)
    data = {
        "period": ("branch", period, {"long_name": "steps k of the branch's map"}),
        "origin": ("branch", origin, {"long_name": "label row of the flip the branch was switched from (-1: a start's branch)"}),
        "stop": ("branch", branches.stop.astype(np.int8), {"long_name": "why the branch ended",
                 "flag_values": [int(s) for s in STOP_MEANINGS], "flag_meanings": " ".join(s.name.lower() for s in STOP_MEANINGS),
                 "flag_descriptions": "; ".join(f"{int(s)} {s.name.lower()}: {m}" for s, m in STOP_MEANINGS.items())}),
        "failure": ("branch", branches.failure.astype(np.int8), {"long_name": "status of the last failed corrector (ok: none)", **flags}),
        "n_points": ("branch", branches.n_points.astype(np.int32), {"long_name": "points recorded"}),
        "parameter": (bp, branches.p, {"long_name": spec.description, "units": spec.units}),
        "v": (bps, branches.v, {"long_name": "fixed point of the k-step map (section coordinates)", **section_attrs(model)}),
        "multipliers_real": (bpsm, mu.real, {"long_name": "multipliers of the k-step map, real part (largest modulus first)"}),
        "multipliers_imag": (bpsm, mu.imag, {"long_name": "multipliers of the k-step map, imaginary part"}),
        "lambda_max": (bp, branches.lambda_max, {"long_name": "largest multiplier modulus of the k-step map", "units": "1"}),
        "stable": (bp, branches.lambda_max < 1.0, {"long_name": "lambda_max < 1"}),
        "ds": (bp, branches.ds, {"long_name": "arclength step that reached the point (0 at a start)",
                                 "comment": "the Euclidean length in (v, p): section units and the parameter's together, unscaled"}),
        "iterations": (bp, branches.iterations.astype(np.int32), {"long_name": "corrector evaluations"}),
        "point_status": (bp, branches.status.astype(np.int8), {"long_name": "status of the point (not_computed: past n_points)", **flags}),
        "label_kind": (lab, labels.kind, {"long_name": "kind of labelled point", "flag_values": [int(k) for k in KIND_MEANINGS],
                       "flag_meanings": " ".join(k.name.lower() for k in KIND_MEANINGS),
                       "flag_descriptions": "; ".join(f"{int(k)} {k.name.lower()}: {m}" for k, m in KIND_MEANINGS.items())}),
        "label_parameter": (lab, labels.parameter, {"long_name": f"{config.parameter} at the labelled point", "units": spec.units}),
        "label_branch": (lab, labels.branch, {"long_name": "branch of the labelled point"}),
        "label_period": (lab, labels.period, {"long_name": "k of the branch"}),
        "label_status": (lab, labels.status, {"long_name": "location status (ok: located to tol)", **flags}),
        "label_v": (("label", "section"), labels.v, {"long_name": "fixed point there", **section_attrs(model)}),
        "label_multipliers_real": (("label", "multiplier"), labels.multipliers.real, {"long_name": "multipliers there, real part"}),
        "label_multipliers_imag": (("label", "multiplier"), labels.multipliers.imag, {"long_name": "multipliers there, imaginary part"}),
    }
    attrs = {
        "title": f"pseudo-arclength continuation of {config.model} gaits in {config.parameter}",
        "kind": "continuation", "name": config.name, "model": config.model, "continuation_parameter": config.parameter,
        "continuation_units": spec.units, "section_names": " ".join(model.section_names),
        "fixed_parameters": " ".join(f"{k}={v!r}" for k, v in config.fixed.items() if k != config.parameter),
        "bounds": list(config.bounds), "starts": list(config.starts), "direction": config.direction,
        "location_tol": config.tol, "options": repr(config.options),
        # As a sweep's: the resolved config as JSON (itself a valid config), and the file as written.
        "config": config.to_json(), "config_toml": config.text or "", "config_source": config.source,
        **provenance(command, "jaxwalk.branches.run_continue"),
    }
    # Section names as an attribute: a string coordinate has no zarr v3 data type yet.
    return xr.Dataset({k: (d, np.asarray(x), a) for k, (d, x, a) in data.items()}, attrs=attrs)


def run_continue(config: ContinueConfig, out: str | Path, *, overwrite: bool = False, command: str | None = None,
                 progress: bool = False):
    """Run ``config`` and write ``out/<name>_branches.zarr``; returns ``(path, dataset)``
    (``progress``: :func:`run_branches`'s stage lines and bar)."""
    target = check_output(out, f"{config.name}_branches", overwrite=overwrite)  # before computing
    ds = build_dataset(config, *run_branches(config, progress), command=command)
    return write_zarr(ds, target, overwrite=overwrite), ds
