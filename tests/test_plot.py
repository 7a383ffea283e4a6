"""Figures of sweep datasets (jaxwalk.plot, ``jaxwalk plot``): failures masked and
named, the lambda_max = 1 contour exactly where lambda_max crosses 1, layouts for
1-D, 2-D and 3-D grids, files written, and bad input as one line with exit 2.

Datasets are synthetic (:func:`synthetic`, through the real ``build_dataset``), so
nothing is computed with JAX.
"""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr

from jaxwalk import cli
from jaxwalk.analyses import failure
from jaxwalk.models import get_model
from jaxwalk.plot import choose_layout, heatmap_figure, lines_figure, make_figures, plot_dataset
from jaxwalk.plot.heatmap import CONTOUR_GID
from jaxwalk.plot.layout import parse_at
from jaxwalk.plot.lines import LIMIT_GID
from jaxwalk.plot.source import PlotError, choose_variables
from jaxwalk.status import Status
from jaxwalk.sweep import loads_config
from jaxwalk.sweep.dataset import build_dataset, write_zarr

GRID_1D = 'gamma = { start = 0.002, stop = 0.019, num = 12 }\n'
GRID_2D = 'gamma = { start = 0.01, stop = 0.1, num = 10 }\nm_h = { start = 2.0, stop = 20.0, num = 6 }\n'
GRID_3D = GRID_2D + 'a = { values = [0.6, 0.4, 0.5] }\n'


def synthetic(grid: str, *, model: str = "compass", failures=None, lam=(0.4, 1.6), h_max=False, cot=True, stability=True):
    """A sweep dataset with ``lambda_max`` rising linearly along the first axis from
    ``lam[0]`` to ``lam[1]`` (plus a little along the second), ``failures(u) -> status``
    on the grid's unit coordinates ``u`` (one ``(S,)`` array per axis, 0 to 1), NaN
    numbers where a point failed, as the runner writes them."""
    text = f'name = "syn"\nmodel = "{model}"\n[grid]\n{grid}[analysis]\nstability = {str(stability).lower()}\n'
    config = loads_config(text + ("h_max = { step = 0.001, count = 10 }\n" if h_max else ""))
    spec = get_model(config.model)
    n_v = len(spec.section_names)
    mesh = np.meshgrid(*config.grid.values(), indexing="ij")
    u = [(m - m.min()) / (np.ptp(m) or 1.0) for m in mesh]
    status = (failures(u) if failures else np.zeros(u[0].shape)).astype(np.int8)
    failed = status != Status.OK
    lam_max = lam[0] + (lam[1] - lam[0]) * u[0] + (0.05 * u[1] if len(u) > 1 else 0.0)
    nan = lambda a: np.where(failed, np.nan, a)  # noqa: E731
    results = {
        "status": status,
        "lambda_max": nan(lam_max) if stability else np.full(u[0].shape, np.nan),
        "eigenvalues": np.where(failed[..., None], np.nan, lam_max[..., None] * np.ones(n_v)).astype(complex),
        "fixed_point": np.where(failed[..., None], np.nan, np.ones(u[0].shape + (n_v,))),
        "period": nan(1.0 + u[0]),
        "step_length": nan(0.5 + 0.1 * u[0]),
        "speed": nan((0.5 + 0.1 * u[0]) / (1.0 + u[0])),
        "work": nan(0.2 + 0.1 * u[0]),
        "cost_of_transport": nan(0.1 + 0.05 * u[0]),
        "newton_iterations": np.full(u[0].shape, 4, np.int32),
        "h_max": nan(0.001 * np.round(10 * (1 - u[0]))),
        "step_down_status": np.where(failed, status, Status.FELL).astype(np.int8),
        "h_failed": nan(0.001 * np.round(10 * (1 - u[0])) + 0.001),
        **{o.name: np.zeros(u[0].shape, np.int8) for o in failure.OUTPUTS},  # "none": no step failed
    }
    ds = build_dataset(config, spec, results)
    # cost_of_transport is an optional variable: make its presence the test's choice.
    if cot and "cost_of_transport" not in ds:
        ds["cost_of_transport"] = (config.dims, results["cost_of_transport"], {"long_name": "cost of transport", "units": "1"})
    if not cot and "cost_of_transport" in ds:
        ds = ds.drop_vars("cost_of_transport")
    return ds


def three_failures(u):
    """fell at the steep end, scuffing in a corner, no convergence along the lightest hip."""
    s = np.zeros(u[0].shape, int)
    s[u[0] > 0.85] = Status.FELL
    s[(u[0] < 0.15) & (u[1] > 0.5)] = Status.SCUFFING
    s[u[1] < 0.1] = Status.NO_CONVERGENCE
    return s


