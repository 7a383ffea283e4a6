"""``jaxwalk optimize``: config checks, bad input at the command line, the
optimiser's loop on a stand-in program. The optimum on the simplest walker that
a fine grid confirms is in tests/test_sensitivity.py, beside the compiled
programs it shares."""

from __future__ import annotations

import numpy as np
import pytest

from jaxwalk.optimize.config import parse_optimize_config
from tests.conftest import ROOT
from jaxwalk.sweep.config import ConfigError, parse_toml

GOOD = """
name = "opt"
model = "simplest"
[optimize]
objective = "lambda_max"
bounds = { gamma = [0.004, 0.0145] }
iterations = 5
[starts]
gamma = [0.005, 0.009]
"""


def parse(text: str):
    return parse_optimize_config(parse_toml(text), source="t.toml")


def test_good_config_resolves():
    c = parse(GOOD)
    assert c.problem.names == ("gamma",) and c.starts.shape == (2, 1)
    assert c.problem.sign == 1.0 and c.problem.objective == "lambda_max"
    again = parse_optimize_config(c.to_dict(), source="round trip")
    np.testing.assert_array_equal(again.starts, c.starts)
    maximise = parse(GOOD.replace('"lambda_max"', '"-speed"'))
    assert maximise.problem.sign == -1.0 and maximise.problem.objective == "speed"


def test_solver_settings_reach_the_optimiser_as_they_reach_a_sweep():
    from jaxwalk.optimize.output import solver_options

    solver, newton = solver_options(parse(GOOD + '[analysis]\nrtol = 1e-9\nmax_newton_iter = 30\npredictor = "previous"\n'))
    assert (solver.rtol, newton.max_iter, newton.predictor) == (1e-9, 30, "previous")


@pytest.mark.parametrize(
    "old, new, message",
    [
        ('objective = "lambda_max"', 'objective = "sped"', "objective must be one of"),
        ("bounds = { gamma = [0.004, 0.0145] }", "bounds = { gama = [0.004, 0.0145] }", "did you mean 'gamma'"),
        ("bounds = { gamma = [0.004, 0.0145] }", "bounds = { gamma = [0.0145, 0.004] }", "lower < upper"),
        ("bounds = { gamma = [0.004, 0.0145] }", "bounds = { gamma = [0.004, 0.9] }", "must be <= 0.5"),
        ("gamma = [0.005, 0.009]", "gamma = [0.001, 0.009]", "outside its bounds"),
        ("iterations = 5", "iterations = 0", "iterations must be a positive integer"),
        ("iterations = 5", 'iterations = 5\nhold = { lambda_max = 0.5 }', "unknown quantity 'lambda_max'"),
        ("iterations = 5", "iterations = 5\nlearning_rat = 0.1", "did you mean 'learning_rate'"),
        ('model = "simplest"', 'model = "simplist"', "unknown model"),
        ("[starts]", "[heatmap]\ngamma = { start = 0.01, stop = 0.01, num = 3 }\n[starts]", "start equals stop"),
    ],
)
def test_bad_config_is_one_line(old, new, message):
    assert old in GOOD
    with pytest.raises(ConfigError) as err:
        parse(GOOD.replace(old, new))
    text = str(err.value)
    assert message in text and "\n" not in text and text.startswith("t.toml: ")


@pytest.mark.parametrize("field", ["objective", "hold"])
def test_a_quantity_the_model_cannot_compute_is_refused_at_config_time(monkeypatch, field):
    """The gait sensitivity norm needs a step-down: refused while parsing, in one line, nothing traced."""
    from jaxwalk.models import MODELS

    bare = type("SimplestWithoutStepDown", (type(MODELS["simplest"]),), {"ground_next": None})()
    change = ('objective = "lambda_max"', 'objective = "gait_sensitivity_norm"') if field == "objective" else \
        ("iterations = 5", "iterations = 5\nhold = { gait_sensitivity_norm = 0.5 }")
    text = GOOD.replace(*change)
    assert parse(text).problem.names == ("gamma",)  # the registered model has a step-down
    monkeypatch.setitem(MODELS, "simplest", bare)
    with pytest.raises(ConfigError) as err:
        parse(text)
    assert str(err.value) == (
        f"t.toml: [optimize] {field} 'gait_sensitivity_norm' needs gait_sensitivity: model 'simplest' "
        "has no step-down (no 'ground_next' in its context)"
    )
    parse(GOOD)  # a quantity of the gait alone needs nothing


