"""Traced programs on disk (``jaxwalk.program_cache``): a rerun loads instead of
tracing, computes the same numbers, and a change to anything the trace depends
on traces afresh. Compass walker (seconds to trace and compile)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import jax
import numpy as np
import pytest

from jaxwalk import grid as G
from jaxwalk import cache, files, program_cache
from jaxwalk.lines import segment_inputs, segment_program
from jaxwalk.models.compass import CompassWalker

ROOT = Path(__file__).resolve().parents[1]
GRID = {"gamma": np.linspace(0.03, 0.06, 8), "m_h": np.array([8.0, 12.0])}
OPTIONS = G.AnalysisOptions()


class CachedCompass(CompassWalker):
    """A class of its own: its programs are this module's, whatever other tests compiled."""

    name = "compass"


MODEL = CachedCompass()

# In a fresh process: the same analysis, counting the traces the disk cache let through.
RERUN = """
import json, sys
import numpy as np
from jaxwalk import grid as G, program_cache
from tests.test_program_cache import GRID, MODEL, OPTIONS
traced = []
original = program_cache.export.export
program_cache.export.export = lambda f, *a, **k: traced.append(1) or original(f, *a, **k)
out = G.analyse_grid(MODEL, {}, GRID, "gamma", OPTIONS)
np.save(sys.argv[1], out["lambda_max"])
print(json.dumps({"traced": len(traced), "ok": int((out["status"] == 0).sum())}))
"""


@pytest.fixture
def disk_cache(tmp_path, monkeypatch):
    before = cache.directory()
    monkeypatch.setenv("EQX_ON_ERROR", "nan")
    monkeypatch.setenv(cache.ENV, str(tmp_path))  # for the rerun's process; restored after
    cache.configure(tmp_path)
    yield tmp_path / "jaxwalk-programs"
    cache.configure(before, enabled=before is not None)


def test_a_rerun_loads_the_program_and_computes_the_same(disk_cache, tmp_path):
    first = G.analyse_grid(MODEL, {}, GRID, "gamma", OPTIONS)
    assert (first["status"] == 0).sum() >= 12
    saved = list(disk_cache.glob("*.jaxexport"))
    assert len(saved) == 1  # one program (continuation) at one shape

    env = dict(os.environ, PYTHONPATH=os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")])))
    proc = subprocess.run(
        [sys.executable, "-c", RERUN, str(tmp_path / "rerun.npy")], cwd=ROOT, env=env, capture_output=True, text=True, timeout=600
    )
    assert proc.returncode == 0, proc.stderr[-2000:]
    report = json.loads(proc.stdout.strip().splitlines()[-1])
    assert report["traced"] == 0  # loaded from disk
    np.testing.assert_array_equal(np.load(tmp_path / "rerun.npy"), first["lambda_max"])
    assert list(disk_cache.glob("*.jaxexport")) == saved


def test_exported_program_equals_the_traced_one(disk_cache):
    program = segment_program(MODEL, OPTIONS.solver, OPTIONS.newton)
    lines = {k: v.T for k, v in G.parameter_grid(MODEL, {}, GRID).items()}  # (m_h, gamma): lines along gamma
    rows = segment_inputs(MODEL, lines, GRID["gamma"], seed=3)[0][0]
    plain = program(rows)
    exported = program_cache.lower(program, rows).compile()(rows)
    for a, b in zip(jax.tree_util.tree_leaves(plain), jax.tree_util.tree_leaves(exported)):
        np.testing.assert_array_equal(np.asarray(a), np.asarray(b))
    assert (np.asarray(plain[1].status) == 0).sum() >= 12  # (carry, gaits)


def test_key_follows_what_the_trace_depends_on(monkeypatch):
    program = segment_program(MODEL, OPTIONS.solver, OPTIONS.newton)
    rows = {"a": np.zeros((2, 8)), "b": np.zeros((2, 8), bool)}
    key = program_cache.program_key(program, rows)
    assert key == program_cache.program_key(program, {"a": np.ones((2, 8)), "b": np.ones((2, 8), bool)})  # values: no
    assert key != program_cache.program_key(program, {"a": np.zeros((4, 8)), "b": np.zeros((4, 8), bool)})  # shapes
    assert key != program_cache.program_key(program, {"a": np.zeros((2, 8), np.float32), "b": np.zeros((2, 8), bool)})
    other_settings = segment_program(MODEL, replace(OPTIONS.solver, rtol=OPTIONS.solver.rtol * 10), OPTIONS.newton)
    assert key != program_cache.program_key(other_settings, rows)
    assert program_cache.program_key(jax.jit(lambda x: x), rows) is None  # not registered: never cached
    # The model's source outside jaxwalk (this file) is part of the key ...
    assert str(Path(__file__).resolve()) in files.model_sources(CachedCompass)
    # ... and jaxwalk's own source and the libraries' versions are.
    monkeypatch.setattr(program_cache, "_environment_hash", lambda: "another jaxwalk")
    assert key != program_cache.program_key(program, rows)


def test_a_damaged_file_is_traced_afresh(disk_cache):
    program = jax.jit(lambda p: p["x"] * 2.0)
    program_cache.register(program, "test_double", MODEL)
    args = {"x": np.arange(3.0)}
    path = disk_cache / f"{program_cache.program_key(program, args)}.jaxexport"
    disk_cache.mkdir(parents=True)
    path.write_bytes(b"half a file")  # as a run killed while writing would leave, were writes not atomic
    out = program_cache.lower(program, args).compile()(args)
    np.testing.assert_array_equal(np.asarray(out), [0.0, 2.0, 4.0])
    assert program_cache._load(path) is not None  # rewritten whole


def test_off_without_the_caches_or_with_host_callbacks(monkeypatch, tmp_path):
    before = cache.directory()
    try:
        cache.configure(enabled=False)
        assert program_cache.cache_directory() is None
        cache.configure(tmp_path)
        monkeypatch.setenv("EQX_ON_ERROR", "raise")  # equinox's checks are host callbacks: nothing to keep
        assert program_cache.cache_directory() is None
        monkeypatch.setenv("EQX_ON_ERROR", "nan")
        assert program_cache.cache_directory() == tmp_path / "jaxwalk-programs"
    finally:
        cache.configure(before, enabled=before is not None)