def legend_texts(fig) -> list[str]:
    return [t.get_text() for legend in fig.legends for t in legend.get_texts()]


def contours(fig) -> list:
    return [c for ax in fig.axes for c in ax.collections if c.get_gid() == CONTOUR_GID]


# ---------------------------------------------------------------- heatmaps


def test_heatmap_masks_and_names_every_failure():
    ds = synthetic(GRID_2D, failures=three_failures)
    fig = heatmap_figure(ds, "lambda_max", choose_layout(ds, "heatmap"))
    texts = legend_texts(fig)
    status = ds["status"].values
    for code, name in [(Status.FELL, "fell"), (Status.SCUFFING, "scuffing"), (Status.NO_CONVERGENCE, "no convergence")]:
        n = int((status == code).sum())
        assert f"{name} ({n} points)" in texts, texts
    (ax,) = [a for a in fig.axes if a.get_label() != "<colorbar>"]
    # Large regions carry their name on the map too.
    assert {t.get_text() for t in ax.texts if t.get_gid() == "status-label"} == {"fell", "scuffing", "no convergence"}
    # The value mesh shows no failed point; the categorical overlay covers exactly the failures.
    values, overlay = ax.collections[0].get_array(), ax.collections[1].get_array()
    assert values.mask.sum() == (status != 0).sum() and (~overlay.mask).sum() == (status != 0).sum()


def test_contour_exactly_where_lambda_max_crosses_one():
    crossing = synthetic(GRID_2D, lam=(0.5, 1.5))
    fig = heatmap_figure(crossing, "lambda_max", choose_layout(crossing, "heatmap"))
    assert len(contours(fig)) == 1 and any("stability limit" in t for t in legend_texts(fig))
    # Drawn on every variable's map, not only lambda_max's.
    assert len(contours(heatmap_figure(crossing, "speed", choose_layout(crossing, "heatmap")))) == 1

    stable = synthetic(GRID_2D, lam=(0.3, 0.8))
    fig = heatmap_figure(stable, "lambda_max", choose_layout(stable, "heatmap"))
    assert contours(fig) == [] and not any("stability limit" in t or "unstable" in t for t in legend_texts(fig))
    no_stability = synthetic(GRID_2D, stability=False)
    assert contours(heatmap_figure(no_stability, "speed", choose_layout(no_stability, "heatmap"))) == []


def test_unstable_gaits_are_hatched():
    ds = synthetic(GRID_2D, lam=(0.5, 1.5), failures=three_failures)
    fig = heatmap_figure(ds, "h_max" if "h_max" in ds else "speed", choose_layout(ds, "heatmap"))
    (hatched,) = [c for ax in fig.axes for c in ax.collections if c.get_gid() == "unstable"]
    unstable = (ds["status"].values == 0) & (ds["lambda_max"].values >= 1)
    assert unstable.any() and hatched.get_hatch()
    # One rectangle per run of unstable cells along x; together they cover exactly those cells.
    boxes = [p.get_extents() for p in hatched.get_paths()]
    xs, ys = ds["gamma"].values, ds["m_h"].values
    covered = np.zeros_like(unstable)
    for b in boxes:
        covered |= ((xs[:, None] > b.x0) & (xs[:, None] < b.x1)) & ((ys[None, :] > b.y0) & (ys[None, :] < b.y1))
    np.testing.assert_array_equal(covered, unstable)
    assert len(boxes) < unstable.sum()
    assert any("unstable gait" in t for t in legend_texts(fig))


def test_all_failed_grid_still_maps_its_failures():
    ds = synthetic(GRID_2D, failures=lambda u: np.where(u[0] > 0.5, Status.FELL, Status.STALLED))
    assert choose_variables(ds) == ["lambda_max", "speed", "cost_of_transport"]  # nothing computed, all mapped
    fig = heatmap_figure(ds, "lambda_max", choose_layout(ds, "heatmap"))
    texts = legend_texts(fig)
    assert "fell (30 points)" in texts and "stalled (30 points)" in texts
    assert any("no gait found" in t for t in texts) and contours(fig) == []


