"""Two-parameter loci on heatmaps (jaxwalk.plot.loci): the bifurcations located
on continuation lines joined into curves, through located points only.

Synthetic tables go through the real table builder
(:func:`jaxwalk.analyses.bifurcations.table_dataset`); the last test runs a
compass sweep with ``bifurcations = true`` and checks the flip locus it draws
against the table and against Goswami et al.'s period doubling.
"""

from __future__ import annotations

import numpy as np
import pytest

from jaxwalk.analyses.bifurcations import table_dataset
from jaxwalk.bifurcation import Bifurcations, Kind
from jaxwalk.plot import choose_layout, heatmap_figure
from jaxwalk.plot.loci import LOCUS_GID, MAX_JUMP, join, loci
from jaxwalk.status import Status
from tests.test_plot import GRID_2D, GRID_3D, legend_texts, synthetic


def with_table(ds, rows, others=("m_h",)):
    """``ds`` with a bifurcation table of ``rows``: ``(kind, gamma, line index, status)``."""
    kind, gamma, line, status = (np.array(c) for c in zip(*rows))
    n = len(rows)
    found = Bifurcations(
        kind=kind.astype(np.int8), parameter=gamma.astype(float), line=line.astype(np.int64),
        period=np.ones(n, np.int32), status=status.astype(np.int8), v=np.zeros((n, 3)),
        multipliers=np.zeros((n, 3), complex), beyond=np.zeros(n, np.int8), sequence=np.zeros(n, np.int64),
        sequence_beyond=np.zeros(n, np.int64), multipliers_beyond=np.full((n, 3), np.nan + 0j), jumps=np.zeros(n, np.int8),
    )  # fmt: skip
    shape = tuple(ds.sizes[d] for d in others)
    return ds.merge(table_dataset(found, ds, "gamma", list(others), shape))


def drawn(fig):
    return [line for ax in fig.axes for line in ax.lines if line.get_gid() == LOCUS_GID]


def test_a_fold_on_every_line_is_one_curve_through_the_located_points():
    ds = synthetic(GRID_2D)  # gamma 0.01..0.1 (10), m_h 2..20 (6 lines)
    fold = 0.03 + 0.004 * np.arange(6)
    ds = with_table(ds, [(Kind.FOLD, g, i, 0) for i, g in enumerate(fold)])
    fig = heatmap_figure(ds, "lambda_max", choose_layout(ds, "heatmap"))
    (line,) = drawn(fig)
    np.testing.assert_array_equal(line.get_xdata(), fold)  # gamma on x: exact, not a grid value
    np.testing.assert_array_equal(line.get_ydata(), ds["m_h"].values)
    assert any(t.startswith("fold (multiplier +1)") for t in legend_texts(fig))


def test_a_line_without_the_point_or_a_far_jump_breaks_the_curve():
    ds = synthetic(GRID_2D)
    span = float(np.ptp(ds["gamma"].values))
    flip = [(Kind.FLIP, 0.05, i, 0) for i in (0, 1, 2, 4)]  # line 3 has none
    flip.append((Kind.FLIP, 0.05 + 1.01 * MAX_JUMP * span, 5, 0))  # too far from line 4's
    ds = with_table(ds, flip)
    curves, unlocated = loci(ds, ds, "gamma", "m_h")
    assert unlocated == []
    assert sorted(len(c.continuation) for c in curves) == [1, 1, 3]
    assert {c.kind for c in curves} == {"flip"}


def test_two_branches_of_one_kind_pair_nearest_first():
    c = np.array([0.02, 0.08, 0.081, 0.021])
    a = np.array([1.0, 1.0, 2.0, 2.0])
    curves = join("fold", c, a, np.array([1.0, 2.0]), max_jump=0.05)
    assert sorted(tuple(x.continuation) for x in curves) == [(0.02, 0.021), (0.08, 0.081)]


def test_unlocated_points_are_hollow_and_never_joined():
    ds = synthetic(GRID_2D)
    ds = with_table(ds, [(Kind.FLIP, 0.05, 0, 0), (Kind.FLIP, 0.051, 1, Status.NO_CONVERGENCE), (Kind.FLIP, 0.052, 2, 0)])
    curves, unlocated = loci(ds, ds, "gamma", "m_h")
    assert [len(c.continuation) for c in curves] == [1, 1]
    assert unlocated == [("flip", 0.051, float(ds["m_h"].values[1]))]
    fig = heatmap_figure(ds, "lambda_max", choose_layout(ds, "heatmap"))
    assert "bifurcation, not located to tolerance" in legend_texts(fig)


def test_axes_swapped_and_panels_select_their_own_lines():
    ds = synthetic(GRID_3D)  # gamma x m_h x a; lines along gamma for each (m_h, a)
    rows = [(Kind.FOLD, 0.02 + 0.01 * j, 3 * i + j, 0) for i in range(6) for j in range(3)]
    ds = with_table(ds, rows, others=("m_h", "a"))
    layout = choose_layout(ds, "heatmap", x="m_h", y="gamma")
    fig = heatmap_figure(ds, "lambda_max", layout)
    lines = drawn(fig)
    assert len(lines) == 3  # one curve per panel (a = 0.4, 0.5, 0.6)
    for line in lines:
        np.testing.assert_array_equal(line.get_xdata(), ds["m_h"].values)  # the line axis on x
        assert len(set(np.round(line.get_ydata(), 12))) == 1  # this panel's a only


