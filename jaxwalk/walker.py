"""What a walker is to the engine: phases of constrained point-mass dynamics,
guards that end them, and resets that follow.

A concrete model subclasses :class:`Walker` and says *where its masses are* and
*which constraints hold in which phase*; the equations of motion, energies and
impacts come from :mod:`jaxwalk.mechanics` (from :mod:`jaxwalk.chain` in closed
form where the model gives :meth:`Walker.chain_weights`). The model object is
static Python (shapes, names, which phase uses which constraints); every number
that may be swept is a leaf of the ``params`` dict.

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
* Every model has a slope parameter ``gamma`` (rad, downhill positive): gravity,
  the step-down and the figures' world frame read it through :meth:`Walker.slope`.

The contract
------------
Methods marked *model* below are required. Beyond them a model may offer
*capabilities*, each with a default here, that some analyses and outputs need:

* **step-down** (:attr:`Walker.ground_next`): a ``ctx`` entry holding the
  height of the ground at the next touchdown; the step-down test (``h_max``),
  the global-stability measures on uneven ground and a simulation's ``drop``
  need it.
* **step-up** (step-down, and :attr:`Walker.cannot_step_up` ``None``): the model
  walks on after a touchdown on higher ground; the MFPT chain and the Monte
  Carlo walks (random terrain, half of it steps up) need it.
* **drawing** (:meth:`Walker.skeleton`, :meth:`Walker.foot_points`): the figures
  and the GIF of ``jaxwalk simulate`` need both.
* **actuators** (:meth:`Walker.actuator_power`, :meth:`Walker.actuator_work`):
  default none, a passive walker.

A config that asks for an analysis whose capability the model lacks is refused
with one line before anything is traced (:func:`check_supported`), never by a
crash while tracing. ``tests/test_walker_contract.py`` checks every registered
model against the same properties.
"""

from __future__ import annotations

import math
from typing import Callable, Mapping, NamedTuple

import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Bool, Float, Int8, Int32

from jaxwalk import chain, mechanics
from jaxwalk.errors import ConfigError
from jaxwalk.parameters import ParamSpec

Params = dict


def as_params(values: Mapping[str, float]) -> Params:
    """Parameter values as the engine's pytree: a dict of float64 scalars."""
    return {k: jnp.asarray(v, dtype=jnp.float64) for k, v in values.items()}


def distal(angle: Array) -> Array:
    """``(2,)`` unit vector from a segment's proximal to its distal end at ``angle``
    (the engine's angle convention): ``(sin a, -cos a)``."""
    return jnp.stack([jnp.sin(angle), -jnp.cos(angle)])


