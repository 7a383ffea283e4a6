"""The notebook API: jaxwalk.sweep returns the dataset the CLI writes, from a path,
TOML text or a dict, writing nothing without ``out``; bad input raises the one
documented exception, jaxwalk.ConfigError, with the CLI's one-line message.
With the fake analysis: nothing compiles."""

from __future__ import annotations

import tomllib

import numpy as np
import pytest
import xarray as xr

import jaxwalk
import jaxwalk.grid
from jaxwalk import cli
from tests.conftest import COMPASS_2D as SWEEP, RUN_ATTRS



def assert_same(a: xr.Dataset, b: xr.Dataset, run_attrs=RUN_ATTRS) -> None:
    assert sorted(a.variables) == sorted(b.variables)
    for name in a.variables:
        x, y = a[name], b[name]
        assert x.dims == y.dims and x.dtype == y.dtype and x.attrs == y.attrs, name
        np.testing.assert_array_equal(x.values, y.values, err_msg=name)
    strip = lambda d: {k: v for k, v in d.attrs.items() if k not in run_attrs}
    assert strip(a) == strip(b)


@pytest.fixture
def cli_store(tmp_path, monkeypatch, fake_analysis):
    monkeypatch.setattr(jaxwalk.grid, "analyse_grid", fake_analysis(fail_above=15.0))
    (tmp_path / "sweep.toml").write_text(SWEEP)
    assert cli.main(["sweep", str(tmp_path / "sweep.toml"), "--out", str(tmp_path / "cli"), "--no-plot", "--no-progress"]) == 0
    with xr.open_dataset(tmp_path / "cli" / "grid2d.zarr", engine="zarr") as ds:
        return ds.load()


@pytest.mark.parametrize("form", ["path", "text", "dict"])
def test_sweep_returns_the_cli_store(cli_store, tmp_path, monkeypatch, fake_analysis, form):
    config = {"path": tmp_path / "sweep.toml", "text": SWEEP, "dict": tomllib.loads(SWEEP)}[form]
    monkeypatch.chdir(tmp_path / "cli")
    before = sorted(p.name for p in tmp_path.rglob("*"))
    ds = jaxwalk.sweep(config, analyse=fake_analysis(fail_above=15.0), progress=False)
    assert isinstance(ds, xr.Dataset)
    # A dict has no TOML text to record (the resolved config is recorded all the same).
    assert_same(ds, cli_store, RUN_ATTRS + (("config_toml",) if form == "dict" else ()))
    assert sorted(p.name for p in tmp_path.rglob("*")) == before  # nothing written without out


def test_sweep_writes_only_to_out(cli_store, tmp_path, fake_analysis):
    ds = jaxwalk.sweep(SWEEP, tmp_path / "api", analyse=fake_analysis(fail_above=15.0), progress=False)
    assert sorted(p.name for p in (tmp_path / "api").iterdir()) == ["grid2d.zarr"]
    assert_same(ds, cli_store)
    assert_same(jaxwalk.open_dataset(tmp_path / "api" / "grid2d.zarr"), cli_store)


BAD = [
    ('name = "x"\nmodel = "nomodel"\n[grid]\ngamma = { start = 0.0, stop = 1.0, num = 3 }\n', "sweep"),
    ('name = "x"\nmodel = "simplest"\n[grid]\ngama = { start = 0.0, stop = 1.0, num = 3 }\n', "sweep"),
    ('name = "x"\nmodel = "simplest"\n[simulate]\nsteps = 0\n', "simulate"),
    ('name = "x"\nmodel = "simplest"\n', "optimize"),
]


@pytest.mark.parametrize("text,command", BAD)
def test_bad_input_raises_config_error_with_the_cli_message(tmp_path, capsys, text, command):
    path = tmp_path / "bad.toml"
    path.write_text(text)
    extra = ["--steps", "2"] if command == "simulate" and "steps" not in text else []
    assert cli.main([command, str(path), "--out", str(tmp_path / "out"), *extra]) == 2
    line = capsys.readouterr().err.strip()
    with pytest.raises(jaxwalk.ConfigError) as err:
        getattr(jaxwalk, command)(path)
    assert line == f"jaxwalk: error: {err.value}"
    assert not (tmp_path / "out").exists()


def test_a_config_of_another_type_is_refused():
    with pytest.raises(jaxwalk.ConfigError, match="expected a path, TOML text or a dict"):
        jaxwalk.sweep(42)
    with pytest.raises(jaxwalk.ConfigError, match="keys must be strings .*got 1"):
        jaxwalk.sweep({1: 2, "name": "x", "model": "simplest"})


@pytest.mark.parametrize("option, value", [("chunk_size", "x"), ("chunk_size", -5), ("chunk_size", 2.5),
                                           ("max_points", "x"), ("max_points", 0), ("max_points", True)])
def test_bad_options_raise_the_one_error_type(option, value):
    """The API's options are checked as the command line's are: a ConfigError, not a TypeError
    from deep inside, nor a value silently clamped."""
    with pytest.raises(jaxwalk.ConfigError, match=f"{option} must be a positive integer"):
        jaxwalk.sweep({"name": "x", "model": "simplest", "grid": {"gamma": {"values": [0.01]}}}, **{option: value})


def test_numpy_integers_are_integers():
    from jaxwalk.api import _count

    assert _count("chunk_size", np.int64(64)) == 64 and _count("chunk_size", None, optional=True) is None


def test_shape_annotations_resolve():
    """The jaxtyping shapes on the result types and core signatures are valid
    annotations (they are strings until asked for: a typo would pass unseen)."""
    import typing

    from jaxwalk import attractor, bifurcation, mechanics, sensitivity, stepbase
    from jaxwalk.flatstep import run_step_flat

    things = [jaxwalk.Gait, jaxwalk.StepResult, stepbase.PhaseEnd, jaxwalk.Transition, attractor.Attractor,
              bifurcation.Bifurcations, sensitivity.GaitMetrics, sensitivity.Sensitivity, jaxwalk.find_gait,
              jaxwalk.step_map, jaxwalk.run_step, run_step_flat, mechanics.impact, mechanics.constrained_accelerations,
              *(getattr(jaxwalk.Walker, m) for m in ("section_to_state", "guard_values", "on_event", "points"))]
    for thing in things:
        hints = typing.get_type_hints(thing)
        assert hints, thing
    assert "n_v n_v" in str(typing.get_type_hints(jaxwalk.Gait)["jacobian"])




def test_solver_options_take_a_diffrax_solver():
    """A diffrax solver object or its name: hashable and equal by value (a jit
    static argument), with a program-cache repr that holds no object address."""
    import diffrax

    a, b = jaxwalk.SolverOptions(solver=diffrax.Dopri8()), jaxwalk.SolverOptions(solver=diffrax.Dopri8())
    assert hash(a) == hash(b) and a == b and a != jaxwalk.SolverOptions(solver=diffrax.Tsit5())
    assert "0x" not in repr(a) and isinstance(a.make_solver(), diffrax.Dopri8)
    assert isinstance(jaxwalk.SolverOptions(solver="tsit5").make_solver(), diffrax.Tsit5)
    with pytest.raises(ValueError, match="dopri8, tsit5, dopri5"):
        jaxwalk.SolverOptions(solver="rk4")
    # A dataset records the solver by name (an object by its repr), never by its fields alone.
    assert jaxwalk.SolverOptions(solver=diffrax.Tsit5()).as_record()["solver"] == "Tsit5()"
    assert jaxwalk.SolverOptions().as_record()["solver"] == "dopri8"
