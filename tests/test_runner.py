"""The sweep runner: calling the analysis, its contract, atomic writes, its figures."""

from __future__ import annotations

import json

import numpy as np
import pytest
import xarray as xr

from jaxwalk.analyses import gait
from jaxwalk.status import Status, flag_attributes
from jaxwalk.stepdown import StepDownOptions
from jaxwalk.sweep import ConfigError, check_results, loads_config, run_sweep
from jaxwalk.grid import AnalysisOptions
from jaxwalk.sweep.runner import RESULT_KEYS, STEP_DOWN_KEYS, analysis_options
from tests.conftest import COMPASS_2D



def results_of(path):
    with xr.open_dataset(path, engine="zarr") as ds:
        return ds.load()


# ---------------------------------------------------------------- calling the analysis


def test_solver_settings_reach_the_analysis_options(tmp_path, fake_analysis):
    config = loads_config(COMPASS_2D + 'rtol = 1e-9\natol = 1e-11\nnewton_tol = 1e-7\nmax_newton_iter = 40\npredictor = "previous"\n')
    options = analysis_options(config)
    assert (options.solver.rtol, options.solver.atol) == (1e-9, 1e-11)
    assert (options.newton.tol, options.newton.max_iter, options.newton.predictor) == (1e-7, 40, "previous")
    defaults = AnalysisOptions()
    assert options.solver.solver == defaults.solver.solver and options.chunk_size == defaults.chunk_size
    assert analysis_options(loads_config(COMPASS_2D)) == defaults

    fake = fake_analysis()
    path = run_sweep(config, tmp_path, progress=False, analyse=fake, plot=False)
    (call,) = fake.calls
    assert call["options"] == options
    assert list(call["grid"]) == ["m_h", "gamma"] and call["continuation_axis"] == "gamma"
    assert call["fixed"] == {p: s.default for p, s in call["model"].param_specs.items() if p not in ("m_h", "gamma")}
    assert json.loads(results_of(path).attrs["analysis_options"])["newton"]["tol"] == 1e-7
    assert json.loads(results_of(path).attrs["analysis_options"])["newton"]["predictor"] == "previous"


def test_h_max_reaches_the_analysis_options(tmp_path, fake_analysis):
    config = loads_config(COMPASS_2D + "rtol = 1e-9\nh_max = { step = 0.002, count = 6, steps = 4 }\n")
    options = analysis_options(config)
    assert options.step_down == StepDownOptions(dh=0.002, count=6, n_steps=4)
    assert options.solver.rtol == 1e-9
    assert analysis_options(loads_config(COMPASS_2D + "h_max = true\n")).step_down == StepDownOptions()
    assert analysis_options(loads_config(COMPASS_2D + "h_max = false\n")).step_down is None
    assert analysis_options(loads_config(COMPASS_2D)).step_down is None

    fake = fake_analysis()
    path = run_sweep(config, tmp_path, progress=False, analyse=fake, plot=False)
    (call,) = fake.calls
    assert call["options"] == options
    recorded = json.loads(results_of(path).attrs["analysis_options"])
    assert recorded["step_down"] == {"dh": 0.002, "count": 6, "n_steps": 4}
    assert json.loads(results_of(path).attrs["config"])["analysis"]["h_max"] == {"step": 0.002, "count": 6, "steps": 4}


def test_progress_bar_counts_points(tmp_path, fake_analysis, capsys):
    run_sweep(loads_config(COMPASS_2D), tmp_path, progress=True, analyse=fake_analysis(), plot=False)
    assert "35/35" in capsys.readouterr().err


# ---------------------------------------------------------------- the contract


def fake_results(shape=(4,), n_v=3, **changes):
    """Every gait output with the shape and dtype :mod:`jaxwalk.analyses.gait` declares: a gait everywhere."""
    value = {"int8": 0, "int32": 3, "float64": 0.5, "complex128": 0.5 + 0.1j}
    out = {o.name: np.full(o.shape(shape, {"section": n_v, "eigen": n_v}), value[o.dtype], o.dtype) for o in gait.OUTPUTS}
    out.update(changes)
    return out