def test_cli_bad_input_exits_2_and_writes_nothing(write_toml, run_cli, tmp_path, capsys):
    from jaxwalk.cli import main

    bad = write_toml(GOOD.replace("[0.004, 0.0145]", "[0.004]"), "bad.toml")
    out = tmp_path / "out"
    proc = run_cli("optimize", str(bad), "--out", str(out))  # once as a real process
    assert proc.returncode == 2, proc.stderr
    assert proc.stderr.strip().startswith("jaxwalk: error: ") and len(proc.stderr.strip().splitlines()) == 1
    for args in (
        ["optimize", str(tmp_path / "missing.toml"), "--out", str(out)],
        ["optimize", str(write_toml(GOOD, "good.toml")), "--out", str(out), "--heatmap", str(tmp_path / "none.zarr")],
        ["optimize", str(write_toml(GOOD, "good.toml")), "--out", str(bad)],  # --out is a file
        ["optimize", str(write_toml(GOOD, "good.toml"))],  # no --out
    ):
        assert main(args) == 2
        lines = capsys.readouterr().err.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith("jaxwalk: error: "), lines
    assert not out.exists()


class _FakeSensitivity:
    """Stands in for the compiled sensitivity program (no compile): ``lambda_max``
    and ``speed`` are simple functions of the optimised parameters, with
    ``status`` FELL where ``fails(p)``."""

    def __init__(self, names, lam, d_lam, speed, d_speed, fails):
        self.names, self.lam, self.d_lam, self.speed, self.d_speed, self.fails = names, lam, d_lam, speed, d_speed, fails

    def __call__(self, params, v0):
        from types import SimpleNamespace

        from jaxwalk.status import Status

        p = np.stack([np.asarray(params[n]) for n in self.names], axis=-1)
        bad = self.fails(p)
        nan = lambda x: np.where(bad.reshape(bad.shape + (1,) * (np.ndim(x) - 1)), np.nan, x)
        n = p.shape[0]
        metrics = SimpleNamespace(
            v=nan(np.asarray(v0)), lambda_max=nan(self.lam(p)), speed=nan(self.speed(p)),
            step_length=nan(np.ones(n)), period=nan(np.ones(n)), cost_of_transport=nan(np.zeros(n)),
        )
        zeros = np.zeros((n, len(self.names)))
        return SimpleNamespace(
            metrics=metrics, d_lambda_max=nan(self.d_lam(p)), d_speed=nan(self.d_speed(p)),
            d_step_length=zeros, d_period=zeros, d_cost_of_transport=zeros,
            status=np.where(bad, Status.FELL, Status.OK).astype(np.int8),
        )


def test_gait_guess_is_where_each_start_s_first_search_begins(monkeypatch, tmp_path):
    """``[starts] gait_guess``: one point for every start, or one per start, is the
    ``v0`` of each start's first gait search in place of the model's initial
    guess (a gait reached by continuation, far from the documented ones, can be
    optimised from), and the resolved config keeps it."""
    import json

    from jaxwalk.models import get_model
    from jaxwalk.optimize.engine import optimise
    from jaxwalk.optimize.output import run_optimize

    seen = []
    fake = _FakeSensitivity(("gamma",), lambda p: p[:, 0] ** 2, lambda p: 2 * p, lambda p: p[:, 0],
                            lambda p: np.ones_like(p), lambda p: np.zeros(p.shape[0], bool))
    _fake(monkeypatch, lambda params, v0: seen.append(np.asarray(v0)) or fake(params, v0))
    points = [[0.21, -0.19, -0.18], [0.22, -0.18, -0.17]]
    per_start = parse(GOOD + f"gait_guess = {points}\n")
    one = parse(GOOD + f"gait_guess = {points[0]}\n")
    np.testing.assert_array_equal(one.guesses, [points[0]] * 2)
    again = parse_optimize_config(per_start.to_dict(), source="round trip")
    np.testing.assert_array_equal(again.guesses, per_start.guesses)
    model = get_model("simplest")
    optimise(model, per_start.problem, per_start.fixed_per_start(), per_start.starts, guesses=per_start.guesses)
    np.testing.assert_array_equal(seen[0], points)
    seen.clear()
    optimise(model, per_start.problem, per_start.fixed_per_start(), per_start.starts)
    guess = [np.asarray(model.initial_guess({**per_start.fixed, "gamma": g})) for g in (0.005, 0.009)]
    np.testing.assert_array_equal(seen[0], guess)
    # What `jaxwalk optimize` and jaxwalk.optimize() run: the guesses reach the engine and the dataset.
    seen.clear()
    _, ds = run_optimize(one, tmp_path / "out", plot=False, progress=False)
    np.testing.assert_array_equal(seen[0], [points[0]] * 2)
    assert json.loads(ds.attrs["config"])["starts"]["gait_guess"] == [points[0]] * 2


