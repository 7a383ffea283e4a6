"""The point-foot kneed walker (McGeer 1990; Hsu Chen 2007) against truth:
conservation laws along each phase and through each impact, constraint
residuals, the period-one gait of Hsu Chen's parameters, and the step map's
forward-mode Jacobian against central differences.

Compiled programs are built once per module (module-scoped fixtures): the
Jacobian of the step map (15-30 s to compile on two cores) serves Newton's
method and the eigenvalues; one tight-tolerance step map the finite differences.
"""

from __future__ import annotations

import math
from types import SimpleNamespace

import diffrax
import jax
import jax.numpy as jnp
import numpy as np
import optimistix as optx
import pytest

from jaxwalk import compiling
from jaxwalk.models import get_model, kneed
from jaxwalk.models.kneed import KneedStopWalker, KneedWalker
from jaxwalk.status import Status
from jaxwalk.step import SolverOptions, step_map

MODEL = get_model("kneed")
STOP_MODEL = KneedStopWalker()
# Compiled once for every test (guard and phase are traced arguments).
ON_EVENT = jax.jit(MODEL.on_event)
STOP_ON_EVENT = jax.jit(STOP_MODEL.on_event)

#: The period-one gait of the defaults, converged at rtol = atol = 1e-14 (12 digits;
#: see docs/models/kneed.md). At the default tolerances (1e-10) Newton lands within 1e-8 of it.
FIXED_POINT = (0.238534170409, -1.10951293632, -0.0577472669394)


@pytest.fixture(scope="module")
def params():
    return MODEL.default_params()


@pytest.fixture(scope="module")
def gait(params):
    """Newton's method on ``P(v) - v`` with the forward-mode Jacobian."""

    def residual(v):
        v_next, res = step_map(MODEL, v, params)
        return v_next - v, (v_next, res)

    jac = compiling.jit(jax.jacfwd(residual, has_aux=True), MODEL)  # as a sweep compiles it
    v = MODEL.initial_guess(params)
    for _ in range(8):
        j, (v_next, _) = jac(v)
        step = jnp.linalg.solve(j, v_next - v)
        v = v - step
        if float(jnp.max(jnp.abs(step))) < 1e-11:
            break
    j, (v_next, res) = jac(v)
    jacobian = np.asarray(j) + np.eye(3)
    return SimpleNamespace(v=v, v_next=v_next, res=res, jacobian=jacobian, eig=np.linalg.eigvals(jacobian), jac=jac)


def _phase_solver():
    """One phase integrated with the model's vector field and guards, as in
    :mod:`jaxwalk.step`, with dense output to sample the trajectory."""
    term = diffrax.ODETerm(MODEL.vector_field)

    def smallest_guard(t, y, args, **kwargs):
        return jnp.min(MODEL.guard_values(t, y, *args))

    event = diffrax.Event(smallest_guard, root_finder=optx.Newton(rtol=1e-13, atol=1e-13), direction=False)

    @jax.jit
    def solve(y0, t0, params, phase, ctx):
        sol = diffrax.diffeqsolve(
            term,
            diffrax.Dopri8(),
            t0,
            t0 + 2.0,
            None,
            y0,
            args=(params, phase, ctx),
            event=event,
            saveat=diffrax.SaveAt(t1=True, dense=True),
            stepsize_controller=diffrax.PIDController(rtol=1e-11, atol=1e-11),
            max_steps=4096,
        )
        ts = jnp.linspace(t0, sol.ts[-1], 101)
        return sol.ts[-1], sol.ys[-1], ts, jax.vmap(sol.evaluate)(ts)

    return solve


@pytest.fixture(scope="module")
def trajectory(params):
    return one_step(params)


def one_step(params):
    """One step from the fixed point, phase by phase: each phase's samples, the
    state just before its event, and the model's transition."""
    solve = _phase_solver()
    guards = jax.jit(MODEL.guard_values)
    y, phase, ctx = MODEL.section_to_state(jnp.asarray(FIXED_POINT), params)
    t = jnp.zeros(())
    phases = []
    for _ in range(4):
        t_event, y_event, ts, ys = solve(y, t, params, phase, ctx)
        which = jnp.argmin(guards(t_event, y_event, params, phase, ctx))
        tr = ON_EVENT(which, t_event, y_event, params, phase, ctx)
        phases.append(SimpleNamespace(phase=int(phase), ctx=ctx, ts=ts, ys=ys, t_event=t_event, y_event=y_event, guard=int(which), tr=tr))
        if bool(tr.step_done) or int(tr.status) != Status.IN_PROGRESS:
            break
        y, phase, ctx, t = tr.y, tr.phase, tr.ctx, t_event
    return phases


