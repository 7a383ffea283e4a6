"""Traced grid programs kept on disk, so that a rerun skips tracing.

JAX's persistent compilation cache keeps compiled programs, not the tracing
before compiling. Tracing the flat-foot walker's grid programs (nested while
loops: Newton, the step's phases, diffrax's steps, the event root finder, all
under forward-mode derivatives) takes about 50 s per program on every run.
With the caches on (:mod:`jaxwalk.cache`, the default) and ``EQX_ON_ERROR=nan``
(``import jaxwalk`` sets it; without it equinox's error checks are host
callbacks, which neither cache can keep), a grid program is exported once
(``jax.export``: the program as traced and lowered, StableHLO) into
``<cache directory>/jaxwalk-programs/``, and later runs load it instead of
tracing.

The key is a hash of everything the trace depends on: what the program is and
its settings (:func:`register`), the input's shapes and dtypes, the source of
every jaxwalk module and of every module defining a class of the model, and
the versions of the libraries that trace (jax, jaxlib, diffrax, equinox,
optimistix, lineax, numpy). Change any of them and the program is traced
afresh. Every run, the one that exports included, runs the exported program,
so a run that traced and a run that loaded compute the same numbers bit for bit.
"""

from __future__ import annotations

import functools
import hashlib
import importlib.metadata
import os
import sys
import warnings
from pathlib import Path

import jax
import numpy as np
from jax import export

from jaxwalk import cache, compiling
from jaxwalk.continuation import LineCarry
from jaxwalk.files import file_digest, model_sources, source_digest, write_atomically
from jaxwalk.gait import Gait, GaitStats
from jaxwalk.stepdown import StepDownResult

_serializable: set[type] = set()


def serializable(output_type: type) -> type:
    """Let a grid program's NamedTuple output be saved in its exported form (a
    class decorator for modules this one cannot import without a circle); a
    type registered before is left as it is."""
    if output_type not in _serializable:
        export.register_namedtuple_serialization(output_type, serialized_name=f"{output_type.__module__}.{output_type.__qualname__}")
        _serializable.add(output_type)
    return output_type


def _inputs_serializable(args) -> None:
    """Register every NamedTuple type in a program's input (its rows and their
    declared inputs, :class:`jaxwalk.batching.Rows`), so each program declares
    its input type once, where it is used, and the exporter can save it."""
    if isinstance(args, tuple) and hasattr(args, "_fields"):
        serializable(type(args))
    if isinstance(args, dict):
        args = list(args.values())
    if isinstance(args, (tuple, list)):
        for x in args:
            _inputs_serializable(x)


#: Output types of the grid programs, so that their exported form can be saved.
for _type in (Gait, GaitStats, LineCarry, StepDownResult):
    serializable(_type)

_LIBRARIES = ("jax", "jaxlib", "diffrax", "equinox", "optimistix", "lineax", "numpy")
_identities: dict = {}
#: Grid programs this process traced, and loaded from disk instead (tests count them).
counts = {"traced": 0, "loaded": 0}


def register(program, kind: str, model, *settings) -> None:
    """Name ``program`` (a jitted function) for the disk cache: ``kind`` (which
    factory made it), the model (its class, name and lockstep batch) and the
    settings it closes over (dataclasses; their ``repr`` holds every field);
    also the model's compiler options, which the exported program is compiled
    with (:mod:`jaxwalk.compiling`)."""
    model_id = f"{type(model).__module__}.{type(model).__qualname__}:{model.name}:{model.lockstep_batch}:{sorted(vars(model).items())!r}"
    _identities[program] = (kind, model_id, tuple(repr(s) for s in settings), type(model),
                            compiling.compiler_options(model))


def cache_directory() -> Path | None:
    """Where exported programs go, or ``None`` when the disk cache is off."""
    root = cache.directory()
    if root is None or os.environ.get("EQX_ON_ERROR") != "nan":
        return None
    return root / cache.PROGRAMS


@functools.lru_cache(maxsize=1)
def _environment_hash() -> str:
    """jaxwalk's own source, the tracing libraries' versions, float64 on or off."""
    h = hashlib.sha256()
    h.update(f"jaxwalk source {source_digest()}\n".encode())
    for name in _LIBRARIES:
        try:
            version = importlib.metadata.version(name)
        except importlib.metadata.PackageNotFoundError:
            version = "absent"
        h.update(f"{name}=={version}\n".encode())
    h.update(f"x64={jax.config.jax_enable_x64}\n".encode())
    return h.hexdigest()


def program_key(program, args) -> str | None:
    """The cache key of ``program`` at ``args``' shapes, or ``None`` if it was not registered."""
    identity = _identities.get(program)
    if identity is None:
        return None
    kind, model_id, settings, model_class, _ = identity  # the compiler options do not change the trace
    leaves, tree = jax.tree_util.tree_flatten(args)
    signature = [(tuple(np.shape(x)), str(np.result_type(x))) for x in leaves]  # as workers.executable's key
    h = hashlib.sha256()
    for part in (kind, model_id, *settings, str(tree), repr(signature), _environment_hash()):
        h.update(part.encode() + b"\0")
    for path in model_sources(model_class):
        h.update(f"{path}:{file_digest(path)}\0".encode())
    return h.hexdigest()


def _load(path: Path):
    try:
        return export.deserialize(bytearray(path.read_bytes()))
    except Exception:  # absent, half-written by a killed run, or from another jax: trace afresh
        return None


def _save(path: Path, exported) -> None:
    """Write atomically (a temporary file renamed): concurrent runs may share the directory."""
    try:
        data = exported.serialize()
        def write(tmp: Path) -> None:
            tmp.write_bytes(data)
            os.chmod(tmp, 0o644)  # as the compilation cache's files: readable by whoever shares it

        write_atomically(path, write)
    except Exception as err:  # a read-only or full disk costs the next run a trace, nothing else
        warnings.warn(f"traced program not kept in the cache ({' '.join(str(err).split())})", cache.CacheWarning, stacklevel=3)


#: What each registered kind of program is, for the line a compile prints.
_WHAT = {"independent": "gait search", "continuation": "gait search along continuation lines", "step_down": "step-down test"}


def announce(program) -> None:
    """One line on stderr before a registered program is traced and compiled, so a
    wait of seconds to minutes has a reason (kept clear of a running progress bar)."""
    identity = _identities.get(program)
    if identity is None:
        return
    kind, model_id = identity[0], identity[1]
    model_name = model_id.split(":")[1]
    when = "first run; cached afterwards" if cache_directory() is not None else "caches off: on every run"
    from tqdm.auto import tqdm

    tqdm.write(f"jaxwalk: compiling the {model_name} {_WHAT.get(kind, kind)} ({when})", file=sys.stderr)


def lower(program, args):
    """``program`` lowered for ``args``: from the disk cache when it holds it, else
    traced (and, with the cache on, exported and saved, then run as exported)."""
    cache.report()
    root = cache_directory()
    key = None if root is None else program_key(program, args)
    if key is None:
        counts["traced"] += 1
        announce(program)
        return program.lower(args)
    path = root / f"{key}.jaxexport"
    _inputs_serializable(args)  # before loading too: the saved form names them
    exported = _load(path)
    if exported is None:
        counts["traced"] += 1
        announce(program)
        try:
            exported = export.export(program)(args)
        except Exception:  # something the exporter cannot hold: the plain path
            return program.lower(args)
        _save(path, exported)
    else:
        counts["loaded"] += 1
    # The model's compiler options (jaxwalk.compiling): the exported program is
    # compiled here, not by the jit it was traced from.
    return jax.jit(exported.call, compiler_options=_identities[program][4]).lower(args)
