"""What a walker is to the engine: phases of constrained point-mass dynamics,
guards that end them, and resets that follow.

A concrete model subclasses :class:`Walker` and says *where its masses are* and
*which constraints hold in which phase*; the equations of motion, energies and
impacts come from :mod:`jaxwalk.mechanics`. The model object is static Python
(shapes, names, which phase uses which constraints); every number that may be
swept is a leaf of the ``params`` dict.

Conventions shared by every model
---------------------------------
* ``q`` starts with the hip position ``(x_h, y_h)`` in the slope frame, followed by
  absolute segment angles measured from the slope normal, positive when the
  segment's distal end lies ahead of (downhill of) its proximal end
  (so a leg's foot is at ``hip + l (sin a, -cos a)``, as in the paper's xi_1).
* Leg 1 is the stance leg, leg 2 the swing leg; labels swap at the end of a step.
* ``y = concat(q, qd)``; ``phase`` is an int32 index into :attr:`Walker.phases`;
  ``ctx`` is a small float vector of discrete state (contact anchors, ground
  height, event times) laid out by :attr:`Walker.context`.
* Guards are positive while a phase goes on; an event is a downward zero crossing
  of the smallest one. Guards that do not apply in a phase return ``1.0``.
"""

from __future__ import annotations

from typing import NamedTuple

import jax
import jax.numpy as jnp

from jaxwalk import mechanics
from jaxwalk.parameters import ParamSpec

Array = jax.Array
Params = dict


class Transition(NamedTuple):
    """What follows an event. All leaves are scalars or vectors of the state's dtype."""

    phase: Array  # int32, the next phase
    y: Array  # (2 n_q,) state after the reset
    ctx: Array  # (n_ctx,) discrete state after the reset
    status: Array  # int8 Status; IN_PROGRESS while the step goes on
    step_done: Array  # bool, True when this event ends the step (legs swapped)
    shift: Array  # x translation of the frame at this event: the step length when step_done, else 0


