"""``[analysis] attractors``: resolved with its defaults, bad values refused in one line."""

import pytest

from jaxwalk.sweep import ConfigError, loads_config
from jaxwalk.sweep.runner import analysis_options

BASE = """
name = "a"
model = "simplest"
[grid]
gamma = { start = 0.009, stop = 0.016, num = 4 }
[analysis]
"""


def test_off_by_default_and_fingerprint_unchanged():
    config = loads_config(BASE)
    assert config.attractors is None and analysis_options(config).attractors is None
    assert "attractors" not in config.to_dict()["analysis"]


@pytest.mark.parametrize("text,expected", [
    ("attractors = true", {"max_period": 8, "steps": 200}),
    ("attractors = { max_period = 4 }", {"max_period": 4, "steps": 200}),
    ("attractors = { steps = 50, max_period = 16 }", {"max_period": 16, "steps": 50}),
])
def test_resolved(text, expected):
    config = loads_config(BASE + text)
    assert config.attractors == expected
    options = analysis_options(config).attractors
    assert (options.max_period, options.steps) == (expected["max_period"], expected["steps"])
    assert loads_config(BASE).to_dict() != config.to_dict()
    assert config.to_dict()["analysis"]["attractors"] == expected


@pytest.mark.parametrize("text,message", [
    ("attractors = 3", "must be true, false or a table"),
    ("attractors = { max_period = 6 }", "max_period must be a power of two"),
    ("attractors = { max_period = 0 }", "max_period must be a positive integer"),
    ("attractors = { steps = 1.5 }", "steps must be a positive integer"),
    ("attractors = { stesp = 5 }", "unknown key 'stesp'"),
])
def test_refused(text, message):
    with pytest.raises(ConfigError, match=message) as err:
        loads_config(BASE + text)
    assert "\n" not in str(err.value) and "[analysis] attractors" in str(err.value)


def test_bifurcations_key():
    assert loads_config(BASE + "bifurcations = true").to_dict()["analysis"]["bifurcations"] is True
    assert "bifurcations" not in loads_config(BASE + "bifurcations = false").to_dict()["analysis"]
    with pytest.raises(ConfigError, match="bifurcations must be true or false"):
        loads_config(BASE + "bifurcations = 1")
    with pytest.raises(ConfigError, match="needs a continuation axis"):
        loads_config(BASE + "bifurcations = true\ncontinuation = false")


def test_loop_bounds_are_at_least_one():
    """The walk's and the step's loops stop at these bounds (their conditions): a zero is refused."""
    from jaxwalk.attractor import AttractorOptions
    from jaxwalk.step import SolverOptions

    with pytest.raises(ValueError, match="steps must be >= 1"):
        AttractorOptions(steps=0)
    with pytest.raises(ValueError, match="max_events must be >= 1"):
        SolverOptions(max_events=0)
    assert AttractorOptions(steps=1).steps == 1 and SolverOptions(max_events=1).max_events == 1
