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
