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


@pytest.mark.parametrize("sub_batch, per_call, calls", [(1, 1, [2, 2, 1]), (2, 1, [4, 1]), (1, 2, [4, 1])])
def test_slow_analyses_run_in_calls_of_sub_batches_per_thread_under_their_bar(at_once, capsys, monkeypatch, sub_batch,
                                                                               per_call, calls):
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
        found = run_with_bar(SimpleNamespace(run=run), None, rows, "basin", "gait", sub_batch, per_call)
    assert seen == calls
    np.testing.assert_array_equal(found.fraction, np.arange(5.0) * 2)
    assert "basin, 5 gaits" in capsys.readouterr().err


@pytest.mark.parametrize("sub_batch", [1, 64])
@pytest.mark.parametrize("n, chunk", [(200, 256), (600, 256)])
def test_the_split_leaves_every_row_its_lockstep_partners(monkeypatch, sub_batch, n, chunk):
    """Where the rows fit one chunk, or the chunk is a multiple of a call's rows,
    each row of a split run shares its vmapped sub-batch with the same rows as
    in one run of them all (so a lockstep while loop gives the same result): a
    program that returns each sub-batch's largest and smallest row, run for real
    on the worker threads."""
    from types import SimpleNamespace

    import equinox.internal as eqxi
    import jax
    import jax.numpy as jnp
    import numpy as np

    from jaxwalk.analyses.base import run_with_bar
    from jaxwalk.batching import Rows, over_rows, run_chunks

    def partners(p, _):
        x = p["x"]
        return jnp.stack([x, eqxi.unvmap_max(x), -eqxi.unvmap_max(-x)])

    for where in ("jaxwalk.workers.thread_count", "jaxwalk.batching.thread_count"):
        monkeypatch.setattr(where, lambda: 2)  # two worker threads, as on the project's 2-core machine
    program = jax.jit(over_rows(partners, sub_batch))
    rows = Rows({"x": np.arange(n, dtype=float)}, ())
    block = SimpleNamespace(run=lambda prog, r: run_chunks(prog, r, chunk, None))
    whole = block.run(program, rows)
    if sub_batch > 1:  # the program sees its partners
        assert (whole[:, 1] > whole[:, 2]).all()
    np.testing.assert_array_equal(run_with_bar(block, program, rows, "t", "row", sub_batch), whole)
