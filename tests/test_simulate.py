"""``jaxwalk simulate``: the recorded trajectory against run_step, energy along it,
the dataset, the figures and GIF, and bad input (one line, exit 2, nothing written).

One compass walk of two steps is made once per module (in process, through the
command line), so everything compiles once: the gait search, the recorder and
run_step (about 20-30 s on two cores).
"""

from __future__ import annotations

import json

import jax
import jax.numpy as jnp
import numpy as np
import pytest
import xarray as xr
from PIL import Image

from jaxwalk import cli, simulate
from jaxwalk.models import get_model
from jaxwalk.models.compass import CompassWalker
from jaxwalk.simulate import AFTER_EVENT, BEFORE_EVENT, REGULAR
from jaxwalk.status import Status, flag_attributes
from jaxwalk.step import run_step
from jaxwalk.sweep.config import ConfigError
from jaxwalk.walker import Walker
from tests.conftest import ROOT

MODEL = get_model("compass")
CONFIG = """
name = "walk"
model = "compass"
[simulate]
dt = 0.01
"""
STEPS = 2


def listing(path):
    return sorted(str(p.relative_to(path)) for p in path.rglob("*"))


@pytest.fixture(scope="module")
def walk(tmp_path_factory):
    """The compass walker's defaults, 2 steps from its gait, every output."""
    root = tmp_path_factory.mktemp("walk")
    (root / "walk.toml").write_text(CONFIG)
    argv = ["simulate", str(root / "walk.toml"), "--steps", str(STEPS), "--out", str(root / "out")]
    assert cli.main(argv) == 0
    ds = xr.open_dataset(root / "out" / "walk_trajectory.zarr", engine="zarr").load()
    return root / "out", ds


@pytest.fixture(scope="module")
def step_fn():
    return jax.jit(run_step, static_argnums=0)


def params_of(ds):
    return simulate.as_params(json.loads(ds.attrs["params"]))


def state_at(ds, i):
    y = np.concatenate([ds["q"].values[i], ds["qd"].values[i]])
    return jnp.asarray(y), jnp.asarray(int(ds["phase"].values[i]), jnp.int32), jnp.asarray(ds["ctx"].values[i])


# ---------------------------------------------------------------- the recorded trajectory


def test_end_of_each_step_is_run_steps_result(walk, step_fn):
    _, ds = walk
    params = params_of(ds)
    step = ds["step"].values
    assert int(ds["steps_completed"]) == STEPS and int(ds["status"]) == Status.OK
    np.testing.assert_array_equal(ds["step_status"].values, [Status.OK] * STEPS)

    # The walk starts at the gait's section state.
    v = json.loads(ds.attrs["start_section"])
    y0, phase0, ctx0 = simulate.initial_state(MODEL, params, v)
    y, phase, ctx = state_at(ds, 0)
    np.testing.assert_allclose(y, y0, rtol=0, atol=1e-15)
    assert int(phase) == int(phase0)

    # run_step, chained on its own results, lands on the first sample of each next step.
    for k in range(STEPS):
        res = step_fn(MODEL, params, y, phase, ctx)
        assert int(res.status) == Status.OK
        first_next = int(np.nonzero(step == k + 1)[0][0])
        assert ds["sample_kind"].values[first_next] == AFTER_EVENT
        y_rec, phase_rec, ctx_rec = state_at(ds, first_next)
        np.testing.assert_allclose(y_rec, res.y, rtol=0, atol=1e-9)
        np.testing.assert_allclose(ctx_rec, res.ctx, rtol=0, atol=1e-12)
        assert int(phase_rec) == int(res.phase)
        assert float(ds["step_duration"][k]) == pytest.approx(float(res.time), abs=1e-9)
        assert float(ds["step_length"][k]) == pytest.approx(float(res.length), abs=1e-9)
        y, phase, ctx = res.y, res.phase, res.ctx
    # Two steps of the periodic gait end where they began (to the gait's tolerance).
    np.testing.assert_allclose(ds["section_end"].values[-1], v, atol=1e-7)