@pytest.mark.parametrize("guess, message", [
    ("[0.21, -0.19]", "each point must be 3 numbers"),
    ("[[0.2, -0.1, -0.1], [0.2, -0.1, -0.1], [0.2, -0.1, -0.1]]", "3 points for 2 starts"),
    ('["a", -0.1, -0.1]', "each point must be 3 numbers"),
    ("[nan, -0.1, -0.1]", "each point must be 3 numbers"),
    ("0.2", "each point must be 3 numbers"),
    ("[true, -0.1, -0.1]", "each point must be 3 numbers"),
    ("[]", "each point must be 3 numbers"),
    ("[[[0.2, -0.1, -0.1]]]", "each point must be 3 numbers"),
])
def test_a_bad_gait_guess_is_one_line(guess, message):
    with pytest.raises(ConfigError) as err:
        parse(GOOD + f"gait_guess = {guess}\n")
    text = str(err.value)
    assert message in text and "[starts] gait_guess" in text and "\n" not in text


def test_a_misspelt_gait_guess_is_named():
    with pytest.raises(ConfigError, match=r"unknown key 'gait_gues' \(did you mean 'gait_guess'\?\)"):
        parse(GOOD + "gait_gues = [0.2, -0.1, -0.1]\n")


def _fake(monkeypatch, fake):
    import jaxwalk.optimize.engine as engine

    monkeypatch.setattr(engine, "sensitivity_program", lambda *args: fake)


def test_a_start_that_loses_its_gait_ends_with_a_status(monkeypatch):
    """lambda_max = (gamma - 0.01)^2 falls towards gamma = 0.01, but there is no gait
    below 0.0105: steps into it are undone and halved, then the start ends FELL
    near the edge; a start with no gait at all ends at once."""
    from jaxwalk.models import get_model
    from jaxwalk.optimize.engine import Problem, optimise
    from jaxwalk.status import Status

    fake = _FakeSensitivity(
        ("gamma",), lambda p: (p[:, 0] - 0.01) ** 2, lambda p: 2 * (p - 0.01),
        lambda p: p[:, 0], lambda p: np.ones_like(p), lambda p: p[:, 0] < 0.0105,
    )
    _fake(monkeypatch, fake)
    problem = Problem(names=("gamma",), lower=(0.004,), upper=(0.02,), iterations=60, learning_rate=0.05, max_retries=3)
    path = optimise(get_model("simplest"), problem, {}, np.array([[0.018], [0.005]]))
    assert list(path.final_status) == [Status.FELL, Status.FELL]
    assert path.ended_at[1] == 0 and not path.accepted[:, 1].any()
    assert 0 < path.ended_at[0] < 60
    assert 0.0105 <= path.best_params[0, 0] < 0.0115  # went as far as the gait allowed
    failed = path.status[: path.ended_at[0] + 1, 0] != 0
    assert failed[-4:].all() and not path.accepted[path.ended_at[0], 0]  # max_retries + 1 failures in a row


def test_a_nan_objective_at_a_gait_found_is_a_failed_point_not_a_step(monkeypatch):
    """The same landscape, but below 0.0105 the program reports a gait (status OK) with a
    NaN ``lambda_max`` and gradient: the optimiser must not step on it (a NaN would
    poison the optax state and every later point). Each such point is a failure,
    ``not_differentiable``, undone and halved as a lost gait is."""
    from jaxwalk.models import get_model
    from jaxwalk.optimize.engine import Problem, optimise
    from jaxwalk.status import Status

    fake = _FakeSensitivity(
        ("gamma",), lambda p: (p[:, 0] - 0.01) ** 2, lambda p: 2 * (p - 0.01),
        lambda p: p[:, 0], lambda p: np.ones_like(p), lambda p: p[:, 0] < 0.0105,
    )
    found = fake.__call__

    def nan_at_ok(params, v0):
        out = found(params, v0)
        out.status = np.zeros_like(out.status)  # the NaNs stay: a gait "found" with NaN numbers
        return out

    _fake(monkeypatch, nan_at_ok)
    problem = Problem(names=("gamma",), lower=(0.004,), upper=(0.02,), iterations=60, learning_rate=0.05, max_retries=3)
    path = optimise(get_model("simplest"), problem, {}, np.array([[0.018], [0.005]]))
    assert list(path.final_status) == [Status.NOT_DIFFERENTIABLE, Status.NOT_DIFFERENTIABLE]
    assert 0.0105 <= path.best_params[0, 0] < 0.0115 and np.isfinite(path.params[path.accepted]).all()
    assert np.isfinite(path.objective[path.accepted]).all()