def test_3d_grid_small_multiples_or_one_index():
    ds = synthetic(GRID_3D, failures=three_failures)
    layout = choose_layout(ds, "heatmap")
    assert (layout.x, layout.y, layout.panels) == ("gamma", "m_h", "a")
    assert [float(ds["a"][i]) for i in layout.panel_indices] == [0.4, 0.5, 0.6]  # panels by value
    fig = heatmap_figure(ds, "lambda_max", layout)
    titles = [ax.get_title() for ax in fig.axes if ax.get_title()]
    assert titles == ["a = 0.4 m", "a = 0.5 m", "a = 0.6 m"]
    assert f"fell ({int((ds['status'] == Status.FELL).sum())} points)" in legend_texts(fig)  # counted over every panel

    one = choose_layout(ds, "heatmap", at={"a": 1})
    assert one.panels is None and one.fixed == {"a": 1}
    fig = heatmap_figure(ds, "lambda_max", one)
    assert "at a = 0.4 m" in fig.get_suptitle() and len([a for a in fig.axes if a.get_title()]) == 0


def test_layout_choices_and_errors():
    ds = synthetic(GRID_2D)
    assert (choose_layout(ds, "lines").x, choose_layout(ds, "lines").y) == ("gamma", "m_h")  # longest first
    swapped = choose_layout(ds, "lines", x="m_h")
    assert (swapped.x, swapped.y) == ("m_h", "gamma")
    assert parse_at(["a=2", "m_h=-1"]) == {"a": 2, "m_h": -1}
    for kwargs, fragment in [
        ({"x": "gama"}, "--x: 'gama' is not a grid axis"),
        ({"at": {"gamma": 10}}, "index 10 out of range for 'gamma'"),
        ({"x": "gamma", "y": "gamma"}, "--x and --y are both 'gamma'"),
        ({"x": "gamma", "at": {"gamma": 0}}, "also fixed by --at"),
    ]:
        with pytest.raises(PlotError, match=fragment):
            choose_layout(ds, "heatmap", **kwargs)
    with pytest.raises(PlotError, match="a heatmap needs two grid axes"):
        choose_layout(synthetic(GRID_1D, model="simplest"), "heatmap")
    with pytest.raises(PlotError, match="AXIS=INDEX"):
        parse_at(["a:2"])


# ---------------------------------------------------------------- line plots


def test_1d_single_curve_failures_marked_by_status():
    ds = synthetic(GRID_1D, model="simplest", failures=lambda u: np.where(u[0] > 0.8, Status.FELL, 0))
    layout = choose_layout(ds, "lines")
    assert layout.y is None and layout.panels is None
    fig = lines_figure(ds, "lambda_max", layout)
    curves = [ln for ax in fig.axes for ln in ax.get_lines() if ln.get_linestyle() == "-"]
    assert len(curves) == 1
    (failed,) = [ln for ax in fig.axes for ln in ax.get_lines() if ln.get_gid() == f"failed:{int(Status.FELL)}"]
    np.testing.assert_array_equal(failed.get_xdata(), ds["gamma"].values[ds["status"].values == Status.FELL])
    assert any(ln.get_gid() == LIMIT_GID for ax in fig.axes for ln in ax.get_lines())
    assert f"fell ({len(failed.get_xdata())} points)" in legend_texts(fig)


def test_2d_one_curve_per_value_of_the_other_axis():
    grid = 'm_h = { values = [20.0, 5.0, 10.0] }\ngamma = { start = 0.01, stop = 0.1, num = 10 }\n'
    ds = synthetic(grid, failures=lambda u: np.where(u[0] > 0.9, Status.SCUFFING, 0))
    layout = choose_layout(ds, "lines")
    assert (layout.x, layout.y) == ("gamma", "m_h")  # the paper's Fig. 5: against r, one line per l_f
    fig = lines_figure(ds, "speed", layout)
    labels = [t for t in legend_texts(fig)]
    assert labels[:3] == ["5", "10", "20"]  # curves in ascending order of the value
    assert fig.legends[0].get_title().get_text().startswith("m_h [kg]")
    assert not any(ln.get_gid() == LIMIT_GID for ax in fig.axes for ln in ax.get_lines())  # only on lambda_max
    assert "scuffing (10 points)" in labels


