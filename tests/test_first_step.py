"""Each phase's first step, carried from the phase before (SolverOptions.carry_step)."""

from __future__ import annotations

import diffrax
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxwalk.models import get_model
from jaxwalk.status import Status
from jaxwalk.step import FIRST_STEP, ProposingController, SolverOptions, _solve_phase, start_guards, step_map


def _oscillator_solve(controller, t1, saveat):
    term = diffrax.ODETerm(lambda t, y, args: jnp.stack([y[1], -y[0] - 0.3 * y[1] ** 3]))
    return diffrax.diffeqsolve(term, diffrax.Dopri8(), 0.0, t1, FIRST_STEP, jnp.array([1.0, 0.0]),
                               stepsize_controller=controller, saveat=saveat, max_steps=256)


def test_the_proposal_is_the_step_a_longer_solve_takes_next():
    """A solve that ends where a longer one has a step end proposes exactly the longer one's next step,
    and its steps and solution are diffrax's PIDController's, bit for bit."""
    pid = diffrax.PIDController(rtol=1e-10, atol=1e-10, safety=0.75)
    longer = _oscillator_solve(pid, 6.0, diffrax.SaveAt(steps=True))
    ts = np.asarray(longer.ts)[: int(longer.stats["num_accepted_steps"])]
    k = len(ts) // 2
    plain = _oscillator_solve(pid, ts[k], diffrax.SaveAt(t1=True))
    proposing = _oscillator_solve(ProposingController(pid), ts[k], diffrax.SaveAt(t1=True, controller_state=True))
    assert int(proposing.stats["num_steps"]) == int(plain.stats["num_steps"])
    np.testing.assert_array_equal(proposing.ys, plain.ys)
    np.testing.assert_allclose(proposing.controller_state.proposed, ts[k + 1] - ts[k], rtol=1e-14)
    assert float(proposing.controller_state.proposed) > 10 * FIRST_STEP  # not the first step, grown since


@pytest.mark.slow
@pytest.mark.parametrize("engine", ["nested", "flat"])
def test_a_carried_first_step_takes_fewer_solver_steps_and_the_same_step(engine):
    """The compass gait's step from its stored guess (two events: a mid-stance split, heel-strike):
    with the first step carried over the split, fewer solver steps, and the same step to
    the integration noise of rtol 1e-10."""
    model = get_model("compass")
    p = model.default_params()
    v = model.initial_guess(p)
    out = {}
    for carry in (False, True):
        opts = SolverOptions(engine=engine, carry_step=carry)
        out[carry] = jax.jit(lambda v, opts=opts: step_map(model, v, p, opts))(v)
    (v_fixed, r_fixed), (v_carried, r_carried) = out[False], out[True]
    assert int(r_fixed.status) == int(r_carried.status) == Status.OK
    assert int(r_fixed.n_events) == int(r_carried.n_events) == 2
    assert int(r_carried.ode_steps) < int(r_fixed.ode_steps)
    np.testing.assert_allclose(v_carried, v_fixed, atol=1e-8)
    np.testing.assert_allclose(r_carried.time, r_fixed.time, atol=1e-8)


def test_the_walker_decides_where_the_settings_do_not_and_datasets_record_it():
    """``carry_step=None`` resolves to the walker's own (the simplest walker: no), and
    ``as_record`` writes the resolved value, as it does the safety factor."""
    simplest, flatfoot = get_model("simplest"), get_model("flatfoot")
    default = SolverOptions()
    assert default.carry_step is None
    assert default.carries_step(flatfoot) and not default.carries_step(simplest)
    assert SolverOptions(carry_step=True).carries_step(simplest)
    assert not SolverOptions(carry_step=False).carries_step(flatfoot)
    assert default.as_record(simplest)["carry_step"] is False
    assert default.as_record(flatfoot)["carry_step"] is True


@pytest.mark.slow
def test_a_phase_that_takes_no_step_hands_on_its_own_first_step():
    """A phase solved over an empty interval (it ended at its start) takes no step, and the
    next phase starts with the step this one was given: not diffrax's proposal there, which
    is in its flipped time (t1 <= t0) and negative."""
    model = get_model("compass")
    p = model.default_params()
    y, phase, ctx = model.section_to_state(model.initial_guess(p), p)
    t0 = jnp.zeros(())
    g0 = start_guards(model, p, t0, y, phase, ctx)
    for empty, expect_given in ((True, True), (False, False)):
        _, steps, dt_next = _solve_phase(model, p, y, phase, ctx, t0, g0, SolverOptions(), empty, jnp.asarray(0.0375))
        assert (int(steps) == 0) == empty
        assert float(dt_next) > 0
        assert (float(dt_next) == 0.0375) == expect_given