def _angular_momentum(y, params, about, which):
    """``sum m_i (p_i - about) x v_i`` over the point masses ``which``."""
    q, qd = MODEL.split(y)
    points = lambda q_: MODEL.points(q_, params)
    pos, vel = jax.jvp(points, (q,), (qd,))
    r = pos - about
    per_point = MODEL.masses(params) * (r[:, 0] * vel[:, 1] - r[:, 1] * vel[:, 0])
    return jnp.sum(per_point[jnp.asarray(which)])


def _weight_length(params):
    return float(jnp.sum(MODEL.masses(params)) * params["g"] * MODEL.lengths(params)[2])


# Point masses: 0 hip; 1, 2 thigh and shank of leg 1 (stance); 3, 4 of leg 2 (swing).
ALL, LEG_1, LEG_2 = (0, 1, 2, 3, 4), (1, 2), (3, 4)


# ---------------------------------------------------------------- set-up
def test_defaults_are_hsu_chen_table_3_1(params):
    assert isinstance(MODEL, KneedWalker) and not MODEL.stance_knee_stop
    expected = dict(a1=0.375, b1=0.125, a2=0.175, b2=0.325, m_h=0.5, m_t=0.5, m_s=0.05, g=9.81)
    for name, value in expected.items():
        assert float(params[name]) == pytest.approx(value, rel=1e-15)
    assert float(params["gamma"]) == pytest.approx(math.asin(7.25 / 144.0), rel=1e-15)
    assert [s.name for s in MODEL.parameters][:1] == ["gamma"]


def test_section_round_trip(params):
    v = jnp.asarray(FIXED_POINT)

    @jax.jit
    def section(v):
        y, phase, ctx = MODEL.section_to_state(v, params)
        q, qd = MODEL.split(y)
        sigma, _ = MODEL.constraint_terms(q, qd, params, ctx)
        return MODEL.state_to_section(y, params, ctx), phase, MODEL.constraints(q, params, ctx), sigma @ qd

    v_back, phase, position, velocity = section(v)
    np.testing.assert_allclose(v_back, v, rtol=0, atol=1e-15)
    assert int(phase) == kneed.UNLOCKED  # the freed swing knee flexes
    # Both feet on the ground, both knees straight, the stance foot at rest.
    np.testing.assert_allclose(np.asarray(position)[[0, 1, 2, 3, 5]], 0.0, atol=1e-15)
    np.testing.assert_allclose(np.asarray(velocity)[[0, 1, 2, 3]], 0.0, atol=1e-15)


# ---------------------------------------------------------------- continuous phases
def test_phases_visited_in_order(trajectory):
    assert [p.phase for p in trajectory] == [kneed.UNLOCKED, kneed.LOCKED]
    assert [p.guard for p in trajectory] == [kneed.KNEE_STRIKE, kneed.HEEL_STRIKE]
    assert bool(trajectory[-1].tr.step_done)
    assert int(trajectory[-1].tr.phase) == kneed.UNLOCKED  # the new swing knee is released
    assert 0.0 < float(trajectory[0].t_event) < float(trajectory[1].t_event)


def test_energy_conserved_along_each_phase(trajectory, params):
    scale = _weight_length(params)
    for p in trajectory:
        energy = jax.jit(jax.vmap(lambda y: MODEL.energy(y, params, jnp.int32(p.phase), p.ctx)))(p.ys)
        drift = float(jnp.max(jnp.abs(energy - energy[0]))) / scale
        assert drift < 1e-10, (p.phase, drift)


def test_constraint_residuals_small(trajectory, params):
    for p in trajectory:
        mask = MODEL.constraint_mask(jnp.int32(p.phase), params)

        def residuals(y):
            q, qd = MODEL.split(y)
            sigma, _ = MODEL.constraint_terms(q, qd, params, p.ctx)
            return MODEL.constraints(q, params, p.ctx) * mask, (sigma @ qd) * mask

        pos, vel = jax.jit(jax.vmap(residuals))(p.ys)
        assert float(jnp.max(jnp.abs(pos))) < 1e-10
        assert float(jnp.max(jnp.abs(vel))) < 1e-10