def test_a_variable_with_an_error_estimate_gets_error_bars():
    """An MFPT's error estimate is often half its value: where ``<name>_error`` exists,
    each gait's value carries its bar (of that size, in the curve's colour) and the
    legend names the estimate; other variables get none."""
    grid = 'm_h = { values = [20.0, 5.0] }\ngamma = { start = 0.01, stop = 0.1, num = 10 }\n'
    ds = synthetic(grid, failures=lambda u: np.where(u[0] > 0.9, Status.SCUFFING, 0))
    ds["mfpt"] = (100.0 + 0.0 * ds["speed"]).assign_attrs(long_name="MFPT", units="steps")
    ds["mfpt_error"] = (30.0 + 0.0 * ds["speed"]).assign_attrs(long_name="MFPT error", units="steps")
    layout = choose_layout(ds, "lines")
    fig = lines_figure(ds, "mfpt", layout)
    bars = [c for ax in fig.axes for c in ax.collections if c.get_gid() == "error-bar"]
    assert len(bars) == 1  # on the curve with gaits; the other (all scuffing) has no value to bar
    ok = int((ds["status"] == Status.OK).sum())
    segments = [seg for c in bars for seg in c.get_segments()]
    assert len(segments) == ok and all(abs(seg[1][1] - seg[0][1] - 60.0) < 1e-9 for seg in segments)
    assert "error bars: \u00b1 mfpt_error" in legend_texts(fig)
    plain = lines_figure(ds, "speed", layout)
    assert not [c for ax in plain.axes for c in ax.collections if c.get_gid() == "error-bar"]


def test_lines_of_a_3d_grid_are_small_multiples():
    ds = synthetic(GRID_3D)
    fig = lines_figure(ds, "lambda_max", choose_layout(ds, "lines"))
    assert sorted(ax.get_title() for ax in fig.axes if ax.get_title()) == ["a = 0.4 m", "a = 0.5 m", "a = 0.6 m"]


# ---------------------------------------------------------------- variables


@pytest.mark.parametrize(
    "kwargs, expected",
    [
        ({}, ["lambda_max", "speed", "cost_of_transport"]),
        ({"cot": False}, ["lambda_max", "speed"]),
        ({"h_max": True, "cot": False}, ["lambda_max", "h_max", "speed"]),
        ({"stability": False}, ["speed", "cost_of_transport"]),
    ],
    ids=["plain", "no-cot", "h_max", "no-stability"],
)
def test_default_variables_are_those_with_values(kwargs, expected):
    assert choose_variables(synthetic(GRID_2D, **kwargs)) == expected


def test_a_passive_walkers_zero_cost_of_transport_is_drawn_only_when_asked():
    ds = synthetic(GRID_2D)
    ds["cost_of_transport"] = ds["cost_of_transport"].where(np.isnan(ds["cost_of_transport"]), 0.0)
    assert choose_variables(ds) == ["lambda_max", "speed"]
    assert choose_variables(ds, ["cost_of_transport"]) == ["cost_of_transport"]


def test_requested_variables_are_checked():
    ds = synthetic(GRID_2D, stability=False)
    assert choose_variables(ds, ["period", "speed", "period"]) == ["period", "speed"]
    with pytest.raises(PlotError, match="unknown variable 'sped' \\(did you mean 'speed'\\?\\)"):
        choose_variables(ds, ["sped"])
    with pytest.raises(PlotError, match="'lambda_max' has no values"):
        choose_variables(ds, ["lambda_max"])
    with pytest.raises(PlotError, match="unknown variable 'h_max'"):
        choose_variables(ds, ["h_max"])


# ---------------------------------------------------------------- files


def test_plot_dataset_writes_one_file_per_figure(tmp_path):
    store = write_zarr(synthetic(GRID_2D, h_max=True, failures=three_failures), tmp_path / "syn.zarr")
    paths = plot_dataset(store)  # default: next to the dataset
    names = sorted(p.name for p in paths)
    assert names == sorted(f"syn_{v}_{k}.png" for v in ("lambda_max", "h_max", "speed", "cost_of_transport") for k in ("heatmap", "lines"))
    assert all(p.parent == tmp_path and p.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" for p in paths)
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]  # no temporary left

    (svg,) = plot_dataset(store, tmp_path / "new" / "dir", fmt="svg", variables=["h_max"], kinds=["lines"])
    assert svg.name == "syn_h_max_lines.svg" and b"<svg" in svg.read_bytes()[:400]


def test_make_figures_draws_lines_only_for_a_1d_grid():
    figures = make_figures(synthetic(GRID_1D, model="simplest", cot=False))
    assert list(figures) == [("lambda_max", "lines"), ("speed", "lines")]


def test_a_figure_failure_keeps_the_sweep_dataset(tmp_path, fake_analysis, monkeypatch):
    import jaxwalk.plot
    from jaxwalk.sweep import run_sweep

    def broken(*args, **kwargs):
        raise RuntimeError("no display\nat all")

    monkeypatch.setattr(jaxwalk.plot, "plot_dataset", broken)
    config = loads_config(f'name = "kept"\nmodel = "compass"\n[grid]\n{GRID_2D}')
    with pytest.warns(UserWarning, match="figures not written: no display at all"):
        path = run_sweep(config, tmp_path, progress=False, analyse=fake_analysis())
    with xr.open_dataset(path, engine="zarr") as ds:
        assert ds.sizes["gamma"] == 10