def test_samples_regular_grid_plus_events(walk):
    _, ds = walk
    t, kind = ds["time"].values, ds["sample_kind"].values
    dt = ds.attrs["dt"]
    assert np.all(np.diff(t) >= 0)
    regular = t[kind == REGULAR]
    np.testing.assert_allclose(regular / dt, np.round(regular / dt), atol=1e-9)
    assert np.all(np.diff(regular) > 0)
    # Every event is recorded twice at one time: before, then after.
    before, after = np.nonzero(kind == BEFORE_EVENT)[0], np.nonzero(kind == AFTER_EVENT)[0]
    np.testing.assert_array_equal(after, before + 1)
    np.testing.assert_array_equal(t[before], t[after])
    guards = ds["event_guard"].values
    assert set(guards[kind == REGULAR]) == {-1}
    names = ds["event_guard"].attrs["flag_meanings"].split()
    # Each compass step: mid-stance, then heel-strike.
    assert [names[g + 1] for g in guards[before]] == ["midstance", "heel_strike"] * STEPS


def test_energy_constant_within_phases_and_drops_at_impacts(walk):
    _, ds = walk
    energy, kind = ds["energy"].values, ds["sample_kind"].values
    step, phase = ds["step"].values, ds["phase"].values
    scale = np.abs(energy).max()
    blocks = 0
    for k in range(STEPS):
        for p in range(len(MODEL.phases)):
            rows = (step == k) & (phase == p)
            assert rows.sum() > 10
            e = energy[rows]
            assert (e.max() - e.min()) / scale < 1e-8, (k, p)
            blocks += 1
    assert blocks == 2 * STEPS
    before = np.nonzero(kind == BEFORE_EVENT)[0]
    for i in before:
        change = energy[i + 1] - energy[i]
        if step[i + 1] != step[i]:  # heel-strike: an inelastic impact
            assert change < -1e-3 * scale
        else:  # mid-stance: a change of phase, no impact
            assert abs(change) < 1e-12 * scale
    np.testing.assert_array_equal(ds["work"].values, 0.0)  # passive


def test_dataset_layout(walk):
    _, ds = walk
    n = ds.sizes["time"]
    assert list(ds["coordinate"].values) == list(MODEL.coordinates)
    assert list(ds["q_units"].values) == ["m", "m", "rad", "rad"]
    assert list(ds["qd_units"].values) == ["m s-1", "m s-1", "rad s-1", "rad s-1"]
    assert ds["q"].dims == ds["qd"].dims == ("time", "coordinate")
    assert ds["contact_force"].dims == ("time", "constraint")
    assert list(ds["constraint"].values) == list(range(MODEL.n_constraints))
    force = ds["contact_force"].values
    assert np.all(np.isfinite(force[:, :2])) and np.all(np.isnan(force[:, 2:]))  # swing foot rows inactive
    assert np.all(force[:, 1] > 0)  # the ground pushes up on the stance foot
    # The compass walker checks no contact limit: an empty limit axis, no column.
    assert ds["limit_use"].dims == ("time", "limit") and ds["limit_use"].shape == (n, 0)
    assert ds["phase"].attrs["flag_meanings"] == " ".join(MODEL.phases)
    assert ds["phase"].attrs["flag_values"] == [0, 1]
    for key, value in flag_attributes().items():
        assert ds["step_status"].attrs[key] == value
    assert ds["phase"].dtype == np.int32 and ds["step"].dtype == np.int32
    assert ds["frame_origin"].shape == (n, 2)
    assert ds["time"].attrs["units"] == "s" and ds["energy"].attrs["units"] == "J"
    assert ds.attrs["model"] == "compass" and ds.attrs["command"].startswith("jaxwalk simulate ")
    assert json.loads(ds.attrs["params"])["m_h"] == 10.0
    assert json.loads(ds.attrs["units"])["length"] == "m"
    assert ds.attrs["jax_version"] and ds.attrs["status_meanings"].startswith("0 ok")
    assert 0 < ds.attrs["gait_lambda_max"] < 1


