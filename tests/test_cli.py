"""The command line: bad input is one line on stderr, exit 2, nothing written;
a good sweep writes a dataset that xarray opens with the documented layout."""

from __future__ import annotations

import json
import numpy as np
import pytest
import xarray as xr

from jaxwalk import cli
from jaxwalk.grid import AnalysisOptions
from jaxwalk.models import get_model
from jaxwalk.status import Status, flag_attributes
from jaxwalk.stepdown import StepDownOptions
from jaxwalk.sweep import load_config, run_sweep

GOOD = """
name = "slope_scan"
model = "simplest"
[grid]
gamma = { start = 0.002, stop = 0.019, num = 18 }
"""


def listing(path):
    return sorted(str(p.relative_to(path)) for p in path.rglob("*"))


def assert_one_line_error(proc, *fragments):
    assert proc.returncode == 2, proc.stderr
    assert "Traceback" not in proc.stderr
    lines = proc.stderr.splitlines()
    assert len(lines) == 1, proc.stderr
    assert lines[0].startswith("jaxwalk: error: ")
    for fragment in fragments:
        assert fragment in lines[0]
    assert proc.stdout == ""


# ---------------------------------------------------------------- bad input, in a subprocess


DEFAULT_ARGS = ["sweep.toml", "--out", "out"]


@pytest.mark.parametrize(
    "config, args, fragments",
    [
        (GOOD.replace("0.019", "0.7"), DEFAULT_ARGS, ["sweep.toml: [grid] axis 'gamma': stop", "must be <= 0.5, got 0.7"]),
        (GOOD.replace('"simplest"', '"hopper"'), DEFAULT_ARGS, ["unknown model 'hopper'"]),
        (None, DEFAULT_ARGS, ["config file 'sweep.toml' not found"]),
        (GOOD, ["sweep.toml", "--out", "file.txt"], ["--out 'file.txt' exists and is not a directory"]),
        (GOOD + "[analysis]\nh_max = { step = -0.001 }\n", DEFAULT_ARGS,
         ["sweep.toml: [analysis] h_max: step must be a positive number", "got -0.001"]),
    ],
    ids=["nonphysical", "unknown-model", "missing-file", "out-is-file", "bad-h-max"],
)
def test_bad_input_subprocess(run_cli, tmp_path, config, args, fragments):
    if config is not None:
        (tmp_path / "sweep.toml").write_text(config)
    (tmp_path / "file.txt").write_text("not a directory")
    before = listing(tmp_path)
    proc = run_cli("sweep", *args)
    assert_one_line_error(proc, *fragments)
    assert listing(tmp_path) == before  # nothing written, --out not created


# ---------------------------------------------------------------- bad input, in process (fast)

BAD_PARAM = GOOD + "[params]\nm = 3.0\n"
BAD_TOML = 'name = "a"\nmodel = "simplest"\n[grid\n'
H_MAX = GOOD + "[analysis]\nh_max = "


@pytest.mark.parametrize(
    "config, argv, fragment",
    [
        (BAD_PARAM, ["sweep", "sweep.toml", "--out", "out"], "unknown parameter 'm' for model 'simplest'"),
        (BAD_TOML, ["sweep", "sweep.toml", "--out", "out"], "line 3"),
        (GOOD, ["sweep", "sweep.toml", "--out", "out", "--max-points", "ten"], "argument --max-points"),
        (GOOD, [], "the following arguments are required: COMMAND"),
        (GOOD, ["walk"], "invalid choice: 'walk'"),
        (GOOD, ["sweep", "sweep.toml"], "the following arguments are required: --out"),
        (GOOD, ["sweep", "sweep.toml", "--out", "out", "--max-points", "0"], "expected a positive integer, got '0'"),
        (GOOD, ["sweep", "sweep.toml", "--out", "out", "--max-points", "10"], "more than the limit of 10"),
        (GOOD, ["sweep", ".", "--out", "out"], "config file '.' is a directory"),
        (H_MAX + "{ stp = 0.001 }\n", ["sweep", "sweep.toml", "--out", "out"], "h_max: unknown key 'stp' (did you mean 'step'?)"),
        (H_MAX + "{ count = 0 }\n", ["sweep", "sweep.toml", "--out", "out"], "h_max: count must be a positive integer"),
        (H_MAX + "{ steps = 2.5 }\n", ["sweep", "sweep.toml", "--out", "out"], "h_max: steps must be a positive integer"),
        (H_MAX + '"on"\n', ["sweep", "sweep.toml", "--out", "out"], "h_max must be true, false or a table"),
        (H_MAX + "{ step = 0.001\n", ["sweep", "sweep.toml", "--out", "out"], "invalid TOML"),
    ],
)
def test_bad_input_in_process(tmp_path, monkeypatch, capsys, config, argv, fragment):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "sweep.toml").write_text(config)
    before = listing(tmp_path)
    assert cli.main(argv) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    assert captured.err.count("\n") == 1 and captured.err.startswith("jaxwalk: error: ")
    assert fragment in captured.err
    assert listing(tmp_path) == before


