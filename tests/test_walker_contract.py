"""Every registered model against the same contract (:mod:`jaxwalk.walker`).

Parametrised over ``jaxwalk.models.MODELS``: a model added to the registry is
checked here without a line of this file changing. Per model: the declared
names against the shapes the methods return, the section round trip, energy
minus actuator work conserved along a continuous phase (plain conservation for
a passive model; for the flat-foot walker, whose hip torque works, energy alone
is not conserved), the drawing methods' shapes, value equality (a second
instance reuses the compiled program, counted by JAX's compile events), and
the refusal of analyses whose capability a model lacks.

Cost: all of that runs eagerly or in one small jitted program per model
(seconds). The gait search from the model's initial guess (Newton through
forward-mode derivatives of the whole step) is the one costly program, run
here for the point-foot walkers that trace and compile it in seconds
(``GAIT_SEARCHED``; compass's is the one ``tests/test_simulate.py`` compiles
too). The kneed walkers' took 1.5 to 5 minutes on this 2-core machine, the
flat-foot walker's longer; their gaits from the guess are tested where those
programs are compiled anyway: ``tests/test_kneed.py`` (``gait``: Newton from
``initial_guess``; ``kneed_stop``'s defaults buckle there), and
``tests/test_flatfoot_gaits.py`` (the shoe gait of the flat-foot walker's defaults,
Newton from ``initial_guess``).
"""

from __future__ import annotations

import functools

import diffrax
import jax
import jax.monitoring
import jax.numpy as jnp
import numpy as np
import pytest

from jaxwalk.models import MODELS, get_model
from jaxwalk.simulate import check_drawable, find_start_gait, parse_simulate_config
from jaxwalk.status import Status
from jaxwalk.step import SolverOptions, step_map
from jaxwalk.sweep.config import ConfigError, parse_config
from jaxwalk.walker import NEEDS, Walker, check_supported, missing

NAMES = sorted(MODELS)
#: Models whose gait search traces and compiles in seconds (see the module docstring for the others).
GAIT_SEARCHED = ["compass", "simplest"]


@pytest.fixture(scope="module", params=NAMES)
def model(request) -> Walker:
    return MODELS[request.param]


@pytest.fixture(scope="module")
def start(model):
    """``(params, v, y, phase, ctx)``: the defaults and the section state of the initial guess."""
    params = model.default_params()
    v = model.initial_guess(params)
    y, phase, ctx = model.section_to_state(v, params)
    return params, v, y, phase, ctx


@functools.lru_cache(maxsize=None)
def _gait(model: Walker):
    return find_start_gait(model, model.default_params())


def _compiles(fn):
    """``(result, number of XLA compilations fn caused)``, from JAX's own monitoring events."""
    count = [0]

    def on_duration(event, secs, **kwargs):
        count[0] += event == "/jax/core/compile/backend_compile_duration"

    jax.monitoring.register_event_duration_secs_listener(on_duration)
    try:
        out = fn()
    finally:
        jax.monitoring.unregister_event_duration_listener(on_duration)
    return out, count[0]


# ---------------------------------------------------------------- declarations


def test_declared_names(model):
    for names in (model.coordinates, model.phases, model.guards, model.context, model.section_names):
        assert names and len(set(names)) == len(names) and all(isinstance(n, str) and n for n in names)
    assert MODELS[model.name] is model
    assert model.coordinates[:2] == ("x_h", "y_h")
    specs = model.param_specs
    assert len(specs) == len(model.parameters) and "gamma" in specs
    for spec in model.parameters:
        spec.check(spec.default)  # every default is physical
    assert set(model.units) >= {"length", "time"}
    assert model.n_constraints > 0 and model.lockstep_batch >= 1
    if model.ground_next is not None:
        assert model.context[model.ground_next] == "ground_next"
    else:
        assert "ground_next" not in model.context
    # Guard names the engine looks up at trace time: a misspelt one is caught here.
    assert set(model.failure_guards) <= set(model.guards) and set(model.limit_guards) <= set(model.guards)
    assert len(model.limit_guards) in (0, len(model.limits))


