"""jaxwalk: a JAX-vectorised engine for the stability of dynamic walkers."""

import os

# One XLA CPU device per core, so that a sharded batch uses every core (a single
# vmapped program runs on one core). Must happen before JAX starts its backend;
# a user's own XLA_FLAGS setting wins.
if "xla_force_host_platform_device_count" not in os.environ.get("XLA_FLAGS", ""):
    os.environ["XLA_FLAGS"] = (
        os.environ.get("XLA_FLAGS", "") + f" --xla_force_host_platform_device_count={os.cpu_count() or 1}"
    ).strip()

import jax  # noqa: E402

# Newton's method and step-map Jacobians need float64 (see docs/engine.md).
jax.config.update("jax_enable_x64", True)

__version__ = "0.1.0"