def test_unwritable_out(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "sweep.toml").write_text(GOOD)
    monkeypatch.setattr("os.access", lambda *a, **k: False)
    assert cli.main(["sweep", "sweep.toml", "--out", "out/deeper"]) == 2
    assert "is not writable" in capsys.readouterr().err
    assert not (tmp_path / "out").exists()


def test_help_lists_sweep(capsys):
    with pytest.raises(SystemExit) as info:
        cli.main(["--help"])
    assert info.value.code == 0
    assert "sweep" in capsys.readouterr().out


# ---------------------------------------------------------------- a good sweep


@pytest.fixture
def fake_grid(monkeypatch, fake_analysis):
    """The fake in place of ``jaxwalk.grid.analyse_grid``, the CLI's analysis (importing
    ``jaxwalk.grid`` compiles nothing)."""
    import jaxwalk.grid

    fake = fake_analysis(fail_above=0.0155)
    monkeypatch.setattr(jaxwalk.grid, "analyse_grid", fake)
    return fake


def test_cli_sweep_writes_dataset(tmp_path, monkeypatch, capsys, fake_grid):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "sweep.toml").write_text(GOOD)
    argv = ["sweep", "sweep.toml", "--out", "res", "--no-progress", "--no-plot"]
    assert cli.main(argv) == 0
    out = capsys.readouterr().out
    assert out.startswith("wrote res/slope_scan.zarr: 18 points, 14 ok, 4 no_convergence")
    assert len(fake_grid.calls) == 1
    with xr.open_dataset(tmp_path / "res" / "slope_scan.zarr", engine="zarr") as ds:
        assert ds.attrs["command"] == "jaxwalk " + " ".join(argv)
    assert [p.name for p in (tmp_path / "res").iterdir()] == ["slope_scan.zarr"]  # no temporaries, no figure

    # Running again refuses to overwrite (before any computing), unless asked to.
    assert cli.main(argv) == 2
    assert "already exists (pass --overwrite" in capsys.readouterr().err
    assert len(fake_grid.calls) == 1
    assert cli.main(argv + ["--overwrite"]) == 0
    assert len(fake_grid.calls) == 2


def test_cli_sweep_with_h_max(tmp_path, monkeypatch, capsys, fake_grid):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "sweep.toml").write_text(GOOD + "[analysis]\nh_max = { step = 0.0005, count = 4, steps = 3 }\n")
    assert cli.main(["sweep", "sweep.toml", "--out", "res", "--no-progress", "--no-plot"]) == 0
    assert capsys.readouterr().out.startswith("wrote res/slope_scan.zarr: 18 points")
    assert fake_grid.calls[0]["options"].step_down == StepDownOptions(dh=0.0005, count=4, n_steps=3)
    with xr.open_dataset(tmp_path / "res" / "slope_scan.zarr", engine="zarr") as ds:
        ds.load()
    assert ds["h_max"].attrs["units"] == "1" and ds["h_max"].attrs["limit"] == pytest.approx(0.002)
    status = ds["status"].values
    np.testing.assert_array_equal(np.isnan(ds["h_max"].values), status != 0)
    assert np.isin(ds["step_down_status"].values, flag_attributes()["flag_values"]).all()