def test_every_gait_output_is_read_from_a_gait_field():
    """``analyse_chunk`` reads each gait output from the ``Gait`` field its ``source`` names."""
    from jaxwalk.gait import Gait
    from jaxwalk.outputs import Output

    missing = [o.source for o in gait.OUTPUTS if o.source not in Gait._fields]
    assert not missing
    assert Output("x", "float64", "an output").source == "x"
    assert {o.name: o.source for o in gait.OUTPUTS}["fixed_point"] == "v"


def test_the_fake_analysis_follows_the_declared_gait_outputs(monkeypatch, fake_analysis):
    """A new gait output reaches the fake with its declared shape and dtype, no edit of the fake."""
    from jaxwalk.grid import AnalysisOptions
    from jaxwalk.models import get_model
    from jaxwalk.outputs import Output

    extra = Output("extra_metric", "float64", "a metric declared in a test", trailing=("section",))
    monkeypatch.setattr(gait, "OUTPUTS", gait.OUTPUTS + (extra,))
    model = get_model("compass")
    n_v = len(model.section_names)
    out = fake_analysis(fail_above=0.03)(model, {}, {"gamma": np.array([0.02, 0.04])}, None, AnalysisOptions(more=()))
    assert list(out) == [o.name for o in gait.OUTPUTS]
    assert all(out[o.name].dtype == np.dtype(o.dtype) for o in gait.OUTPUTS)
    assert out["extra_metric"].shape == (2, n_v)
    assert np.isfinite(out["extra_metric"][0]).all() and np.isnan(out["extra_metric"][1]).all()


def test_nan_with_status_ok_becomes_nonfinite():
    period = np.ones(4)
    period[1] = np.nan
    fixed_point = np.ones((4, 3))
    fixed_point[2, 1] = np.inf
    out = check_results(fake_results(period=period, fixed_point=fixed_point), (4,), 3)
    np.testing.assert_array_equal(out["status"], [0, Status.NONFINITE, Status.NONFINITE, 0])
    assert out["status"].dtype == np.int8
    assert np.isnan(out["lambda_max"][1:3]).all() and np.isnan(out["fixed_point"][1:3]).all()
    assert np.isnan(out["eigenvalues"][1:3].real).all() and np.isnan(out["eigenvalues"][1:3].imag).all()


def test_failed_points_have_nan_numbers():
    status = np.array([0, Status.FELL, Status.NO_CONVERGENCE, 0], np.int8)
    out = check_results(fake_results(status=status), (4,), 3)
    for key in ("lambda_max", "period", "step_length", "speed", "fixed_point", "eigenvalues"):
        np.testing.assert_array_equal(np.isnan(out[key]).reshape(4, -1).any(axis=1), [False, True, True, False])
    np.testing.assert_array_equal(out["newton_iterations"], 3)  # kept: how hard Newton tried


def test_without_stability_eigenvalues_are_not_required_nor_written():
    out = check_results(fake_results(lambda_max=np.full(4, np.nan), eigenvalues=np.full((4, 3), np.nan)), (4,), 3, stability=False)
    np.testing.assert_array_equal(out["status"], 0)
    out = check_results(fake_results(), (4,), 3, stability=False)
    assert np.isnan(out["lambda_max"]).all() and np.isnan(out["eigenvalues"].real).all()
    assert np.isfinite(out["period"]).all()


@pytest.mark.parametrize(
    "changes, match",
    [
        ({"period": np.ones(5)}, "'period' of shape \\(5,\\), expected \\(4,\\)"),
        ({"fixed_point": np.ones((4, 2))}, "'fixed_point' of shape"),
        ({"status": np.full(4, 127, np.int8)}, "status codes \\[127\\]"),
        ({"status": np.zeros(4)}, "dtype float64"),
    ],
)
def test_contract_violations_raise(changes, match):
    with pytest.raises(ValueError, match=match):
        check_results(fake_results(**changes), (4,), 3)