# ---------------------------------------------------------------- the command line


@pytest.fixture
def store(tmp_path):
    return write_zarr(synthetic(GRID_2D, failures=three_failures), tmp_path / "data" / "syn.zarr")


@pytest.mark.parametrize(
    "args, fragment",
    [
        (["missing.zarr"], "dataset 'missing.zarr' not found"),
        (["data/notes.txt"], "is not a zarr store"),
        (["data/plain.zarr"], "is not a jaxwalk sweep dataset"),
        (["data/syn.zarr", "--vars", "lamda_max"], "unknown variable 'lamda_max' (did you mean 'lambda_max'?)"),
        (["data/line.zarr", "--kind", "heatmap"], "a heatmap needs two grid axes with more than one value each"),
        (["data/syn.zarr", "--at", "a=1"], "--at: 'a' is not a grid axis"),
        (["data/syn.zarr", "--format", "jpg"], "invalid choice: 'jpg'"),
        (["data/syn.zarr", "--out", "data/notes.txt"], "exists and is not a directory"),
    ],
    ids=["missing", "not-zarr", "not-sweep", "unknown-var", "no-heatmap", "bad-at", "bad-format", "out-is-file"],
)
def test_bad_input_is_one_line_exit_2_nothing_written(tmp_path, store, monkeypatch, capsys, args, fragment):
    (tmp_path / "data" / "notes.txt").write_text("not a dataset")
    xr.Dataset({"x": ("i", np.arange(3.0))}).to_zarr(tmp_path / "data" / "plain.zarr", zarr_format=3, consolidated=False)
    write_zarr(synthetic(GRID_1D, model="simplest"), tmp_path / "data" / "line.zarr")
    before = sorted(tmp_path.rglob("*"))
    monkeypatch.chdir(tmp_path)
    assert cli.main(["plot", *args]) == 2
    out, err = capsys.readouterr()
    assert out == "" and len(err.splitlines()) == 1 and err.startswith("jaxwalk: error: ") and fragment in err, err
    assert sorted(tmp_path.rglob("*")) == before


def test_command_line_writes_figures(tmp_path, store, run_cli):
    proc = run_cli("plot", str(store), "--out", "figs", "--vars", "lambda_max", "--kind", "heatmap")
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.strip() == "wrote figs/syn_lambda_max_heatmap.png"
    assert (tmp_path / "figs" / "syn_lambda_max_heatmap.png").is_file()
    bad = run_cli("plot", str(store), "--vars", "nope")
    assert bad.returncode == 2 and len(bad.stderr.splitlines()) == 1 and "Traceback" not in bad.stderr


# ---------------------------------------------------------------- figures a scientist would publish


def test_lambda_max_scale_gives_the_stable_range_half_the_colours():
    from matplotlib.colors import TwoSlopeNorm

    ds = synthetic(GRID_2D, lam=(0.3, 3.4))  # one far-unstable corner must not flatten the stable range
    fig = heatmap_figure(ds, "lambda_max", choose_layout(ds, "heatmap"))
    (mesh,) = [c for a in fig.axes if a.get_label() != "<colorbar>" for c in a.collections if c.get_array() is not None][:1]
    norm = mesh.norm
    assert isinstance(norm, TwoSlopeNorm) and norm.vcenter == 1.0
    top = float(ds.lambda_max.max())
    assert norm(0.3) == pytest.approx(0.0) and norm(1.0) == pytest.approx(0.5) and norm(top) == pytest.approx(1.0)
    (bar,) = [a for a in fig.axes if a.get_label() == "<colorbar>"]
    assert "1 at mid-scale" in bar.get_ylabel()  # the scale is named on the bar
    assert heatmap_figure(synthetic(GRID_2D, lam=(0.3, 0.9)), "lambda_max", choose_layout(ds, "heatmap")).axes[0].collections[0].norm.__class__.__name__ == "Normalize"


def test_two_slope_colour_bar_ticks_stay_on_the_bar():
    """A lambda_max range whose end rounds outward (1.7219536 -> 1.722) gave the
    two-slope colour bar a tick past its end, and matplotlib then drew every
    tick at the bar's foot and the bar blank (the flat-foot loci map)."""
    ds = synthetic(GRID_2D, lam=(0.5726556, 1.6719536))  # max 1.7219536 (+0.05 along m_h)
    assert float(ds.lambda_max.max()) == pytest.approx(1.7219536)
    fig = heatmap_figure(ds, "lambda_max", choose_layout(ds, "heatmap"))
    (bar,) = [a for a in fig.axes if a.get_label() == "<colorbar>"]
    low, high = bar.get_ylim()
    ticks = bar.get_yticks()
    assert len(ticks) >= 5 and 1.0 in ticks and ((ticks >= low) & (ticks <= high)).all(), (ticks, low, high)


