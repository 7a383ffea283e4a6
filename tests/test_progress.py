"""The bars of work inside a sweep's block (jaxwalk.progress): drawn only where the
sweep's runner asks for them, never from the Python API or a Dask worker."""

import pytest

from jaxwalk import progress


@pytest.fixture
def at_once(monkeypatch):
    """Bars drawn from their first update (the default waits 2 s)."""
    monkeypatch.setattr(progress, "DELAY", 0.0)


def test_a_stage_draws_its_bar_only_where_bars_are_shown(at_once, capsys):
    with progress.stage("hidden stage", 4, "step") as advance:
        advance(4)
    assert capsys.readouterr().err == ""
    with progress.shown(), progress.stage("shown stage", 4, "step") as advance:
        advance(2)
    err = capsys.readouterr().err
    assert "shown stage" in err and "/4 " in err  # its count of the total


def test_bars_off_inside_shown_false(at_once, capsys):
    with progress.shown(), progress.shown(False), progress.stage("off", 4, "step") as advance:
        advance(4)
    assert capsys.readouterr().err == ""


@pytest.mark.parametrize("per_thread, calls", [(1, [2, 2, 1]), (2, [4, 1])])
def test_slow_analyses_run_a_sub_batch_per_thread_per_call_under_their_bar(at_once, capsys, monkeypatch, per_thread, calls):
    """A sweep's basin and h_max (seconds to minutes per flat-foot gait) advance a
    bar per call of one sub-batch per worker thread, and hand back every row's
    result in order."""
    from types import SimpleNamespace

    import numpy as np

    from jaxwalk.analyses.base import run_with_bar
    from jaxwalk.batching import Rows
    from jaxwalk.global_stability.basin import Basin as basin_result, BasinStart

    monkeypatch.setattr("jaxwalk.workers.thread_count", lambda: 2)
    seen = []

    def run(program, rows):
        seen.append(len(rows.inputs.v_star))
        return basin_result(rows.params["gamma"] * 2, *([None] * 4))

    rows = Rows({"gamma": np.arange(5.0)}, BasinStart(np.zeros((5, 3)), np.zeros((5, 1, 3))))
    with progress.shown():
        found = run_with_bar(SimpleNamespace(run=run), None, rows, "basin", "gait", per_thread)
    assert seen == calls
    np.testing.assert_array_equal(found.fraction, np.arange(5.0) * 2)
    assert "basin, 5 gaits" in capsys.readouterr().err
