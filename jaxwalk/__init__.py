"""jaxwalk: a JAX-vectorised engine for the stability of dynamic walkers."""

import jax

# Newton's method and step-map Jacobians need float64 (see docs/engine.md).
jax.config.update("jax_enable_x64", True)

__version__ = "0.1.0"