def test_an_event_names_its_least_guard_but_at_a_start_its_first_failure():
    """``Walker.named_guard`` on plain values (the flat-foot walker's order of failures)."""
    model = MODELS["flatfoot"]
    g = lambda **values: jnp.asarray([values.get(name, 1.0) for name in model.guards])
    index = lambda name: model.guards.index(name)
    at_heel_strike = g(heel_strike=-1e-13, scuff=-1e-13)  # a located crossing: a tie with scuff_tol = 0
    assert int(model.named_guard(at_heel_strike, False)) == index("heel_strike")
    pulls = g(running=-0.13, slip=-0.30, foot_roll=-0.05)  # the defaults with k = 0.2 at the section
    assert int(model.named_guard(pulls, True)) == index("running")
    assert int(model.named_guard(pulls, False)) == index("slip")
    transition_first = g(unlock=-0.5, foot_roll=-0.01)  # a failure due beside a lower transition guard
    assert int(model.named_guard(transition_first, True)) == index("foot_roll")
    assert int(model.named_guard(g(unlock=-0.5), True)) == index("unlock")  # no failure: the least guard


def test_shapes_against_declared_names(model, start):
    params, v, y, phase, ctx = start
    n_q, n_c = model.n_q, model.n_constraints
    assert v.shape == (len(model.section_names),)
    assert y.shape == (2 * n_q,) and y.dtype == jnp.float64
    assert ctx.shape == (len(model.context),)
    assert phase.dtype == jnp.int32 and 0 <= int(phase) < len(model.phases)
    q, qd = model.split(y)
    points, masses = model.points(q, params), model.masses(params)
    assert points.shape == (masses.shape[0], 2) and bool(jnp.all(masses >= 0)) and float(jnp.sum(masses)) > 0
    assert model.constraints(q, params, ctx).shape == (n_c,)
    mask = np.asarray(model.constraint_mask(phase, params))
    assert mask.shape == (n_c,) and set(np.unique(mask)) <= {0.0, 1.0}
    assert model.guard_values(jnp.zeros(()), y, params, phase, ctx).shape == (len(model.guards),)
    qdd, lam = model.dynamics(y, params, phase, ctx)
    assert qdd.shape == (n_q,) and lam.shape == (n_c,) and bool(jnp.all(jnp.isfinite(qdd)))
    assert model.vector_field(0.0, y, (params, phase, ctx)).shape == (2 * n_q,)
    for scalar in (
        model.energy(y, params, phase, ctx),
        model.actuator_power(q, qd, params, phase, ctx),
        model.actuator_work(y, y, params, phase, ctx),
        model.weight(params),
        model.time_scale(params),
    ):
        assert jnp.shape(scalar) == ()


def test_section_round_trip(model, start):
    params, v, y, phase, ctx = start
    np.testing.assert_allclose(model.state_to_section(y, params, ctx), v, rtol=0, atol=1e-12)
    # The section state is one the phase's constraints allow: positions and velocities.
    q, qd = model.split(y)
    active = np.asarray(model.constraint_mask(phase, params)) > 0
    sigma, _ = model.constraint_terms(q, qd, params, ctx)
    np.testing.assert_allclose(np.asarray(model.constraints(q, params, ctx))[active], 0.0, atol=1e-12)
    np.testing.assert_allclose(np.asarray(sigma @ qd)[active], 0.0, atol=1e-12)


def test_power_is_the_rate_of_energy_along_the_flow(model, start):
    """dE/dt = actuator power at the section state (springs are in E; constraints do no work)."""
    params, _, y, phase, ctx = start
    f = model.vector_field(0.0, y, (params, phase, ctx))
    _, rate = jax.jvp(lambda y_: model.energy(y_, params, phase, ctx), (y,), (f,))
    q, qd = model.split(y)
    power = model.actuator_power(q, qd, params, phase, ctx)
    scale = model.weight(params) * jnp.linalg.norm(qd[:2])  # weight times hip speed
    assert abs(float(rate - power)) < 1e-10 * float(scale)
    if not model.actuated:
        assert float(power) == 0.0


def test_energy_minus_work_is_conserved_over_a_continuous_phase(model, start):
    """Integrate the section state's phase (no events: the continuous dynamics
    alone) for a tenth of the time scale; E - actuator work stays constant."""
    params, _, y, phase, ctx = start
    t1 = 0.1 * float(model.time_scale(params))
    sol = diffrax.diffeqsolve(
        diffrax.ODETerm(model.vector_field), diffrax.Tsit5(), t0=0.0, t1=t1, dt0=None, y0=y,
        args=(params, phase, ctx), stepsize_controller=diffrax.PIDController(rtol=1e-11, atol=1e-11),
        saveat=diffrax.SaveAt(ts=jnp.linspace(0.0, t1, 5)),
    )
    balance = [model.energy(y_t, params, phase, ctx) - model.actuator_work(y, y_t, params, phase, ctx) for y_t in sol.ys]
    # Energy scale: weight x leg length, the leg length being g T^2 (T = sqrt(L/g)).
    scale = float(model.weight(params) * jnp.linalg.norm(model.gravity(params)) * model.time_scale(params) ** 2)
    np.testing.assert_allclose(np.asarray(balance) - float(balance[0]), 0.0, atol=1e-9 * scale)
    assert float(jnp.max(jnp.abs(sol.ys[-1] - y))) > 1e-6  # the state did move


