"""The best point of every line of a sweep (jaxwalk.sweep.optimum, `jaxwalk optimum`)."""

import numpy as np
import pytest
import xarray as xr

from jaxwalk.cli import main
from jaxwalk.errors import ConfigError
from jaxwalk.status import Status
from jaxwalk.sweep.optimum import KINDS, line_optima

R = np.linspace(0.1, 1.0, 10)  # grid step 0.1


def _dataset(lines: dict[float, tuple[np.ndarray, np.ndarray]]) -> xr.Dataset:
    """A sweep-shaped dataset over (l_f, r) from ``{l_f: (values, status)}``."""
    l_f = np.array(sorted(lines))
    values = np.stack([lines[k][0] for k in l_f])
    status = np.stack([lines[k][1] for k in l_f]).astype(np.int8)
    return xr.Dataset(
        {"lambda_max": (("l_f", "r"), values), "status": (("l_f", "r"), status)},
        coords={"l_f": l_f, "r": R},
    )


OK = np.zeros(R.size, np.int8)


def _kind(optima, l_f):
    return KINDS[int(optima.optimum_kind.sel(l_f=l_f))]


def test_an_interior_minimum_is_refined_off_the_grid_by_the_parabola():
    # A parabola with its vertex between grid points: the three-point fit is exact.
    values = 0.6 + 2.0 * (R - 0.437) ** 2
    optima = line_optima(_dataset({0.22: (values, OK)}))
    assert _kind(optima, 0.22) == "interior"
    assert float(optima.star.sel(l_f=0.22)) == pytest.approx(0.437, abs=1e-12)
    assert float(optima.value.sel(l_f=0.22)) == pytest.approx(0.6, abs=1e-12)
    assert (float(optima.star_lower.sel(l_f=0.22)), float(optima.star_upper.sel(l_f=0.22))) == pytest.approx((0.3, 0.5))  # around the grid point 0.4


def test_an_optimum_beside_a_failure_is_a_band_edge_with_the_status_beyond():
    # Least at the smallest r that walks; below it the walker runs.
    values = 0.5 + R
    status = np.where(R < 0.35, Status.RUNNING, Status.OK)
    optima = line_optima(_dataset({0.2: (np.where(status == 0, values, np.nan), status)}))
    assert _kind(optima, 0.2) == "band_edge"
    assert float(optima.star.sel(l_f=0.2)) == pytest.approx(0.4)
    assert int(optima.beyond_status.sel(l_f=0.2)) == Status.RUNNING
    assert float(optima.band_lower.sel(l_f=0.2)) == pytest.approx(0.4)
    assert float(optima.band_upper.sel(l_f=0.2)) == pytest.approx(1.0)


def test_the_grid_edge_and_a_plateau_are_named_and_the_largest_value_can_be_best():
    falling = 1.0 - R
    plateau = np.array([0.0, 0.001, 0.002, 0.004, 0.004, 0.004, 0.003, 0.002, 0.001, 0.0])
    ds = _dataset({0.15: (falling, OK), 0.25: (plateau, OK)})
    least = line_optima(ds)
    assert _kind(least, 0.15) == "grid_edge" and float(least.star.sel(l_f=0.15)) == pytest.approx(1.0)
    largest = line_optima(ds, sense="max")
    assert _kind(largest, 0.25) == "plateau"
    assert float(largest.star.sel(l_f=0.25)) == pytest.approx(0.5)  # the middle of 0.4-0.6
    assert float(largest.value.sel(l_f=0.25)) == pytest.approx(0.004)
    assert float(largest.star_lower.sel(l_f=0.25)) == pytest.approx(0.4)


def test_a_line_where_nothing_walks_has_no_optimum():
    status = np.full(R.size, Status.SLIPPING, np.int8)
    optima = line_optima(_dataset({0.1: (np.full(R.size, np.nan), status), 0.2: (R, OK)}))
    assert _kind(optima, 0.1) == "no_gait" and np.isnan(float(optima.star.sel(l_f=0.1)))
    assert _kind(optima, 0.2) == "grid_edge"


def test_bad_names_raise_the_one_error_type():
    ds = _dataset({0.2: (R, OK)})
    with pytest.raises(ConfigError, match="no variable 'h_mx'"):
        line_optima(ds, "h_mx")
    with pytest.raises(ConfigError, match="no grid axis 'gamma'"):
        line_optima(ds, along="gamma")
    with pytest.raises(ConfigError, match="sense"):
        line_optima(ds, sense="best")
    ds["fixed_point"] = (("l_f", "r", "section"), np.zeros((1, R.size, 3)))
    with pytest.raises(ConfigError, match="'fixed_point' is not one number per grid point .*section"):
        line_optima(ds, "fixed_point")
    with pytest.raises(ConfigError, match="'status' is not a measure to optimise"):
        line_optima(ds, "status")


def test_the_command_prints_a_stores_optima_and_refuses_a_bad_variable(tmp_path, monkeypatch, capsys, fake_analysis):
    import jaxwalk.grid
    from tests.conftest import COMPASS_2D

    # The fake analysis: lambda_max = 0.3 + 50 (m_h + gamma), no gait for m_h > 15.
    monkeypatch.setattr(jaxwalk.grid, "analyse_grid", fake_analysis(fail_above=15.0))
    (tmp_path / "sweep.toml").write_text(COMPASS_2D)
    assert main(["sweep", str(tmp_path / "sweep.toml"), "--out", str(tmp_path), "--no-plot", "--no-progress"]) == 0
    capsys.readouterr()
    store, table = str(tmp_path / "grid2d.zarr"), tmp_path / "optima.csv"
    assert main(["optimum", store, "--along", "gamma", "--csv", str(table)]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0].startswith("| m_h | gamma* |") and len(lines) == 2 + 7 + 1  # header, rule, 7 lines, "wrote"
    assert sum("grid_edge" in line for line in lines) == 5 and sum("no_gait" in line for line in lines) == 2
    assert "| 5 | 0.01 |" in lines[2]  # least lambda_max at the smallest slope
    assert table.read_text().count("\n") == 8
    assert main(["optimum", store, "--var", "lambda_mx"]) == 2
    assert capsys.readouterr().err.startswith("jaxwalk: error: line_optima: no variable 'lambda_mx'")
    # The CSV is checked before anything is computed or printed, and never replaced unasked.
    for csv, fragment in ((table, "already exists (pass --overwrite"), (tmp_path, "is a directory"),
                          (tmp_path / "nodir" / "x.csv", "is not a directory")):
        assert main(["optimum", store, "--along", "gamma", "--csv", str(csv)]) == 2
        captured = capsys.readouterr()
        assert captured.out == "" and captured.err.count("\n") == 1 and fragment in captured.err, captured.err
    assert main(["optimum", store, "--along", "gamma", "--csv", str(table), "--overwrite"]) == 0
    assert table.read_text().count("\n") == 8 and not list(tmp_path.glob(".optima.csv.*"))
