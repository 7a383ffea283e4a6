"""``jaxwalk optimize``: config checks, bad input at the command line, and an
optimum on the simplest walker that a fine grid confirms."""

from __future__ import annotations

import numpy as np
import pytest

from jaxwalk.optimize.config import parse_optimize_config
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


@pytest.mark.slow
def test_simplest_optimum_confirmed_by_a_fine_grid():
    """Minimising lambda_max over the slope from four starts ends where a fine grid
    puts the minimum: at the kink where the complex pair of multipliers turns
    real (gamma ~ 0.0137). The kink is not differentiable, so the iterates
    straddle it; the test asks for the grid's spacing, not more."""
    from tests.test_sensitivity import GAMMAS, SIMPLEST, grid_at

    from jaxwalk.optimize.engine import Problem, optimise

    problem = Problem(names=("gamma",), lower=(0.004,), upper=(0.0145,), iterations=40, learning_rate=0.05)
    starts = GAMMAS[:, None].copy()  # the sensitivity tests' batch: the same compiled program
    starts[-1] = 0.0144
    path = optimise(SIMPLEST, problem, {}, starts)
    assert (path.final_status == 0).all()
    fine = np.linspace(0.0125, 0.0145, 64)
    grid = grid_at(fine)
    assert (grid["status"] == 0).all()
    best = fine[np.argmin(grid["lambda_max"])]
    spacing = fine[1] - fine[0]
    lam_best = path.metrics["lambda_max"][path.best_row, np.arange(4)]
    for s in range(4):
        assert abs(path.best_params[s, 0] - best) <= spacing
        assert abs(path.final_params[s, 0] - best) <= 2 * spacing
        assert lam_best[s] <= grid["lambda_max"].min() + 1e-3
