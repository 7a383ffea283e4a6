"""Conservation laws of the autodiff mechanics, on the compass walker.

Energy along the continuous phase; linear and angular momentum balances
through the heel-strike impact, computed from the point masses directly
(positions and velocities), not from the mass matrix the engine uses.
"""

import re

import diffrax
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxwalk import mechanics
from jaxwalk.models import get_model
from jaxwalk.step import step_map
from jaxwalk.walker import Walker

MODEL = get_model("compass")
PARAMS = MODEL.default_params()
PHASE = jnp.asarray(0, jnp.int32)


def cross(a, b):
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


def start_state():
    y, _, ctx = MODEL.section_to_state(jnp.array([0.271, -1.092, -0.377]), PARAMS)
    return y, ctx


@pytest.fixture(scope="module")
def trajectory():
    y0, ctx = start_state()
    ts = jnp.linspace(0.0, 0.6, 25)
    sol = diffrax.diffeqsolve(
        diffrax.ODETerm(MODEL.vector_field),
        diffrax.Dopri8(),
        t0=0.0,
        t1=0.6,
        dt0=None,
        y0=y0,
        args=(PARAMS, PHASE, ctx),
        saveat=diffrax.SaveAt(ts=ts),
        stepsize_controller=diffrax.PIDController(rtol=1e-11, atol=1e-11),
    )
    return sol.ys, ctx


def test_energy_conserved_along_single_support(trajectory):
    ys, ctx = trajectory
    energy = jax.vmap(lambda y: MODEL.energy(y, PARAMS, PHASE, ctx))(ys)
    scale = float(jnp.max(jnp.abs(energy)))
    assert float(jnp.max(energy) - jnp.min(energy)) < 1e-9 * scale


def test_constraint_residuals_stay_at_integration_accuracy(trajectory):
    ys, ctx = trajectory
    residual = jax.vmap(lambda y: MODEL.constraints(y[:4], PARAMS, ctx)[:2])(ys)
    assert float(jnp.max(jnp.abs(residual))) < 1e-9


def test_contact_force_is_compressive(trajectory):
    ys, ctx = trajectory
    forces = jax.vmap(lambda y: MODEL.dynamics(y, PARAMS, PHASE, ctx)[1])(ys)
    assert float(jnp.min(forces[:, 1])) > 0.0  # normal force on the stance foot pushes up
    assert np.all(np.asarray(forces[:, 2:]) == 0.0)  # inactive constraints carry nothing


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_heel_strike_conserves_momenta_and_loses_energy(seed):
    """Random asymmetric pre-impact states (stance foot pinned)."""
    rng = np.random.default_rng(seed)
    a1, a2 = -rng.uniform(0.1, 0.4), rng.uniform(0.1, 0.4)
    ad1, ad2 = -rng.uniform(0.5, 2.0), rng.uniform(-2.0, 2.0)
    l = 1.0
    q = jnp.array([-l * np.sin(a1), l * np.cos(a1), a1, a2])
    qd = jnp.array([-l * np.cos(a1) * ad1, -l * np.sin(a1) * ad1, ad1, ad2])
    y = jnp.concatenate([q, qd])
    ctx = jnp.zeros(2)
    y_plus, impulses = MODEL.apply_impact(y, PARAMS, ctx, jnp.array([0.0, 0.0, 1.0, 1.0]))
    qd_plus = y_plus[4:]

    masses = MODEL.masses(PARAMS)
    pts = MODEL.points(q, PARAMS)
    vel = lambda qd_: jax.jvp(lambda q_: MODEL.points(q_, PARAMS), (q,), (qd_,))[1]
    v_minus, v_plus = vel(qd), vel(qd_plus)
    contact = MODEL.feet(q, PARAMS)[1]
    hip = q[:2]

    # New contact point at rest afterwards.
    foot_velocity = jax.jvp(lambda q_: MODEL.feet(q_, PARAMS)[1], (q,), (qd_plus,))[1]
    np.testing.assert_allclose(foot_velocity, 0.0, atol=1e-12)
    # Whole walker, about the new contact point (the only impulse acts there).
    L = lambda v: jnp.sum(masses * cross(pts - contact, v))
    np.testing.assert_allclose(L(v_plus), L(v_minus), rtol=1e-12, atol=1e-12)
    # Trailing leg (old stance, point 1) about the hip: only the hip joint's impulse acts on it.
    L_leg = lambda v: masses[1] * cross(pts[1] - hip, v[1])
    np.testing.assert_allclose(L_leg(v_plus), L_leg(v_minus), rtol=1e-12, atol=1e-12)
    # Linear momentum changes by exactly the contact impulse.
    dP = jnp.sum(masses[:, None] * (v_plus - v_minus), axis=0)
    np.testing.assert_allclose(dP, impulses[2:], rtol=1e-12, atol=1e-12)
    # An inelastic impact loses kinetic energy.
    T = lambda v: 0.5 * jnp.sum(masses * jnp.sum(v**2, axis=-1))
    assert float(T(v_plus)) < float(T(v_minus))


