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


def test_the_basin_runs_a_thread_s_worth_of_gaits_per_call_under_its_bar(at_once, capsys, monkeypatch):
    """A sweep's basin (hundreds of walks per gait) advances its bar per call of
    one gait per worker thread, and hands back every row's result in order."""
    from types import SimpleNamespace

    import numpy as np

    from jaxwalk.analyses import basin
    from jaxwalk.batching import Rows
    from jaxwalk.global_stability.basin import Basin as basin_result, BasinStart

    monkeypatch.setattr("jaxwalk.workers.thread_count", lambda: 2)
    calls = []

    def run(program, rows):
        calls.append(len(rows.inputs.v_star))
        return basin_result(rows.params["gamma"] * 2, *([None] * 4))

    rows = Rows({"gamma": np.arange(5.0)}, BasinStart(np.zeros((5, 3)), np.zeros((5, 1, 3))))
    with progress.shown():
        found = basin._run_with_progress(SimpleNamespace(run=run), None, rows)
    assert calls == [2, 2, 1]
    np.testing.assert_array_equal(found.fraction, np.arange(5.0) * 2)
    assert "basin, 5 gaits" in capsys.readouterr().err