@pytest.mark.parametrize("optimizer", ["adam", "normalized"])
def test_held_speed_by_augmented_lagrangian(monkeypatch, optimizer):
    """minimise gamma^2 + b^2 holding speed = gamma + b at 1: the optimum is (0.5, 0.5)."""
    from jaxwalk.models import get_model
    from jaxwalk.optimize.engine import Problem, optimise

    fake = _FakeSensitivity(
        ("gamma", "b"), lambda p: (p**2).sum(-1), lambda p: 2 * p,
        lambda p: p.sum(-1), lambda p: np.ones_like(p), lambda p: np.zeros(p.shape[0], bool),
    )
    _fake(monkeypatch, fake)
    problem = Problem(
        names=("gamma", "b"), lower=(0.0, 0.1), upper=(0.5, 1.0), hold={"speed": 1.0}, penalty=10.0,
        iterations=300, learning_rate=0.05, optimizer=optimizer,
    )
    model = get_model("compass")
    fixed = {k: v for k, v in model.default_params().items() if k not in problem.names}
    path = optimise(model, problem, fixed, np.array([[0.1, 0.9], [0.45, 0.2]]))
    np.testing.assert_allclose(path.final_params, 0.5, atol=5e-3)
    np.testing.assert_allclose(path.multipliers[-1, :, 0], -1.0, atol=0.05)  # lambda* = -df/dc = -2 p |target|


@pytest.mark.parametrize("path", sorted((ROOT / "sweeps" / "optimize").glob("*.toml")), ids=lambda p: p.name)
def test_bundled_optimize_configs_are_valid(path):
    from jaxwalk.optimize.config import load_optimize_config

    cfg = load_optimize_config(path)
    assert cfg.name == path.stem
    # A background is drawn wherever the paths can be drawn over one (one or two
    # optimised parameters); a descent over more has none to draw.
    assert (bool(cfg.heatmap) or len(cfg.problem.names) > 2) and cfg.starts.shape[0] >= 1




class _Handshake:
    """Two events the stand-ins of the optimiser's compile and of the background
    grid set and wait for (up to 20 s each): both waits succeed only where the
    two run at the same time."""

    def __init__(self):
        import threading

        self.compiling, self.background = threading.Event(), threading.Event()
        self.seen = {}

    def meet(self, mine, theirs, name):
        mine.set()
        self.seen.setdefault(name, theirs.wait(20.0))


class _AheadOfTime:
    """A stand-in jitted program: ``lower(...).compile()`` meets the background
    grid; each evaluation records whether the grid's thread had ended by then."""

    def __init__(self, hand, fake):
        self.hand, self.fake = hand, fake

    def lower(self, *args):
        return self

    def compile(self):
        self.hand.meet(self.hand.compiling, self.hand.background, "compile")
        return self

    def __call__(self, params, v0):
        threads = self.hand.seen.get("threads", [])
        self.hand.seen.setdefault("grid running at an evaluation", []).append(any(t.is_alive() for t in threads))
        return self.fake(params, v0)


def _with_background(monkeypatch, background, fails=lambda p: p[:, 0] < 0.0):
    """The simplest config with a background grid; the sensitivity program an
    :class:`_AheadOfTime` stand-in; ``background(hand, stop)`` stands in for compute_heatmap."""
    import jaxwalk.optimize.output as output

    hand = _Handshake()
    fake = _FakeSensitivity(("gamma",), lambda p: (p[:, 0] - 0.01) ** 2, lambda p: 2 * (p - 0.01),
                            lambda p: p[:, 0], lambda p: np.ones_like(p), fails)
    _fake(monkeypatch, _AheadOfTime(hand, fake))
    monkeypatch.setattr(output, "compute_heatmap", lambda *args, stop: background(hand, stop))
    config = parse(GOOD.replace("[starts]", "[heatmap]\ngamma = { start = 0.005, stop = 0.012, num = 4 }\n[starts]"))
    return config, hand


def _grid(hand, stop):
    """A background grid of four points, after meeting the optimiser's compile."""
    import threading
    import time

    import xarray as xr

    hand.seen.setdefault("threads", []).append(threading.current_thread())
    hand.meet(hand.background, hand.compiling, "background")
    time.sleep(0.2)  # still running when the optimiser's compile is done
    axis = "heatmap_gamma"
    return xr.Dataset({"heatmap_lambda_max": (axis, np.arange(4.0)), "heatmap_status": (axis, np.zeros(4, np.int8))},
                      coords={axis: np.linspace(0.005, 0.012, 4)})


