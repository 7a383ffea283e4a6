"""The analyses of a sweep: the gait, and the plug-ins beside it, found by module.

Every module of this package that defines ``ANALYSIS`` (an
:class:`~jaxwalk.analyses.base.Analysis`) is one: adding an analysis, or an
output to one, is one module and touches nothing else. The config parser, the
grid, the runner's checks, the store's template and the dataset iterate over
:func:`registry` (in ``order``); :mod:`jaxwalk.analyses.gait` is always on.

Shapes: ``S`` is a block's (or the grid's) shape; ``n_v`` the model's section size.
"""

from __future__ import annotations

import functools
import importlib
import pkgutil
from typing import Any, Iterator, Mapping

import numpy as np

from jaxwalk import outputs as schema
from jaxwalk.analyses.base import Analysis, Block, did_you_mean
from jaxwalk.outputs import Output


@functools.cache
def registry() -> tuple[Analysis, ...]:
    """Every analysis, the gait first, in ``order``."""
    found = []
    for info in pkgutil.iter_modules(__path__):
        if info.name == "base":
            continue
        module = importlib.import_module(f"{__name__}.{info.name}")
        if isinstance(getattr(module, "ANALYSIS", None), Analysis):
            found.append(module.ANALYSIS)
    return tuple(sorted(found, key=lambda a: a.order))


def plugins() -> tuple[Analysis, ...]:
    """The analyses beside the gait."""
    return tuple(a for a in registry() if a.name != "gait")


def keys() -> tuple[str, ...]:
    """The ``[analysis]`` keys the plug-ins read, in order."""
    return tuple(k for a in plugins() for k in a.keys)


def active(config) -> list[tuple[Analysis, Any]]:
    """``[(analysis, resolved)]`` of a :class:`~jaxwalk.sweep.config.SweepConfig`, the gait first."""
    return active_settings({"gait": config.stability, **config.analyses})


def active_settings(settings: Mapping[str, Any]) -> list[tuple[Analysis, Any]]:
    """``[(analysis, resolved)]`` of ``{name: resolved}`` (the gait's: ``stability``), in order."""
    return [(a, settings[a.name]) for a in registry() if a.name in settings]


def sizes(active_: list[tuple[Analysis, Any]], n_v: int) -> dict[str, int]:
    out: dict[str, int] = {}
    for a, resolved in active_:
        out.update(a.sizes(resolved, n_v))
    return out


def outputs(active_: list[tuple[Analysis, Any]]) -> list[Output]:
    """Every per-point output of the active analyses, in order."""
    return [o for a, resolved in active_ for o in a.outputs(resolved)]


def check_block(results: Mapping[str, np.ndarray], shape: tuple[int, ...], n_v: int,
                active_: list[tuple[Analysis, Any]]) -> dict[str, np.ndarray]:
    """Hold one block's analysis output to the schema and make its failures explicit.

    Every output must be there with its shape (``ValueError`` otherwise, statuses
    with dataset codes). The gait's status becomes ``NONFINITE`` where an output
    that must exist there is not finite (the gait's numbers and those of
    analyses whose ``status_of_outputs`` is ``"status"``); then each analysis
    finalises its own (:meth:`Analysis.finalise`) from that status.
    """
    arrays = {}
    for a, resolved in active_:
        arrays.update(schema.take(results, a.outputs(resolved), shape, a.sizes(resolved, n_v)))
    folded = [o for a, resolved in active_ if a.status_of_outputs == "status" for o in a.outputs(resolved)]
    status = schema.nonfinite(arrays["status"], arrays, folded)
    out = {}
    for a, resolved in active_:
        out.update(a.finalise(arrays, status, resolved))
    return out


def template(config, n_v: int) -> dict[str, np.ndarray]:
    """A store's results for the whole grid, as zero-stride views of each output's fill value."""
    act = active(config)
    return schema.template(outputs(act), config.shape, sizes(act, n_v))


def variables(config, dims: tuple[str, ...], results: Mapping[str, np.ndarray], units: Mapping[str, str],
              model=None) -> dict[str, tuple]:
    """Every dataset variable of the active analyses (``{name: (dims, values, attrs)}``);
    ``model``: the walker (:meth:`Analysis.variables`)."""
    out = {}
    for a, resolved in active(config):
        out.update(a.variables(dims, results, resolved, units, model))
    return out


def declared() -> Iterator[Output]:
    """Every output any analysis can write (each analysis at its fullest settings)."""
    for a in registry():
        yield from a.outputs(a.fullest())


def plotted() -> tuple[str, ...]:
    """The outputs drawn by default, in drawing order (:attr:`~jaxwalk.outputs.Output.plot`)."""
    return tuple(o.name for o in sorted((o for o in declared() if o.plot is not None), key=lambda o: o.plot))


def output(name: str) -> Output | None:
    """The declaration of a dataset variable or result named ``name``, if any."""
    return next((o for o in declared() if o.name == name), None)


__all__ = ["Analysis", "Block", "active", "active_settings", "check_block", "declared", "did_you_mean", "keys", "output",
           "outputs", "plotted", "plugins", "registry", "sizes", "template", "variables"]