def test_title_names_the_fixed_parameters():
    ds = synthetic(GRID_1D)
    ds.attrs["fixed_parameters"] = '{"m": 5.0, "m_h": 10.0, "a": 0.6}'  # compass defaults: m 5, m_h 10, a 0.5
    fig = lines_figure(ds, "lambda_max", choose_layout(ds, "lines"))
    assert "fixed: a = 0.6 m; others at the model's defaults" in fig.get_suptitle()


def test_curves_are_readable_on_white_and_failure_rows_named():
    from matplotlib.colors import to_rgb

    ds = synthetic(GRID_2D, failures=three_failures)
    fig = lines_figure(ds, "lambda_max", choose_layout(ds, "lines", x="gamma", y="m_h"))
    ax = fig.axes[0]
    for line in ax.get_lines():
        if line.get_linestyle() == "-":
            lin = [c / 12.92 if c <= 0.04045 else ((c + 0.055) / 1.055) ** 2.4 for c in to_rgb(line.get_color())]
            luminance = 0.2126 * lin[0] + 0.7152 * lin[1] + 0.0722 * lin[2]
            assert 1.05 / (luminance + 0.05) >= 3.0  # WCAG contrast on white, for graphics
    strip = fig.axes[1]
    labels = [t.get_text() for t in strip.get_yticklabels()]
    assert labels == [f"{v:.3g}" for v in ds.m_h.values]  # one row per curve, named by its value


def test_legends_say_where_the_failed_steps_failed():
    """With the failure variables (jaxwalk.analyses.failure) a failure status's legend entry
    names the event, phase and limit where its points' steps failed most often ("mostly"
    unless all did), in heatmaps and line plots alike; a status with no failed step
    (no convergence) names none; legend columns make room for the longer labels."""
    ds = synthetic(GRID_2D, failures=three_failures)
    model = get_model("compass")
    status = ds["status"].values
    code = lambda names, name: names.index(name) + 1  # noqa: E731
    phase = np.where(status != 0, code(model.phases, "single_support_early"), 0)
    event = np.select([status == Status.FELL, status == Status.SCUFFING], [code(model.guards, "fall"), code(model.guards, "midstance")], 0)
    event[np.argwhere(status == Status.FELL)[0][0], np.argwhere(status == Status.FELL)[0][1]] = code(model.guards, "swing_range")
    ds["failure_phase"].values[...] = phase
    ds["failure_event"].values[...] = event
    heat = legend_texts(heatmap_figure(ds, "lambda_max", choose_layout(ds, "heatmap")))
    lines = legend_texts(lines_figure(ds, "lambda_max", choose_layout(ds, "lines", x="gamma", y="m_h")))
    for texts in (heat, lines):
        assert any(t.startswith("fell (") and t.endswith(": mostly fall in single support early") for t in texts), texts
        assert any(t.startswith("scuffing (") and t.endswith(": midstance in single support early") for t in texts)
        assert any(t.startswith("no convergence (") and ":" not in t for t in texts)


def test_the_attractor_view_names_no_cause_of_the_gait_search():
    """Figures of attractor variables read the attractor walk's statuses; the failure
    variables say where the gait search failed, so that view leaves them out."""
    from jaxwalk.plot.attractors import view_for
    from jaxwalk.plot.statuses import FAILURE_VARIABLES

    ds = synthetic(GRID_2D, failures=three_failures)
    ds = ds.assign(attractor_status=ds["status"], attractor_lambda_max=ds["lambda_max"])
    assert all(v in view_for(ds, "lambda_max") for v in FAILURE_VARIABLES)
    assert not any(v in view_for(ds, "attractor_period") for v in FAILURE_VARIABLES)


def test_a_long_axis_label_wraps_without_breaking_its_units():
    """A parameter description longer than a figure's width goes on two lines,
    and a short parenthesis (units such as "(M g L)") stays whole; a short label
    stays on one line."""
    from jaxwalk.plot.labels import AXIS_LABEL_WIDTH, axis_label

    long = "push-off torque at the trailing ankle while its foot pivots on its toe (M g L), toe-down on the foot"
    ds = xr.Dataset(coords={"ankle_push": ("ankle_push", [0.05, 0.1], {"long_name": long}),
                            "gamma": ("gamma", [0.01], {"long_name": "slope angle", "units": "rad"})})
    lines = axis_label(ds, "ankle_push").split("\n")
    assert len(lines) == 2 and all(len(line) <= AXIS_LABEL_WIDTH for line in lines)
    assert "(M\u00a0g\u00a0L)" in lines[1]
    assert axis_label(ds, "gamma") == "gamma: slope angle [rad]"


