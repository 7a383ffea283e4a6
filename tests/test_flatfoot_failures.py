"""How a failed flat-foot step is named: the status, and where it failed (the
phase, the event, the contact limit at its edge: ``jaxwalk.gait.failure_cause``,
what a gait search keeps and a sweep writes). Each case is built so that one
cause is checked by hand beside the name the engine gives it.
"""

from __future__ import annotations

import functools

import jax
import numpy as np

from jaxwalk.models.flatfoot import events as ev
from jaxwalk.models.flatfoot import geometry as geo
from jaxwalk.models.flatfoot import phases as ph
from jaxwalk.models.flatfoot.model import HIP_SPRING_PARAMS, PAPER_PARAMS
from jaxwalk.simulate import record_walk
from jaxwalk.status import Status
from tests.flatfoot_program import MODEL, failure_names, newton, step_fn, tangent_fn, with_params

_reactions = jax.jit(MODEL.reactions)


@jax.jit
def _at_section(v, params):
    """``(guards, stance)``: the guard values and the stance foot's ground reaction ``(2,)`` at the section."""
    y, phase, ctx = MODEL.section_to_state(v, params)
    return MODEL.guard_values(0.0, y, params, phase, ctx), MODEL.reactions(y, params, phase, ctx)[0]


@functools.cache
def _paper():
    """The paper's walker (``PAPER_PARAMS``) and its gait, Newton from the stored guess."""
    p = with_params(MODEL.default_params(), **PAPER_PARAMS)
    return p, newton(p, step_fn, tangent_fn)[0]


def test_a_low_friction_coefficient_slips():
    """With mu = 0.05 the trailing toe cannot hold its force and lifts at the
    section, and entering locked swing the stance foot needs 2.9 times the
    friction it has: named as such where the swing foot may rest 0.1 L in the
    floor. With the paper's 0.03 the lifted foot, held perpendicular to its
    shank, is also 0.011 L deeper than that: two failures at once, and the
    model's order of failures (``events.FAILURES``) names the scuff."""
    params, v = _paper()
    p = with_params(params, mu=0.05, scuff_tol=0.1)
    _, res = step_fn(v, p)
    assert int(res.status) == Status.SLIPPING
    assert failure_names(p, res) == ("locked_swing", "slip", "stance_friction")
    use = dict(zip(MODEL.limits, np.asarray(MODEL.limit_use(res.y, p, res.phase, res.ctx))))
    assert use["stance_friction"] > 1.0 and use["cop_toe"] < 1.0 and use["cop_heel"] < 1.0
    p = with_params(params, mu=0.05)
    guards, _ = _at_section(v, p)
    assert float(guards[ev.SCUFF]) < 0.0 and float(guards[ev.SLIP]) < 0.0
    _, res = step_fn(v, p)
    assert int(res.status) == Status.SCUFFING and failure_names(p, res)[:2] == ("locked_swing", "scuff")


def test_a_stiff_ankle_rolls_the_flat_stance_foot_at_its_located_toe_edge():
    """A flat foot holds its ankle spring's torque only while the centre of
    pressure lies between heel and toe. The hip-spring walker with an ankle
    spring of 0.2 (about half a human's) pushes the trailing flat foot's centre
    of pressure to its toe in heel pivot, before the leading foot is flat: the
    step ends ``FOOT_ROLLING`` on the ``foot_roll`` event, located where the
    centre of pressure is at the toe (measured 2e-15 from ``a_t``)."""
    p = with_params(_paper()[0], **{**HIP_SPRING_PARAMS, "k": 0.2})
    _, res = step_fn(MODEL.initial_guess(p), p)
    names = [ev.GUARD_NAMES[c] for c in ph.decode_history(np.asarray(res.ctx))]
    assert int(res.status) == Status.FOOT_ROLLING and int(res.phase) == ph.HEEL_PIVOT
    assert names == ["unlock", "knee_flex", "toe_off", "knee_strike", "heel_strike", "foot_roll"]
    stance, cop, _, _ = _reactions(res.y, p, int(res.phase), res.ctx)
    assert float(stance[1]) > 0.1 and abs(float(cop) - float(geo.foot_arms(p)[1])) < 1e-9
    # Recorded, the walk's contact limits say which edge: the toe, at 1.
    walk = record_walk(MODEL, p, *MODEL.section_to_state(MODEL.initial_guess(p), p), n_steps=1, dt=0.05)
    use = dict(zip(MODEL.limits, walk.limit_use[-1]))
    assert walk.status == Status.FOOT_ROLLING and abs(use["cop_toe"] - 1.0) < 1e-9
    assert use["cop_heel"] < 0.0 and use["stance_friction"] < 1.0
    # What a gait search reports of it: the phase, the event, the limit at its edge.
    assert failure_names(p, res) == ("heel_pivot", "foot_roll", "cop_toe")
    # The documented hip-spring gait itself (k = 0.03) keeps its centre of pressure inside.
    p = with_params(_paper()[0], **HIP_SPRING_PARAMS)
    assert int(step_fn(MODEL.initial_guess(p), p)[1].status) == Status.OK