# ---------------------------------------------------------------- drawing


def test_drawing_shapes(model, start):
    params, _, y, _, ctx = start
    q, _ = model.split(y)
    assert missing(model, "drawing") is None
    skeleton = np.asarray(model.skeleton(q, params, ctx))
    feet = np.asarray(model.foot_points(q, params, ctx))
    assert skeleton.ndim == 3 and skeleton.shape[0] == 2 and skeleton.shape[1] >= 2 and skeleton.shape[2] == 2
    assert feet.ndim == 3 and feet.shape[0] == 2 and feet.shape[2] == 2
    assert np.all(np.isfinite(skeleton)) and np.all(np.isfinite(feet))
    np.testing.assert_allclose(skeleton[:, 0], np.tile(np.asarray(q[:2]), (2, 1)), atol=1e-12)  # legs start at the hip
    for leg in range(2):  # every foot point is a vertex of its leg's polyline
        gaps = np.linalg.norm(feet[leg][:, None, :] - skeleton[leg][None, :, :], axis=-1).min(axis=1)
        np.testing.assert_allclose(gaps, 0.0, atol=1e-12)
    assert abs(feet[0, :, 1].min()) < 1e-12  # the stance foot stands on the slope at the section


# ---------------------------------------------------------------- identity


def test_models_compare_by_value(model):
    twin = type(model)()
    assert twin == model and hash(twin) == hash(model) and twin is not model
    assert all((MODELS[other] == model) == (other == model.name) for other in NAMES)

    traces = []

    @functools.partial(jax.jit, static_argnums=0)
    def energy(m, y, params, phase, ctx):
        traces.append(m)
        return m.energy(y, params, phase, ctx)

    y, phase, ctx = model.section_to_state(model.initial_guess(model.default_params()), model.default_params())
    first = energy(model, y, model.default_params(), phase, ctx)
    second, compiles = _compiles(lambda: energy(twin, y, twin.default_params(), phase, ctx))
    assert len(traces) == 1 and compiles == 0 and float(first) == float(second)


@pytest.mark.parametrize("name", GAIT_SEARCHED)
def test_gait_from_the_initial_guess(name):
    model = MODELS[name]
    gait = _gait(model)
    n_v = len(model.section_names)
    assert gait.v.shape == (n_v,) and gait.jacobian.shape == (n_v, n_v) and gait.eigenvalues.shape == (n_v,)
    assert int(gait.status) == Status.OK, Status(int(gait.status)).name
    assert 0 < int(gait.iterations) < 25
    assert float(gait.period) > 0 and float(gait.step_length) > 0 and np.isfinite(float(gait.lambda_max))
    # The guess lies near the gait it leads to (the defaults' own gait, not another found far away).
    assert np.max(np.abs(gait.v - np.asarray(model.initial_guess(model.default_params())))) < 0.05
    # A second instance finds it again with the programs already compiled: none is compiled twice.
    again, compiles = _compiles(lambda: find_start_gait(type(model)(), model.default_params()))
    assert compiles == 0
    np.testing.assert_array_equal(again.v, gait.v)


# ---------------------------------------------------------------- capabilities

SWEEP = """
name = "contract"
model = "{model}"
[grid]
gamma = {{ values = [{gamma}] }}
[analysis]
{analysis}
"""
#: Each analysis a sweep may ask for, with the capability it needs.
ANALYSES = {
    "h_max": "h_max = true",
    "gait_sensitivity": "gait_sensitivity = true",
    "mfpt": "mfpt = { sigma = 0.001 }",
}


def _sweep(model: Walker, key: str) -> dict:
    from jaxwalk.sweep.config import parse_toml

    gamma = model.param_specs["gamma"].default
    return parse_toml(SWEEP.format(model=model.name, gamma=gamma, analysis=ANALYSES[key]))


def _without(model: Walker, capability: str) -> Walker:
    """The model with one capability taken away (a class of its own, same name)."""
    strip = {"step_down": {"ground_next": None}, "drawing": {"skeleton": Walker.skeleton}}[capability]
    return type(f"{type(model).__name__}Without_{capability}", (type(model),), dict(strip))()


