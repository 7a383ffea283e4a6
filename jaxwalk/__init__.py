"""jaxwalk: a JAX-vectorised engine for the stability of dynamic walkers.

Importing jaxwalk changes process-wide settings, before JAX and equinox start:

- ``XLA_FLAGS``: one XLA CPU device per core (``--xla_force_host_platform_device_count``),
  so a sweep keeps every core busy; a user's own setting of that flag wins.
- ``EQX_ON_ERROR=nan`` unless already set (and only if equinox is not imported
  yet): equinox's run-time checks then give NaN instead of raising through a
  host callback, and programs without host callbacks can be cached on disk.
  jaxwalk reports failures as status codes, never by equinox's exceptions.
- float64 (``jax_enable_x64``): Newton and the Jacobians need it.
- the program caches (:mod:`jaxwalk.cache`): JAX's persistent compilation cache
  and jaxwalk's traced programs in ``$JAXWALK_CACHE_DIR``, else
  ``$XDG_CACHE_HOME/jaxwalk`` or ``~/.cache/jaxwalk``.
"""

import os
import sys

# One XLA CPU device per core, so that a sharded batch uses every core (a single
# vmapped program runs on one core). Must happen before JAX starts its backend;
# a user's own XLA_FLAGS setting wins.
if "xla_force_host_platform_device_count" not in os.environ.get("XLA_FLAGS", ""):
    os.environ["XLA_FLAGS"] = (
        os.environ.get("XLA_FLAGS", "") + f" --xla_force_host_platform_device_count={os.cpu_count() or 1}"
    ).strip()

# equinox reads EQX_ON_ERROR once, when it is imported: its default ("raise")
# puts host callbacks in every program, and neither cache can keep those.
if "equinox" not in sys.modules:
    os.environ.setdefault("EQX_ON_ERROR", "nan")

import jax  # noqa: E402

# Newton's method and step-map Jacobians need float64 (see docs/engine.md).
jax.config.update("jax_enable_x64", True)

from jaxwalk import cache as _cache  # noqa: E402

_cache.configure(warn=False)  # an unusable directory is reported at the first compile

__version__ = "0.1.0"

# The notebook API (docs/python.md): configs in, xarray datasets out; bad input
# raises ConfigError with the command line's one-line message. jaxwalk.sweep,
# .simulate and .optimize are the packages of those commands, and calling one
# runs it (jaxwalk.api); they are imported when first used.
from jaxwalk.api import open_dataset  # noqa: E402
from jaxwalk.sweep.config import ConfigError  # noqa: E402

__all__ = ["ConfigError", "open_dataset", "optimize", "simulate", "sweep", "__version__"]


def __getattr__(name: str):
    if name in ("sweep", "simulate", "optimize"):
        import importlib

        return importlib.import_module(f"jaxwalk.{name}")
    raise AttributeError(f"module 'jaxwalk' has no attribute {name!r}")
