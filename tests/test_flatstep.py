"""The flat step engine (jaxwalk.flatstep) against the nested one and against truth.

Cheap walkers only (simplest, compass): the flat-foot walker on the flat
engine is covered by running tests/test_flatfoot.py with JAXWALK_ENGINE=flat.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxwalk.flatstep import implicit_root, locate_event
from jaxwalk.gait import find_gait
from jaxwalk.models import get_model
from jaxwalk.status import Status
from jaxwalk.step import SolverOptions, run_step, step_map

FLAT = SolverOptions(engine="flat")
NESTED = SolverOptions(engine="nested")
SIMPLEST = get_model("simplest")


def test_locate_event_root_and_implicit_tangent():
    """Root of t^2 - p in [0, 2] and its derivative 1 / (2 sqrt p), from the implicit step."""

    def root(p):
        guard = lambda t: p - t * t  # positive before the root, as guards are
        frozen = lambda t: jax.lax.stop_gradient(p) - t * t
        t_k, ok = locate_event(frozen, 0.0, 2.0, jax.lax.stop_gradient(p), jax.lax.stop_gradient(p) - 4.0, 8, 1e-13)
        return implicit_root(guard, t_k), ok

    (t, ok), (dt, _) = jax.jvp(root, (jnp.asarray(2.0),), (jnp.asarray(1.0),))
    assert bool(ok)
    np.testing.assert_allclose(t, np.sqrt(2.0), rtol=1e-14)
    np.testing.assert_allclose(dt, 0.5 / np.sqrt(2.0), rtol=1e-12)


@pytest.fixture(scope="module")
def simplest_maps():
    p = SIMPLEST.default_params()
    v = SIMPLEST.initial_guess(p)
    out = {}
    for name, opts in (("flat", FLAT), ("nested", NESTED)):
        fn = jax.jit(lambda v, opts=opts: step_map(SIMPLEST, v, p, opts))
        jac = jax.jit(jax.jacfwd(lambda v, opts=opts: step_map(SIMPLEST, v, p, opts)[0]))
        out[name] = (fn(v), jac(v))
    return p, v, out


def test_flat_equals_nested_step_map(simplest_maps):
    """Same step, both engines: the same events and the map to integration accuracy."""
    _, _, out = simplest_maps
    (v_f, r_f), j_f = out["flat"]
    (v_n, r_n), j_n = out["nested"]
    assert int(r_f.status) == int(r_n.status) == Status.OK
    assert int(r_f.n_events) == int(r_n.n_events)
    assert int(r_f.guard) == int(r_n.guard) == SIMPLEST.guards.index("heel_strike")  # the event that ended the step
    np.testing.assert_allclose(v_f, v_n, atol=1e-8)
    np.testing.assert_allclose(r_f.time, r_n.time, atol=1e-7)
    np.testing.assert_allclose(j_f, j_n, rtol=1e-5, atol=1e-5)


def test_flat_jacobian_matches_central_differences(simplest_maps):
    """Forward mode through the flat loop (event-time terms included) against
    central differences of its own map at a tight tolerance."""
    p, v, _ = simplest_maps
    tight = SolverOptions(engine="flat", rtol=1e-12, atol=1e-12)
    f = jax.jit(lambda v: step_map(SIMPLEST, v, p, tight)[0])
    jac = np.asarray(jax.jit(jax.jacfwd(lambda v: step_map(SIMPLEST, v, p, tight)[0]))(v))
    # As tests/test_simplest.py: h = 1e-4 with Richardson extrapolation (the map's
    # second derivatives are ~1e3); at h = 1e-5 the solver's noise reached 2e-6
    # on both engines alike.
    h = 1e-4
    cols = []
    for i in range(v.shape[0]):
        e = jnp.zeros_like(v).at[i].set(h)
        d1 = (f(v + e) - f(v - e)) / (2 * h)
        d2 = (f(v + 2 * e) - f(v - 2 * e)) / (4 * h)
        cols.append(np.asarray((4 * d1 - d2) / 3))
    np.testing.assert_allclose(jac, np.stack(cols, axis=1), rtol=1e-6, atol=1e-6)


class _WoundUpSimplest(type(SIMPLEST)):
    """The simplest walker whose step-ending reset does 0.125 of actuator work
    (a stand-in for the flat-foot walker's ankle springs wound up at toe-strike)."""

    def on_event(self, guard, t, y, params, phase, ctx):
        tr = super().on_event(guard, t, y, params, phase, ctx)
        return tr._replace(work=jnp.where(tr.step_done, 0.125, 0.0))


def test_both_engines_add_a_resets_own_work_to_the_step():
    """``Transition.work`` reaches ``StepResult.work`` on both engines, once per step:
    the simplest walker is passive, so its step's work is the reset's alone."""
    model = _WoundUpSimplest()
    p = model.default_params()
    v = model.initial_guess(p)
    for opts in (FLAT, NESTED):
        _, res = jax.jit(lambda v, opts=opts: step_map(model, v, p, opts))(v)
        assert int(res.status) == Status.OK and float(res.work) == 0.125, (opts.engine, float(res.work))


def test_flat_vmap_equals_single_runs_and_failures_are_statuses():
    """A batch on the flat engine, each lane in its own phase, equals one run per
    config to the map's integration noise (not to round-off as on the nested
    engine: measured 1e-10 in the map, docs/engine.md "Known limits"; gait
    tolerances of tests/test_simplest.py); an uphill slope fails with the
    nested engine's status."""

    def params(g):
        return {**SIMPLEST.default_params(), "gamma": g}

    def search(g, opts):
        return find_gait(SIMPLEST, params(g), SIMPLEST.initial_guess(params(g)), opts)

    gammas = jnp.array([0.004, 0.009, 0.014, -0.01])
    one_map = jax.jit(lambda g: step_map(SIMPLEST, SIMPLEST.initial_guess(params(g)), params(g), FLAT)[0])
    maps = jax.jit(jax.vmap(lambda g: step_map(SIMPLEST, SIMPLEST.initial_guess(params(g)), params(g), FLAT)[0]))(gammas[:3])
    batch = jax.jit(jax.vmap(lambda g: search(g, FLAT)))(gammas)
    one = jax.jit(lambda g: search(g, FLAT))
    for i, g in enumerate(gammas[:3]):
        np.testing.assert_allclose(maps[i], one_map(g), rtol=0, atol=1e-9)
        single = one(g)
        assert int(single.status) == int(batch.status[i]) == Status.OK
        np.testing.assert_allclose(single.v, batch.v[i], atol=1e-9)
        np.testing.assert_allclose(single.lambda_max, batch.lambda_max[i], atol=1e-6)
    nested = jax.jit(lambda g: search(g, NESTED))(gammas[-1])
    assert int(batch.status[-1]) == int(nested.status) != Status.OK
    # ... in the same phase, at the same event (GaitStats: where the failed step failed).
    for field in ("failure_phase", "failure_guard", "failure_limit"):
        assert int(getattr(batch.stats, field)[-1]) == int(getattr(nested.stats, field))
    assert int(nested.stats.failure_guard) == SIMPLEST.guards.index("stall")
    assert np.isnan(batch.lambda_max[-1])


def test_out_of_steps_on_a_rejected_try_ends_at_the_last_accepted_step():
    """The simplest walker's first step with 8 solver steps allowed: the 8th try is
    rejected (measured: the flat engine reported its end, t = 2.506, where the
    nested one, diffrax, ends at its last accepted step, t = 2.022). Both engines
    end ``solver_failed`` at the same time and state."""
    p = SIMPLEST.default_params()
    y0, phase0, ctx0 = SIMPLEST.section_to_state(SIMPLEST.initial_guess(p), p)
    ends = []
    for engine in ("flat", "nested"):
        opts = SolverOptions(engine=engine, max_solver_steps=8)
        ends.append(jax.jit(lambda y: run_step(SIMPLEST, p, y, phase0, ctx0, opts))(y0))
    flat, nested = ends
    assert int(flat.status) == int(nested.status) == Status.SOLVER_FAILED
    np.testing.assert_allclose(float(flat.time), float(nested.time), rtol=0, atol=1e-12)
    np.testing.assert_allclose(flat.y, nested.y, rtol=0, atol=1e-12)


def test_unknown_engine_is_an_error():
    p = SIMPLEST.default_params()
    with pytest.raises(ValueError, match="engine"):
        step_map(SIMPLEST, SIMPLEST.initial_guess(p), p, SolverOptions(engine="fast"))


def test_guard_offsets_lift_only_the_guards_that_just_fired():
    """A guard in [-margin, 0] at a phase's start (the one whose event just ended
    the last phase) is lifted by twice the margin, so the smallest guard starts
    positive and every other guard's crossing is seen; a guard below -margin is
    an event at the start and is left alone, and a positive one is not moved."""
    from jaxwalk.stepbase import SolverOptions, guard_offsets

    opts = SolverOptions()
    off = np.asarray(guard_offsets(jnp.array([0.5, -6e-17, 0.0, -1e-3, -5e-10]), opts))
    m = opts.start_guard_margin
    np.testing.assert_array_equal(off, [0.0, 2 * m, 2 * m, 0.0, 2 * m])
    lifted = np.array([0.5, -6e-17, 0.0, -1e-3, -5e-10]) + off
    assert (np.delete(lifted, 3) > 0).all() and lifted[3] < -m


def test_reverse_mode_through_a_step_equals_forward_mode():
    """``jax.grad`` of a function of one step (the next section point and the step's
    time) with respect to the model's parameters, on the flat engine's checkpointed
    loop, equals forward mode (``jacfwd``) on its ordinary loop, to round-off: the
    same derivative of the same computation, built the other way round. A central
    difference of the map agrees to its own error (integration noise / h). The
    compass walker: every parameter has a derivative (the simplest walker has one)."""
    model = get_model("compass")
    p0 = {k: jnp.asarray(v) for k, v in model.default_params().items()}
    v = model.initial_guess(p0)
    weights = jnp.linspace(1.0, -0.5, v.shape[0])

    def metric(opts):
        def f(p):
            v1, res = step_map(model, v, p, opts)
            return jnp.dot(weights, v1) + res.time
        return f

    forward = jax.jit(jax.jacfwd(metric(FLAT)))(p0)
    reverse = jax.jit(jax.grad(metric(SolverOptions(engine="flat", reverse_mode=True))))(p0)
    for key in p0:
        np.testing.assert_allclose(reverse[key], forward[key], rtol=1e-10, atol=1e-12, err_msg=key)
    key = "gamma"
    h = 1e-5
    f = jax.jit(metric(FLAT))
    central = (f({**p0, key: p0[key] + h}) - f({**p0, key: p0[key] - h})) / (2 * h)
    np.testing.assert_allclose(reverse[key], central, rtol=1e-4)


def test_reverse_mode_needs_the_flat_engine():
    with pytest.raises(ValueError, match="reverse_mode needs engine='flat'"):
        SolverOptions(engine="nested", reverse_mode=True)