def test_swing_foot_clears_the_ground(trajectory, params):
    # Knees are there for foot clearance: between lift-off and heel-strike the
    # swing foot stays above the ground (no mid-stance scuffing to ignore).
    swing_height = jax.jit(jax.vmap(lambda y: MODEL.feet(y[:6], params)[1, 1]))
    heights = jnp.concatenate([swing_height(p.ys[1:-1]) for p in trajectory])
    assert float(jnp.min(heights)) > 0.0


# ---------------------------------------------------------------- impacts
def test_knee_strike_loses_energy_and_keeps_angular_momenta(trajectory, params):
    p = trajectory[0]
    y_minus, y_plus = p.y_event, p.tr.y
    assert int(p.tr.phase) == kneed.LOCKED
    energy = lambda y: float(MODEL.energy(y, params, jnp.int32(kneed.LOCKED), p.ctx))
    assert energy(y_plus) < energy(y_minus)
    stance_foot = MODEL.feet(y_minus[:6], params)[0]
    hip = y_minus[:2]
    for about, which in ((stance_foot, ALL), (hip, LEG_2)):
        before = float(_angular_momentum(y_minus, params, about, which))
        after = float(_angular_momentum(y_plus, params, about, which))
        assert after == pytest.approx(before, rel=1e-12, abs=1e-14)
    # The swing knee is now straight and locked: no flexion rate left.
    assert abs(float(y_plus[10] - y_plus[11])) < 1e-13


def test_heel_strike_loses_energy_and_keeps_angular_momenta(trajectory, params):
    p = trajectory[1]
    y_minus = p.y_event
    y_plus, impulses = MODEL.apply_impact(y_minus, params, p.ctx, jnp.array(kneed._MASK_HEEL_STRIKE))
    energy = lambda y: float(MODEL.energy(y, params, jnp.int32(kneed.LOCKED), p.ctx))
    assert energy(y_plus) < energy(y_minus)
    new_contact = MODEL.feet(y_minus[:6], params)[1]
    hip = y_minus[:2]
    for about, which in ((new_contact, ALL), (hip, LEG_1)):
        before = float(_angular_momentum(y_minus, params, about, which))
        after = float(_angular_momentum(y_plus, params, about, which))
        assert after == pytest.approx(before, rel=1e-12, abs=1e-14)
    # The ground pushes the new stance foot; the trailing foot leaves the ground.
    assert float(impulses[kneed.SWING_Y]) > 0.0
    trailing_foot_velocity = jax.jvp(lambda q: MODEL.feet(q, params)[0], (y_plus[:6],), (y_plus[6:],))[1]
    assert float(trailing_foot_velocity[1]) > 0.0
    # The transition is this impact followed by the swap of labels.
    y_next = p.tr.y
    np.testing.assert_allclose(np.asarray(y_next)[[8, 9, 10, 11]], np.asarray(y_plus)[[10, 11, 8, 9]], rtol=0, atol=1e-15)
    assert float(p.tr.shift) == pytest.approx(float(new_contact[0]), rel=1e-15)


def test_impact_losses_balance_the_descent(trajectory, params):
    # On the periodic gait the two impacts dissipate exactly the potential
    # energy released by one step down the slope, M g d sin(gamma).
    energy = lambda y, ctx: float(MODEL.energy(y, params, jnp.int32(kneed.LOCKED), ctx))
    knee, heel = trajectory
    y_heel, _ = MODEL.apply_impact(heel.y_event, params, heel.ctx, jnp.array(kneed._MASK_HEEL_STRIKE))
    lost = energy(knee.y_event, knee.ctx) - energy(knee.tr.y, knee.ctx) + energy(heel.y_event, heel.ctx) - energy(y_heel, heel.ctx)
    released = float(jnp.sum(MODEL.masses(params)) * params["g"] * heel.tr.shift * jnp.sin(params["gamma"]))
    assert lost == pytest.approx(released, rel=1e-8)


# ---------------------------------------------------------------- the gait
def test_period_one_gait_of_the_defaults(gait):
    res = gait.res
    assert int(res.status) == Status.OK
    assert int(res.n_events) == 2
    np.testing.assert_allclose(gait.v_next, gait.v, rtol=0, atol=1e-9)
    np.testing.assert_allclose(gait.v, FIXED_POINT, rtol=0, atol=3e-8)
    assert float(res.time) == pytest.approx(0.564290239794, rel=1e-7)
    assert float(res.length) == pytest.approx(0.472557111240, rel=1e-7)
    # Stable: a complex pair of modulus 0.655 and a real 0.144.
    moduli = np.sort(np.abs(gait.eig))
    np.testing.assert_allclose(moduli, [0.1438698, 0.6553842, 0.6553842], atol=1e-6)
    print("kneed fixed point", np.asarray(gait.v), "eigenvalues", gait.eig)


