"""Seed lines (``[analysis] seed_axis``): continuation lines started from a
continuation along another axis. Compass walker only (fast to compile)."""

from __future__ import annotations

import json

import jax
import numpy as np
import pytest
import xarray as xr

from jaxwalk import cli, grid as G
from jaxwalk.gait import find_gait
from jaxwalk.lines import segment_program
from jaxwalk.models import get_model
from jaxwalk.seedline import seed_lines
from jaxwalk.sweep import loads_config, run_sweep
from jaxwalk.sweep.config import ConfigError, parse_config
from jaxwalk.workers import compiled_shapes

MODEL = get_model("compass")
GAMMA0 = MODEL.param_specs["gamma"].default
# Lines along m_h (seed: the default 10 kg), one per slope. At gamma = 0.13 the
# model's guess (made for the default slope) misses the gait at m_h = 10, so the
# whole line is lost; the seed line walks there along gamma from the default.
GRID = {"gamma": np.array([GAMMA0, 0.09, 0.13]), "m_h": np.array([8.0, 10.0, 12.0])}
OPTIONS = G.AnalysisOptions()

CONFIG = f"""
name = "seeded"
model = "compass"
[grid]
gamma = {{ values = [{GAMMA0!r}, 0.09, 0.13] }}
m_h = {{ values = [8.0, 10.0, 12.0] }}
[analysis]
continuation = "m_h"
seed_axis = "gamma"
"""


def _program():
    return segment_program(MODEL, OPTIONS.solver, OPTIONS.newton)


@pytest.fixture(scope="module")
def runs():
    plain = G.analyse_grid(MODEL, {}, GRID, "m_h", OPTIONS)
    compiled = len(compiled_shapes(_program()))
    seeded = G.analyse_grid(MODEL, {}, GRID, "m_h", OPTIONS, seed_axis="gamma")
    return plain, seeded, compiled, len(compiled_shapes(_program()))


def test_seeding_finds_the_lines_lost_without_it(runs):
    plain, seeded, _, _ = runs
    assert (plain["status"][2] != 0).all()  # lost at its seed, so along the whole line
    assert (plain["status"][:2] == 0).all()
    assert (seeded["status"] == 0).all()
    assert (seeded["seed_line_status"] == 0).all() and seeded["seed_line_fixed_point"].shape == (3, 3)
    # Where both converge, the same gait.
    np.testing.assert_allclose(seeded["fixed_point"][:2], plain["fixed_point"][:2], atol=1e-8)
    # The seed line runs at m_h's seed value: there the lines' seed points are its points.
    np.testing.assert_allclose(seeded["fixed_point"][:, 1], seeded["seed_line_fixed_point"], atol=1e-8)


def test_seed_line_reuses_the_compiled_program(runs):
    """Visiting order, restarts and start points are inputs, lines run in
    fixed-length segments: a seed line compiles nothing new."""
    _, _, before, after = runs
    assert after == before


def test_shorter_seed_line_runs_the_same_program(runs):
    """Two slopes, three hip masses: the seed line (length 2) runs the compiled
    program (one segment, most of it skipped); its points are the long one's."""
    _, seeded, _, compiled = runs
    short = {"gamma": GRID["gamma"][:2], "m_h": GRID["m_h"]}
    seeds = seed_lines(MODEL, {}, short, "m_h", "gamma", OPTIONS)
    assert len(compiled_shapes(_program())) == compiled
    assert (seeds.status == 0).all() and seeds.v.shape == (2, 3)
    np.testing.assert_allclose(seeds.v, seeded["seed_line_fixed_point"][:2], atol=1e-9)


