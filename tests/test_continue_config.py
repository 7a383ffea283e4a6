"""The ``jaxwalk continue`` config: the example parses; bad input is one line with a hint, exit 2."""

import json

import pytest

from jaxwalk import cli
from jaxwalk.branches.config import load_continue_config, parse_continue_config
from jaxwalk.sweep.config import ConfigError

GOOD = {"name": "c", "model": "simplest", "continuation": {"parameter": "gamma", "start": 0.01, "min": 0.009, "max": 0.026}}


def _with(**changes):
    table = {**GOOD["continuation"], **changes}
    return {**GOOD, "continuation": {k: v for k, v in table.items() if v is not None}}


def test_resolved_config_is_itself_a_valid_config():
    config = load_continue_config("sweeps/continue_simplest.toml")
    again = parse_continue_config(json.loads(config.to_json()), source="round trip")
    assert again.to_dict() == config.to_dict() and again.fixed == config.fixed and again.options == config.options


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
    (_with(tol=-1.0), "[continuation] tol must be a finite number > 0, got -1.0"),
    (_with(tol=float("nan")), "[continuation] tol must be a finite number > 0, got nan"),
    (_with(switch_eps=0.0), "[continuation] switch_eps must be a finite number > 0"),
    (_with(switch_max_steps=-5), "[continuation] switch_max_steps must be an integer from 1 to 10000, got -5"),
    (_with(max_steps=100000000), "[continuation] max_steps must be an integer from 1 to 10000, got 100000000"),
    (_with(ds_max=float("inf")), "[continuation] ds_max must be a finite number, got inf"),
    (_with(min=float("-inf")), "[continuation] min must be a finite number, got -inf"),
    (_with(min=-10.0), "[continuation] min: parameter 'gamma'"),
    ({**GOOD, "params": {"gamma": 0.01}}, "parameter 'gamma' is both fixed in [params] and continued in [continuation]"),
    ({**GOOD, "continuation": 3}, "'continuation' must be a table ([continuation]), got 3"),
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


def _fake_run():
    """A hand-made period-1 and period-2 branch (3 section coordinates) and one flip label."""
    import numpy as np

    from jaxwalk.arclength import Branch, Stop
    from jaxwalk.bifurcation import Kind
    from jaxwalk.branchpoints import BranchPoints

    n, p = 5, np.linspace(0.01, 0.02, 5)
    lam = np.stack([np.linspace(0.6, 1.4, n), np.linspace(0.9, 0.5, n)])
    mu = np.zeros((2, n, 3), complex)
    mu[..., 0] = -lam
    branch = Branch(stop=np.array([Stop.PARAMETER_BOUND] * 2, np.int8), failure=np.zeros(2, np.int8), n_points=np.full(2, n, np.int32),
                    attempts=np.full(2, n, np.int32), p=np.stack([p, p]), v=np.ones((2, n, 3)), tangent=np.ones((2, n, 4)),
                    multipliers=mu, lambda_max=lam, ds=np.ones((2, n)), iterations=np.ones((2, n), np.int32), status=np.zeros((2, n), np.int8))
    labels = BranchPoints(kind=np.array([Kind.FLIP], np.int8), parameter=np.array([0.015]), branch=np.array([0], np.int32),
                          index=np.array([2], np.int32), period=np.array([1], np.int32), status=np.zeros(1, np.int8),
                          v=np.ones((1, 3)), multipliers=np.array([[-1, 0.2, 0]], complex), eigenvector=np.ones((1, 3)), s=np.zeros(1))
    return branch, labels, np.array([1, 2], np.int32), np.array([-1, 0], np.int32)


def test_dataset_is_self_describing_and_plots(tmp_path, capsys):
    import xarray as xr

    from jaxwalk.branches.run import build_dataset
    from jaxwalk.sweep.dataset import write_zarr

    config = load_continue_config("sweeps/continue_simplest.toml")
    path = write_zarr(build_dataset(config, *_fake_run(), command="test"), tmp_path / "c_branches.zarr")
    ds = xr.open_zarr(path)
    assert ds.attrs["kind"] == "continuation" and ds.attrs["continuation_units"] == "rad" and "jaxwalk_version" in ds.attrs
    assert "parameter_bound" in ds["stop"].attrs["flag_meanings"] and "flip" in ds["label_kind"].attrs["flag_meanings"]
    assert json.loads(ds.attrs["config"]) == config.to_dict() and ds.attrs["config_toml"] == config.text
    assert ds["stable"].values[0].tolist() == [True, True, False, False, False]
    assert cli.main(["plot", str(path), "--out", str(tmp_path), "--vars", "lambda_max", "v0"]) == 0
    assert (tmp_path / "continue_simplest_bifurcation_lambda_max.png").stat().st_size > 1000
    assert (tmp_path / "continue_simplest_bifurcation_v0.png").exists()
    assert cli.main(["plot", str(path), "--vars", "speed"]) == 2
    assert "unknown quantity 'speed'" in capsys.readouterr().err
    # Every choice checked before the first figure: nothing half-drawn, one line, exit 2.
    other = tmp_path / "other"
    other.mkdir()
    (tmp_path / "afile").write_text("")
    for args, fragment in ((["--out", str(other), "--vars", "lambda_max", "speed"], "unknown quantity 'speed'"),
                           (["--out", str(tmp_path / "afile")], "exists and is not a directory"),
                           (["--out", str(other), "--kind", "heatmap", "--x", "gamma"], "--kind, --x: not for a continuation dataset")):
        assert cli.main(["plot", str(path), *args]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and fragment in err, err
    assert list(other.iterdir()) == []


def test_section_variables_say_their_units(tmp_path):
    """The section coordinates mix angles and rates: every variable over them says which is which."""
    import xarray as xr

    from jaxwalk.branches.run import build_dataset
    from jaxwalk.sweep.dataset import write_zarr

    config = load_continue_config("sweeps/continue_simplest.toml")
    ds = xr.open_zarr(write_zarr(build_dataset(config, *_fake_run(), command="test"), tmp_path / "c.zarr"))
    for name in ("v", "label_v"):
        assert json.loads(ds[name].attrs["section_units"]) == ["rad", "rad", "rad"]  # dimensionless time: rad per unit
        assert "alpha_1 in rad, alpha_1_dot in rad per time unit" in ds[name].attrs["comment"]