def test_no_locus_when_the_continuation_axis_is_not_drawn():
    ds = synthetic(GRID_3D)
    ds = with_table(ds, [(Kind.FOLD, 0.05, 0, 0)], others=("m_h", "a"))
    layout = choose_layout(ds, "heatmap", x="m_h", y="a")
    assert drawn(heatmap_figure(ds, "lambda_max", layout)) == []


@pytest.mark.slow
def test_compass_flip_locus_from_a_sweep(tmp_path):
    """A compass sweep over (gamma, m_h) with ``bifurcations = true``: the drawn flip
    locus passes through the table's located flips, one per hip mass, and at
    Goswami et al.'s walker (m_h = 2 m = 10 kg) the flip is their 4.39 degrees."""
    import jaxwalk

    text = """
name = "compass_flip"
model = "compass"
[grid]
gamma = { start = 0.068, stop = 0.082, num = 8 }
m_h = { values = [9.0, 10.0, 11.0] }
[analysis]
continuation = "gamma"
bifurcations = true
"""
    path = tmp_path / "compass_flip.toml"
    path.write_text(text)
    ds = jaxwalk.sweep(str(path))
    flips = ds["bifurcation_kind"].values == Kind.FLIP
    assert flips.sum() == 3 and (ds["bifurcation_status"].values[flips] == 0).all()
    gamma_10 = ds["bifurcation_parameter"].values[flips & (ds["bifurcation_m_h"].values == 10.0)]
    assert abs(np.degrees(gamma_10[0]) - 4.39) <= 0.005
    fig = heatmap_figure(ds, "lambda_max", choose_layout(ds, "heatmap"))
    (line,) = [x for x in drawn(fig) if x.get_linestyle() == "--"]
    order = np.argsort(ds["bifurcation_m_h"].values[flips])
    np.testing.assert_array_equal(line.get_xdata(), ds["bifurcation_parameter"].values[flips][order])
    np.testing.assert_array_equal(line.get_ydata(), [9.0, 10.0, 11.0])


def test_line_plots_mark_each_curves_own_located_points_at_their_largest_multiplier():
    """On the lambda_max line figure (gamma on x, one curve per m_h), each row of
    the table is marked on its own line's curve, in that curve's colour, at its
    parameter and the largest modulus of its multipliers (zero here); a point not
    located is hollow; a line plot over another axis marks nothing."""
    from jaxwalk.plot import lines_figure

    ds = synthetic(GRID_2D)
    ds = with_table(ds, [(Kind.FLIP, 0.05, 1, 0), (Kind.BORDER_COLLISION, 0.07, 3, 0), (Kind.FOLD, 0.04, 3, Status.STALLED)])
    fig = lines_figure(ds, "lambda_max", choose_layout(ds, "lines", x="gamma", y="m_h"))
    marks = drawn(fig)
    assert sorted(float(m.get_xdata()[0]) for m in marks) == [0.05, 0.07]
    curves = {line.get_label(): line.get_color() for ax in fig.axes for line in ax.lines if line.get_label() in
              {f"{float(v):.4g}" for v in ds["m_h"].values}}
    by_x = {float(m.get_xdata()[0]): m.get_markerfacecolor() for m in marks}
    assert by_x[0.05] == curves[f"{float(ds['m_h'].values[1]):.4g}"]
    assert by_x[0.07] == curves[f"{float(ds['m_h'].values[3]):.4g}"]
    hollow = [line for ax in fig.axes for line in ax.lines if line.get_gid() == "bifurcation-unlocated"]
    assert [float(h.get_xdata()[0]) for h in hollow] == [0.04] and hollow[0].get_markerfacecolor() == "none"
    assert {"flip (multiplier -1), located", "border collision (event order changes), located",
            "bifurcation, not located to tolerance"} <= set(legend_texts(fig))
    other = lines_figure(ds, "lambda_max", choose_layout(ds, "lines", x="m_h", y="gamma"))
    assert drawn(other) == []


def test_a_row_without_multipliers_is_marked_on_its_curve():
    """An unlocated row whose last solve failed has NaN multipliers: its hollow
    marker sits on the curve, at the curve's lambda_max interpolated there."""
    from jaxwalk.plot import lines_figure

    ds = synthetic(GRID_2D)
    ds = with_table(ds, [(Kind.FLIP, 0.055, 2, Status.STALLED)])
    ds["bifurcation_multipliers_real"][:] = np.nan
    ds["bifurcation_multipliers_imag"][:] = np.nan
    fig = lines_figure(ds, "lambda_max", choose_layout(ds, "lines", x="gamma", y="m_h"))
    (hollow,) = [line for ax in fig.axes for line in ax.lines if line.get_gid() == "bifurcation-unlocated"]
    curve = ds.isel(m_h=2)
    ok = curve["status"].values == 0
    expected = np.interp(0.055, curve["gamma"].values[ok], curve["lambda_max"].values[ok])
    assert float(hollow.get_xdata()[0]) == 0.055 and float(hollow.get_ydata()[0]) == pytest.approx(expected, rel=1e-12)
