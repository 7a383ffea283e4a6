"""jaxwalk: a JAX-vectorised engine for the stability of dynamic walkers.

The public API is what this module re-exports (docs/python.md): the notebook
functions ``sweep``, ``simulate``, ``optimize`` (configs in, xarray datasets
out; bad input raises :class:`ConfigError` with the command line's one-line
message), the engine (models, one step, gaits and their stability) and the
status codes. Everything else is internal, reached through these names.

Importing jaxwalk changes these process-wide settings, every one before JAX
or equinox starts (they cannot be made later), and nothing else:

- ``XLA_FLAGS``: appends ``--xla_force_host_platform_device_count=<cores>``,
  one XLA CPU device per core, so a sweep keeps every core busy (one vmapped
  program runs on one core). A ``XLA_FLAGS`` that already sets that flag wins.
- ``EQX_ON_ERROR=nan``, unless it is set, and only if equinox is not imported
  yet: equinox's run-time checks then give NaN instead of raising through a
  host callback, so that programs have no host callbacks and both program
  caches can keep them. jaxwalk reports failures as status codes, never by
  equinox's exceptions.
- ``jax_enable_x64``: float64, which Newton's method and the step-map
  Jacobians need (docs/engine.md).
- the program caches (:func:`jaxwalk.cache.configure`, docs/cache.md): JAX's
  options ``jax_enable_compilation_cache``, ``jax_compilation_cache_dir`` and
  ``jax_persistent_cache_min_compile_time_secs = 0``, and ``$JAXWALK_CACHE_DIR``
  set to the directory chosen (``$JAXWALK_CACHE_DIR``, else
  ``$JAX_COMPILATION_CACHE_DIR``, else ``$XDG_CACHE_HOME/jaxwalk`` or
  ``~/.cache/jaxwalk``) so that worker processes use the same one.
  ``JAXWALK_CACHE_DIR=`` (empty) switches the caches off.
"""

import os
import sys

if "xla_force_host_platform_device_count" not in os.environ.get("XLA_FLAGS", ""):
    os.environ["XLA_FLAGS"] = (
        os.environ.get("XLA_FLAGS", "") + f" --xla_force_host_platform_device_count={os.cpu_count() or 1}"
    ).strip()

# equinox reads EQX_ON_ERROR once, when it is imported.
if "equinox" not in sys.modules:
    os.environ.setdefault("EQX_ON_ERROR", "nan")

import jax  # noqa: E402

jax.config.update("jax_enable_x64", True)

from jaxwalk import cache as _cache  # noqa: E402

_cache.configure(warn=False)  # an unusable directory is reported at the first compile

__version__ = "0.1.0"

from jaxwalk.api import open_dataset as open_dataset  # noqa: E402
from jaxwalk.gait import (  # noqa: E402
    Gait as Gait,
    GaitStats as GaitStats,
    NewtonOptions as NewtonOptions,
    find_gait as find_gait,
    step_jacobian as step_jacobian,
)
from jaxwalk.models import MODELS as MODELS, get_model as get_model  # noqa: E402
from jaxwalk.parameters import ParamSpec as ParamSpec  # noqa: E402
from jaxwalk.status import Status as Status, describe as describe  # noqa: E402
from jaxwalk.step import (  # noqa: E402
    SolverOptions as SolverOptions,
    StepResult as StepResult,
    run_step as run_step,
    step_map as step_map,
)
from jaxwalk.errors import ConfigError as ConfigError  # noqa: E402
from jaxwalk.walker import Transition as Transition, Walker as Walker, as_params as as_params  # noqa: E402

#: The notebook functions, which are also the packages of their commands:
#: calling ``jaxwalk.sweep(config)`` runs a sweep (:mod:`jaxwalk.api`), while
#: ``jaxwalk.sweep.runner`` stays a module. Imported when first used.
_COMMANDS = ("sweep", "simulate", "optimize")


def __getattr__(name: str):
    if name in _COMMANDS:
        import importlib

        return importlib.import_module(f"jaxwalk.{name}")
    raise AttributeError(f"module 'jaxwalk' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted({*globals(), *_COMMANDS})
