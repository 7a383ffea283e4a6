"""Sweep configs: every bad input is one ConfigError line naming the problem;
good configs resolve to the grid, fixed values and options they say."""

from __future__ import annotations

import json
import re
import tomllib
from pathlib import Path

import numpy as np
import pytest

from jaxwalk.models import MODELS, get_model
from jaxwalk.stepdown import StepDownOptions
from jaxwalk.sweep.config import ConfigError, load_config, loads_config, parse_config

ROOT = Path(__file__).resolve().parents[1]

SIMPLEST = """
name = "scan"
model = "simplest"
[grid]
gamma = { start = 0.002, stop = 0.015, num = 64 }
"""

COMPASS = """
name = "scan"
model = "compass"
[params]
m = 4.0
[grid]
m_h = { values = [12.0, 8.0, 10.0] }
gamma = { start = 0.01, stop = 0.05, num = 5 }
[analysis]
continuation = "gamma"
"""


def config_error(text: str, **kwargs) -> str:
    """The message of the ConfigError that ``text`` raises (checked to be one line)."""
    with pytest.raises(ConfigError) as info:
        loads_config(text, source="t.toml", **kwargs)
    message = str(info.value)
    assert "\n" not in message
    assert message.startswith("t.toml: ")
    return message


# ---------------------------------------------------------------- files


def test_missing_file(tmp_path):
    with pytest.raises(ConfigError, match="config file '.*nope.toml' not found"):
        load_config(tmp_path / "nope.toml")


def test_directory_is_not_a_config(tmp_path):
    with pytest.raises(ConfigError, match="is a directory"):
        load_config(tmp_path)


def test_binary_file(tmp_path):
    path = tmp_path / "bin.toml"
    path.write_bytes(b"\xff\xfe\x00name")
    with pytest.raises(ConfigError, match="not a UTF-8 text file"):
        load_config(path)


def test_toml_syntax_error_names_the_line(write_toml):
    path = write_toml('name = "a"\nmodel = "simplest"\n[grid]\ngamma = { start = 0.01 stop = 0.02 }\n')
    with pytest.raises(ConfigError) as info:
        load_config(path)
    message = str(info.value)
    assert "invalid TOML" in message and "line 4" in message and str(path) in message
    assert "\n" not in message


def test_good_file_keeps_its_text(write_toml):
    path = write_toml(SIMPLEST)
    cfg = load_config(path)
    assert cfg.source == str(path)
    assert tomllib.loads(cfg.text) == tomllib.loads(SIMPLEST)


# ---------------------------------------------------------------- top level


@pytest.mark.parametrize(
    "text, match",
    [
        ("parms = 1\n" + SIMPLEST, r"unknown top-level key 'parms' \(did you mean 'params'\?\)"),
        (SIMPLEST + "[solver]\nrtol = 1e-8\n", "unknown top-level section 'solver'"),
    ],
)
def test_unknown_top_level(text, match):
    assert re.search(match, config_error(text))


@pytest.mark.parametrize(
    "text, match",
    [
        ('model = "simplest"\n[grid]\ngamma = { values = [0.01] }\n', "missing 'name'"),
        ('name = "a/b"\nmodel = "simplest"\n[grid]\ngamma = { values = [0.01] }\n', "'name' must be a string of letters"),
        ('name = 3\nmodel = "simplest"\n[grid]\ngamma = { values = [0.01] }\n', "'name' must be a string"),
        ('name = "a"\n[grid]\ngamma = { values = [0.01] }\n', "missing 'model'"),
        ('name = "a"\nmodel = 1\n[grid]\ngamma = { values = [0.01] }\n', "'model' must be a string"),
        ('name = "a"\nmodel = "simplest"\nparams = 3\n[grid]\ngamma = { values = [0.01] }\n', r"'params' must be a table"),
    ],
)
def test_top_level_shape(text, match):
    assert match in config_error(text)