class Walker:
    """Base class of all models. Subclasses set the class attributes and
    implement the methods marked *model*.

    Class attributes:
        name: registry name (``"compass"``).
        parameters: the model's :class:`ParamSpec` tuple, in a stable order.
        coordinates: names of ``q``.
        phases: names of the phases, in the order they occur in a step.
        guards: names of the guard functions (the order of ``guard_values``).
        context: names of the entries of ``ctx``.
        section_names: names of the independent section coordinates ``v``.
        n_constraints: number of constraint rows (active or not).
        lockstep_batch: configurations one worker thread runs together in a grid analysis.
    """

    name: str = ""
    description: str = ""
    parameters: tuple[ParamSpec, ...] = ()
    coordinates: tuple[str, ...] = ()
    phases: tuple[str, ...] = ()
    guards: tuple[str, ...] = ()
    context: tuple[str, ...] = ()
    section_names: tuple[str, ...] = ()
    n_constraints: int = 0
    #: Units of lengths and times in outputs (period, step length, speed).
    units: dict = {"length": "1", "time": "1"}
    #: Configurations (or continuation lines) one worker thread advances together,
    #: ``vmap``-ed, in a grid analysis (``jaxwalk.grid``). A vmapped while loop
    #: runs until its slowest element is done, every element paying for every
    #: iteration: large batches pay off where every configuration costs about
    #: the same (the passive walkers), small ones where some cost many times the
    #: others (failing steps that integrate long, Newton iterations, drops of
    #: the step-down test: the flat-foot walker, see benchmarks/README.md).
    lockstep_batch: int = 64

    # Python identity is the cache key of every jitted function that closes
    # over a model: one instance per model, shared through the registry.
    def __hash__(self) -> int:
        return id(self)

    def __eq__(self, other: object) -> bool:
        return self is other

    @property
    def n_q(self) -> int:
        return len(self.coordinates)

    @property
    def param_specs(self) -> dict[str, ParamSpec]:
        return {p.name: p for p in self.parameters}

    def default_params(self) -> Params:
        """Defaults as a dict of float64 scalars (a pytree ready for jit)."""
        return {p.name: jnp.asarray(p.default, dtype=jnp.float64) for p in self.parameters}

    def ctx_index(self, name: str) -> int:
        return self.context.index(name)

    # ---------------------------------------------------------------- model
    def points(self, q: Array, params: Params) -> Array:
        """*model* ``(n_points, 2)`` positions of the point masses."""
        raise NotImplementedError

    def masses(self, params: Params) -> Array:
        """*model* ``(n_points,)`` the point masses."""
        raise NotImplementedError

    def gravity(self, params: Params) -> Array:
        """``(2,)`` gravity in the slope frame, ``g (sin gamma, -cos gamma)``."""
        g = params.get("g", 1.0)
        gamma = params["gamma"]
        return g * jnp.stack([jnp.sin(gamma), -jnp.cos(gamma)])

    def constraints(self, q: Array, params: Params, ctx: Array) -> Array:
        """*model* ``(n_constraints,)`` every constraint the model can use."""
        raise NotImplementedError

    def constraint_mask(self, phase: Array, params: Params) -> Array:
        """*model* ``(n_constraints,)`` 1.0 where the constraint holds in ``phase``."""
        raise NotImplementedError

    def joint_forces(self, q: Array, qd: Array, params: Params, phase: Array, ctx: Array) -> Array:
        """Generalized torques from actuators and springs, ``(n_q,)``. Default none."""
        return jnp.zeros_like(q)

    def spring_energy(self, q: Array, params: Params, phase: Array, ctx: Array) -> Array:
        """Elastic energy stored in springs (scalar). Default none."""
        return jnp.zeros((), q.dtype)

    def actuator_work(self, y_start: Array, y_end: Array, params: Params) -> Array:
        """Work done by the actuators from ``y_start`` to ``y_end`` within one phase
        (scalar, model energy units). Default none: a passive walker."""
        return jnp.zeros((), y_start.dtype)

    def weight(self, params: Params) -> Array:
        """Total weight, ``g`` times the sum of the point masses (model force units)."""
        return params.get("g", 1.0) * jnp.sum(self.masses(params))

    def guard_values(self, t: Array, y: Array, params: Params, phase: Array, ctx: Array) -> Array:
        """*model* ``(len(guards),)``, positive while the phase goes on."""
        raise NotImplementedError

    def on_event(self, guard: Array, t: Array, y: Array, params: Params, phase: Array, ctx: Array) -> Transition:
        """*model* the reset after guard ``guard`` (an int index) crossed zero."""
        raise NotImplementedError

    def section_to_state(self, v: Array, params: Params) -> tuple[Array, Array, Array]:
        """*model* full ``(y, phase, ctx)`` at the start of a step from section coordinates."""
        raise NotImplementedError

    def state_to_section(self, y: Array, params: Params, ctx: Array) -> Array:
        """*model* section coordinates ``v`` of a state at the start of a step."""
        raise NotImplementedError

    def initial_guess(self, params: Params) -> Array:
        """*model* a starting point for Newton's method, ``(len(section_names),)``."""
        raise NotImplementedError

    def time_scale(self, params: Params) -> Array:
        """Characteristic time ``sqrt(l/g)``, used to size time limits."""
        return jnp.sqrt(1.0 / params.get("g", 1.0))

    # ---------------------------------------------------------------- derived
    def split(self, y: Array) -> tuple[Array, Array]:
        return y[: self.n_q], y[self.n_q :]

    def constraint_terms(self, q: Array, qd: Array, params: Params, ctx: Array) -> tuple[Array, Array]:
        """``Sigma`` ``(n_c, n_q)`` and ``Psi`` ``(n_c,)`` (paper eqs. 3-4)."""
        xi = lambda q_: self.constraints(q_, params, ctx)
        sigma = jnp.stack(mechanics.jacobian_columns(xi, q), axis=1)
        return sigma, mechanics.second_derivative_along(xi, q, qd)

    def dynamics(self, y: Array, params: Params, phase: Array, ctx: Array) -> tuple[Array, Array]:
        """Accelerations ``(n_q,)`` and constraint forces ``(n_c,)`` in ``phase``."""
        q, qd = self.split(y)
        pts = lambda q_: self.points(q_, params)
        masses = self.masses(params)
        mass, forces = mechanics.mass_matrix_and_forces(pts, masses, self.gravity(params), q, qd)
        forces = forces + self.joint_forces(q, qd, params, phase, ctx)
        sigma, psi = self.constraint_terms(q, qd, params, ctx)
        # A mask that does not depend on traced values (one constant for all
        # phases) comes out concrete here, and the solve drops its inactive rows.
        with jax.ensure_compile_time_eval():
            mask = self.constraint_mask(phase, params)
        return mechanics.constrained_accelerations(mass, forces, sigma, psi, mask)

    def vector_field(self, t: Array, y: Array, args: tuple) -> Array:
        """``dy/dt`` for diffrax: ``args = (params, phase, ctx)``."""
        params, phase, ctx = args
        qdd, _ = self.dynamics(y, params, phase, ctx)
        return jnp.concatenate([y[self.n_q :], qdd])

    def apply_impact(self, y: Array, params: Params, ctx: Array, mask: Array) -> tuple[Array, Array]:
        """Inelastic impact onto the constraints in ``mask``: new ``y`` and impulses."""
        q, qd = self.split(y)
        pts = lambda q_: self.points(q_, params)
        mass = mechanics.mass_matrix(pts, self.masses(params), q)
        sigma, _ = self.constraint_terms(q, qd, params, ctx)
        qd_plus, impulses = mechanics.impact(mass, qd, sigma, mask)
        return jnp.concatenate([q, qd_plus]), impulses

    def energy(self, y: Array, params: Params, phase: Array, ctx: Array) -> Array:
        """Total mechanical energy: kinetic + gravity + springs (scalar)."""
        q, qd = self.split(y)
        pts = lambda q_: self.points(q_, params)
        masses = self.masses(params)
        return (
            mechanics.kinetic_energy(pts, masses, q, qd)
            + mechanics.gravity_potential(pts, masses, self.gravity(params), q)
            + self.spring_energy(q, params, phase, ctx)
        )