def test_figures_and_gif_written(walk):
    out, _ = walk
    assert sorted(p.name for p in out.iterdir()) == [
        "walk_stick.png", "walk_timeseries.png", "walk_trajectory.zarr", "walk_walk.gif",
    ]  # no temporaries left
    for name in ("walk_stick.png", "walk_timeseries.png"):
        with Image.open(out / name) as im:
            assert im.format == "PNG" and im.size[0] > 300
    gif = out / "walk_walk.gif"
    assert 0 < gif.stat().st_size < 3_000_000
    with Image.open(gif) as im:
        assert im.format == "GIF" and im.n_frames > 20


def test_step_down_moves_the_ground(walk, step_fn):
    """A drop at the first touchdown: the frame's origin moves down by h cos(gamma)
    at the first heel-strike and stays there; the end state is still run_step's."""
    _, ds = walk
    params = params_of(ds)
    h = 0.005
    y0, phase0, ctx0 = simulate.initial_state(MODEL, params, json.loads(ds.attrs["start_section"]), h)
    traj = simulate.record_walk(MODEL, params, y0, phase0, ctx0, 2, 0.01)
    assert traj.steps_completed == 2
    drop = h * np.cos(float(params["gamma"]))
    np.testing.assert_allclose(traj.origin[traj.step == 0, 1], 0.0)
    np.testing.assert_allclose(traj.origin[traj.step >= 1, 1], -drop, atol=1e-15)
    res = step_fn(MODEL, params, y0, phase0, ctx0)
    first_next = int(np.nonzero(traj.step == 1)[0][0])
    np.testing.assert_allclose(traj.y[first_next], res.y, atol=1e-9)


def test_guard_past_at_a_phase_start_is_an_event_there(walk, step_fn):
    """After a 0.2 m drop the compass walker lands its swing foot behind the hip,
    so the next step starts with its mid-stance guard negative. The recorder, like
    run_step (both through jaxwalk.step.end_phase), takes that as an event at the
    phase's start: the walker falls there instead of running into the time limit."""
    _, ds = walk
    params = params_of(ds)
    y0, phase0, ctx0 = simulate.initial_state(MODEL, params, json.loads(ds.attrs["start_section"]), 0.2)
    traj = simulate.record_walk(MODEL, params, y0, phase0, ctx0, 2, 0.01)
    first = step_fn(MODEL, params, y0, phase0, ctx0)
    second = step_fn(MODEL, params, first.y, first.phase, first.ctx)
    assert int(first.status) == Status.OK and int(second.status) == Status.FELL
    np.testing.assert_array_equal(traj.step_status, [Status.OK, Status.FELL])
    assert traj.status == Status.FELL and traj.steps_completed == 1
    assert traj.step_duration[1] == float(second.time) == 0.0
    # The failing event is recorded at the step's start, the state unchanged.
    assert traj.sample_kind[-1] == BEFORE_EVENT and traj.step[-1] == 1
    assert traj.sample_kind[-2] == AFTER_EVENT and traj.step[-2] == 1
    assert traj.time[-1] == traj.time[-2] == traj.step_start_time[1]
    np.testing.assert_array_equal(traj.y[-1], traj.y[-2])


class PoweredCompass(CompassWalker):
    """The passive compass walker with a bookkeeping "actuator power" q_dot[2]
    (it does no work on the dynamics): its integral along a step is alpha_1(t) - alpha_1(0)."""

    name = "compass_powered"

    def actuator_power(self, q, qd, params, phase, ctx):
        return qd[2]