@pytest.mark.parametrize("key", sorted(ANALYSES))
def test_supported_analyses_are_accepted(model, key):
    assert NEEDS[key] in ("step_down", "step_up") and missing(model, "step_down") is None
    if missing(model, NEEDS[key]) is not None:
        pytest.skip(f"{model.name} lacks {NEEDS[key]}: test_a_model_that_cannot_step_up_refuses_the_mfpt_and_the_walks")
    config = parse_config(_sweep(model, key))
    assert config.model == model.name


def test_a_model_that_cannot_step_up_refuses_the_mfpt_and_the_walks():
    """The heel-rise walker keeps its trailing foot's height in its section (it
    cannot walk up a step); its step-downs and the norm are accepted."""
    from jaxwalk.global_stability.mfpt import MFPTOptions, mfpt
    from jaxwalk.global_stability.walks import monte_carlo, steps_to_fall

    model = get_model("flatfoot_heel_rise")
    reason = ("cannot walk up a step: its section keeps the trailing foot's height and its step assumes both feet "
              "on one level ground (docs/model.md, \"The heel-rise walker\")")
    assert missing(model, "step_up") == reason and missing(get_model("flatfoot"), "step_up") is None
    with pytest.raises(ConfigError) as err:
        parse_config(_sweep(model, "mfpt"), source="contract.toml")
    assert str(err.value) == f"contract.toml: [analysis] mfpt: model 'flatfoot_heel_rise' {reason}"
    for key in ("h_max", "gait_sensitivity"):
        assert parse_config(_sweep(model, key)).model == model.name
    params, v = model.default_params(), np.zeros(3)  # refused before anything is traced
    for sigma in (0.001, 0.0):  # at sigma 0 too, where nothing would walk
        with pytest.raises(ConfigError, match="^mfpt: model 'flatfoot_heel_rise' cannot walk up a step"):
            mfpt(model, params, v, MFPTOptions(sigma=sigma))
    with pytest.raises(ConfigError, match="^monte_carlo: model 'flatfoot_heel_rise' cannot walk up a step"):
        monte_carlo(model, params, v, 0.001, n_walks=4, max_steps=3)
    with pytest.raises(ConfigError, match="^steps_to_fall: model 'flatfoot_heel_rise' cannot walk up a step"):
        steps_to_fall(model, params, v, jax.random.PRNGKey(0), 0.001, 3)


@pytest.mark.parametrize("key", sorted(ANALYSES))
def test_unsupported_analyses_are_refused_in_one_line(model, key, monkeypatch):
    bare = _without(model, "step_down")
    monkeypatch.setitem(MODELS, model.name, bare)
    with pytest.raises(ConfigError) as err:
        parse_config(_sweep(model, key), source="contract.toml")
    message = str(err.value)
    assert "\n" not in message
    assert message == (
        f"contract.toml: [analysis] {key}: model '{model.name}' has no step-down (no 'ground_next' in its context)"
    )


def test_a_drop_and_the_figures_are_refused_without_their_capability(model, monkeypatch):
    bare = _without(model, "step_down")
    monkeypatch.setitem(MODELS, model.name, bare)
    data = {"name": "walk", "model": model.name, "simulate": {"steps": 1, "drop": 0.01}}
    with pytest.raises(ConfigError, match=r"\[simulate\] drop: model '.*' has no step-down"):
        parse_simulate_config(data)
    assert parse_simulate_config({**data, "simulate": {"steps": 1}}).drop == 0.0
    # The engine refuses a ground drop too, before it traces a step.
    params = bare.default_params()
    with pytest.raises(ValueError, match="has no step-down"):
        jax.eval_shape(lambda v: step_map(bare, v, params, SolverOptions(), ground_drop=0.01), bare.initial_guess(params))
    with pytest.raises(ConfigError, match=r"cannot be drawn: it has no skeleton\(\) method"):
        check_drawable(_without(model, "drawing"))
    check_drawable(model)


def test_check_supported_ignores_what_is_off(model):
    bare = _without(model, "step_down")

    def fail(message):
        return ConfigError(message)

    check_supported(bare, {"h_max": None, "gait_sensitivity": {}, "drop": 0.0, "bifurcations": True}, fail)
    with pytest.raises(ConfigError, match=r"^\[simulate\] drop: "):
        check_supported(bare, {"drop": 0.5}, fail, where="[simulate]")