@pytest.mark.parametrize("n", [3, 8, 12, 15])
def test_solve_matches_numpy_and_its_derivative_matches_differences(n):
    # mechanics.solve inside the integration loops: unrolled up to order 8,
    # LAPACK one matrix per call above (the kneed and flat-foot KKT systems, 12 and 15).
    # A zero on the diagonal forces pivoting; a KKT-like block structure too.
    rng = np.random.default_rng(n)
    a = rng.normal(size=(n, n))
    a[0, 0] = 0.0
    b = rng.normal(size=n)
    x = np.asarray(jax.jit(mechanics.solve)(jnp.asarray(a), jnp.asarray(b)))
    np.testing.assert_allclose(x, np.linalg.solve(a, b), rtol=1e-10, atol=1e-12)
    # Forward mode against central differences along one direction of (a, b).
    da, db = rng.normal(size=(n, n)), rng.normal(size=n)
    _, dx = jax.jvp(mechanics.solve, (jnp.asarray(a), jnp.asarray(b)), (jnp.asarray(da), jnp.asarray(db)))
    h = 1e-6
    fd = (np.linalg.solve(a + h * da, b + h * db) - np.linalg.solve(a - h * da, b - h * db)) / (2 * h)
    np.testing.assert_allclose(np.asarray(dx), fd, rtol=1e-6, atol=1e-8)
    # vmap equals a loop over single solves.
    batch_a = np.stack([a, a + 0.1 * da])
    batch = np.asarray(jax.vmap(mechanics.solve)(jnp.asarray(batch_a), jnp.asarray(np.stack([b, b]))))
    for i in range(2):
        np.testing.assert_allclose(batch[i], np.linalg.solve(batch_a[i], b), rtol=1e-10, atol=1e-12)


#: A LAPACK call in a lowered CPU program: its target and its first operand's type.
LAPACK_CALL = re.compile(r"custom_call @(lapack_\w+)\(.*?:\s*\(tensor<([0-9x]+)x?f64>")


def _lapack_operand_shapes(program, *args) -> list[tuple]:
    """``(target, first operand shape)`` of every LAPACK call in ``jit(program)``
    lowered for the CPU (every function of the module: loops, branches, jits).
    Each of jaxlib's kernels may split a batch over XLA's intra-op pool."""
    text = jax.jit(program).lower(*args).as_text()
    return [(m.group(1), tuple(int(d) for d in m.group(2).split("x") if d)) for m in LAPACK_CALL.finditer(text)]