def test_unknown_model_lists_the_known_ones():
    message = config_error(SIMPLEST.replace('"simplest"', '"hopper"'))
    assert "unknown model 'hopper'" in message
    for name in MODELS:
        assert name in message


def test_get_model_message_is_one_line():
    with pytest.raises(KeyError) as info:
        get_model("hopper")
    assert info.value.args[0].startswith("unknown model 'hopper'")


# ---------------------------------------------------------------- [params]


def test_unknown_parameter():
    message = config_error(SIMPLEST + "[params]\ngama = 0.01\n")
    assert "[params]: unknown parameter 'gama' for model 'simplest'" in message
    assert "did you mean 'gamma'" in message


@pytest.mark.parametrize(
    "value, match",
    [("-1.0", "'m' .* must be > 0.0, got -1.0"), ('"heavy"', "'m' must be a number"), ("true", "'m' must be a number"),
     ("nan", "'m' must be finite"), ("inf", "'m' must be finite")],
)
def test_nonphysical_fixed_value(value, match):
    message = config_error(COMPASS.replace("m = 4.0", f"m = {value}"))
    assert message.startswith("t.toml: [params]: ")
    assert re.search(match, message)


def test_parameter_both_fixed_and_swept():
    message = config_error(COMPASS.replace("m = 4.0", "m_h = 4.0"))
    assert "'m_h' is both fixed in [params] and swept in [grid]" in message


# ---------------------------------------------------------------- [grid]


def grid_error(axis: str) -> str:
    return config_error(f'name = "a"\nmodel = "compass"\n[grid]\n{axis}\n')


@pytest.mark.parametrize(
    "axis, match",
    [
        ("gamma = { start = 0.01, stop = 0.6, num = 4 }", "axis 'gamma': stop: parameter 'gamma' (slope angle (downhill positive)) must be <= 0.5, got 0.6"),
        ("gamma = { start = -0.6, stop = 0.1, num = 4 }", "axis 'gamma': start: parameter 'gamma'"),
        ("m = { values = [1.0, 0.0, 2.0] }", "axis 'm': value 1: parameter 'm' (leg mass) must be > 0.0, got 0.0"),
        ("m = { values = [1.0, nan] }", "axis 'm': value 1: parameter 'm' must be finite"),
        ("m = { values = [1.0, \"x\"] }", "axis 'm': value 1: parameter 'm' must be a number"),
        ("m = { values = [] }", "axis 'm': values is empty"),
        ("m = { values = 3.0 }", "axis 'm': values must be an array"),
        ("m = { values = [1.0, 2.0, 1.0] }", "axis 'm': value 1.0 appears more than once"),
        ("m = { start = 1.0, stop = 2.0, num = 0 }", "axis 'm': num must be at least 1, got 0"),
        ("m = { start = 1.0, stop = 2.0, num = -3 }", "axis 'm': num must be at least 1, got -3"),
        ("m = { start = 1.0, stop = 2.0, num = 2.5 }", "axis 'm': num must be an integer, got 2.5"),
        ("m = { start = 1.0, stop = 2.0, num = \"10\" }", "axis 'm': num must be an integer, got '10'"),
        ("m = { start = 1.0, stop = 2.0, num = true }", "axis 'm': num must be an integer, got True"),
        ("m = { start = 1.0, num = 3 }", "axis 'm': needs start, stop and num, or values (missing: stop)"),
        ("m = { stop = 1.0 }", "(missing: start, num)"),
        ("m = { start = 1.0, stop = 2.0, num = 3, values = [1.0] }", "axis 'm': give either values or start/stop/num, not both"),
        ("m = { start = 1.0, stop = 1.0, num = 3 }", "axis 'm': start equals stop with num = 3"),
        ("m = { start = 1.0, stop = 2.0, num = 1 }", "axis 'm': num = 1 with start != stop"),
        ("m = { start = 1.0, stop = 2.0, n = 3 }", "axis 'm': unknown key 'n'"),
        ("m = 3.0", "axis 'm' must be a table"),
        ("mass = { values = [1.0] }", "[grid]: unknown parameter 'mass' for model 'compass'"),
    ],
)
def test_malformed_or_nonphysical_grid(axis, match):
    assert match in grid_error(axis)