def test_a_variable_that_asks_for_it_is_drawn_on_a_log_scale_where_it_spans_decades():
    """``mfpt`` (8 to 40,000 steps on one line of the shoe walker) asks for a log scale
    (``plot_scale = "log"``); it gets one only where every drawn value is positive and
    they span more than a decade. Other variables stay linear."""
    from matplotlib.colors import LogNorm, Normalize

    from jaxwalk.analyses.global_stability import MFPT
    from jaxwalk.outputs import attributes

    resolved = {"mfpt": {"sigma": 0.005, "span": 3.0, "mesh": 15, "samples": 64, "max_axes": 3}}
    attrs = attributes(MFPT[0], resolved, {"length": "1", "time": "1"})
    assert attrs["plot_scale"] == "log" and "plot_scale" not in attributes(MFPT[3], resolved, {"length": "1", "time": "1"})

    ds = synthetic(GRID_2D)
    lam = ds["lambda_max"]
    spans = {"decades": 10.0 ** (4.0 * (lam - lam.min()) / (lam.max() - lam.min())),  # 1 .. 1e4
             "narrow": 100.0 + 300.0 * (lam - lam.min()) / (lam.max() - lam.min()),  # 100 .. 400
             "with_zero": 1e4 * (lam - lam.min()) / (lam.max() - lam.min())}  # 0 .. 1e4
    for name, values in spans.items():
        ds[name] = values.assign_attrs(long_name=name, units="steps", plot_scale="log")
    ds["unasked"] = spans["decades"].assign_attrs(long_name="unasked", units="steps")

    def scales(name):
        heat = heatmap_figure(ds, name, choose_layout(ds, "heatmap"))
        norm = heat.axes[0].collections[0].norm
        (bar,) = [a for a in heat.axes if a.get_label() == "<colorbar>"]
        lines = lines_figure(ds, name, choose_layout(ds, "lines"))
        return type(norm), "log scale" in bar.get_ylabel(), lines.axes[0].get_yscale()

    assert scales("decades") == (LogNorm, True, "log")
    for name in ("narrow", "with_zero", "unasked"):
        assert scales(name) == (Normalize, False, "linear"), name


def test_figure_titles_wrap_between_words_and_outside_math():
    """Every declared quantity's title stays inside a figure (TITLE_CHARS a line)
    and never breaks inside a $...$ label."""
    import xarray as xr

    from jaxwalk.plot.labels import MEANINGS, SYMBOLS, TITLE_CHARS, figure_title

    ds = xr.Dataset(attrs={"name": "flatfoot_human_measures_map", "model": "no_such_model"})
    for name in sorted(set(SYMBOLS) | set(MEANINGS)):
        title = figure_title(ds, name, {})
        for line in title.splitlines():
            assert len(line) <= TITLE_CHARS and line.count("$") % 2 == 0, (name, line)


def test_a_few_outliers_do_not_take_the_whole_linear_colour_scale():
    """The shoe walker's gait sensitivity norm is 14.8-24.2 at 90 % of its gaits
    and up to 232 next to a flip: the scale ends at the 99th percentile, the cells beyond
    take the end colour under a marker, and the bar's arrow and label say how many and how far."""
    from jaxwalk.plot.heatmap import linear_limits

    ds = synthetic(GRID_2D)  # 60 gaits
    lam = ds["lambda_max"]
    bulk = 14.0 + 11.0 * (lam - lam.min()) / (lam.max() - lam.min())
    ds["norm"] = bulk.where(lam < lam.max(), 230.0).assign_attrs(long_name="norm", units="1")
    # An infinite norm (an unstable gait's) is drawn blank: no value, so not beyond the scale either.
    ds["norm"] = ds["norm"].where(lam > lam.min(), np.inf)
    fig = heatmap_figure(ds, "norm", choose_layout(ds, "heatmap"))
    norm = fig.axes[0].collections[0].norm
    (bar,) = [a for a in fig.axes if a.get_label() == "<colorbar>"]
    assert 20.0 < norm.vmax < 30.0 and 14.0 < norm.vmin < 14.2  # the least finite value
    assert fig.axes[0].collections[0].colorbar.extend == "max" and "1 above, up to 230" in bar.get_ylabel()
    # The clipped cell shares the end colour, so a marker and a legend entry tell it apart.
    (marks,) = [c for c in fig.axes[0].collections if c.get_gid() == "beyond-scale-above"]
    assert len(marks.get_offsets()) == 1
    assert not [c for c in fig.axes[0].collections if c.get_gid() == "beyond-scale-below"]
    assert "above the colour scale (1 point)" in [t.get_text() for t in fig.legends[0].get_texts()]

    # No outlier: the scale spans every value, and no arrow.
    assert linear_limits(bulk.values.ravel()) == (pytest.approx(14.0), pytest.approx(25.0), "neither")
    # Outliers at both ends.
    both = np.concatenate([np.linspace(0.0, 1.0, 200), [-50.0, 60.0]])
    low, high, extend = linear_limits(both)
    assert extend == "both" and -1.0 < low < 0.1 and 0.9 < high < 2.0
    # A nearly constant variable has no central range to keep: never clipped.
    assert linear_limits(np.array([5.0] * 12 + [4.0])) == (4.0, 5.0, "neither")
    assert linear_limits(np.array([0.0, 1.0, 10.0])) == (0.0, 10.0, "neither")