@pytest.mark.parametrize("batch", [1, 5, 70])
def test_a_batch_of_kkt_solves_never_hands_lapack_more_than_one_matrix(batch):
    """jaxlib splits a batched LAPACK call over XLA's intra-op pool and waits on the
    calling thread, which deadlocked two programs running at once (mechanics.py,
    above ``_lapack_one``). Every LAPACK call in a batched, nested and differentiated
    solve of order 15, and in reverse mode of one of order 6, takes one matrix; the
    results equal NumPy's, and reverse mode equals forward mode."""
    rng = np.random.default_rng(batch)
    n = 15
    a = rng.normal(size=(2, batch, n, n)) + 4 * np.eye(n)
    b = rng.normal(size=(2, batch, n))
    nested = jax.vmap(jax.vmap(mechanics.solve))
    np.testing.assert_allclose(np.asarray(jax.jit(nested)(a, b)), np.linalg.solve(a, b[..., None])[..., 0], rtol=1e-10, atol=1e-12)
    jac = jax.vmap(jax.vmap(jax.jacfwd(mechanics.solve)))
    loss = lambda a, b: jnp.sum(jnp.sin(nested(a, b)))
    small = lambda a, b: jnp.sum(jnp.sin(nested(a[..., :6, :6], b[..., :6])))  # the unrolled solve's reverse mode
    programs = [nested, jac, jax.grad(loss, argnums=(0, 1)), jax.grad(small, argnums=(0, 1))]
    shapes = [s for f in programs for s in _lapack_operand_shapes(f, a, b)]
    assert {name for name, _ in shapes} == {"lapack_dgetrf_ffi", "lapack_dtrsm_ffi"}
    assert all(len(shape) == 2 for _, shape in shapes), shapes
    grad_b = jax.grad(loss, argnums=1)(jnp.asarray(a), jnp.asarray(b))
    direction = rng.normal(size=b.shape)
    _, forward = jax.jvp(lambda b: loss(jnp.asarray(a), b), (jnp.asarray(b),), (jnp.asarray(direction),))
    assert float(jnp.sum(grad_b * direction)) == pytest.approx(float(forward), rel=1e-12)


def test_a_batched_step_map_of_the_kneed_walker_hands_lapack_one_matrix_at_a_time():
    """The property above for a whole program as sweeps run it: every LAPACK call in
    the loops of a vmapped step map (the KKT solves of its vector field, guards and
    start) takes one matrix."""
    model = get_model("kneed")
    params = {k: jnp.full((3,), v) for k, v in model.default_params().items()}
    v = jnp.broadcast_to(model.initial_guess(model.default_params()), (3, len(model.section_names)))
    shapes = _lapack_operand_shapes(jax.vmap(lambda p, v: step_map(model, v, p)[0]), params, v)
    assert shapes and all(len(shape) == 2 for _, shape in shapes), shapes


def test_a_batch_of_kkt_solves_off_the_cpu_is_one_batched_call():
    """The branch for backends without the CPU's intra-op pool (chosen when a
    program is lowered for its platform; called here on the CPU): the same solutions,
    also where the batch equals the order (a vector right-hand side must not be
    read as a matrix) and with matrix right-hand sides."""
    rng = np.random.default_rng(7)
    n = batch = 15
    a = rng.normal(size=(batch, n, n)) + 4 * np.eye(n)
    b = rng.normal(size=(batch, n))
    np.testing.assert_allclose(np.asarray(mechanics._batched(a, b)), np.linalg.solve(a, b[..., None])[..., 0], rtol=1e-10, atol=1e-12)
    rhs = rng.normal(size=(batch, n, 3))
    np.testing.assert_allclose(np.asarray(mechanics._batched(a, rhs)), np.linalg.solve(a, rhs), rtol=1e-10, atol=1e-12)