def test_missing_output_raises():
    results = fake_results()
    del results["speed"]
    with pytest.raises(ValueError, match="returned no speed"):
        check_results(results, (4,), 3)
    assert "speed" in RESULT_KEYS


def step_down_results(shape=(4,), **changes):
    """Gait OK everywhere; h_max 0, 1, 2, 3 (x 0.001), the last with no failure up to the limit."""
    out = {
        "h_max": np.array([0.0, 0.001, 0.002, 0.003]),
        "step_down_status": np.array([Status.FELL, Status.FELL, Status.STALLED, Status.OK], np.int8),
        "h_failed": np.array([0.001, 0.002, 0.003, np.nan]),
    }
    out.update(changes)
    return fake_results(shape, **out)


def test_step_down_keys_pass_through_and_are_typed():
    out = check_results(step_down_results(step_down_status=np.array([1, 1, 2, 0])), (4,), 3, step_down=True)
    assert out["step_down_status"].dtype == np.int8 and out["h_max"].dtype == np.float64 and out["h_failed"].dtype == np.float64
    np.testing.assert_array_equal(out["status"], 0)
    np.testing.assert_array_equal(out["h_max"], [0.0, 0.001, 0.002, 0.003])
    np.testing.assert_array_equal(out["step_down_status"], [1, 1, 2, 0])
    np.testing.assert_array_equal(out["h_failed"], [0.001, 0.002, 0.003, np.nan])


def test_step_down_keys_ignored_without_step_down():
    out = check_results(step_down_results(step_down_status=np.full(4, 127)), (4,), 3)
    assert not set(STEP_DOWN_KEYS) & set(out)


def test_no_gait_no_h_max():
    status = np.array([0, Status.NO_CONVERGENCE, Status.FELL, 0], np.int8)
    out = check_results(step_down_results(status=status), (4,), 3, step_down=True)
    np.testing.assert_array_equal(np.isnan(out["h_max"]), status != 0)  # NaN exactly where there is no gait
    np.testing.assert_array_equal(out["step_down_status"], [Status.FELL, Status.NO_CONVERGENCE, Status.FELL, Status.OK])
    np.testing.assert_array_equal(np.isnan(out["h_failed"]), [False, True, True, True])


def test_h_max_nan_with_gait_ok_becomes_nonfinite():
    out = check_results(step_down_results(h_max=np.array([0.0, np.nan, 0.002, 0.003])), (4,), 3, step_down=True)
    np.testing.assert_array_equal(out["status"], [0, Status.NONFINITE, 0, 0])
    np.testing.assert_array_equal(out["step_down_status"], [Status.FELL, Status.NONFINITE, Status.STALLED, Status.OK])
    assert np.isnan(out["h_max"][1]) and np.isnan(out["h_failed"][1]) and np.isnan(out["period"][1])
    assert not np.isnan(out["h_max"][out["status"] == 0]).any()


def test_h_failed_is_nan_where_no_drop_failed():
    out = check_results(step_down_results(h_failed=np.array([0.001, 0.002, 0.003, 0.004])), (4,), 3, step_down=True)
    np.testing.assert_array_equal(np.isnan(out["h_failed"]), [False, False, False, True])


@pytest.mark.parametrize(
    "changes, match",
    [
        ({"h_max": np.zeros(5)}, "'h_max' of shape \\(5,\\), expected \\(4,\\)"),
        ({"h_failed": np.zeros((4, 1))}, "'h_failed' of shape"),
        ({"step_down_status": np.full(4, 127, np.int8)}, "step_down_status codes \\[127\\]"),
        ({"step_down_status": np.zeros(4)}, "'step_down_status' of dtype float64"),
        ({"h_max": np.array([0.0, -0.001, 0.0, 0.0])}, "negative 'h_max'"),
    ],
)
def test_step_down_contract_violations_raise(changes, match):
    with pytest.raises(ValueError, match=match):
        check_results(step_down_results(**changes), (4,), 3, step_down=True)


def test_missing_step_down_output_raises():
    results = step_down_results()
    del results["h_failed"], results["step_down_status"]
    with pytest.raises(ValueError, match="returned no step_down_status, h_failed"):
        check_results(results, (4,), 3, step_down=True)


