"""Caches on by default (``jaxwalk.cache``): a second identical CLI run in a fresh
cache directory compiles and traces nothing and writes the same numbers, bit for
bit; an unusable cache directory costs a warning and a compile, never a failure.

Compiles are counted with JAX's own monitoring events (every compile request,
less the persistent cache's hits), traces by :mod:`jaxwalk.program_cache`;
nothing is timed. Simplest walker (compiles in seconds).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from jaxwalk import cache

ROOT = Path(__file__).resolve().parents[1]

# The command line in a fresh process, reporting what it compiled and traced.
PROBE = """
import json, sys
import jax.monitoring
events = {"requests": 0, "hits": 0}
def on_duration(event, secs, **kw):
    events["requests"] += event == "/jax/core/compile/backend_compile_duration"  # hits included
def on_event(event, **kw):
    events["hits"] += event == "/jax/compilation_cache/cache_hits"
jax.monitoring.register_event_duration_secs_listener(on_duration)
jax.monitoring.register_event_listener(on_event)
from jaxwalk import cli, program_cache
status = cli.main(sys.argv[1:])
print(json.dumps({"status": status, "compiled": events["requests"] - events["hits"], **program_cache.counts}))
"""

SWEEP = """
name = "small"
model = "simplest"
[grid]
gamma = {{ start = 0.004, stop = 0.012, num = {num} }}
[analysis]
stability = true
continuation = "gamma"
"""


def run_probe(*args: str, env: dict | None = None) -> tuple[dict, str]:
    """``jaxwalk ARGS`` in a fresh process with nothing set: (its report, its stderr)."""
    base = {k: v for k, v in os.environ.items() if k not in ("JAXWALK_CACHE_DIR", "JAX_COMPILATION_CACHE_DIR", "EQX_ON_ERROR")}
    base["PYTHONPATH"] = os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")]))
    proc = subprocess.run(
        [sys.executable, "-c", PROBE, *args], cwd=ROOT, env={**base, **(env or {})}, capture_output=True, text=True,
        timeout=600,
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    return json.loads(proc.stdout.strip().splitlines()[-1]), proc.stderr


def assert_same_store(a: Path, b: Path) -> None:
    with xr.open_dataset(a, engine="zarr") as x, xr.open_dataset(b, engine="zarr") as y:
        assert set(x.data_vars) == set(y.data_vars)
        for name in x.data_vars:
            np.testing.assert_array_equal(x[name].values, y[name].values, err_msg=name)  # NaN == NaN, bit for bit


@pytest.fixture(scope="module")
def two_runs(tmp_path_factory):
    """The same sweep twice, in a fresh cache directory (given by XDG_CACHE_HOME, as a new user's)."""
    tmp = tmp_path_factory.mktemp("cache")
    config = tmp / "small.toml"
    config.write_text(textwrap.dedent(SWEEP.format(num=8)))
    env = {"XDG_CACHE_HOME": str(tmp / "xdg")}
    runs = [run_probe("sweep", str(config), "--out", str(tmp / f"run{i}"), "--no-plot", "--no-progress", env=env) for i in (1, 2)]
    return tmp, runs


@pytest.mark.slow
def test_a_rerun_compiles_and_traces_nothing_and_is_bit_identical(two_runs):
    tmp, ((first, first_err), (second, second_err)) = two_runs
    assert first["status"] == second["status"] == 0
    compiling = "jaxwalk: compiling the simplest gait search along continuation lines (first run; cached afterwards)"
    assert compiling in first_err and "compiling" not in second_err  # a wait has its reason, a rerun none
    assert first["compiled"] > 0 and first["traced"] > 0  # the counters see a cold run
    assert second["compiled"] == 0 and second["traced"] == 0 and second["loaded"] == first["traced"]
    assert (tmp / "xdg" / "jaxwalk" / cache.PROGRAMS).is_dir()  # in the user's cache directory
    assert_same_store(tmp / "run1" / "small.zarr", tmp / "run2" / "small.zarr")


@pytest.mark.slow
def test_a_sweep_of_a_new_size_compiles_nothing(two_runs):
    """Continuation lines run in segments of 64 visits, every call of one shape
    (jaxwalk.lines): after the 8-point sweep, one of 150 points (three segments)
    reuses its programs."""
    tmp, _ = two_runs
    config = tmp / "resized.toml"
    config.write_text(textwrap.dedent(SWEEP.format(num=150)))
    report, stderr = run_probe(
        "sweep", str(config), "--out", str(tmp / "resized"), "--no-plot", "--no-progress", env={"XDG_CACHE_HOME": str(tmp / "xdg")}
    )
    assert report["status"] == 0 and report["compiled"] == 0 and report["traced"] == 0, stderr[-2000:]
    with xr.open_dataset(tmp / "resized" / "small.zarr", engine="zarr") as ds:
        assert ds.sizes["gamma"] == 150 and (ds.status.values == 0).all()


@pytest.mark.slow
def test_an_unusable_cache_directory_warns_and_computes(tmp_path):
    (tmp_path / "a_file").write_text("")
    config = tmp_path / "tiny.toml"  # no stability, no continuation: the cheapest program to compile
    config.write_text(textwrap.dedent(SWEEP.format(num=2)).replace("true", "false").replace('continuation = "gamma"', ""))
    report, stderr = run_probe(
        "--cache-dir", str(tmp_path / "a_file" / "cache"), "sweep", str(config), "--out", str(tmp_path / "out"),
        "--no-plot", "--no-progress",
    )
    assert report["status"] == 0 and report["compiled"] > 0
    warnings = [line for line in stderr.splitlines() if line.startswith("jaxwalk: warning: cache directory")]
    assert len(warnings) == 1 and "a_file" in warnings[0], stderr[-2000:]
    with xr.open_dataset(tmp_path / "out" / "small.zarr", engine="zarr") as ds:
        assert (ds.status.values == 0).all() and np.isfinite(ds.period.values).all()


@pytest.mark.slow
def test_dry_run_estimates_from_the_previous_run(two_runs):
    tmp, _ = two_runs
    config = tmp / "bigger.toml"
    config.write_text(textwrap.dedent(SWEEP.format(num=300)))
    env = {k: v for k, v in os.environ.items() if k not in ("JAXWALK_CACHE_DIR", "JAX_COMPILATION_CACHE_DIR")}
    env.update(XDG_CACHE_HOME=str(tmp / "xdg"), PYTHONPATH=str(ROOT))
    proc = subprocess.run(
        [sys.executable, "-m", "jaxwalk", "sweep", str(config), "--out", str(tmp / "big"), "--dry-run"],
        cwd=ROOT, env=env, capture_output=True, text=True, timeout=120,
    )
    assert proc.returncode == 0, proc.stderr
    lines = proc.stdout.splitlines()
    assert lines[0] == "small: 300 points (300, simplest model) in 1 chunk of 300"  # whole continuation lines
    assert lines[1].startswith(f"store: {tmp / 'big' / 'small.zarr'}, up to ")
    assert lines[2].startswith("time: about ") and "a previous simplest run" in lines[2] and "programs cached" in lines[2]
    assert not (tmp / "big").exists()  # nothing written


def test_directory_follows_the_environment(monkeypatch, tmp_path):
    monkeypatch.delenv("JAX_COMPILATION_CACHE_DIR", raising=False)
    monkeypatch.delenv(cache.ENV, raising=False)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert cache.default_directory() == tmp_path / "xdg" / "jaxwalk"
    monkeypatch.delenv("XDG_CACHE_HOME")
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    assert cache.default_directory() == tmp_path / "home" / ".cache" / "jaxwalk"
    monkeypatch.setenv("JAX_COMPILATION_CACHE_DIR", str(tmp_path / "jax"))
    assert cache.default_directory() == tmp_path / "jax"
    monkeypatch.setenv(cache.ENV, str(tmp_path / "mine"))
    assert cache.default_directory() == tmp_path / "mine"
    monkeypatch.setenv(cache.ENV, "")
    assert cache.default_directory() is None  # set empty: off


def test_clear_removes_only_cache_files(tmp_path):
    (tmp_path / "abc-cache").write_bytes(b"x" * 10)
    (tmp_path / "abc-atime").write_bytes(b"")
    (tmp_path / cache.PROGRAMS).mkdir()
    (tmp_path / cache.PROGRAMS / "k.jaxexport").write_bytes(b"y" * 5)
    (tmp_path / "notes.txt").write_text("not ours")
    found = cache.info(tmp_path)
    assert (found.compiled_files, found.compiled_bytes, found.traced_files, found.traced_bytes) == (2, 10, 1, 5)
    assert cache.clear(tmp_path) == found
    assert sorted(p.name for p in tmp_path.iterdir()) == ["notes.txt"]
    assert cache.info(tmp_path).compiled_files == 0


def test_cache_command(tmp_path, capsys):
    from jaxwalk.cli import main

    before = cache.directory()
    try:
        (tmp_path / "k-cache").write_bytes(b"z" * 3)
        assert main(["cache", "info", "--cache-dir", str(tmp_path)]) == 0
        assert capsys.readouterr().out.startswith(f"{tmp_path} holds 1 compiled")
        assert main(["--cache-dir", str(tmp_path), "cache", "clear"]) == 0
        assert "removed 1 compiled" in capsys.readouterr().out and not (tmp_path / "k-cache").exists()
        assert main(["cache", "info", "--no-cache"]) == 0
        assert "off" in capsys.readouterr().out
        # A --cache-dir the cache command cannot use is its input's fault: one line, exit 2
        # (not "caches off (--no-cache, or JAXWALK_CACHE_DIR set empty)", a cause not given).
        (tmp_path / "afile").write_text("")
        for action in ("info", "clear"):
            assert main(["cache", action, "--cache-dir", str(tmp_path / "afile")]) == 2
            captured = capsys.readouterr()
            assert captured.out == "" and captured.err.count("\n") == 1
            assert f"--cache-dir '{tmp_path / 'afile'}' cannot be used" in captured.err
        # The same directory from the environment: its fault too, named as such.
        with pytest.MonkeyPatch.context() as mp:
            mp.setenv(cache.ENV, str(tmp_path / "afile"))
            assert main(["cache", "info"]) == 2
            err = capsys.readouterr().err
            assert err.count("\n") == 1 and f"the cache directory '{tmp_path / 'afile'}' ({cache.ENV}, JAX_COMPILATION_CACHE_DIR or the default) cannot be used" in err
    finally:
        cache.configure(before, enabled=before is not None)