def test_a_singular_kkt_system_gives_nan_not_finite_garbage():
    """Two active constraints that are the same row make the KKT system singular;
    its LU ends with a pivot of rounding size, and a plain LAPACK solve returned
    finite values from plausible to 1e35 in 3 of these 10 cases (inf/NaN in the rest).
    mechanics' solve returns NaN for all (so a step ends ``nonfinite``), singly,
    batched, on the batched branch of other backends and in impacts, and an
    independent row keeps the solution finite and equal to NumPy's."""
    rng = np.random.default_rng(0)
    n_q, n_c = 7, 3  # KKT order 10: LAPACK
    systems = []
    for trial in range(10):
        a = rng.normal(size=(n_q, n_q))
        mass = a @ a.T + n_q * np.eye(n_q)
        sigma, psi = rng.normal(size=(n_c, n_q)), rng.normal(size=n_c)
        sigma[1] = sigma[0]
        if trial % 2:  # consistent as well as contradictory constraints
            psi[1] = psi[0]
        systems.append((mass, rng.normal(size=n_q), sigma, psi))
    solve = lambda m, f, s, p: mechanics.constrained_accelerations(m, f, s, p, np.ones(n_c))
    for system in systems:
        assert np.all(np.isnan(np.concatenate([np.asarray(x) for x in solve(*map(jnp.asarray, system))])))
    stacked = [jnp.asarray(np.stack(parts)) for parts in zip(*systems)]
    assert np.all(np.isnan(np.asarray(jax.jit(jax.vmap(solve))(*stacked)[0])))
    mass, forces, repeated, psi = systems[0]
    sigma = repeated.copy()
    sigma[1] = rng.normal(size=n_q)
    qdd, lam = solve(*map(jnp.asarray, (mass, forces, sigma, psi)))
    kkt = np.block([[mass, -sigma.T], [sigma, np.zeros((n_c, n_c))]])
    np.testing.assert_allclose(np.concatenate([qdd, lam]), np.linalg.solve(kkt, np.concatenate([forces, -psi])), rtol=1e-10, atol=1e-12)
    singular = np.block([[mass, -repeated.T], [repeated, np.zeros((n_c, n_c))]])
    batch = jnp.asarray(np.stack([kkt, singular]))
    x = np.asarray(mechanics._batched(batch, jnp.ones((2, n_q + n_c))))
    assert np.all(np.isfinite(x[0])) and np.all(np.isnan(x[1]))
    # Impacts onto the same constraints: the LAPACK solve (a mask known when
    # tracing) and the looped elimination (a traced mask) alike.
    qd_minus = jnp.asarray(rng.normal(size=n_q))
    traced = jax.jit(lambda m, qd, s, k: mechanics.impact(m, qd, s, k))
    for impact in (lambda m, qd, s: mechanics.impact(m, qd, s, np.ones(n_c)), lambda m, qd, s: traced(m, qd, s, jnp.ones(n_c))):
        assert np.all(np.isnan(np.asarray(impact(jnp.asarray(mass), qd_minus, jnp.asarray(repeated))[0])))
        assert np.all(np.isfinite(np.asarray(impact(jnp.asarray(mass), qd_minus, jnp.asarray(sigma))[0])))


@pytest.mark.parametrize("name", sorted(__import__("jaxwalk.models", fromlist=["MODELS"]).MODELS))
def test_entrywise_and_stacked_dynamics_agree(name, monkeypatch):
    """Both forms of the automatic derivatives (``mechanics.ENTRYWISE_MAX``) give every
    walker the same mass matrix, forces, constraint Jacobian and accelerations at a
    generic state: they differ only in the order of their sums. (A model with closed
    forms, :mod:`jaxwalk.chain`, computes its accelerations from those in both runs;
    tests/test_chain.py compares them with these derivatives.)"""
    model = get_model(name)
    params = model.default_params()
    rng = np.random.default_rng(7)
    q, qd = (jnp.asarray(rng.uniform(-0.6, 0.6, model.n_q)) for _ in range(2))
    y = jnp.concatenate([q, qd])
    _, _, ctx = model.section_to_state(model.initial_guess(params), params)
    pts = lambda q_: model.points(q_, params)  # noqa: E731

    def terms():
        mass, forces = mechanics.mass_matrix_and_forces(pts, model.masses(params), model.gravity(params), q, qd)
        sigma, psi = Walker.constraint_terms(model, q, qd, params, ctx)
        qdd, lam = model.dynamics(y, params, jnp.asarray(0, jnp.int32), ctx)
        return mass, mechanics.mass_matrix(pts, model.masses(params), q), forces, sigma, psi, qdd, lam

    monkeypatch.setattr(mechanics, "ENTRYWISE_MAX", 10**6)
    by_entries = terms()
    monkeypatch.setattr(mechanics, "ENTRYWISE_MAX", 0)
    stacked = terms()
    for a, b in zip(by_entries, stacked):
        assert a.shape == b.shape
        np.testing.assert_allclose(np.asarray(b), np.asarray(a), rtol=1e-12, atol=1e-12 * float(np.max(np.abs(a)) + 1))
    assert float(np.max(np.abs(by_entries[0]))) > 0.1  # a real mass matrix