def test_seeded_line_equals_single_searches_from_its_starts(runs):
    """The gamma = 0.13 line against find_gait run on its own from the starts
    continuation gives: the seed point from the seed line's gait, its
    neighbours from the seed point's."""
    _, seeded, _, _ = runs
    v_seed = seeded["seed_line_fixed_point"][2]
    v_mid = seeded["fixed_point"][2, 1]
    params = {s.name: np.full(3, s.default) for s in MODEL.parameters}
    params["gamma"] = np.full(3, 0.13)
    params["m_h"] = GRID["m_h"].copy()
    starts = np.stack([v_mid, v_seed, v_mid])
    gaits = jax.jit(jax.vmap(lambda p, v: find_gait(MODEL, p, v, OPTIONS.solver, OPTIONS.newton)))(params, starts)
    assert (np.asarray(gaits.status) == 0).all()
    np.testing.assert_allclose(np.asarray(gaits.v), seeded["fixed_point"][2], atol=1e-9)
    np.testing.assert_allclose(np.asarray(gaits.lambda_max), seeded["lambda_max"][2], atol=1e-7)


def _arrays(path):
    ds = xr.open_dataset(path, engine="zarr")
    return ds.load()


def test_chunked_and_resumed_sweep_equals_the_grid(runs, tmp_path):
    """Blocks of two lines and one; the first run dies after its first block, the
    same call continues it: every variable bit for bit the in-memory grid's."""
    _, seeded, _, _ = runs
    config = loads_config(CONFIG)
    calls = []

    def dies_after_one_block(*args, **kwargs):
        calls.append(kwargs.get("starts"))
        if len(calls) == 2:
            raise RuntimeError("killed")
        return G.analyse_grid(*args, **kwargs)

    with pytest.raises(RuntimeError, match="killed"):
        run_sweep(config, tmp_path, progress=False, plot=False, chunk_size=6, analyse=dies_after_one_block)
    assert not (tmp_path / "seeded.zarr").exists()
    path = run_sweep(config, tmp_path, progress=False, plot=False, chunk_size=6)
    ds = _arrays(path)
    assert calls[0].shape == (2, 3)  # a block's lines' starts: (lines, n_v)
    assert "continued" in ds.attrs["history"]
    np.testing.assert_array_equal(ds["status"].values, seeded["status"])
    for key in ("fixed_point", "lambda_max", "period", "newton_iterations"):
        np.testing.assert_array_equal(ds[key].values, seeded[key])
    assert ds.attrs["seed_axis"] == "gamma" and ds.attrs["continuation_axis"] == "m_h"
    assert ds.attrs["seed_line_dims"] == "gamma"
    assert ds.attrs["seed_line_status"] == "[0, 0, 0]"
    np.testing.assert_array_equal(np.array(json.loads(ds.attrs["seed_line_fixed_point"]), float), seeded["seed_line_fixed_point"])


def test_without_seed_axis_nothing_changes():
    config = loads_config(CONFIG.replace('seed_axis = "gamma"\n', ""))
    assert config.seed_axis is None and "seed_axis" not in config.to_dict()["analysis"]
    assert loads_config(CONFIG).to_dict()["analysis"]["seed_axis"] == "gamma"


@pytest.mark.parametrize(
    "analysis, fragment",
    [
        ('continuation = "m_h"\nseed_axis = "gama"', "seed_axis = 'gama' is not a grid axis (did you mean 'gamma'?) (axes: gamma, m_h)"),
        ('continuation = "m_h"\nseed_axis = "m_h"', "seed_axis = 'm_h' is the continuation axis"),
        ('continuation = false\nseed_axis = "gamma"', "seed_axis = 'gamma' needs continuation along another grid axis"),
        ('continuation = "m_h"\nseed_axis = 1', "seed_axis must be a grid axis name or false, got 1"),
    ],
    ids=["unknown-axis", "continuation-axis", "no-continuation", "not-a-name"],
)
def test_bad_seed_axis(tmp_path, monkeypatch, capsys, analysis, fragment):
    _refused(tmp_path, monkeypatch, capsys, analysis, fragment)