def test_h_max_dataset(tmp_path, fake_analysis):
    config = loads_config(COMPASS_2D + "h_max = { step = 0.002, count = 6, steps = 4 }\n")
    path = run_sweep(config, tmp_path, progress=False, analyse=fake_analysis(fail_above=15.0), plot=False)
    ds = results_of(path)
    for name in STEP_DOWN_KEYS:
        assert ds[name].dims == ("m_h", "gamma")
    assert ds["step_down_status"].dtype == np.int8
    assert ds["h_max"].dtype == np.float64 and ds["h_failed"].dtype == np.float64
    h = ds["h_max"]
    assert h.attrs["description"] == "largest survived step-down (every smaller tested drop survived)"
    assert h.attrs["long_name"] == "largest survived step-down"  # short: xarray's plots label axes with it
    assert h.attrs["units"] == "m" and ds["h_failed"].attrs["units"] == "m"  # compass: SI lengths
    assert h.attrs["resolution"] == 0.002 and h.attrs["limit"] == pytest.approx(0.012) and h.attrs["steps_after_drop"] == 4
    assert "survived together with every smaller one" in h.attrs["comment"] and "4 more steps" in h.attrs["comment"]
    for key, value in flag_attributes().items():
        assert ds["step_down_status"].attrs[key] == value

    status, drop = ds["status"].values, ds["step_down_status"].values
    failed = ds["m_h"].values[:, None] > 15.0
    np.testing.assert_array_equal(status != 0, np.broadcast_to(failed, status.shape))
    np.testing.assert_array_equal(np.isnan(h.values), status != 0)  # NaN exactly where there is no gait
    np.testing.assert_array_equal(drop[status != 0], status[status != 0])
    ok = status == 0
    k = np.round(h.values[ok] / 0.002)
    np.testing.assert_allclose(h.values[ok], k * 0.002)
    assert set(k.tolist()) == set(range(7))  # 0 .. count, both ends reached
    assert set(drop[ok].tolist()) == {Status.OK, Status.FELL}
    np.testing.assert_array_equal(drop[ok] == Status.OK, k == 6)
    np.testing.assert_allclose(ds["h_failed"].values[ok & (drop != 0)], h.values[ok & (drop != 0)] + 0.002)
    assert np.isnan(ds["h_failed"].values[~ok | (drop == 0)]).all()


def test_the_fixed_point_says_its_coordinates_units(tmp_path, fake_analysis):
    """The compass walker's section: an angle and two rates, in SI time (seconds)."""
    import json

    ds = results_of(run_sweep(loads_config(COMPASS_2D), tmp_path, progress=False, analyse=fake_analysis(), plot=False))
    for units in (ds["fixed_point"].attrs["section_units"], ds["section"].attrs["section_units"]):
        assert json.loads(units) == ["rad", "rad s-1", "rad s-1"]
    assert ds["fixed_point"].attrs["comment"] == "units differ along 'section': alpha_1 in rad, alpha_1_dot in rad s-1, alpha_2_dot in rad s-1"


def test_no_h_max_no_step_down_variables(tmp_path, fake_analysis):
    ds = results_of(run_sweep(loads_config(COMPASS_2D), tmp_path, progress=False, analyse=fake_analysis(), plot=False))
    assert not set(STEP_DOWN_KEYS) & set(ds.variables)
    assert json.loads(ds.attrs["analysis_options"])["step_down"] is None


def test_nan_with_ok_end_to_end(tmp_path, fake_analysis):
    path = run_sweep(loads_config(COMPASS_2D), tmp_path, progress=False, analyse=fake_analysis(nan_with_ok=True), plot=False)
    ds = results_of(path)
    assert ds["status"].values.flat[0] == Status.NONFINITE
    assert not (np.isnan(ds["period"].values) & (ds["status"].values == Status.OK)).any()


# ---------------------------------------------------------------- writing