class Transition(NamedTuple):
    """What follows an event. All leaves are scalars or vectors of the state's dtype
    (``work`` may be left at its default, a Python 0.0)."""

    phase: Int32[Array, ""]  # the next phase
    y: Float[Array, "2*n_q"]  # state after the reset
    ctx: Float[Array, "n_ctx"]  # discrete state after the reset
    status: Int8[Array, ""]  # Status; IN_PROGRESS while the step goes on
    step_done: Bool[Array, ""]  # True when this event ends the step (legs swapped)
    shift: Float[Array, ""]  # x translation of the frame at this event: the step length when step_done, else 0
    # Work done by an actuator in the reset itself (model energy units), added to
    # StepResult.work; 0 unless the reset winds up stored energy (the flat-foot
    # walker's ankle springs at toe-strike, forces.reset_work).
    work: Float[ArrayLike, ""] = 0.0


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
        section_units: their units (CF strings), or ``None``: each an angle (``rad``)
            or, named ``*_dot``, its rate (``rad`` per time unit), as in every walker
            here (:func:`jaxwalk.sweep.dataset.section_units`).
        n_constraints: number of constraint rows (active or not).
        limits: names of the contact limits :meth:`limit_use` measures (none by default).
        limit_guards: for each of :attr:`limits`, the name of the guard whose
            margin it is part of (a guard may be the least of several limits'
            margins, zero where one of them reaches its edge): where a step
            fails by that guard, the one of its limits at its edge is named
            (:attr:`jaxwalk.gait.GaitStats.failure_limit`).
        failure_guards: names of the guards that end a step by a failure, in
            order of precedence: where a phase ends at its start (a guard below
            ``-start_guard_margin``) with one or more of these below zero, the
            first of them is the one named (:meth:`named_guard`).
        ground_next: index in ``ctx`` of the ground height at the next touchdown
            (the step-down capability), or ``None``.
        lockstep_batch: configurations one worker thread runs together in a grid analysis.
        basin_radius, basin_scale: the basin measure's ball of starts by default.
        step_safety: the step-size controller's safety factor where the solver
            settings name none (:class:`jaxwalk.stepbase.SolverOptions`).
        carry_step: whether a phase starts with the step the controller
            proposed at the end of the phase before, where the solver settings
            do not say (:attr:`jaxwalk.stepbase.SolverOptions.carry_step`).
        cpu_fusion_emitters: whether XLA's CPU fusion emitters compile the
            model's programs (:mod:`jaxwalk.compiling`).
        event_log: the context entries logging the step's events, or ``None``.

    Models are compared and hashed by value, their class and instance
    attributes (which must be hashable): every jitted program closes over its
    model and is cached under it, so two ``CompassWalker()`` share every
    compiled program, while a subclass (another model) gets its own.
    """

    name: str = ""
    description: str = ""
    parameters: tuple[ParamSpec, ...] = ()
    coordinates: tuple[str, ...] = ()
    phases: tuple[str, ...] = ()
    guards: tuple[str, ...] = ()
    context: tuple[str, ...] = ()
    section_names: tuple[str, ...] = ()
    section_units: tuple[str, ...] | None = None
    n_constraints: int = 0
    limits: tuple[str, ...] = ()
    limit_guards: tuple[str, ...] = ()
    failure_guards: tuple[str, ...] = ()
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
    #: Index of the ground height at the next touchdown in ``ctx`` (slope frame,
    #: normal to the slope; 0 on the slope itself), which the step-down writes
    #: (:meth:`with_ground_drop`). ``None``: the model always lands on the
    #: slope, and the analyses that lower the ground refuse it.
    ground_next: int | None = None
    #: ``None``, or why the model cannot walk on after a step up (the ground at a
    #: touchdown higher than under the trailing foot, a negative drop), the end
    #: of a sentence "model 'name' cannot walk up a step: ...". The heel-rise
    #: walker's section keeps the trailing foot's height while its step assumes
    #: both feet on one level ground: the step after a step-up starts with that
    #: foot below the ground it assumes, a start it ends ``SCUFFING`` that no
    #: walker on such terrain would. The analyses whose terrain steps up (the
    #: MFPT chain, Monte Carlo walks) refuse such a model; the lower-level
    #: :func:`~jaxwalk.step.step_map` (``ground_drop < 0``) and the walks of
    #: :mod:`jaxwalk.global_stability.walks` given drops of their own cannot
    #: check traced values and do not.
    cannot_step_up: str | None = None
    #: The ball of starts of the basin measure where a config names none
    #: (``[analysis] basin``'s ``radius`` and ``scale``: the Euclidean norm of
    #: ``(v - v*) / scale``, ``scale`` ``(n_v,)`` in each section coordinate's
    #: units, ``None`` for 1): about the basin's half-width at the model's
    #: default gait, so that the ball lies neither wholly inside nor wholly
    #: outside typical basins (measured per model, docs/global_stability.md).
    basin_radius: float = 0.01
    basin_scale: tuple[float, ...] | None = None
    #: The step-size controller's safety factor where ``SolverOptions.safety``
    #: is ``None`` (the default): diffrax's 0.9, measured per model
    #: (benchmarks/bench_controller.py; 0.75 for the flat-foot walker).
    step_safety: float = 0.9
    #: Each phase's first step carried from the phase before where
    #: ``SolverOptions.carry_step`` is ``None`` (the default): a sixth fewer
    #: solver steps on the flat-foot walker, 0-2 of 23 on the kneed walker
    #: (benchmarks/bench_first_step.py); the simplest walker's own setting
    #: says why it does not.
    carry_step: bool = True
    #: XLA's CPU fusion emitters for this model's programs (XLA's default); False:
    #: its elemental emitters, measured per model (:mod:`jaxwalk.compiling`,
    #: benchmarks/bench_compile_options.py): they compile every walker's gait
    #: search 1.2-1.9x faster, run the flat-foot walker's as fast and the kneed
    #: walker's 2-3 % slower, but the passive walkers' 64-wide batches 1.5x slower.
    cpu_fusion_emitters: bool = True
    #: The context entries where the model logs its step's events ``(history,
    #: count)``, each event's guard index a base-16 digit of the history
    #: (:mod:`jaxwalk.event_log`), or ``None``: the model logs none, and no
    #: change of a gait's event sequence is located (:mod:`jaxwalk.bifurcation`).
    event_log: tuple[str, str] | None = None

    def _identity(self) -> tuple:
        return type(self), tuple(sorted(vars(self).items()))

    def __hash__(self) -> int:
        return hash(self._identity())

    def __eq__(self, other: object) -> bool:
        return isinstance(other, Walker) and self._identity() == other._identity()

    def __repr__(self) -> str:
        return f"{type(self).__name__}({', '.join(f'{k}={v!r}' for k, v in sorted(vars(self).items()))})"

    @property
    def n_q(self) -> int:
        return len(self.coordinates)

    @property
    def param_specs(self) -> dict[str, ParamSpec]:
        return {p.name: p for p in self.parameters}

    def default_params(self) -> Params:
        """Defaults as a dict of float64 scalars (a pytree ready for jit)."""
        return as_params({p.name: p.default for p in self.parameters})

    def ctx_index(self, name: str) -> int:
        """Index of the entry ``name`` of ``ctx`` (one-line ``KeyError`` if the model has none)."""
        if name not in self.context:
            raise KeyError(f"model '{self.name}' has no '{name}' in its context ({', '.join(self.context)})")
        return self.context.index(name)

    def slope(self, params: Params) -> Array:
        """The slope angle ``gamma`` (rad, downhill positive)."""
        return params["gamma"]

    def with_ground_drop(self, ctx: Array, params: Params, drop: Array | float) -> Array:
        """``ctx`` with the ground at the next touchdown lower by ``drop`` (model
        length units, vertical): ``ground_next = -drop cos(gamma)`` normal to the slope.

        Raises:
            ValueError: the model has no step-down (:attr:`ground_next` is ``None``).
        """
        if self.ground_next is None:
            raise ValueError(f"model '{self.name}' {missing(self, 'step_down')}")
        return ctx.at[self.ground_next].set(-drop * jnp.cos(self.slope(params)))

    # ---------------------------------------------------------------- model
    def points(self, q: Float[Array, "n_q"], params: Params) -> Float[Array, "n_points 2"]:
        """*model* ``(n_points, 2)`` positions of the point masses."""
        raise NotImplementedError

    def masses(self, params: Params) -> Float[Array, "n_points"]:
        """*model* ``(n_points,)`` the point masses."""
        raise NotImplementedError

    def chain_weights(self, params: Params) -> Float[Array, "n_points n_angles"] | None:
        """``S`` ``(n_points, n_q - 2)`` (lengths) where :meth:`points` is ``hip + S
        (sin a, -cos a)``: the mass matrix and forces then come in closed form
        (:mod:`jaxwalk.chain`); ``None`` (the default): from derivatives of
        :meth:`points`."""
        return None

    def gravity(self, params: Params) -> Array:
        """``(2,)`` gravity in the slope frame, ``g (sin gamma, -cos gamma)``."""
        g = params.get("g", 1.0)
        gamma = self.slope(params)
        return g * jnp.stack([jnp.sin(gamma), -jnp.cos(gamma)])

    def constraints(self, q: Float[Array, "n_q"], params: Params, ctx: Float[Array, "n_ctx"]) -> Float[Array, "n_constraints"]:
        """*model* ``(n_constraints,)`` every constraint the model can use."""
        raise NotImplementedError

    def constraint_mask(self, phase: Int32[ArrayLike, ""], params: Params) -> Float[Array, "n_constraints"]:
        """*model* ``(n_constraints,)`` 1.0 where the constraint holds in ``phase``."""
        raise NotImplementedError

    def joint_forces(self, q: Float[Array, "n_q"], qd: Float[Array, "n_q"], params: Params, phase: Int32[ArrayLike, ""], ctx: Float[Array, "n_ctx"]) -> Float[Array, "n_q"]:
        """Generalized torques from actuators and springs, ``(n_q,)``. Default none."""
        return jnp.zeros_like(q)

    def spring_energy(self, q: Float[Array, "n_q"], params: Params, phase: Int32[ArrayLike, ""], ctx: Float[Array, "n_ctx"]) -> Float[Array, ""]:
        """Elastic energy stored in springs (scalar). Default none."""
        return jnp.zeros((), q.dtype)

    def actuator_power(self, q: Float[Array, "n_q"], qd: Float[Array, "n_q"], params: Params, phase: Int32[ArrayLike, ""], ctx: Float[Array, "n_ctx"]) -> Float[Array, ""]:
        """*actuators* power of the actuators, ``qd . Q_actuator`` (scalar, model
        power units); the recorder of ``jaxwalk simulate`` integrates it to work.
        Default none: a passive walker (see :attr:`actuated`)."""
        return jnp.zeros((), qd.dtype)

    def actuator_work(self, y_start: Float[Array, "2*n_q"], y_end: Float[Array, "2*n_q"], params: Params, phase: Int32[ArrayLike, ""],
                      ctx: Float[Array, "n_ctx"]) -> Float[Array, ""]:
        """*actuators* work done by the actuators from ``y_start`` to ``y_end`` within
        ``phase`` (its discrete state ``ctx``, which a phase does not change; scalar,
        model energy units). Default none: a passive walker."""
        return jnp.zeros((), y_start.dtype)

    def limit_use(self, y: Float[Array, "2*n_q"], params: Params, phase: Int32[ArrayLike, ""], ctx: Float[Array, "n_ctx"]) -> Float[Array, "n_limits"]:
        """*contact limits* how much of each limit in :attr:`limits` the state uses,
        ``(len(limits),)``: 0 unloaded, 1 at the limit's edge (where its failure
        guard crosses zero), above 1 beyond it; NaN where the limit does not apply
        in ``phase``. The recorder of ``jaxwalk simulate`` samples it, which says
        which limit a walk approaches, when, and by how much. Default none."""
        return jnp.zeros((0,), y.dtype)

    @property
    def actuated(self) -> bool:
        """Whether the model defines :meth:`actuator_power` (else no actuator does work)."""
        return overrides(self, "actuator_power")

    def weight(self, params: Params) -> Array:
        """Total weight, ``g`` times the sum of the point masses (model force units)."""
        return params.get("g", 1.0) * jnp.sum(self.masses(params))

    def guard_values(self, t: Float[Array, ""], y: Float[Array, "2*n_q"], params: Params, phase: Int32[ArrayLike, ""], ctx: Float[Array, "n_ctx"]) -> Float[Array, "n_guards"]:
        """*model* ``(len(guards),)``, positive while the phase goes on."""
        raise NotImplementedError

    def named_guard(self, guards: Float[Array, "n_guards"], at_start: Bool[ArrayLike, ""]) -> Int32[Array, ""]:
        """Index of the guard an event at guard values ``guards`` names.

        A located crossing names its least guard, the one at zero (the first on a
        tie: the flat-foot heel's ``heel_strike`` and ``scuff`` are equal there with
        ``scuff_tol = 0``). An event at a phase's start (``at_start``: a guard was
        already below ``-start_guard_margin``, as where a step starts from a state
        the walker cannot hold: Newton's iterates, a basin's starts) may find
        several guards below zero, and the least of them is then a matter of
        scale, not of cause: a stance contact that pulls is outside its friction
        cone too, often by more. There the first of :attr:`failure_guards` below
        zero is named. ``guards`` include the phase's :func:`~jaxwalk.stepbase.guard_offsets`.
        """
        least = jnp.argmin(guards)
        if not self.failure_guards:
            return least
        ranked = jnp.asarray([self.guards.index(name) for name in self.failure_guards])
        failing = guards[ranked] < 0.0
        return jnp.where(at_start & jnp.any(failing), ranked[jnp.argmax(failing)], least)

    def on_event(self, guard: Int32[ArrayLike, ""], t: Float[Array, ""], y: Float[Array, "2*n_q"], params: Params, phase: Int32[ArrayLike, ""],
                 ctx: Float[Array, "n_ctx"]) -> Transition:
        """*model* the reset after guard ``guard`` (an int index) crossed zero."""
        raise NotImplementedError

    def section_to_state(self, v: Float[Array, "n_v"], params: Params) -> tuple[Float[Array, "2*n_q"], Int32[ArrayLike, ""], Float[Array, "n_ctx"]]:
        """*model* full ``(y, phase, ctx)`` at the start of a step from section coordinates."""
        raise NotImplementedError

    def state_to_section(self, y: Float[Array, "2*n_q"], params: Params, ctx: Float[Array, "n_ctx"]) -> Float[Array, "n_v"]:
        """*model* section coordinates ``v`` of a state at the start of a step."""
        raise NotImplementedError

    def initial_guess(self, params: Params) -> Float[Array, "n_v"]:
        """*model* a starting point for Newton's method, ``(len(section_names),)``."""
        raise NotImplementedError

    def into_section(self, v: Float[Array, "n_v"], params: Params) -> Float[Array, "n_v"]:
        """A point of the section that is a state of the walker, for ``v`` that may not be.

        Newton's iterates (:func:`jaxwalk.gait.find_gait`, the attractors' cycle
        solve) pass through it after every update, so a search whose linear step
        leaves the section goes on from its edge instead of ending at a start the
        walker cannot have. By default every section point is a state: ``v`` itself.
        A model whose gaits can lie on the section's edge (the heel-rise walker's
        heel-down gaits) returns a point on that edge; where ``v`` is a state (as
        the model's step judges one: a start it does not fail at once for being
        outside) it must return ``v`` unchanged, bit for bit, so the searches of
        other points are untouched.
        """
        return v

    def guess_made_at(self, params: Mapping[str, float]) -> Mapping[str, float]:
        """Parameter values of the walker whose gait :meth:`initial_guess` gives at
        ``params`` (those that differ from the defaults); by default none, the
        guess being made for the defaults. Continuation starts nearest them
        (:meth:`seed_value`)."""
        return {}

    def seed_value(self, name: str, fixed: Mapping[str, float], values=None) -> float:
        """Where a continuation along parameter ``name`` starts, for a walker whose
        other parameters are ``fixed`` (defaults for the rest; entries that are not
        scalar parameters are ignored): the value of ``name`` at which the initial guess
        was made (:meth:`guess_made_at`), else its default. Given the axis's grid
        ``values``, the one nearest the value its own guess was made at, so an
        axis that itself selects the guess (the flat-foot walker's ``k_hip``) is
        judged at each of its values; other grid axes are judged at their defaults.

        Not simply the default: a model whose guess is chosen from several
        documented gaits (the flat-foot walker: the paper's walker's, the shoe
        walker's, ...) has each at its own parameters, and a line started far from
        them starts from a guess made for another walker.
        """
        given = {**self.default_params(), **{k: v for k, v in fixed.items() if k in self.param_specs and np.ndim(v) == 0}}
        given = {k: float(v) for k, v in given.items()}
        default = self.param_specs[name].default

        def made_at(value: float) -> float:
            return float(self.guess_made_at({**given, name: value}).get(name, default))

        if values is None:
            return made_at(given[name])
        values = np.asarray(values, np.float64).reshape(-1)
        distance = [abs(v - made_at(float(v))) for v in values]
        return float(values[int(np.argmin(distance))])

    def time_scale(self, params: Params) -> Array:
        """Characteristic time ``sqrt(l/g)``, used to size time limits."""
        return jnp.sqrt(1.0 / params.get("g", 1.0))

    # ---------------------------------------------------------------- drawing
    def skeleton(self, q: Float[Array, "n_q"], params: Params, ctx: Float[Array, "n_ctx"]) -> Float[Array, "2 n_points 2"]:
        """*drawing* ``(2, n_points, 2)``: a polyline per leg (leg 1 the stance leg)
        from the hip to the foot, ``hip, [knee], ankle or foot, [heel, toe]``, in
        the slope frame (:mod:`jaxwalk.figures`)."""
        raise NotImplementedError(f"model '{self.name}' {missing(self, 'drawing')}")

    def foot_points(self, q: Float[Array, "n_q"], params: Params, ctx: Float[Array, "n_ctx"]) -> Float[Array, "2 n_foot 2"]:
        """*drawing* ``(2, n_foot, 2)``: the points of each foot that can touch the
        ground, in the slope frame (the figures' foot clearance)."""
        raise NotImplementedError(f"model '{self.name}' {missing(self, 'drawing')}")

    # ---------------------------------------------------------------- derived
    def split(self, y: Array) -> tuple[Array, Array]:
        return y[: self.n_q], y[self.n_q :]

    def constraint_terms(self, q: Array, qd: Array, params: Params, ctx: Array) -> tuple[Array, Array]:
        """``Sigma`` ``(n_c, n_q)`` and ``Psi`` ``(n_c,)`` (paper eqs. 3-4); ``Sigma``
        in the form the walker's mass matrix takes (:func:`mechanics.entrywise`,
        decided by the point masses, so one walker builds all its dynamics alike).
        A model may write both by hand (the flat-foot walkers', from
        :mod:`jaxwalk.chain`), tested against this default (tests/test_chain.py)."""
        xi = lambda q_: self.constraints(q_, params, ctx)
        n_coordinates = math.prod(jax.eval_shape(lambda q_: self.points(q_, params), q).shape)
        sigma = mechanics.jacobian(xi, q, mechanics.entrywise(self.n_q, n_coordinates)).T
        return sigma, mechanics.second_derivative_along(xi, q, qd)

    def dynamics(self, y: Float[Array, "2*n_q"], params: Params, phase: Int32[ArrayLike, ""], ctx: Float[Array, "n_ctx"]) -> tuple[Float[Array, "n_q"], Float[Array, "n_constraints"]]:
        """Accelerations ``(n_q,)`` and constraint forces ``(n_c,)`` in ``phase``."""
        q, qd = self.split(y)
        pts = lambda q_: self.points(q_, params)
        masses, weights = self.masses(params), self.chain_weights(params)
        if weights is None:
            mass, forces = mechanics.mass_matrix_and_forces(pts, masses, self.gravity(params), q, qd)
        else:
            mass, forces = chain.mass_matrix_and_forces(weights, masses, self.gravity(params), q, qd)
        forces = forces + self.joint_forces(q, qd, params, phase, ctx)
        sigma, psi = self.constraint_terms(q, qd, params, ctx)
        # A mask that does not depend on traced values (one constant for all
        # phases) comes out concrete here, and the solve drops its inactive rows.
        with jax.ensure_compile_time_eval():
            mask = self.constraint_mask(phase, params)
        return mechanics.constrained_accelerations(mass, forces, sigma, psi, mask)

    def vector_field(self, t: Float[Array, ""], y: Float[Array, "2*n_q"], args: tuple) -> Float[Array, "2*n_q"]:
        """``dy/dt`` for diffrax: ``args = (params, phase, ctx)``."""
        params, phase, ctx = args
        qdd, _ = self.dynamics(y, params, phase, ctx)
        return jnp.concatenate([y[self.n_q :], qdd])

    def apply_impact(self, y: Array, params: Params, ctx: Array, mask: Array) -> tuple[Array, Array]:
        """Inelastic impact onto the constraints in ``mask``: new ``y`` and impulses."""
        q, qd = self.split(y)
        weights = self.chain_weights(params)
        if weights is None:
            mass = mechanics.mass_matrix(lambda q_: self.points(q_, params), self.masses(params), q)
        else:
            mass = chain.mass_matrix(weights, self.masses(params), q)
        sigma, _ = self.constraint_terms(q, qd, params, ctx)
        qd_plus, impulses = mechanics.impact(mass, qd, sigma, mask)
        return jnp.concatenate([q, qd_plus]), impulses

    def energy(self, y: Float[Array, "2*n_q"], params: Params, phase: Int32[ArrayLike, ""], ctx: Float[Array, "n_ctx"]) -> Float[Array, ""]:
        """Total mechanical energy: kinetic + gravity + springs (scalar)."""
        q, qd = self.split(y)
        pts = lambda q_: self.points(q_, params)
        masses = self.masses(params)
        return (
            mechanics.kinetic_energy(pts, masses, q, qd)
            + mechanics.gravity_potential(pts, masses, self.gravity(params), q)
            + self.spring_energy(q, params, phase, ctx)
        )