def test_actuator_work_is_the_integral_of_power(walk):
    _, ds = walk
    model = PoweredCompass()
    params = params_of(ds)
    y0, phase0, ctx0 = simulate.initial_state(model, params, json.loads(ds.attrs["start_section"]))
    traj = simulate.record_walk(model, params, y0, phase0, ctx0, 1, 0.01)
    rows = traj.step == 0
    np.testing.assert_allclose(traj.actuator_power[rows], traj.y[rows, 6], rtol=0, atol=1e-12)
    # Simpson on intervals <= dt: error ~dt^4 (4e-10 at 0.01 s, 6e-9 at 0.02 s).
    np.testing.assert_allclose(traj.work[rows], traj.y[rows, 2] - traj.y[0, 2], rtol=0, atol=1e-9)
    # No work in the impact: the sample after heel-strike carries the same total.
    assert traj.work[-1] == traj.work[-2]


# ---------------------------------------------------------------- bad input

S2 = ["--steps", "2"]
BAD = [
    (CONFIG + "speed = 2\n", S2, "[simulate]: unknown key 'speed'"),
    (CONFIG + "stps = 2\n", S2, "did you mean 'steps'?"),
    (CONFIG, [], "no step count: give --steps N or [simulate] steps = N"),
    (CONFIG + "steps = 0\n", [], "[simulate] steps must be a positive integer, got 0"),
    (CONFIG + "steps = 100000\n", [], "more than the limit of 1000 steps"),
    (CONFIG, ["--steps", "0"], "expected a positive integer, got '0'"),
    (CONFIG + "steps = 2.5\n", S2, "[simulate] steps must be a positive integer, got 2.5"),
    (CONFIG, S2 + ["--drop", "-0.01"], "--drop must be a number >= 0"),
    (CONFIG, S2 + ["--drop", "nan"], "--drop must be a number >= 0"),
    (CONFIG, S2 + ["--drop", "high"], "argument --drop: invalid float value: 'high'"),
    (CONFIG + "drop = -1\n", S2, "[simulate] drop must be a number >= 0"),
    (CONFIG.replace("dt = 0.01", "dt = 0"), S2, "[simulate] dt (output sampling interval) must be a number from"),
    (CONFIG.replace("dt = 0.01", "dt = 5.0"), S2, "got 5.0"),
    (CONFIG + "v0 = [0.27, -1.09]\n", S2, "[simulate] v0 must be an array of 3 finite numbers (alpha_1, alpha_1_dot, alpha_2_dot)"),
    (CONFIG.replace('"compass"', '"hopper"'), S2, "unknown model 'hopper'"),
    (CONFIG + "[params]\nm_hip = 3.0\n", S2, "unknown parameter 'm_hip' for model 'compass' (did you mean 'm_h'?)"),
    (CONFIG + "[params]\nm = -3.0\n", S2, "parameter 'm' (leg mass) must be > 0.0, got -3.0"),
    (CONFIG + "[grid]\ngamma = { values = [0.05] }\n", S2, "[grid] is for sweeps"),
    (CONFIG + "[analysis]\nstability = true\n", S2, "unknown top-level section 'analysis'"),
    ('name = "walk"\n[simulate]\n', S2, "missing 'model'"),
    ('name = "walk"\nmodel = "compass"\n[simulate\n', S2, "invalid TOML"),
    (CONFIG, ["--steps", "2", "--outt", "x"], "unrecognized arguments"),
]


@pytest.mark.parametrize("config, args, fragment", BAD, ids=[b[2][:40] for b in BAD])
def test_bad_input_one_line_nothing_written(tmp_path, monkeypatch, capsys, config, args, fragment):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "walk.toml").write_text(config)
    before = listing(tmp_path)
    assert cli.main(["simulate", "walk.toml", "--out", "out", *args]) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    assert captured.err.count("\n") == 1 and captured.err.startswith("jaxwalk: error: "), captured.err
    assert fragment in captured.err
    assert listing(tmp_path) == before


