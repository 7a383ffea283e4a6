"""The ``jaxwalk continue`` config: the example parses; bad input is one line with a hint, exit 2."""

import pytest

from jaxwalk import cli
from jaxwalk.branches.config import load_continue_config, parse_continue_config
from jaxwalk.sweep.config import ConfigError

GOOD = {"name": "c", "model": "simplest", "continuation": {"parameter": "gamma", "start": 0.01, "min": 0.009, "max": 0.026}}


def _with(**changes):
    table = {**GOOD["continuation"], **changes}
    return {**GOOD, "continuation": {k: v for k, v in table.items() if v is not None}}


def test_example_config_parses():
    config = load_continue_config("sweeps/continue_simplest.toml")
    assert config.parameter == "gamma" and config.starts == (0.010,) and config.bounds == (0.009, 0.026)
    assert config.switch_branches and config.options.max_steps == 40 and config.fixed == {"gamma": 0.010}


@pytest.mark.parametrize("data, message", [
    (_with(paramter="gamma"), "unknown key 'paramter' (did you mean 'parameter'?)"),
    (_with(parameter="gama"), "unknown parameter 'gama' for model 'simplest' (did you mean 'gamma'?)"),
    (_with(start=0.03), "start 0.03 is outside [min, max] = [0.009, 0.026]"),
    (_with(min=0.03), "needs min < max"),
    (_with(direction=2), "direction must be 1 or -1"),
    (_with(ds_min=0.1), "need 0 < ds_min <= ds <= ds_max"),
    (_with(max_steps=1.5), "max_steps must be an integer"),
    (_with(switch_branches="yes"), "switch_branches must be true or false"),
    (_with(max=None), "missing 'max'"),
    ({**GOOD, "contination": {}}, "unknown top-level key 'contination' (did you mean 'continuation'?)"),
])
def test_bad_config_is_one_line(data, message):
    with pytest.raises(ConfigError) as err:
        parse_continue_config(data, source="c.toml")
    assert message in str(err.value) and "\n" not in str(err.value) and str(err.value).startswith("c.toml: ")


def test_cli_bad_config_exits_2_with_one_line(tmp_path, capsys):
    path = tmp_path / "c.toml"
    path.write_text('name = "c"\nmodel = "simplest"\n[continuation]\nparameter = "gamma"\nstart = 0.01\nmin = 0.009\nmax = 0.026\nds = -1\n')
    assert cli.main(["continue", str(path), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "ds_min <= ds" in err and not (tmp_path / "out").exists()