def test_a_long_key_grows_the_figure_instead_of_squeezing_the_panels(monkeypatch):
    """A key of four rows under two panels against one of two: with every row
    beyond ``LEGEND_ROWS_FREE`` paid for in figure height (here all of them),
    the panels keep their height (to 10 %); without, the longer key squeezes
    them by more than that (what made the heel-rise sweeps' figures unreadable)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    import jaxwalk.plot.lines as lines

    kinds = np.asarray([Status.FELL, Status.STALLED, Status.TIMEOUT, Status.RUNNING, Status.SHANK_RELEASING,
                        Status.SCUFFING])
    many = lambda u: np.where(u[0] > 0.45, kinds[np.minimum((u[1] * len(kinds)).astype(int), len(kinds) - 1)], 0)
    few = lambda u: np.where(u[0] > 0.45, Status.FELL, 0)

    def panel_height(failures):
        ds = synthetic(GRID_3D, failures=failures)
        fig = lines_figure(ds, "lambda_max", choose_layout(ds, "lines"))
        FigureCanvasAgg(fig).draw()
        (first, *_) = [ax for ax in fig.axes if ax.get_ylabel()]
        return first.get_position().height * fig.get_size_inches()[1]

    monkeypatch.setattr(lines, "LEGEND_ROWS_FREE", 0)
    kept = panel_height(many), panel_height(few)
    assert abs(kept[0] / kept[1] - 1.0) < 0.1, kept
    monkeypatch.setattr(lines, "LEGEND_ROWS_FREE", 100)
    squeezed = panel_height(many), panel_height(few)
    assert squeezed[0] / squeezed[1] < 0.9, squeezed


def test_a_key_of_six_rows_or_fewer_leaves_the_figure_size_as_before():
    """What keeps every figure with a short key (the quickstart's) bit for bit:
    the size is the layout's own while the key has at most ``LEGEND_ROWS_FREE`` rows."""
    import jaxwalk.plot.lines as lines

    kinds = np.asarray([Status.FELL, Status.STALLED, Status.TIMEOUT, Status.RUNNING, Status.SHANK_RELEASING,
                        Status.SCUFFING])
    ds = synthetic(GRID_3D, failures=lambda u: np.where(u[0] > 0.45, kinds[np.minimum((u[1] * 6).astype(int), 5)], 0))
    fig = lines_figure(ds, "lambda_max", choose_layout(ds, "lines"))
    key = fig.legends[-1]
    rows = -(-len(key.get_texts()) // key._ncols)
    assert rows <= lines.LEGEND_ROWS_FREE
    np.testing.assert_allclose(fig.get_size_inches(), [3.6 * 3 + 2.4, 3.0 + 1.4], rtol=1e-12)  # three panels, one row


def test_every_failure_status_has_its_own_colour_and_marker():
    """A figure tells every failure apart: each dataset status but ``OK`` has a colour
    and a marker, none shared (the attractors' two were drawn alike, in the fallback)."""
    from jaxwalk.plot.statuses import STATUS_COLORS, STATUS_MARKERS
    from jaxwalk.status import DATASET_STATUSES, Status

    failures = [s for s in DATASET_STATUSES if s != Status.OK]
    assert sorted(STATUS_COLORS) == sorted(failures) == sorted(STATUS_MARKERS)
    assert len(set(STATUS_COLORS.values())) == len(failures)
    assert len(set(STATUS_MARKERS.values())) == len(failures)
