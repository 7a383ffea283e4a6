"""Stores that never lie: the points of an unfinished run read as NOT_COMPUTED
(never as "ok"), plot refuses an unfinished or damaged store with one line naming
the chunks (or draws what is done, marked, with --partial), Ctrl-C says what was
kept and the command that continues, and the run that continues says so.
With the fake analysis: nothing compiles."""

from __future__ import annotations

import shutil

import numpy as np
import pytest
import xarray as xr

import jaxwalk.grid
from jaxwalk import cli
from jaxwalk.status import Status
from jaxwalk.sweep.store import partial_path
from tests.conftest import COMPASS_2D



def opened(path):
    with xr.open_dataset(path, engine="zarr") as ds:
        return ds.load()


@pytest.fixture
def interrupted(tmp_path, monkeypatch, capsys, fake_analysis):
    """A CLI sweep of 7 chunks (one gamma line each), Ctrl-C during the third chunk."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "sweep.toml").write_text(COMPASS_2D)
    fake = fake_analysis()

    def interrupted_in_the_third(*args, **kwargs):
        if len(fake.calls) == 2:
            raise KeyboardInterrupt
        return fake(*args, **kwargs)

    monkeypatch.setattr(jaxwalk.grid, "analyse_grid", interrupted_in_the_third)
    argv = ["sweep", "sweep.toml", "--out", "out", "--chunk-size", "5", "--no-plot", "--no-progress"]
    status = cli.main(argv)
    err = capsys.readouterr().err
    monkeypatch.setattr(jaxwalk.grid, "analyse_grid", fake)
    return status, err, argv, tmp_path / "out"


def test_ctrl_c_says_what_was_kept_and_how_to_continue(interrupted, capsys):
    status, err, argv, out = interrupted
    assert status == 130
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert "interrupted: kept 2 of 7 chunks (10 of 35 points) in 'out/.grid2d.zarr.partial'" in lines[0]
    assert lines[0].endswith("continue with: jaxwalk " + " ".join(argv))

    assert cli.main(argv) == 0  # the command it named continues the run ...
    captured = capsys.readouterr()
    assert "continuing the unfinished run" in captured.err and "2 of 7 chunks (10 of 35 points) were done" in captured.err
    assert (opened(out / "grid2d.zarr").status == Status.OK).all()


def test_uncomputed_points_read_as_not_computed(interrupted):
    _, _, _, out = interrupted
    ds = opened(partial_path(out / "grid2d.zarr") / "grid2d.zarr")
    status = ds.status.transpose("m_h", "gamma").values
    assert (status[:2] == Status.OK).all()  # the two chunks done
    assert (status[2:] == Status.NOT_COMPUTED).all()  # never "ok" with NaN numbers
    assert np.isnan(ds.lambda_max.transpose("m_h", "gamma").values[2:]).all()
    meanings = ds.status.attrs["flag_meanings"].split()
    assert meanings[list(ds.status.attrs["flag_values"]).index(13)] == "not_computed"


def test_plot_refuses_an_unfinished_store_naming_its_chunks(interrupted, capsys, tmp_path):
    _, _, argv, out = interrupted
    store = partial_path(out / "grid2d.zarr") / "grid2d.zarr"
    assert cli.main(["plot", str(store), "--out", str(tmp_path / "figs")]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "25 of 35 points in chunks 2-6 of 7 not computed" in err
    assert "continue it with: jaxwalk " + " ".join(argv) in err
    assert not (tmp_path / "figs").exists()

    assert cli.main(["plot", str(store), "--out", str(tmp_path / "figs"), "--partial"]) == 0  # what is done, marked
    assert {"grid2d_lambda_max_heatmap.png", "grid2d_lambda_max_lines.png"} <= {p.name for p in (tmp_path / "figs").iterdir()}


def test_plot_refuses_a_damaged_store(interrupted, capsys, tmp_path):
    _, _, argv, out = interrupted
    assert cli.main(argv) == 0
    store = out / "grid2d.zarr"
    ds = opened(store)
    assert ds.lambda_max.encoding["chunks"] == (1, 5)
    damaged = tmp_path / "damaged.zarr"
    shutil.copytree(store, damaged)
    (damaged / "lambda_max" / "c" / "3" / "0").unlink()  # a lost chunk file of a number: NaN where status is ok
    (damaged / "status" / "c" / "5" / "0").unlink()  # a lost status file: reads as not computed
    assert cli.main(["plot", str(damaged), "--out", str(tmp_path / "figs")]) == 2
    err = capsys.readouterr().err
    assert "10 of 35 points in chunks 3, 5 of 7 not computed or damaged" in err and "rerun the sweep" in err
    assert cli.main(["plot", str(store), "--out", str(tmp_path / "figs")]) == 0  # the whole one draws