def test_failed_analysis_leaves_nothing(tmp_path, fake_analysis):
    out = tmp_path / "out"
    with pytest.raises(RuntimeError, match="boom"):
        run_sweep(loads_config(COMPASS_2D), out, progress=False, analyse=fake_analysis(error=RuntimeError("boom")))
    assert not out.exists()


def test_failed_write_leaves_nothing(tmp_path, fake_analysis, monkeypatch):
    original = xr.Dataset.to_zarr

    def half_then_fail(self, store, **kwargs):
        original(self, store, **kwargs)  # a whole store in the temporary directory...
        raise OSError("disk full")  # ...then the failure

    monkeypatch.setattr(xr.Dataset, "to_zarr", half_then_fail)
    with pytest.raises(OSError, match="disk full"):
        run_sweep(loads_config(COMPASS_2D), tmp_path, progress=False, analyse=fake_analysis(), plot=False)
    assert list(tmp_path.iterdir()) == []


def test_existing_dataset_needs_overwrite(tmp_path, fake_analysis):
    config = loads_config(COMPASS_2D)
    first = fake_analysis()
    path = run_sweep(config, tmp_path, progress=False, analyse=first, plot=False, command="first")
    second = fake_analysis()
    with pytest.raises(ConfigError, match="already exists"):
        run_sweep(config, tmp_path, progress=False, analyse=second, plot=False)
    assert second.calls == []  # refused before computing
    run_sweep(config, tmp_path, progress=False, analyse=second, plot=False, overwrite=True, command="second")
    assert results_of(path).attrs["command"] == "second"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["grid2d.zarr"]


# ---------------------------------------------------------------- figures


@pytest.mark.parametrize(
    "text",
    [COMPASS_2D, COMPASS_2D.replace("[analysis]", 'm = { values = [4.0, 5.0] }\n[analysis]'),
     'name = "grid1d"\nmodel = "simplest"\n[grid]\ngamma = { start = 0.002, stop = 0.019, num = 18 }\n'],
    ids=["2d", "3d", "1d"],
)
def test_sweep_writes_its_figures(tmp_path, fake_analysis, text):
    config = loads_config(text)
    path = run_sweep(config, tmp_path, progress=False, analyse=fake_analysis(fail_above=0.0155 if config.model == "simplest" else 15.0))
    figures = sorted(p.name for p in tmp_path.iterdir() if p != path)
    kinds = ["lines", "heatmap"] if len(config.dims) > 1 else ["lines"]
    assert {f"{config.name}_lambda_max_{k}.png" for k in kinds} <= set(figures)
    for name in figures:  # jaxwalk.plot's names, nothing else beside the dataset
        assert name.startswith(f"{config.name}_") and name.endswith(tuple(f"_{k}.png" for k in kinds)), name
        assert (tmp_path / name).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_a_gait_sensitivity_norm_nan_at_a_gait_is_nonfinite_but_inf_is_a_value():
    """The norm of an unstable gait is inf, a result; NaN at a gait found (the step re-run
    at the gait failed, or its Jacobian is not finite) must not leave with status 0."""
    from jaxwalk import outputs as schema
    from jaxwalk.analyses.global_stability import GSN

    status = np.zeros(4, np.int8)
    gsn = np.array([1.3, np.inf, np.nan, 2.0])
    out = schema.nonfinite(status, {"gait_sensitivity_norm": gsn}, [GSN])
    np.testing.assert_array_equal(out, [0, 0, Status.NONFINITE, 0])


def test_a_model_says_its_own_section_units():
    """A model whose section is not angles and their rates declares its units."""
    from jaxwalk.models.compass import CompassWalker
    from jaxwalk.sweep.dataset import section_units

    class Hopper(CompassWalker):
        section_units = ("m", "m s-1", "rad s-1")

    assert section_units(Hopper()) == ["m", "m s-1", "rad s-1"]
    assert section_units(CompassWalker()) == ["rad", "rad s-1", "rad s-1"]

    class Short(CompassWalker):
        section_units = ("m",)

    with pytest.raises(ValueError, match="declares 1 section_units for 3 section_names"):
        section_units(Short())
