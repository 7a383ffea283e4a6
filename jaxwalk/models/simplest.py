"""The simplest walking model (Garcia, Chatterjee, Ruina, Coleman 1998).

The compass walker with all its mass at the hip (``M = 1``) and infinitesimal
point feet (mass ``beta -> 0``), legs of length 1, ``g = 1``: its only parameter is
the slope ``gamma``. Garcia's equations are the ``beta -> 0`` limit of the
compass walker's; we run the compass walker's own autodiff-derived equations at
``beta = FOOT_MASS_RATIO``, so results differ from the limit by ``O(beta)``,
far below every tolerance we test (see ``docs/engine.md``).

Garcia's section (just after heel-strike) uses ``theta`` = stance angle and
``phi`` = angle between the legs; in ours ``alpha_1 = theta`` and
``alpha_2 = theta - phi``, so his fixed point ``(theta, theta_dot)`` is our
``(alpha_1, alpha_1_dot)``.
"""

from __future__ import annotations

import jax.numpy as jnp

from jaxwalk.models.compass import CompassWalker
from jaxwalk.parameters import ParamSpec

#: Foot-to-hip mass ratio standing in for Garcia's limit beta -> 0.
FOOT_MASS_RATIO = 1e-12


class SimplestWalker(CompassWalker):
    name = "simplest"
    description = "simplest walking model, Garcia, Chatterjee, Ruina & Coleman (1998)"
    units = {"length": "1", "time": "1"}  # leg length 1, g = 1: time in sqrt(l/g)
    parameters = (
        ParamSpec("gamma", 0.009, "rad", "slope angle (downhill positive)", lower=-0.5, upper=0.5),
    )
    # Not the compass gait's ball: a ball of radius 0.01 rad (rad per unit
    # time), unscaled, of which 0.28 returns at the default gamma (the basin is
    # a thin strip along d alpha_1 = -d alpha_1_dot; docs/global_stability.md).
    basin_radius = 0.01
    basin_scale = None
    # Every phase starts at 0.01, as before 2026-12-06. With the first step
    # carried from the phase before (2 solver steps fewer of 18, 1.07-1.13x
    # faster) this walker's lambda_max noise at rtol 1e-10 moved its period-2
    # multipliers 1.8e-6 from the SciPy walker's, beyond that test's 1e-6, the
    # noise of its strongly curved map (benchmarks/README.md, "Each phase's
    # first step"); the test's bound was not loosened.
    carry_step = False

    def mass_model(self, params):
        one = jnp.ones_like(params["gamma"])
        # (m, m_h, a, b, g): the feet carry all leg mass, at the leg's end.
        return FOOT_MASS_RATIO * one, one, 0.0 * one, one, one

    def initial_guess(self, params):
        # Garcia's gait at gamma = 0.009 scaled by his small-slope asymptotics
        # (theta* ~ gamma^(1/3)); alpha_2_dot = theta_dot cos(2 theta) after impact.
        scale = (jnp.abs(params["gamma"]) / 0.009) ** (1.0 / 3.0)
        theta, theta_dot = 0.2003 * scale, -0.1998 * scale
        return jnp.stack([theta, theta_dot, theta_dot * jnp.cos(2.0 * theta)])