def test_gait_close_to_hsu_chen(gait):
    # Hsu Chen (2007), sec. 3.3: q1 = 0.1877 from the vertical, q1_dot = -1.1014,
    # on gamma = 0.0504 (4 digits). Her q2_dot = -0.0399 differs from our
    # -0.0577, and her eigenvalues (a least-squares fit of perturbed runs) from
    # ours; see docs/models/kneed.md.
    alpha_1, alpha_1_dot, _ = np.asarray(gait.v)
    assert alpha_1 == pytest.approx(0.1877 + 0.0504, abs=1e-3)
    assert alpha_1_dot == pytest.approx(-1.1014, rel=1e-2)


def test_jacobian_matches_central_differences(gait, params):
    # Differences of the map at tight tolerances (its noise, ~1e-12, over h is
    # 1e-7); the forward-mode Jacobian is the one of the default tolerances.
    opts = SolverOptions(rtol=1e-12, atol=1e-12, max_solver_steps=8192)
    step = compiling.jit(lambda v: step_map(MODEL, v, params, opts)[0], MODEL)
    h = 1e-5
    fd = np.stack([(step(gait.v + h * e) - step(gait.v - h * e)) / (2 * h) for e in jnp.eye(3)], axis=1)
    scale = np.max(np.abs(gait.jacobian))
    assert np.max(np.abs(fd - gait.jacobian)) / scale < 1e-6


# ---------------------------------------------------------------- failures
def test_stop_knee_buckles_on_hsu_chen_gait(trajectory, params):
    # Just after heel-strike the stance knee would have to be held from flexing.
    y, phase, ctx = STOP_MODEL.section_to_state(jnp.asarray(FIXED_POINT), params)
    assert float(STOP_MODEL.knee_lock_torque(y, params, phase, ctx)) < 0.0
    assert float(STOP_MODEL.guard_values(0.0, y, params, phase, ctx)[kneed.KNEE_BUCKLE]) < 0.0
    assert float(MODEL.guard_values(0.0, y, params, phase, ctx)[kneed.KNEE_BUCKLE]) == 1.0
    # So the stop model ends the step at heel-strike: the next stance knee buckles.
    p = trajectory[1]
    tr = STOP_ON_EVENT(jnp.asarray(kneed.HEEL_STRIKE), p.t_event, p.y_event, params, jnp.int32(p.phase), p.ctx)
    assert int(tr.status) == Status.KNEE_BUCKLED
    assert not bool(tr.step_done)
    # Before knee-strike the torque turns positive and stays so: the knee-strike
    # itself does not make it buckle.
    p = trajectory[0]
    tr = STOP_ON_EVENT(jnp.asarray(kneed.KNEE_STRIKE), p.t_event, p.y_event, params, jnp.int32(p.phase), p.ctx)
    assert int(tr.status) == Status.IN_PROGRESS


def test_heel_strike_with_free_knee_is_shank_releasing(trajectory, params):
    p = trajectory[1]
    tr = ON_EVENT(jnp.asarray(kneed.HEEL_STRIKE), p.t_event, p.y_event, params, jnp.int32(kneed.UNLOCKED), p.ctx)
    assert int(tr.status) == Status.SHANK_RELEASING
    assert not bool(tr.step_done)


@pytest.mark.parametrize(
    "guard, status",
    [
        (kneed.FALL, Status.FELL),
        (kneed.SWING_RANGE, Status.FELL),
        (kneed.STALL, Status.STALLED),
        (kneed.KNEE_LATE, Status.TIMEOUT),
        (kneed.KNEE_BUCKLE, Status.KNEE_BUCKLED),
    ],
)
def test_failure_guards_end_the_step(trajectory, params, guard, status):
    p = trajectory[0]
    tr = ON_EVENT(jnp.asarray(guard), p.t_event, p.y_event, params, jnp.int32(p.phase), p.ctx)
    assert int(tr.status) == status
    assert not bool(tr.step_done)
    np.testing.assert_array_equal(tr.y, p.y_event)