@pytest.mark.parametrize("text", ['name = "a"\nmodel = "simplest"\n', 'name = "a"\nmodel = "simplest"\n[grid]\n'])
def test_grid_missing_or_empty(text):
    assert "[grid] is missing or empty" in config_error(text)


def test_grid_too_large_gives_size_and_memory():
    text = 'name = "a"\nmodel = "compass"\n[grid]\nm = { start = 1.0, stop = 2.0, num = 4000 }\nm_h = { start = 1.0, stop = 2.0, num = 4000 }\n'
    message = config_error(text)
    assert "16,000,000 points (4000 x 4000), more than the limit of 10,000,000" in message
    assert "about 2.05 GB" in message  # (1 + 4 + 48 + 3 * 24 + 3) bytes a point
    assert "--max-points" in message


def test_grid_limit_is_configurable():
    assert "limit of 63" in config_error(SIMPLEST, max_points=63)
    assert loads_config(SIMPLEST, max_points=64).n_points == 64


# ---------------------------------------------------------------- [analysis]


@pytest.mark.parametrize(
    "analysis, match",
    [
        ("stabilty = true", "[analysis]: unknown key 'stabilty' (did you mean 'stability'?)"),
        ("stability = 1", "stability must be true or false"),
        ('continuation = "m"', "continuation = 'm' is not a grid axis (axes: gamma)"),
        ("continuation = 3", "continuation must be a grid axis name or false"),
        ("rtol = -1e-8", "rtol must be a positive number"),
        ('atol = "small"', "atol must be a positive number"),
        ("newton_tol = 0.0", "newton_tol must be a positive number"),
        ("max_newton_iter = 0", "max_newton_iter must be a positive integer"),
        ("max_newton_iter = 2.5", "max_newton_iter must be a positive integer"),
        ('predictor = "linear"', "predictor must be one of secant, previous"),
    ],
)
def test_bad_analysis(analysis, match):
    assert match in config_error(SIMPLEST + f"[analysis]\n{analysis}\n")


@pytest.mark.parametrize(
    "h_max, match",
    [
        ("1", "[analysis] h_max must be true, false or a table { step = .., count = .., steps = .. }, got 1"),
        ('"yes"', "h_max must be true, false or a table"),
        ("[0.001, 4]", "h_max must be true, false or a table"),
        ("{ stpe = 0.001 }", "[analysis] h_max: unknown key 'stpe' (did you mean 'step'?) (allowed: step, count, steps)"),
        ("{ step = 0.001, n_steps = 3 }", "h_max: unknown key 'n_steps' (did you mean 'steps'?)"),
        ("{ dh = 0.001 }", "h_max: unknown key 'dh' (allowed: step, count, steps)"),
        ("{ step = 0.0 }", "h_max: step must be a positive number (the resolution, in model length units), got 0.0"),
        ("{ step = -0.001 }", "h_max: step must be a positive number"),
        ('{ step = "fine" }', "step must be a positive number (the resolution, in model length units), got 'fine'"),
        ("{ step = true }", "step must be a positive number"),
        ("{ step = inf }", "step must be a positive number"),
        ("{ step = nan }", "step must be a positive number"),
        ("{ count = 0 }", "h_max: count must be a positive integer (drops tried: step, 2 step, ..., count * step), got 0"),
        ("{ count = -4 }", "count must be a positive integer"),
        ("{ count = 2.5 }", "count must be a positive integer (drops tried: step, 2 step, ..., count * step), got 2.5"),
        ("{ count = true }", "count must be a positive integer"),
        ("{ steps = 0 }", "h_max: steps must be a positive integer (steps to survive after the drop), got 0"),
        ('{ steps = "10" }', "steps must be a positive integer (steps to survive after the drop), got '10'"),
        ("{ step = 0.001, count = 4, steps = { n = 3 } }", "steps must be a positive integer"),
    ],
)
def test_bad_h_max(h_max, match):
    assert match in config_error(SIMPLEST + f"[analysis]\nh_max = {h_max}\n")


