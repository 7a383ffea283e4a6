"""``[analysis] h_max`` end to end: ``jaxwalk sweep`` with the real analysis writes
the global stability (the paper's h_m) of every gait, on the resolution it was asked for."""

from __future__ import annotations

import json

import numpy as np
import pytest
import xarray as xr

from jaxwalk import cli
from jaxwalk.status import Status, flag_attributes

STEP, COUNT, STEPS = 0.0005, 4, 3

CONFIG = f"""
name = "hmax_small"
model = "simplest"
[grid]
gamma = {{ values = [0.009, 0.0095] }}
[analysis]
continuation = "gamma"
h_max = {{ step = {STEP}, count = {COUNT}, steps = {STEPS} }}
"""


@pytest.mark.slow
def test_sweep_with_h_max_end_to_end(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "sweep.toml").write_text(CONFIG)
    assert cli.main(["sweep", "sweep.toml", "--out", "res", "--no-progress", "--no-plot"]) == 0
    assert capsys.readouterr().out.startswith("wrote res/hmax_small.zarr: 2 points, 2 ok")
    with xr.open_dataset(tmp_path / "res" / "hmax_small.zarr", engine="zarr") as ds:
        ds.load()

    status, drop = ds["status"].values, ds["step_down_status"].values
    h, failed_at = ds["h_max"].values, ds["h_failed"].values
    np.testing.assert_array_equal(status, Status.OK)  # the simplest walker has its gait on both slopes
    assert ds["step_down_status"].dtype == np.int8
    assert np.isin(drop, flag_attributes()["flag_values"]).all()
    assert ds["h_max"].attrs["resolution"] == STEP and ds["h_max"].attrs["steps_after_drop"] == STEPS
    assert ds["h_max"].attrs["limit"] == pytest.approx(COUNT * STEP)

    # h_max is k * step with k in 0 .. count, exactly as the search tries it.
    assert np.isfinite(h).all()
    k = np.round(h / STEP)
    np.testing.assert_allclose(h, k * STEP, rtol=0, atol=1e-15)
    assert ((k >= 0) & (k <= COUNT)).all()
    # It stopped at its first failed drop (the next one) or at the limit with none failed.
    survived_all = drop == Status.OK
    np.testing.assert_array_equal(k[survived_all], COUNT)
    assert np.isnan(failed_at[survived_all]).all()
    np.testing.assert_allclose(failed_at[~survived_all], h[~survived_all] + STEP, rtol=0, atol=1e-15)

    options = json.loads(ds.attrs["analysis_options"])["step_down"]
    assert options == {"dh": STEP, "count": COUNT, "n_steps": STEPS}