def test_end_to_end_dataset_layout(tmp_path, fake_analysis):
    config = load_config_text(tmp_path, GOOD)
    fake = fake_analysis(fail_above=0.0155)
    path = run_sweep(config, tmp_path / "res", progress=False, analyse=fake, plot=False, command="test")
    assert path == tmp_path / "res" / "slope_scan.zarr"

    call = fake.calls[0]
    assert call["model"].name == "simplest"
    assert call["fixed"] == {}
    assert list(call["grid"]) == ["gamma"] and call["continuation_axis"] == "gamma"
    assert call["options"] == AnalysisOptions()  # no solver settings in the config: the defaults

    with xr.open_dataset(path, engine="zarr") as ds:
        ds.load()
    n_v = 3
    assert dict(ds.sizes) == {"gamma": 18, "section": n_v, "eigen": n_v}
    np.testing.assert_array_equal(ds["gamma"].values, np.linspace(0.002, 0.019, 18))
    assert ds["gamma"].attrs == {"units": "rad", "long_name": "slope angle (downhill positive)"}
    assert list(ds["section"].values) == ["alpha_1", "alpha_1_dot", "alpha_2_dot"]

    assert ds["status"].dtype == np.int8 and ds["status"].dims == ("gamma",)
    for key, value in flag_attributes().items():
        assert ds["status"].attrs[key] == value
    assert ds["eigenvalues_real"].dims == ("gamma", "eigen")
    assert ds["eigenvalues_imag"].dims == ("gamma", "eigen")
    assert ds["fixed_point"].dims == ("gamma", "section")
    for name in ("lambda_max", "period", "step_length", "speed", "newton_iterations"):
        assert ds[name].dims == ("gamma",)
    assert ds["period"].attrs["units"] == "1" and ds["speed"].attrs["units"] == "1"  # dimensionless model
    # Where failed steps failed: CF flags naming the model's phases, guards and limits (none).
    assert ds["failure_phase"].attrs["flag_meanings"] == "none single_support_early single_support_late"
    assert ds["failure_event"].attrs["flag_meanings"].split() == ["none", *get_model("simplest").guards]
    assert ds["failure_limit"].attrs["flag_values"] == [0] and ds["failure_phase"].dtype == np.int8

    # Failures: status != 0 and NaN numbers; never NaN with status 0.
    failed = ds["gamma"].values > 0.0155
    np.testing.assert_array_equal(ds["status"].values != Status.OK, failed)
    assert set(ds["status"].values[failed]) == {Status.NO_CONVERGENCE}
    for name in ("lambda_max", "period", "step_length", "speed"):
        np.testing.assert_array_equal(np.isnan(ds[name].values), failed)
    np.testing.assert_allclose(ds["lambda_max"].values[~failed], 0.3 + 50 * ds["gamma"].values[~failed])
    np.testing.assert_allclose(
        ds["eigenvalues_real"].values[~failed, 0] + 1j * ds["eigenvalues_imag"].values[~failed, 0],
        ds["lambda_max"].values[~failed],
    )

    attrs = ds.attrs
    assert attrs["model"] == "simplest" and "Garcia" in attrs["model_description"]
    assert attrs["name"] == "slope_scan" and attrs["swept_parameters"] == "gamma"
    assert attrs["continuation_axis"] == "gamma"
    gammas = ds["gamma"].values
    assert attrs["continuation_start"] == gammas[np.argmin(np.abs(gammas - 0.009))]  # the simplest walker's default slope
    assert json.loads(attrs["fixed_parameters"]) == {}
    assert attrs["units_note"].startswith("dimensionless")
    assert json.loads(attrs["config"]) == config.to_dict()
    assert json.loads(attrs["analysis_options"])["newton"]["max_iter"] == AnalysisOptions().newton.max_iter
    assert attrs["config_toml"] == config.text
    assert attrs["command"] == "test"
    for package in ("jaxwalk", "jax", "diffrax", "numpy", "xarray", "zarr", "python"):
        assert attrs[f"{package}_version"]
    assert attrs["created"].endswith("+00:00")


def test_compass_units_and_fixed_parameters(tmp_path, fake_analysis):
    config = load_config_text(
        tmp_path,
        'name = "c"\nmodel = "compass"\n[params]\nm = 4.0\n[grid]\nm_h = { values = [8.0, 12.0] }\ngamma = { values = [0.01, 0.02, 0.03] }\n',
    )
    path = run_sweep(config, tmp_path, progress=False, analyse=fake_analysis(), plot=False)
    with xr.open_dataset(path, engine="zarr") as ds:
        assert ds["status"].dims == ("m_h", "gamma")
        assert ds["fixed_point"].dims == ("m_h", "gamma", "section")
        assert ds["m_h"].attrs["units"] == "kg"
        assert (ds["period"].attrs["units"], ds["step_length"].attrs["units"], ds["speed"].attrs["units"]) == ("s", "m", "m s-1")
        assert json.loads(ds.attrs["fixed_parameters"]) == {"m": 4.0, "a": 0.5, "b": 0.5, "g": 9.81}
        assert (ds["status"].values == 0).all()


def load_config_text(tmp_path, text):
    path = tmp_path / "sweep.toml"
    path.write_text(text)
    return load_config(path)


def test_contradicting_options_and_an_empty_out_are_refused(tmp_path, monkeypatch, capsys):
    """Options that cancel each other are one line and exit 2, not one of them silently
    winning; an empty --out is not the current directory by accident."""
    from jaxwalk import cli

    monkeypatch.chdir(tmp_path)
    (tmp_path / "sweep.toml").write_text('name = "x"\nmodel = "simplest"\n[grid]\ngamma = { values = [0.01] }\n')
    cases = [
        (["cache", "info", "--no-cache", "--cache-dir", str(tmp_path)], "--no-cache and --cache-dir contradict"),
        (["optimize", "sweep.toml", "--out", "o", "--heatmap", "x.zarr", "--no-heatmap"], "--heatmap and --no-heatmap contradict"),
        (["sweep", "sweep.toml", "--out", ""], "--out is empty"),
    ]
    for argv, fragment in cases:
        assert cli.main(argv) == 2, argv
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and fragment in err, err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["sweep.toml"]