def test_misspelt_h_max_key():
    assert "[analysis]: unknown key 'hmax' (did you mean 'h_max'?)" in config_error(SIMPLEST + "[analysis]\nhmax = true\n")


def test_h_max_is_checked_before_the_grid_size():
    assert "count must be a positive integer" in config_error(SIMPLEST + "[analysis]\nh_max = { count = 0 }\n", max_points=2)


# ---------------------------------------------------------------- good configs


def test_linspace_grid_and_defaults():
    cfg = loads_config(SIMPLEST)
    assert cfg.name == "scan" and cfg.model == "simplest"
    assert cfg.dims == ("gamma",) and cfg.shape == (64,) and cfg.n_points == 64
    np.testing.assert_array_equal(cfg.grid["gamma"], np.linspace(0.002, 0.015, 64))
    assert cfg.grid["gamma"].dtype == np.float64
    assert not cfg.grid["gamma"].flags.writeable
    assert cfg.fixed == {}  # gamma, the only parameter, is swept
    assert cfg.stability is True
    assert cfg.continuation == "gamma"  # default: the first axis
    assert cfg.solver == {}


def test_values_grid_and_axis_order_as_written():
    cfg = loads_config(COMPASS)
    assert cfg.dims == ("m_h", "gamma") and cfg.shape == (3, 5)
    np.testing.assert_array_equal(cfg.grid["m_h"], [12.0, 8.0, 10.0])  # not sorted
    assert list(cfg.grid) == ["m_h", "gamma"]
    assert cfg.continuation == "gamma"
    defaults = get_model("compass").param_specs
    assert cfg.params == {"m": 4.0}
    assert cfg.fixed == {"m": 4.0, "a": defaults["a"].default, "b": defaults["b"].default, "g": defaults["g"].default}


def test_subtable_syntax_and_integer_values():
    cfg = loads_config('name = "a"\nmodel = "compass"\n[grid.m_h]\nvalues = [5, 10]\n[grid.gamma]\nstart = 0.01\nstop = 0.02\nnum = 2\n')
    assert cfg.dims == ("m_h", "gamma")
    assert cfg.grid["m_h"].dtype == np.float64 and list(cfg.grid["m_h"]) == [5.0, 10.0]


def test_analysis_options_and_no_continuation():
    cfg = loads_config(SIMPLEST + "[analysis]\nstability = false\ncontinuation = false\nrtol = 1e-9\nmax_newton_iter = 30\n")
    assert cfg.stability is False and cfg.continuation is None
    assert cfg.solver == {"rtol": 1e-9, "max_newton_iter": 30}


DEFAULT_H_MAX = {"step": StepDownOptions().dh, "count": StepDownOptions().count, "steps": StepDownOptions().n_steps}


@pytest.mark.parametrize(
    "analysis, expected",
    [
        ("", None),
        ("h_max = false", None),
        ("h_max = true", DEFAULT_H_MAX),
        ("h_max = {}", DEFAULT_H_MAX),
        ("h_max = { step = 0.0005, count = 40, steps = 10 }", {"step": 0.0005, "count": 40, "steps": 10}),
        ("h_max = { step = 0.001, count = 4, steps = 3 }", {"step": 0.001, "count": 4, "steps": 3}),
        ("h_max = { count = 4 }", {**DEFAULT_H_MAX, "count": 4}),
        ("h_max = { step = 1 }", {**DEFAULT_H_MAX, "step": 1.0}),
        ("h_max = { steps = 2 }", {**DEFAULT_H_MAX, "steps": 2}),
        ("[analysis.h_max]\nstep = 0.002\ncount = 5", {**DEFAULT_H_MAX, "step": 0.002, "count": 5}),
    ],
    ids=["absent", "false", "true", "empty", "full", "small", "count", "int-step", "steps", "subtable"],
)
def test_h_max(analysis, expected):
    cfg = loads_config(SIMPLEST + f"[analysis]\n{analysis}\n")
    assert cfg.h_max == expected
    if expected is not None:
        assert isinstance(cfg.h_max["step"], float) and type(cfg.h_max["count"]) is int and type(cfg.h_max["steps"]) is int
    assert cfg.to_dict()["analysis"]["h_max"] == (expected if expected is not None else False)
    again = parse_config(json.loads(cfg.to_json()))
    assert again.h_max == cfg.h_max and again.to_dict() == cfg.to_dict()