def _refused(tmp_path, monkeypatch, capsys, analysis, fragment):
    """``[analysis]`` text ``analysis``: one ConfigError line naming ``fragment``, and
    from the command line exit status 2, one line on stderr, nothing written."""
    text = CONFIG.split("[analysis]")[0] + f"[analysis]\n{analysis}\n"
    with pytest.raises(ConfigError) as info:
        loads_config(text, source="t.toml")
    assert "\n" not in str(info.value) and fragment in str(info.value)
    monkeypatch.chdir(tmp_path)
    (tmp_path / "sweep.toml").write_text(text)
    assert cli.main(["sweep", "sweep.toml", "--out", "res"]) == 2
    captured = capsys.readouterr()
    assert captured.out == "" and captured.err.count("\n") == 1 and fragment in captured.err
    assert not (tmp_path / "res").exists()


def test_a_line_starts_where_the_guess_was_made():
    """Continuation starts nearest the parameters of the gait the model's guess is:
    the default for a model with one guess; for the flat-foot walker, whose guess is
    one of its documented gaits, that gait's own values (the paper's walker's
    P = 0.0076, not the shoe walker's default 0.045: a (k, P) map of the paper's
    walker seeded at P = 0.045 would start its lines from the paper's gait 0.034
    away in torque)."""
    from jaxwalk.models.flatfoot.model import DOCUMENTED_GAITS, PAPER_PARAMS, SHOE_PARAMS

    assert MODEL.seed_value("m_h", {}) == MODEL.param_specs["m_h"].default
    assert MODEL.seed_value("gamma", {"m_h": 12.0}) == GAMMA0
    flatfoot = get_model("flatfoot")
    assert flatfoot.seed_value("P", PAPER_PARAMS) == PAPER_PARAMS["P"] == 0.0076
    assert flatfoot.seed_value("P", {}) == SHOE_PARAMS["P"] == flatfoot.param_specs["P"].default
    assert flatfoot.seed_value("l_f", PAPER_PARAMS) == flatfoot.param_specs["l_f"].default
    defaults = {k: float(v) for k, v in flatfoot.default_params().items()}
    for params, gait in DOCUMENTED_GAITS:
        walker = {**defaults, **params}
        assert flatfoot.guess_made_at(walker) is params
        np.testing.assert_array_equal(np.asarray(flatfoot.initial_guess(flatfoot.default_params() | params)), gait)
        for name, value in params.items():
            assert flatfoot.seed_value(name, params) == value


def test_a_grid_seeds_its_lines_at_the_guess_walker(monkeypatch):
    """``analyse_grid`` hands the line program the seed index from ``seed_value``."""
    seen = {}

    def fake_run_lines(model, rows, positions, seed, *args, **kwargs):
        seen["seed"] = seed
        raise RuntimeError("stop")

    monkeypatch.setattr(G, "run_lines", fake_run_lines)
    flatfoot = get_model("flatfoot")
    from jaxwalk.models.flatfoot.model import PAPER_PARAMS

    fixed = {k: v for k, v in PAPER_PARAMS.items() if k != "P"}
    p_values = np.linspace(0.004, 0.011, 64)
    with pytest.raises(RuntimeError, match="stop"):
        G.analyse_grid(flatfoot, fixed, {"P": p_values}, "P", OPTIONS)
    assert seen["seed"] == int(np.argmin(np.abs(p_values - 0.0076)))


def test_an_axis_that_selects_the_guess_is_judged_at_each_value():
    """The flat-foot walker's hip spring selects its guess: on the paper's walker a
    k_hip line starts at k_hip = 0 (the paper's gait, made there), not at the
    hip-spring gait's 0.125 that the defaults would select."""
    from jaxwalk.models.flatfoot.model import HIP_SPRING_PARAMS, PAPER_PARAMS

    flatfoot = get_model("flatfoot")
    fixed = {k: v for k, v in PAPER_PARAMS.items() if k != "k_hip"}
    values = np.linspace(0.0, 0.2, 9)
    assert flatfoot.seed_value("k_hip", fixed, values) == 0.0
    assert flatfoot.seed_value("k_hip", fixed, values[3:]) == 0.125 == HIP_SPRING_PARAMS["k_hip"]
    assert flatfoot.seed_value("k_hip", {**fixed, "note": "a string", "r": np.zeros(3)}, values) == 0.0


