"""The basin measure (jaxwalk.global_stability.basin, [analysis] basin) against truth, and
``jaxwalk basin``.

Truth for the fraction and the ray radii is an independent loop: jaxwalk's plain
step map (:func:`jaxwalk.step.step_map`, vmapped) applied step by step from
Python, each start's fate decided in NumPy (its own sampler of the ball, its own
return rule, its own bisection); the analysis walks with
:func:`jaxwalk.global_stability.walks.walk_until` in one compiled program. One
start's fate is also checked against the SciPy walker (tests/reference).

Simplest walker only (seconds to compile). Measured (2026-12-02, shared machine):
see the assertions' messages and docs/global_stability.md.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest
import xarray as xr

from jaxwalk import cli
from jaxwalk.analyses.basin import DEFAULTS
from jaxwalk.gait import find_gait
from jaxwalk.global_stability.basin import BasinOptions, basin
from jaxwalk.models import MODELS, get_model
from jaxwalk.status import Status
from jaxwalk.step import step_map

GAMMA = 0.009
#: The measure as the truth checks it: the perturbed coordinates alpha_1 and alpha_1_dot, a
#: ball where about a quarter of the starts return (the basin is a thin strip, Schwab & Wisse 2001).
OPTIONS = BasinOptions(radius=0.01, samples=256, steps=40, directions=6, scan=8, bisections=8, coordinates=(0, 1))
N_DIRECT = 400


@pytest.fixture(scope="module")
def gait():
    model = get_model("simplest")
    params = {"gamma": jnp.asarray(GAMMA)}
    g = find_gait(model, params, model.initial_guess(params))
    assert int(g.status) == 0 and float(g.lambda_max) < 1
    return model, params, np.asarray(g.v)


@pytest.fixture(scope="module")
def measured(gait):
    model, params, v = gait
    return jax.jit(lambda p, v: basin(model, p, v, v[None], OPTIONS))(params, jnp.asarray(v))


@pytest.fixture(scope="module")
def direct(gait):
    """``walk(starts) -> (returned (n,) bool, status (n,), steps (n,))``: the plain step map, from Python."""
    model, params, v_star = gait
    step = jax.jit(jax.vmap(lambda v: step_map(model, v, params)))

    def walk(starts):
        v = jnp.asarray(starts)
        n = len(starts)
        status, steps, returned = np.zeros(n, int), np.zeros(n, int), np.zeros(n, bool)
        alive = np.ones(n, bool)
        for k in range(1, OPTIONS.steps + 1):
            v_next, res = step(v)
            code = np.asarray(res.status)
            failed = alive & (code != 0)
            status[failed], steps[failed] = code[failed], k - 1
            alive &= ~failed
            back = alive & (np.linalg.norm(np.asarray(v_next) - v_star, axis=1) < OPTIONS.tol)
            returned |= back
            steps[back] = k
            alive &= ~back
            v = jnp.where(jnp.asarray(alive)[:, None], v_next, v)
            if not alive.any():
                break
        status[alive] = Status.NOT_RETURNED
        return returned, status, steps

    return walk


def _offsets_in_disc(rng, n, radius):
    """Uniform in the disc by rejection from the square (not the analysis's sampler)."""
    out = np.empty((0, 2))
    while len(out) < n:
        x = rng.uniform(-radius, radius, (2 * n, 2))
        out = np.concatenate([out, x[np.linalg.norm(x, axis=1) < radius]])
    return out[:n]


def test_fraction_agrees_with_direct_walks_of_random_starts(gait, measured, direct):
    _, _, v_star = gait
    starts = np.repeat(v_star[None], N_DIRECT, 0)
    starts[:, :2] += _offsets_in_disc(np.random.default_rng(12345), N_DIRECT, OPTIONS.radius)
    returned, status, _ = direct(starts)
    f_direct = returned.mean()
    f, se = float(measured.fraction), float(measured.fraction_error)
    se_direct = np.sqrt(f_direct * (1 - f_direct) / N_DIRECT)
    assert 0.1 < f_direct < 0.9, f"direct fraction {f_direct}: the ball says little about the edge"
    assert abs(se - np.sqrt(f * (1 - f) / OPTIONS.samples)) < 1e-12
    assert abs(f - f_direct) <= 3 * np.hypot(se, se_direct), (f, se, f_direct, se_direct)
    # Every failure is a named status.
    assert set(np.unique(np.asarray(measured.sample_status))) <= {int(s) for s in Status}


def test_ray_radii_agree_with_bisection_by_direct_walks(gait, measured, direct):
    from jaxwalk.global_stability.basin import ray_directions

    _, _, v_star = gait
    dirs = ray_directions(2, OPTIONS.directions, OPTIONS.seed)
    grid = OPTIONS.radius * np.arange(1, OPTIONS.scan + 1) / OPTIONS.scan

    def starts_at(r):  # (D,) radii -> (D, n_v)
        s = np.repeat(v_star[None], len(dirs), 0)
        s[:, :2] += dirs * np.asarray(r)[:, None]
        return s

    ok = np.stack([direct(starts_at(np.full(len(dirs), r)))[0] for r in grid], 1)  # (D, scan)
    first = np.where(ok.all(1), OPTIONS.scan, np.argmin(ok, 1))
    lo = np.where(first > 0, grid[np.maximum(first - 1, 0)], 0.0)
    hi = grid[np.minimum(first, OPTIONS.scan - 1)]
    for _ in range(OPTIONS.bisections):
        mid = 0.5 * (lo + hi)
        back = direct(starts_at(mid))[0]
        lo, hi = np.where(back, mid, lo), np.where(back, hi, mid)
    expected = np.where(first == OPTIONS.scan, OPTIONS.radius, lo)
    resolution = OPTIONS.radius / OPTIONS.scan / 2**OPTIONS.bisections
    got = np.asarray(measured.ray_radius)
    assert (first < OPTIONS.scan).any(), "no ray met the basin's edge inside the ball"
    np.testing.assert_allclose(got, expected, atol=resolution, rtol=0)
    assert float(measured.radius) == got.min()


def test_one_fate_agrees_with_the_scipy_walker(gait, direct):
    """A start that returns and one that fails, walked by DOP853 at rtol 1e-12."""
    from tests.reference.stride import simplest_step

    _, _, v_star = gait
    starts = np.repeat(v_star[None], 2, 0)
    starts[0, :2] += [0.002, -0.002]  # along the strip (returns)
    starts[1, :2] += [0.006, 0.006]  # across it (fails)
    returned, status, steps = direct(starts)
    assert returned[0] and not returned[1], (returned, status)
    v, k = starts[0], 0
    while np.linalg.norm(v - v_star) >= OPTIONS.tol:
        v, info = simplest_step(v, GAMMA)
        k += 1
        assert info["status"] == "ok" and k <= OPTIONS.steps
    assert k == steps[0]
    v, info = simplest_step(starts[1], GAMMA)
    for _ in range(steps[1]):
        assert info["status"] == "ok"
        v, info = simplest_step(v, GAMMA)
    assert info["status"] != "ok"


class _HalfSection(type(get_model("simplest"))):
    """The simplest walker with only ``alpha_1 >= HALF_AT`` as its states (a stand-in for
    a section with an edge, as the heel-rise walker's), the rest moved onto the edge."""

    name = "simplest_half_section"
    half_at = None  # set by the test: the gait's alpha_1

    def into_section(self, v, params):
        return v.at[0].set(jnp.maximum(v[0], self.half_at))


def test_starts_that_are_not_states_are_named_and_left_out(gait, measured):
    """With half the ball outside the walker's states, those starts are
    ``not_a_state`` (exactly the offsets below the edge), every other start's
    fate is the full section's, the fraction counts states only, and a ray that
    leaves the states at once meets no failure."""
    from jaxwalk.global_stability.basin import ray_directions, unit_ball

    model, params, v_star = gait
    half = _HalfSection()
    half.half_at = float(v_star[0])
    got = jax.jit(lambda p, v: basin(half, p, v, v[None], OPTIONS))(params, jnp.asarray(v_star))
    status, full = np.asarray(got.sample_status), np.asarray(measured.sample_status)
    outside = unit_ball(2, OPTIONS.samples, OPTIONS.seed)[:, 0] < 0
    assert 0.3 < outside.mean() < 0.7
    np.testing.assert_array_equal(status == Status.NOT_A_STATE, outside)
    np.testing.assert_array_equal(status[~outside], full[~outside])
    states = (~outside).sum()
    f = (status == Status.OK).sum() / states
    assert float(got.fraction) == f and abs(float(got.fraction_error) - np.sqrt(f * (1 - f) / states)) < 1e-12
    leaves = ray_directions(2, OPTIONS.directions, OPTIONS.seed)[:, 0] < 0
    ray, ray_full = np.asarray(got.ray_radius), np.asarray(measured.ray_radius)
    np.testing.assert_array_equal(ray[leaves], OPTIONS.radius)
    np.testing.assert_array_equal(ray[~leaves], ray_full[~leaves])
    assert (ray_full[leaves] < OPTIONS.radius).any(), "no ray that leaves the states would have failed"


def test_analysis_defaults_are_the_measure_defaults():
    import dataclasses

    assert DEFAULTS == {f.name: f.default for f in dataclasses.fields(BasinOptions)}


@pytest.mark.parametrize("model_name, given, radius, scale", [
    ("simplest", {}, 0.01, None),  # the simplest walker's ball: unscaled
    ("compass", {}, 1.0, [0.026, 0.1, 1.1]),
    ("flatfoot", {}, 1.0, [0.12, 0.25]),
    ("flatfoot", {"radius": 0.5}, 0.5, [0.12, 0.25]),  # a radius in the model's norm
    ("flatfoot", {"scale": [1.0, 2.0]}, 1.0, [1.0, 2.0]),
])
def test_the_ball_is_the_models_where_the_config_names_none(model_name, given, radius, scale):
    """A sweep's resolved basin settings (written to its dataset) and the Python
    options name the same ball: the model's radius and scale where none is given."""
    from jaxwalk.sweep.config import parse_config

    axis = {"simplest": "gamma", "compass": "gamma", "flatfoot": "r"}[model_name]
    config = parse_config({"name": "b", "model": model_name, "grid": {axis: {"values": [0.009 if axis == "gamma" else 0.4]}},
                           "analysis": {"basin": given or True}})
    resolved = config.analyses["basin"]
    assert resolved["radius"] == radius and resolved.get("scale") == scale
    options = BasinOptions(**{k: tuple(v) if isinstance(v, list) else v for k, v in given.items()})
    ball = options.for_model(get_model(model_name))
    assert ball.radius == radius and ball.scale == (None if scale is None else tuple(scale))


@pytest.mark.parametrize("model_name", sorted(MODELS))
def test_every_models_ball_fits_its_section_and_the_default_tol(model_name):
    model = get_model(model_name)
    assert model.basin_radius > DEFAULTS["tol"]
    if model.basin_scale is not None:
        assert len(model.basin_scale) == len(model.section_names) and min(model.basin_scale) > 0


def test_tol_must_be_below_the_models_radius():
    from jaxwalk.errors import ConfigError
    from jaxwalk.sweep.config import parse_config

    with pytest.raises(ConfigError, match=r"tol \(0.02\) must be below radius \(0.01\)"):
        parse_config({"name": "b", "model": "simplest", "grid": {"gamma": {"values": [0.009]}},
                      "analysis": {"basin": {"tol": 0.02}}})
    parse_config({"name": "b", "model": "flatfoot", "grid": {"r": {"values": [0.4]}}, "analysis": {"basin": {"tol": 0.02}}})


# ---------------------------------------------------------------- jaxwalk basin

BASIN_TOML = """
name = "tiny"
model = "simplest"
[params]
gamma = 0.009
[basin]
x = "alpha_1"
y = "alpha_1_dot"
span = [0.01, 0.01]
points = [9, 7]
steps = 30
"""


@pytest.mark.parametrize("bad, message", [
    ('[basin]\nx = "alpha_1"\n', "missing 'span'"),
    ('[basin]\nx = "alpha_3"\nspan = [0.01, 0.01]\n', "unknown section coordinate 'alpha_3'"),
    ('[basin]\nspan = [0.01, 0.01]\npionts = [3, 3]\n', "did you mean 'points'"),
    ('[basin]\nx = "alpha_1"\ny = "alpha_1"\nspan = [0.01, 0.01]\n', "x and y must be different"),
    ('[basin]\nspan = [0.01, -1]\n', "span must be two positive numbers"),
    ('[basin]\nspan = [0.01, 0.01]\nsteps = 0\n', "steps must be a positive integer"),
    ('[basin]\nspan = [0.01, 0.01]\nscale = [1.0, 1.0]\n', "scale has 2 entries"),
    ('[simulate]\nsteps = 3\n', "unknown top-level key 'simulate'"),
])
def test_bad_config_is_one_line_exit_2_and_nothing_written(tmp_path, capsys, bad, message):
    path = tmp_path / "bad.toml"
    path.write_text('name = "b"\nmodel = "simplest"\n' + bad)
    out = tmp_path / "out"
    assert cli.main(["basin", str(path), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("jaxwalk: error: ") and message in err, err
    assert not out.exists()


def test_bundled_basin_configs_are_valid():
    from pathlib import Path

    from jaxwalk.basin import load_basin_config

    paths = sorted((Path(__file__).resolve().parents[1] / "sweeps").glob("basin_*.toml"))
    assert paths
    for path in paths:
        assert load_basin_config(path).name == path.stem


def test_resolved_config_is_itself_a_valid_config():
    """What the dataset's ``config`` attribute holds (JSON) parses to the same basin."""
    import json
    from pathlib import Path

    from jaxwalk.basin import load_basin_config, parse_basin_config

    config = load_basin_config(Path(__file__).resolve().parents[1] / "sweeps" / "basin_simplest.toml")
    again = parse_basin_config(json.loads(config.to_json()), source="round trip")
    assert again.to_dict() == config.to_dict() and again.fixed == config.fixed and (again.x, again.y) == (config.x, config.y)


def test_image_and_self_describing_dataset(tmp_path, capsys, gait):
    _, _, v_star = gait
    config = tmp_path / "tiny.toml"
    config.write_text(BASIN_TOML)
    assert cli.main(["basin", str(config), "--out", str(tmp_path)]) == 0
    assert (tmp_path / "tiny_basin.png").stat().st_size > 5000
    ds = xr.open_zarr(tmp_path / "tiny_basin.zarr")
    outcome = ds["outcome"].values
    assert outcome.shape == (7, 9)
    assert "not_returned" in ds["outcome"].attrs["flag_meanings"].split()
    assert "17 not_returned: not returned" in ds["outcome"].attrs["flag_descriptions"]
    assert ds.attrs["kind"] == "basin" and ds.attrs["x_coordinate"] == "alpha_1" and "jax_version" in ds.attrs
    np.testing.assert_allclose(ds.attrs["fixed_point"], v_star, atol=1e-9)
    assert outcome[3, 4] == Status.OK and ds["steps"].values[3, 4] == 1  # the fixed point itself
    assert (outcome != Status.OK).any() and (outcome == Status.OK).sum() > 1
    # Running again without --overwrite refuses, one line, and leaves the files.
    capsys.readouterr()
    assert cli.main(["basin", str(config), "--out", str(tmp_path)]) == 2
    assert "already exists" in capsys.readouterr().err