def test_a_step_from_a_state_the_walker_cannot_hold_is_named_by_its_first_cause():
    """Regression (``Walker.event_guard``): the defaults with k = 0.2 from the
    stored guess start with the stance foot's normal force pulling (``running``
    guard -0.13), so its friction cone is violated too, by more (``slip`` -0.30)
    and its centre of pressure is past an edge (``foot_roll`` -0.05). The least
    guard named the step ``SLIPPING``; the contact that pulls is the cause and
    comes first in the model's order of failures (``events.FAILURES``)."""
    p = with_params(MODEL.default_params(), k=0.2)
    v = MODEL.initial_guess(p)
    guards, stance = _at_section(v, p)
    g = dict(zip(ev.GUARD_NAMES, np.asarray(guards)))
    assert g["running"] < 0.0 and g["slip"] < g["running"] and g["foot_roll"] < 0.0
    assert float(stance[1]) < 0.0  # the normal force pulls: checked apart from the guards
    _, res = step_fn(v, p)
    assert int(res.status) == Status.RUNNING and float(res.time) == 0.0
    assert failure_names(p, res)[1] == "running"


def test_a_knee_stop_pulled_by_an_impact_is_knee_buckled_in_both_implementations():
    """With ``stance_latch = 0`` a knee on its extension stop alone can only push;
    an impact whose knee-stop impulse pulls is ``KNEE_BUCKLED`` (the ``knee_buckle``
    guard's name for the same pull as a force), not ``RUNNING``, which names a
    ground contact that pulls. A pulling ground contact still comes first, a
    slide after. The same synthetic impulses through the SciPy walker's rule."""
    import jax.numpy as jnp

    from tests.reference.flatfoot import constraints as con
    from tests.reference.flatfoot.params import PAPER, PAPER_GUESS
    from tests.reference.flatfoot.resets import impulse_status
    from tests.reference.flatfoot.step import section_to_state

    def ours(stance_latch, **rows):
        params = with_params(MODEL.default_params(), **{**PAPER, "stance_latch": stance_latch})
        y, _, ctx = MODEL.section_to_state(jnp.asarray(PAPER_GUESS), params)
        imp = jnp.zeros(ph.N_CONSTRAINTS).at[ph.ANKLE_1_Y].set(1.0)
        for name, value in rows.items():
            imp = imp.at[getattr(ph, name)].set(value)
        checks = ev.impulse_failures(y[:6], imp, params, ctx)
        return ev._event_status(ev.KNEE_STRIKE, y[:6], y[6:], params, ctx, *checks)

    def reference(stance_latch, **rows):
        p = {**PAPER, "stance_latch": stance_latch}
        y, _, ctx = section_to_state(np.asarray(PAPER_GUESS), p)
        imp = np.zeros(con.N_C)
        imp[con.ANKLE_1_Y] = 1.0
        for name, value in rows.items():
            imp[getattr(con, name)] = value
        return impulse_status(y[:6], imp, p, ctx)

    cases = [  # (stance_latch, impulses beside the stance foot's push of 1) -> status
        (0.0, {"KNEE_1": -0.5}, Status.KNEE_BUCKLED),
        (0.0, {"KNEE_2": -0.5}, Status.KNEE_BUCKLED),
        (1.0, {"KNEE_1": -0.5}, Status.IN_PROGRESS),  # a latch may pull
        (0.0, {"KNEE_1": 0.5}, Status.IN_PROGRESS),  # the stop pushes
        (0.0, {"KNEE_1": -0.5, "ANKLE_2_Y": -0.5}, Status.RUNNING),  # the landing ankle pulls too
        (0.0, {"KNEE_1": -0.5, "ANKLE_1_X": 5.0}, Status.KNEE_BUCKLED),  # and slides
    ]
    names = {Status.KNEE_BUCKLED: "knee_buckled", Status.RUNNING: "running", Status.IN_PROGRESS: None}
    for latch, rows, expected in cases:
        assert int(ours(latch, **rows)) == expected, (latch, rows)
        assert reference(latch, **rows) == names[expected], (latch, rows)


def test_a_failure_due_on_entering_heel_pivot_outranks_the_flat_landing():
    """Entering heel pivot with the ankle on the ground is ``SCUFFING`` (the foot
    landed flat), unless a failure guard is already due: a fall that lands the foot
    flat is ``FELL``, in both implementations (the SciPy walker's entry check)."""
    import jax.numpy as jnp

    from tests.reference.flatfoot.guards import G
    from tests.reference.flatfoot.params import HEEL_PIVOT
    from tests.reference.flatfoot.resets import entry_status

    def ours(**below):
        g = jnp.ones(len(MODEL.guards)).at[ev.TOE_STRIKE].set(-1e-3)
        for name, index in below.items():
            g = g.at[index].set(-1e-3)
        return int(ev.entry_failure(g, ph.HEEL_PIVOT))

    def reference(*below):
        g = np.ones(len(G))
        g[G["toe_strike"]] = -1e-3
        for name in below:
            g[G[name]] = -1e-3
        return entry_status(g, HEEL_PIVOT)

    assert ours() == Status.SCUFFING and reference() == "scuffing"
    assert ours(fall=ev.FALL) == Status.FELL and reference("fall") == "fell"
    assert ours(running=ev.RUNNING) == Status.RUNNING and reference("running") == "running"