def test_seed_lines_start_where_the_guess_was_made(monkeypatch):
    """``seed_lines`` runs its lines at the continuation axis's seed value and
    starts them at the seed axis's, both from ``seed_value``."""
    import jaxwalk.seedline as S
    from jaxwalk.models.flatfoot.model import PAPER_PARAMS

    seen = {}

    def fake_run_lines(model, rows, positions, seed, *args, **kwargs):
        seen.update(seed=seed, P=np.unique(rows["P"]))
        raise RuntimeError("stop")

    monkeypatch.setattr(S, "run_lines", fake_run_lines)
    flatfoot = get_model("flatfoot")
    fixed = {k: v for k, v in PAPER_PARAMS.items() if k != "P"}
    p_values, k_values = np.linspace(0.004, 0.011, 64), np.linspace(0.0, 0.06, 64)
    with pytest.raises(RuntimeError, match="stop"):
        S.seed_lines(flatfoot, fixed, {"k": k_values, "P": p_values}, "P", "k", OPTIONS)
    assert seen["P"].tolist() == [p_values[np.argmin(np.abs(p_values - 0.0076))]]
    assert seen["seed"] == int(np.argmin(np.abs(k_values - 0.03)))


# ---------------------------------------------------------------- [analysis] gait_guess

GUESSED = CONFIG.replace('seed_axis = "gamma"\n', "") + "gait_guess = GUESS\ngait_guess_at = { m_h = 12.0 }\n"


def _guessed(seeded, **fields):
    return G.AnalysisOptions(**{"gait_guess": tuple(seeded["fixed_point"][2, 2]), "gait_guess_at": (("m_h", 12.0),), **fields})


def test_a_gait_guess_starts_the_lines_where_it_says(runs):
    """The gamma = 0.13 line, lost from the model's guess, found from a guess of its
    m_h = 12 gait placed there: the seed point is m_h = 12 (Newton starts at its own
    fixed point: at most one iteration) and the line is the seeded run's gait."""
    plain, seeded, compiled, _ = runs
    line = {"gamma": GRID["gamma"][2:], "m_h": GRID["m_h"]}
    guessed = G.analyse_grid(MODEL, {}, line, "m_h", _guessed(seeded))
    assert (plain["status"][2] != 0).all() and (guessed["status"] == 0).all()
    assert guessed["newton_iterations"][0, 2] <= 1 < guessed["newton_iterations"][0, 0]
    np.testing.assert_allclose(guessed["fixed_point"][0], seeded["fixed_point"][2], atol=1e-8)
    # A guess that is no gait's: every line fails from it (the model's guess is not used instead).
    lost = G.analyse_grid(MODEL, {}, GRID, "m_h", G.AnalysisOptions(gait_guess=(0.5, 0.5, 0.5)))
    assert (lost["status"] != 0).all()
    assert len(compiled_shapes(_program())) == compiled  # the guess is data: nothing compiled


def test_a_gait_guess_starts_the_seed_lines(runs):
    """With a seed axis, the seed line starts from the guess at the slope it names."""
    _, seeded, _, _ = runs
    options = G.AnalysisOptions(gait_guess=tuple(seeded["fixed_point"][2, 1]), gait_guess_at=(("gamma", 0.13),))
    guessed = G.analyse_grid(MODEL, {}, GRID, "m_h", options, seed_axis="gamma")
    assert (guessed["status"] == 0).all()
    np.testing.assert_allclose(guessed["fixed_point"], seeded["fixed_point"], atol=1e-8)
    seeds = seed_lines(MODEL, {}, GRID, "m_h", "gamma", options)
    assert seeds.newton_iterations[2] <= 1 < seeds.newton_iterations[0]


