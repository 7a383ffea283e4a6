"""``[analysis] min_clearance`` (jaxwalk.analyses.clearance): a flat-foot sweep variable
declared in one module; refused on a model that does not track it."""

from __future__ import annotations

import os

import numpy as np
import pytest
import xarray as xr

from jaxwalk.sweep import ConfigError, loads_config, parse_config, run_sweep
from jaxwalk.sweep.runner import analysis_options
from tests.conftest import COMPASS_2D
from tests.flatfoot_program import PAPER_TOML

FLATFOOT_1 = f"""
name = "flatfoot_clearance"
model = "flatfoot"
[params]
{PAPER_TOML}
""" + """
[grid]
gamma = { values = [0.0] }
[analysis]
stability = false
continuation = false
min_clearance = true
"""


def test_min_clearance_is_refused_on_a_model_that_does_not_track_it():
    with pytest.raises(ConfigError, match="min_clearance = true: the compass model does not track its swing foot's clearance"):
        loads_config(COMPASS_2D + "min_clearance = true\n")
    with pytest.raises(ConfigError, match="min_clearance must be true or false"):
        loads_config(FLATFOOT_1.replace("min_clearance = true", "min_clearance = 1"))


def test_min_clearance_is_read_from_each_gaits_end_context():
    """The plug-in computes nothing: it reads ``Gait.context`` (the step from the
    fixed point, the search's last evaluation; tests/test_gait_context.py) for a
    block of any shape: a minimum where one was passed, NaN where none was
    (``NO_MINIMUM``) or no gait was found (a NaN context)."""
    from types import SimpleNamespace

    from jaxwalk.analyses.clearance import ANALYSIS
    from jaxwalk.models.flatfoot import phases

    context = np.zeros((2, 3, len(phases.CONTEXT)))
    where = phases.C["min_clearance"]
    context[..., where] = [[-0.02, 0.1, phases.NO_MINIMUM], [0.0, np.nan, 0.05]]
    block = SimpleNamespace(gaits=SimpleNamespace(context=context))
    out = ANALYSIS.compute(block)
    assert list(out) == ["min_clearance"] and out["min_clearance"].dtype == np.float64
    np.testing.assert_array_equal(out["min_clearance"], [[-0.02, 0.1, np.nan], [0.0, np.nan, 0.05]])


def test_min_clearance_is_resolved_and_recorded_only_when_on():
    config = loads_config(FLATFOOT_1)
    assert config.min_clearance is True and config.to_dict()["analysis"]["min_clearance"] is True
    assert parse_config(config.to_dict()).to_dict() == config.to_dict()  # the resolved config is a config
    # failure_cause and, on a model that logs its events, event_sequence: on by default.
    assert analysis_options(config).more == (("failure_cause", True), ("event_sequence", True), ("min_clearance", True))
    off = loads_config(FLATFOOT_1.replace("min_clearance = true", ""))
    assert off.min_clearance is False and "min_clearance" not in off.to_dict()["analysis"]
    assert analysis_options(off).more == (("failure_cause", True), ("event_sequence", True))


@pytest.fixture(scope="module")
def sweep(tmp_path_factory):
    """One gait of the paper's flat-foot walker (level ground) swept with min_clearance."""
    path = run_sweep(loads_config(FLATFOOT_1), tmp_path_factory.mktemp("clearance"), progress=False, plot=False)
    with xr.open_dataset(path, engine="zarr") as ds:
        return ds.load()


@pytest.mark.slow
@pytest.mark.skipif(not os.environ.get("JAXWALK_SLOW_CHECKS"), reason=(
    "compiles the flat-foot grid gait search, which no other test needs (5-17 min cold on two cores); "
    "the clearance itself is checked against the recorded step in test_flatfoot.py; set JAXWALK_SLOW_CHECKS=1"))
def test_min_clearance_is_a_variable_of_the_flatfoot_sweep(sweep):
    clearance = sweep["min_clearance"]
    assert clearance.dims == ("gamma",) and clearance.dtype == np.float64
    assert clearance.attrs["long_name"] == "minimum swing clearance" and clearance.attrs["units"] == "1"
    assert int(sweep["status"][0]) == 0
    # The paper's walker's gait (scuff_tol = 0.03) dips below the ground by less than the
    # scuffing tolerance (tests/test_flatfoot.py measures it against the recorded step).
    assert -0.03 < float(clearance[0]) < 0.0
