"""Global stability h_max against the independent SciPy implementation."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxwalk.grid import AnalysisOptions, analyse_grid
from jaxwalk.models import get_model
from jaxwalk.status import Status
from jaxwalk.stepdown import StepDownOptions, step_down_trial
from tests.reference import scipy_walkers as ref

CASES = [
    # model, slope, drop resolution, drops tried
    ("simplest", 0.009, 0.0005, 8),
    ("compass", 0.0523598775598, 0.002, 10),
]


@pytest.mark.parametrize("name, gamma, dh, count", CASES)
def test_h_max_matches_scipy(name, gamma, dh, count):
    model = get_model(name)
    options = AnalysisOptions(step_down=StepDownOptions(dh=dh, count=count, n_steps=10))
    ours = analyse_grid(model, {}, {"gamma": np.array([gamma])}, None, options)
    assert ours["status"][0] == Status.OK
    params = {"gamma": gamma} if name == "simplest" else None
    theirs, details = ref.h_max(params, dh=dh, K=count, n_steps=10, model=name, return_details=True)
    assert ours["h_max"][0] == pytest.approx(theirs, abs=1e-12)
    failed = [d for d in details if not d[1]]
    if failed:  # the first failed drop and its cause agree too
        assert ours["h_failed"][0] == pytest.approx(failed[0][0])
        assert Status(int(ours["step_down_status"][0])).name.lower() == failed[0][2]["status"]


def test_zero_drop_keeps_walking_on_the_limit_cycle():
    model = get_model("compass")
    params = model.default_params()
    v = jnp.asarray(analyse_grid(model, {}, {"gamma": np.array([float(params["gamma"])])})["fixed_point"][0])
    trial = jax.jit(lambda v: step_down_trial(model, params, v, 0.0, 5))(v)
    assert bool(trial.survived) and int(trial.steps) == 6