def test_a_sweep_records_its_gait_guess(runs, tmp_path):
    """The config keeps the guess (resolved, re-read, the same), the dataset says where
    its lines started and with what; a config without it keeps its old record."""
    _, seeded, _, _ = runs
    v = [float(x) for x in seeded["fixed_point"][2, 2]]
    config = loads_config(GUESSED.replace("GUESS", repr(v)))
    assert config.gait_guess == tuple(v) and config.gait_guess_at == {"m_h": 12.0}
    again = parse_config(json.loads(config.to_json()))
    assert again.to_dict() == config.to_dict()
    plain = loads_config(CONFIG.replace('seed_axis = "gamma"\n', ""))
    assert "gait_guess" not in plain.to_dict()["analysis"] and "gait_guess_at" not in plain.to_dict()["analysis"]
    ds = _arrays(run_sweep(config, tmp_path, progress=False, plot=False))
    assert ds.attrs["continuation_start"] == 12.0
    # Every line starts from the one guess: the gamma = 0.13 line is found, as above.
    assert (ds["status"].values[2] == 0).all()
    np.testing.assert_allclose(ds["fixed_point"].values[2], seeded["fixed_point"][2], atol=1e-8)
    recorded = json.loads(ds.attrs["analysis_options"])
    assert recorded["gait_guess"] == v and recorded["gait_guess_at"] == [["m_h", 12.0]]


@pytest.mark.parametrize(
    "analysis, fragment",
    [
        ('continuation = "m_h"\ngait_guess = [0.2, -0.2]', "gait_guess must be 3 finite numbers (the model's section coordinates), got [0.2, -0.2]"),
        ('continuation = false\ngait_guess = [0.2, -0.2, 0.1]', "gait_guess needs continuation"),
        ('continuation = "m_h"\ngait_guess = [0.2, -0.2, 0.1]\ngait_guess_at = { gamma = 0.1 }', "gait_guess_at names 'gamma', which no line follows (lines follow 'm_h')"),
        ('continuation = "m_h"\ngait_guess_at = { m_h = 10.0 }', "gait_guess_at needs gait_guess"),
        ('continuation = "m_h"\ngait_guess = true', "gait_guess must be a list of 3 numbers"),
        ('continuation = "m_h"\ngait_guess = [0.2, -0.2, 0.1]\ngait_guess_at = { m_h = "x" }', "gait_guess_at m_h must be a finite number, got 'x'"),
        ('continuation = "m_h"\ngait_guess = [0.2, -0.2, 0.1]\ngait_guess_at = { m_h = 30.0 }', "gait_guess_at m_h = 30.0 is outside the grid's m_h [8, 12]"),
    ],
    ids=["length", "no-continuation", "not-a-line", "at-alone", "true", "at-not-a-number", "at-off-grid"],
)
def test_bad_gait_guess(tmp_path, monkeypatch, capsys, analysis, fragment):
    _refused(tmp_path, monkeypatch, capsys, analysis, fragment)


def test_a_bad_gait_guess_through_the_api_is_one_config_error():
    """The Python API refuses a guess of the wrong length or with NaN before anything runs."""
    for guess in ((0.2, -0.2), (0.2, float("nan"), 0.1)):
        with pytest.raises(ConfigError, match="gait_guess must be 3 finite numbers"):
            G.analyse_grid(MODEL, {}, GRID, "m_h", G.AnalysisOptions(gait_guess=guess))
    # Without continuation the points start independently: the guess is refused, not ignored.
    with pytest.raises(ConfigError, match="gait_guess needs a continuation axis"):
        G.analyse_grid(MODEL, {}, GRID, None, G.AnalysisOptions(gait_guess=(0.2, -0.2, 0.1)))