def is_state(model: Walker, v: Float[Array, "n_v"], params: Params) -> Bool[Array, ""]:
    """Whether section point ``v`` is a state of the walker: one its
    :meth:`Walker.into_section` leaves where it is, bit for bit."""
    return jnp.all(model.into_section(v, params) == v)


# -------------------------------------------------------------------- capabilities


def overrides(model: Walker, method: str) -> bool:
    """Whether ``model``'s class defines ``method`` itself rather than taking :class:`Walker`'s default."""
    return getattr(type(model), method) is not getattr(Walker, method)


def _step_down(model: Walker) -> str | None:
    return None if model.ground_next is not None else "has no step-down (no 'ground_next' in its context)"


def _step_up(model: Walker) -> str | None:
    if model.ground_next is None:
        return _step_down(model)
    return None if model.cannot_step_up is None else f"cannot walk up a step: {model.cannot_step_up}"


def _drawing(model: Walker) -> str | None:
    absent = [m for m in ("skeleton", "foot_points") if not overrides(model, m)]
    return f"cannot be drawn: it has no {' or '.join(f'{m}()' for m in absent)} method" if absent else None


#: Each optional capability: the end of the one-line refusal when ``model`` lacks it, else ``None``.
CAPABILITIES: dict[str, Callable[[Walker], str | None]] = {
    "step_down": _step_down, "step_up": _step_up, "drawing": _drawing}