def test_the_background_grid_runs_while_the_optimiser_compiles(monkeypatch, tmp_path):
    """The background grid and the optimiser's compile run at the same time (a
    cold run compiles both programs at once), the grid once and off the caller's
    thread; no evaluation runs before the grid has ended (no two programs at
    once), and the grid reaches the dataset."""
    import threading

    from jaxwalk.optimize.output import run_optimize

    config, hand = _with_background(monkeypatch, _grid)
    target, ds = run_optimize(config, tmp_path / "out", plot=False)
    assert hand.seen["compile"] and hand.seen["background"], "the two ran one after the other"
    assert len(hand.seen["threads"]) == 1 and hand.seen["threads"][0] is not threading.main_thread()
    running = hand.seen["grid running at an evaluation"]
    assert len(running) == 6 and not any(running)  # 5 iterations and the start
    np.testing.assert_array_equal(ds.heatmap_lambda_max.values, np.arange(4.0))
    assert target.exists()


def test_a_descent_over_several_parameters_without_a_background_is_drawn_along_its_iterations(monkeypatch, tmp_path):
    """Paths over three optimised parameters cannot be drawn over a map: the
    figure shows lambda_max against the iteration, with the stability limit, and
    each iteration that lost its gait (no lambda_max) as a cross on the axis."""
    import matplotlib.figure

    from jaxwalk.optimize.output import run_optimize

    fake = _FakeSensitivity(("gamma", "m_h", "a"), lambda p: (p ** 2).sum(1), lambda p: 2 * p, lambda p: p[:, 0],
                            lambda p: np.ones_like(p), lambda p: p[:, 1] < 12.0)
    _fake(monkeypatch, fake)
    drawn, savefig = [], matplotlib.figure.Figure.savefig

    def crosses(ax):
        return sum(len(line.get_xdata()) for line in ax.lines if line.get_marker() == "x")

    monkeypatch.setattr(matplotlib.figure.Figure, "savefig", lambda fig, path, **kw: (
        drawn.append((fig.axes[0].get_xlabel(), fig.axes[0].get_ylabel(), crosses(fig.axes[0]))), savefig(fig, path, **kw)))
    config = parse(GOOD.replace('"simplest"', '"compass"').replace(
        "bounds = { gamma = [0.004, 0.0145] }", "bounds = { gamma = [0.004, 0.0145], m_h = [5.0, 15.0], a = [0.4, 0.6] }"))
    target, ds = run_optimize(config, tmp_path / "out", plot=True, progress=False)
    lost = int(((ds.status.values != 0) & (np.arange(6)[:, None] <= ds.ended_at.values)).sum())
    assert lost > 0 and drawn == [("iteration", "lambda_max", lost)] and ds.sizes["iteration"] == 6
    assert (tmp_path / "out" / "opt.png").stat().st_size > 0


def test_no_background_grid_asked_for_starts_no_thread_and_compiles_nothing_ahead(monkeypatch, tmp_path):
    from jaxwalk.optimize.output import run_optimize

    config, hand = _with_background(monkeypatch, _grid)
    _, ds = run_optimize(config, tmp_path / "out", plot=False, heatmap=False)
    assert "threads" not in hand.seen and "compile" not in hand.seen and "heatmap_lambda_max" not in ds


def test_a_failing_background_grid_fails_the_run_before_any_evaluation(monkeypatch, tmp_path):
    from jaxwalk.optimize.output import run_optimize

    def broken(hand, stop):
        hand.meet(hand.background, hand.compiling, "background")
        raise RuntimeError("background broke")

    config, hand = _with_background(monkeypatch, broken)
    with pytest.raises(RuntimeError, match="background broke"):
        run_optimize(config, tmp_path / "out", plot=False)
    assert "grid running at an evaluation" not in hand.seen
    assert not (tmp_path / "out" / "opt.zarr").exists()


def test_a_failing_optimisation_cancels_the_background_grid(monkeypatch, tmp_path):
    """The path's error reaches the caller at once, and the grid is told to stop
    (it ends at its next chunk); nothing is written."""
    import threading

    import jaxwalk.optimize.output as output
    from jaxwalk.optimize.output import run_optimize

    stopped = threading.Event()

    def slow(hand, stop):
        if stop.wait(20.0):
            stopped.set()
        raise RuntimeError("cancelled")

    config, _ = _with_background(monkeypatch, slow)
    monkeypatch.setattr(output, "optimise", lambda *a, **k: (_ for _ in ()).throw(KeyError("the path broke")))
    with pytest.raises(KeyError, match="the path broke"):
        run_optimize(config, tmp_path / "out", plot=False)
    assert stopped.wait(20.0)
    assert not (tmp_path / "out" / "opt.zarr").exists()