def test_existing_outputs_and_bad_out(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "walk.toml").write_text(CONFIG)
    (tmp_path / "file.txt").write_text("not a directory")
    (tmp_path / "res").mkdir()
    (tmp_path / "res" / "walk_walk.gif").write_text("an older walk")
    before = listing(tmp_path)
    for out, fragment in (("file.txt", "exists and is not a directory"), ("res", "walk_walk.gif' already exists (pass --overwrite")):
        assert cli.main(["simulate", "walk.toml", "--steps", "2", "--out", out]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and fragment in err
    assert listing(tmp_path) == before


def test_no_gait_is_one_line_naming_the_status(walk, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "walk.toml").write_text(CONFIG + "[params]\ngamma = -0.05\n")  # uphill
    # --no-progress: the subject is the error line, not the stage lines before it.
    assert cli.main(["simulate", "walk.toml", "--steps", "2", "--out", "out", "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1
    assert "no periodic gait found from the compass model's initial guess: status stalled" in err
    assert listing(tmp_path) == ["walk.toml"]


def test_model_without_drawing_methods():
    class Bare(Walker):
        name = "bare"

    with pytest.raises(ConfigError, match="model 'bare' cannot be drawn: it has no skeleton\\(\\) or foot_points\\(\\)"):
        simulate.check_drawable(Bare())


def test_bad_input_subprocess(run_cli, tmp_path):
    (tmp_path / "walk.toml").write_text(CONFIG + "speed = 2\n")
    proc = run_cli("simulate", "walk.toml", "--steps", "2", "--out", "out")
    assert proc.returncode == 2 and proc.stdout == ""
    assert proc.stderr.splitlines() == [
        "jaxwalk: error: walk.toml: [simulate]: unknown key 'speed' (allowed: steps, drop, dt, v0)"
    ]
    assert listing(tmp_path) == ["walk.toml"]


@pytest.mark.parametrize("path", sorted((ROOT / "sweeps").glob("simulate_*.toml")), ids=lambda p: p.name)
def test_bundled_simulate_configs_are_valid(path):
    cfg = simulate.load_simulate_config(path)
    assert cfg.name == path.stem
    assert cfg.steps >= 1 and cfg.dt > 0
    simulate.check_drawable(get_model(cfg.model))


def test_a_start_that_is_not_a_state_is_refused(tmp_path, monkeypatch, capsys):
    """The heel-rise walker's section holds points with the trailing ankle below
    the ground; walked, one ends its first step ``scuffing``, a fault of the
    start. Refused before anything is traced or written, naming a state on the
    edge (both feet flat: psi_2 = -psi)."""
    monkeypatch.chdir(tmp_path)
    sunk = 'name = "walk"\nmodel = "flatfoot_heel_rise"\n[simulate]\nv0 = [0.3245, 0.0, -0.3734]\n'
    (tmp_path / "walk.toml").write_text(sunk)
    assert cli.main(["simulate", "walk.toml", "--steps", "2", "--out", "out"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1, err
    assert ("walk.toml: [simulate] v0 = [0.3245, 0.0, -0.3734] is not a state of the flatfoot_heel_rise walker "
            "(outside its section; a state on the section's edge: [0.3245, -0.3245, -0.3734])") in err
    assert listing(tmp_path) == ["walk.toml"]

    model = get_model("flatfoot_heel_rise")
    params = model.default_params()
    simulate.check_start(model, params, [0.3245, -0.3245, -0.3734], "here")  # on the edge: a state
    simulate.check_start(model, params, [0.3245, -0.5, -0.3734], "here")  # ankle 2 above the ground
    with pytest.raises(ConfigError, match=r"^here v0 = \[0.3245, -0.2, -0.3734\] is not a state"):
        simulate.check_start(model, params, [0.3245, -0.2, -0.3734], "here")