#: The capability each config key needs when it is switched on (its value
#: truthy): ``[analysis]`` keys of a sweep, ``[simulate] drop``. (The figures of
#: a simulation need the drawing capability: :func:`jaxwalk.simulate.check_drawable`.)
NEEDS: dict[str, str] = {
    "h_max": "step_down",
    "gait_sensitivity": "step_down",
    "mfpt": "step_up",
    "drop": "step_down",
}


def missing(model: Walker, capability: str) -> str | None:
    """Why ``model`` lacks ``capability`` (a key of :data:`CAPABILITIES`): the end of a
    sentence that begins "model 'name' ", or ``None`` when it has it."""
    return CAPABILITIES[capability](model)


def require(model: Walker, capability: str, where: str) -> None:
    """Raise :class:`~jaxwalk.errors.ConfigError` ``"where: model 'name' <why>"`` when
    ``model`` lacks ``capability`` (the Python API's refusal; configs use :func:`check_supported`)."""
    reason = missing(model, capability)
    if reason:
        raise ConfigError(f"{where}: model '{model.name}' {reason}")


def check_supported(model: Walker, requested: Mapping[str, object], fail: Callable[[str], Exception], where: str = "[analysis]") -> None:
    """Refuse, before anything is traced, what ``model`` cannot run.

    Args:
        requested: config key (a key of :data:`NEEDS`) -> its resolved value; a
            falsy value (``None``, ``False``, ``0``, ``{}``) asks for nothing.
            Keys that need no capability are ignored.
        fail: ``fail(message)`` returns the exception to raise (the config's
            :class:`jaxwalk.ConfigError`, its source in front).
        where: the config section named in the message.
    """
    for key, value in requested.items():
        reason = missing(model, NEEDS[key]) if value and key in NEEDS else None
        if reason:
            raise fail(f"{where} {key}: model '{model.name}' {reason}")
