"""Bifurcations located on continuation lines: the simplest walker's period
doublings (published value; the next one against an independent SciPy
two-step map) and the compass gait's (Goswami et al.)."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxwalk.bifurcation import BifurcationOptions, Kind, follow, indicators, locate
from jaxwalk.models import get_model
from jaxwalk.status import Status
from jaxwalk.step import step_map
from tests.reference import cycles as ref_cycles

pytestmark = pytest.mark.slow

SIMPLEST = get_model("simplest")
#: Garcia et al.'s simplest walker: its period-1 gait flips at this slope (to 7 digits).
FIRST_DOUBLING = 0.0150884


def _line(values):
    return {"gamma": np.asarray(values, np.float64)[None]}


@pytest.fixture(scope="module")
def period_one():
    lines = _line(np.linspace(0.0125, 0.0185, 13))
    start = np.asarray(SIMPLEST.initial_guess({"gamma": jnp.asarray(0.0125)}))
    status, v, mu = follow(SIMPLEST, lines, start[None], 0)
    return lines, status, v, mu


def test_indicators_vanish_at_their_multipliers():
    assert indicators(np.array([1.0, 0.3, 0.1]))[0] == 0
    assert indicators(np.array([-1.0, 0.3, 0.1]))[1] == 0
    assert abs(indicators(np.array([np.exp(0.4j), np.exp(-0.4j), 0.2]))[2]) < 1e-15


def test_first_period_doubling(period_one):
    lines, status, v, mu = period_one
    assert (status == Status.OK).all()
    found = locate(SIMPLEST, lines, "gamma", status, v, mu)
    assert found.kind.tolist() == [Kind.FLIP] and found.status.tolist() == [Status.OK]
    assert abs(found.parameter[0] - FIRST_DOUBLING) < 1e-6
    assert abs(found.multipliers[0, 0] + 1) < 1e-3  # d mu / d gamma ~ 200: 1e-6 in gamma is 2e-4 in mu


@pytest.fixture(scope="module")
def period_two(period_one):
    """The period-2 branch from 0.016 on, started from 200 steps walked off the unstable gait."""
    lines1, _, v1, _ = period_one
    gammas = np.linspace(0.016, 0.0185, 6)
    i = int(np.argmin(np.abs(lines1["gamma"][0] - gammas[0])))
    params = {"gamma": jnp.asarray(gammas[0])}
    walk = jax.jit(lambda v: jax.lax.scan(lambda x, _: (step_map(SIMPLEST, x, params)[0], None), v, None, length=200)[0])
    start = np.asarray(walk(jnp.asarray(v1[0, i]) + jnp.array([1e-3, 0.0, 0.0])))
    lines = _line(gammas)
    status, v, mu = follow(SIMPLEST, lines, start[None], 0, period=2)
    return lines, status, v, mu


def test_second_period_doubling_on_the_period_two_branch(period_two):
    lines, status, v, mu = period_two
    assert (status == Status.OK).all()
    found = locate(SIMPLEST, lines, "gamma", status, v, mu, period=2)
    assert found.kind.tolist() == [Kind.FLIP] and found.period.tolist() == [2]
    gamma = float(found.parameter[0])
    assert 0.016 < gamma < 0.0185 and found.status[0] == Status.OK
    # Independent check: the SciPy reference's two-step map has its multiplier on
    # either side of -1 at 2e-6 either side of the located slope.
    for side, inside in ((-2e-6, True), (2e-6, False)):
        ref = ref_cycles.simplest_cycle(gamma + side, 2, found.v[0])
        assert ref.status == "ok"
        real = ref.eigenvalues.real[np.abs(ref.eigenvalues.imag) < 1e-12]
        assert (real.min() > -1) == inside



def test_compass_gait_period_doubling():
    """Goswami, Thuilot & Espiau (1998), a = b = 0.5 m, m_h = 2 m: the gait's first
    period doubling near a slope of 4.39 degrees (published to two decimals)."""
    model = get_model("compass")
    degrees = np.arange(3.0, 5.01, 0.25)
    lines = {p.name: np.full((1, len(degrees)), p.default) for p in model.parameters}
    lines["gamma"] = np.radians(degrees)[None]
    start = np.asarray(model.initial_guess({k: jnp.asarray(v[0, 0]) for k, v in lines.items()}))
    status, v, mu = follow(model, lines, start[None], 0)
    assert (status == Status.OK).all()
    found = locate(model, lines, "gamma", status, v, mu)
    assert found.kind.tolist() == [Kind.FLIP] and found.status.tolist() == [Status.OK]
    assert abs(np.degrees(found.parameter[0]) - 4.39) <= 0.005


class _Bar:
    """Records what :func:`locate` tells a progress bar (tqdm's interface)."""

    def __init__(self):
        self.total, self.n, self.totals = 0, 0, []

    def update(self, k):
        self.n += k

    def refresh(self):
        self.totals.append(self.total)


def test_progress_counts_every_round_of_solves(period_one):
    """The bar's total is the rounds planned (edges' bisections, sign changes at
    most max_iter, lowered when they end, raised when an edge moves on) and it
    ends full: a time-left estimate that holds. An edge is made by marking the
    line's last points failed; the gait is found there from its neighbour, so
    the edge is followed past them to the line's end: not an edge of the gait."""
    lines, status, v, mu = period_one
    bar = _Bar()
    flips = locate(SIMPLEST, lines, "gamma", status, v, mu, progress=bar)
    assert bar.totals[0] > bar.total == bar.n > 2  # planned at most max_iter, ended sooner
    failed = status.copy()
    failed[0, -2:] = Status.FELL
    bar = _Bar()
    found = locate(SIMPLEST, lines, "gamma", failed, v, mu, progress=bar)
    assert found.kind.tolist() == flips.kind.tolist() == [Kind.FLIP]
    assert bar.total == bar.n


def test_an_edge_is_grazing_only_where_a_guard_failed_the_step_beyond():
    """A grazing edge names a guard reaching zero; a failure beyond that names none
    (a phase's time limit, the solver, too many events, a shorter cycle) is ``lost``."""
    from jaxwalk.bifurcation import GUARD_FAILURES, _edge_row

    options = BifurcationOptions()
    far = np.array([0.5, -0.3, 0.0], np.complex128)
    kind = lambda beyond, mu=far: _edge_row({"multipliers": mu, "beyond": np.int8(beyond)}, options)["kind"]
    for status in Status:
        expected = Kind.GRAZING if status in GUARD_FAILURES else Kind.LOST
        assert kind(status) == expected, status.name
    for status in (Status.TIMEOUT, Status.SOLVER_FAILED, Status.TOO_MANY_EVENTS, Status.CYCLE_NOT_FOUND,
                   Status.NO_CONVERGENCE, Status.NONFINITE):
        assert kind(status) == Kind.LOST, status.name
    for status in (Status.SCUFFING, Status.FELL, Status.SLIPPING, Status.FOOT_ROLLING):
        assert kind(status) == Kind.GRAZING, status.name
    assert kind(Status.TIMEOUT, np.array([0.99, 0.1, 0.0], np.complex128)) == Kind.FOLD  # a multiplier near +1