def test_h_max_enlarges_the_size_estimate():
    text = 'name = "a"\nmodel = "compass"\n[grid]\nm = { start = 1.0, stop = 2.0, num = 4000 }\nm_h = { start = 1.0, stop = 2.0, num = 4000 }\n'
    message = config_error(text + "[analysis]\nh_max = true\n")
    assert "16,000,000 points (4000 x 4000)" in message
    assert "about 2.32 GB" in message  # (1 + 4 + 48 + 3 * 24 + 3 + 1 + 16) bytes a point


def test_resolved_config_is_itself_a_valid_config():
    cfg = loads_config(COMPASS + "newton_tol = 1e-12\n")
    again = parse_config(json.loads(cfg.to_json()))
    assert again.to_dict() == cfg.to_dict()
    assert again.fixed == cfg.fixed and again.dims == cfg.dims
    for axis in cfg.dims:
        np.testing.assert_array_equal(again.grid[axis], cfg.grid[axis])


# sweeps/simulate_*.toml are `jaxwalk simulate` configs (tests/test_simulate.py),
# sweeps/continue_*.toml `jaxwalk continue` configs (tests/test_continue_config.py),
# sweeps/basin_*.toml `jaxwalk basin` configs (tests/test_basin.py); sweeps/human_bands/
# holds sweeps too.
@pytest.mark.parametrize(
    "path",
    [
        p for p in sorted([*(ROOT / "sweeps").glob("*.toml"), *(ROOT / "sweeps" / "human_bands").glob("*.toml")])
        if not p.name.startswith(("simulate_", "continue_", "basin_"))
    ],
    ids=lambda p: p.name,
)
def test_bundled_configs_are_valid(path):
    cfg = load_config(path)
    assert cfg.name == path.stem
    assert cfg.n_points >= 1


@pytest.mark.parametrize("section, command", [("continuation", "jaxwalk continue"), ("optimize", "jaxwalk optimize")])
def test_another_commands_config_names_that_command(section, command):
    data = {"name": "c", "model": "simplest", section: {"parameter": "gamma"}}
    with pytest.raises(ConfigError) as err:
        parse_config(data, source="c.toml")
    assert str(err.value) == f"c.toml: a [{section}] section makes this a '{command}' config, not a sweep: run {command} c.toml"


@pytest.mark.parametrize("analysis, match", [
    ("basin = { samples = 1000000000 }", "[analysis] basin: samples = 1000000000 is more than the limit of 1000000"),
    ("basin = { steps = 5000 }", "[analysis] basin: steps = 5000 is more than the limit of 1000"),
    ("h_max = { count = 1000000000 }", "[analysis] h_max: count = 1000000000 is more than the limit of 100000"),
    ("h_max = { steps = 5000 }", "[analysis] h_max: steps = 5000 is more than the limit of 1000"),
    ("max_newton_iter = 1000000000", "[analysis]: max_newton_iter = 1000000000 is more than the limit of 1000"),
])
def test_work_per_point_is_capped(analysis, match):
    """A typo's billion starts, drops or iterations per point is refused before anything runs."""
    assert match in config_error(SIMPLEST + f"[analysis]\n{analysis}\n")
