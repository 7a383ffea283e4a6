"""Sweeps at scale: chunks streamed to the store, a killed run continued to the same
dataset, a run of a different sweep refused, a Dask cluster's run equal to a local
one, and configs too large for the disk refused before anything is written."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest
import xarray as xr

from jaxwalk import analyses, cli
from jaxwalk.models import get_model
from jaxwalk.sweep import loads_config, run_sweep
from jaxwalk.sweep.dataset import build_dataset, write_zarr
from jaxwalk.sweep.runner import analysis_options
from jaxwalk.sweep.store import partial_path

from tests.conftest import COMPASS_2D, ROOT, RUN_ATTRS



def opened(path):
    with xr.open_dataset(path, engine="zarr") as ds:
        return ds.load()


def assert_same_dataset(a, b, *, attrs=True):
    """Every variable and coordinate equal bit for bit (NaNs included), same dims,
    dtypes and variable attributes; global attributes too, but for the run's own."""
    assert sorted(a.variables) == sorted(b.variables)
    for name in a.variables:
        x, y = a[name], b[name]
        assert x.dims == y.dims and x.dtype == y.dtype and x.attrs == y.attrs, name
        if x.dtype.kind in "fc":
            np.testing.assert_array_equal(x.values.view(np.uint8), y.values.view(np.uint8), err_msg=name)
        else:
            np.testing.assert_array_equal(x.values, y.values, err_msg=name)
    if attrs:
        strip = lambda d: {k: v for k, v in d.attrs.items() if k not in RUN_ATTRS}
        assert strip(a) == strip(b)


def listing(path):
    return sorted(str(p.relative_to(path)) for p in path.rglob("*"))


class Killed(BaseException):
    """Stands for kill -9 in the middle of a run (nothing after it runs: no cleanup)."""


# ---------------------------------------------------------------- streaming, with the fake analysis


def test_streamed_chunks_equal_the_in_memory_dataset(tmp_path, fake_analysis):
    config = loads_config(COMPASS_2D)
    fake = fake_analysis(fail_above=15.0)
    path = run_sweep(config, tmp_path / "s", progress=False, analyse=fake, plot=False, chunk_size=4)
    # Continuation along gamma: every chunk holds whole gamma lines (one here, 4 // 5 -> 1).
    assert len(fake.calls) == 7
    for call in fake.calls:
        np.testing.assert_array_equal(call["grid"]["gamma"], config.grid["gamma"])
        assert len(call["grid"]["m_h"]) == 1

    model = get_model("compass")
    full = fake_analysis(fail_above=15.0)(model, config.fixed, config.grid, "gamma", analysis_options(config))
    results = analyses.check_block(full, config.shape, len(model.section_names), analyses.active(config))
    options = dict(json.loads(opened(path).attrs["analysis_options"]))
    reference = write_zarr(build_dataset(config, model, results, options=options), tmp_path / "m" / "grid2d.zarr")
    assert_same_dataset(opened(path), opened(reference))
    assert opened(path)["lambda_max"].encoding["chunks"] == (1, 5)
    assert sorted(p.name for p in (tmp_path / "s").iterdir()) == ["grid2d.zarr"]  # no partial left


def test_killed_while_writing_continues_to_the_same_dataset(tmp_path, fake_analysis, monkeypatch, capsys):
    import zarr

    config = loads_config(COMPASS_2D.replace('"gamma"', "false"))  # independent points: 35 in chunks of 4
    whole = run_sweep(config, tmp_path / "whole", progress=False, analyse=fake_analysis(), plot=False, chunk_size=4)

    names = set(opened(whole).data_vars)
    original = zarr.Array.__setitem__
    writes = []

    def dies_in_the_fourth_chunk(self, selection, value):
        if self.path in names and type(self.store).__name__ == "LocalStore":  # a chunk's data, not the template's
            writes.append(self.path)
            if len(writes) == 3 * len(names) + 5:  # dies after 5 of chunk 3's variables
                raise Killed()
        original(self, selection, value)

    monkeypatch.setattr(zarr.Array, "__setitem__", dies_in_the_fourth_chunk)
    out = tmp_path / "out"
    first = fake_analysis()
    with pytest.raises(Killed):
        run_sweep(config, out, progress=False, analyse=first, plot=False, chunk_size=4)
    monkeypatch.undo()
    partial = partial_path(out / "grid2d.zarr")
    assert not (out / "grid2d.zarr").exists()
    assert sorted(os.listdir(partial / "done")) == ["0", "1", "2"]  # chunk 3 half written, not done
    # zarr writes a chunk file under a temporary name first; a kill can leave one.
    torn = partial / "grid2d.zarr" / "period" / "c" / "6" / "1.0123456789abcdef.partial"
    torn.parent.mkdir(parents=True, exist_ok=True)
    torn.write_bytes(b"torn")

    again = fake_analysis()
    path = run_sweep(config, out, progress=True, analyse=again, plot=False, chunk_size=4)
    # Chunks of 1 x 4 points (7 x 2 of them, the second of each row 1 point): 0, 1, 2 were done.
    assert len(again.calls) == 14 - 3  # only the chunks not done
    assert " 9/35" in capsys.readouterr().err  # the bar starts at the points already done
    assert_same_dataset(opened(path), opened(whole))
    assert "continued (3 of 14 chunks were done)" in opened(path).attrs["history"]
    assert not list(path.rglob("*.partial")) and not partial.exists()


def test_a_different_sweep_over_an_unfinished_one_is_refused(tmp_path, fake_analysis, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "sweep.toml").write_text(COMPASS_2D)
    fake = fake_analysis(error=None)
    calls = []

    def dies_after_two_chunks(*args, **kwargs):
        if len(calls) == 2:
            raise Killed()
        calls.append(1)
        return fake(*args, **kwargs)

    import jaxwalk.grid

    monkeypatch.setattr(jaxwalk.grid, "analyse_grid", dies_after_two_chunks)
    argv = ["sweep", "sweep.toml", "--out", "res", "--no-progress", "--no-plot", "--chunk-size", "5"]
    with pytest.raises(Killed):
        cli.main(argv)
    before = listing(tmp_path)
    for change, what in [
        (lambda t: t.replace("num = 7", "num = 8"), "config"),
        (lambda t: t + "rtol = 1e-9\n", "config, analysis options"),
        (None, "analysis options, chunk shape (--chunk-size)"),
    ]:
        (tmp_path / "sweep.toml").write_text(change(COMPASS_2D) if change else COMPASS_2D)
        args = argv[:-1] + ["10"] if change is None else argv
        assert cli.main(args) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and f"holds an unfinished run of a different sweep ({what} differ)" in err
        assert "pass --overwrite to discard it" in err
        assert listing(tmp_path) == before  # nothing written, nothing removed

    # The same config after jaxwalk's code changed (a killed run, an edit, the same command):
    # the chunks done by the old code are not continued with the new one's.
    import jaxwalk.files

    (tmp_path / "sweep.toml").write_text(COMPASS_2D)
    digest = jaxwalk.files.source_digest
    monkeypatch.setattr(jaxwalk.files, "source_digest", lambda: "the code after an edit")
    assert cli.main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "holds an unfinished run of a different sweep (jaxwalk source differ)" in err
    assert "jaxwalk's code has changed since it started: run it with that code to continue it" in err
    assert listing(tmp_path) == before
    monkeypatch.setattr(jaxwalk.files, "source_digest", digest)

    # --overwrite discards it and starts over; the same command continues it.
    monkeypatch.setattr(jaxwalk.grid, "analyse_grid", fake_analysis())
    (tmp_path / "sweep.toml").write_text(COMPASS_2D.replace("num = 7", "num = 8"))
    assert cli.main(argv + ["--overwrite"]) == 0
    assert opened(tmp_path / "res" / "grid2d.zarr").sizes["m_h"] == 8
    assert not partial_path(tmp_path / "res" / "grid2d.zarr").exists()


def test_not_enough_disk_space(tmp_path, monkeypatch, capsys):
    import shutil

    monkeypatch.chdir(tmp_path)
    (tmp_path / "sweep.toml").write_text(COMPASS_2D)
    usage = shutil.disk_usage(tmp_path)
    monkeypatch.setattr(shutil, "disk_usage", lambda path: usage._replace(free=10_000))
    before = listing(tmp_path)
    assert cli.main(["sweep", "sweep.toml", "--out", "res/deeper", "--no-plot"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("jaxwalk: error: the dataset needs up to ")
    assert f"(1 chunk of 7 x 5 points, uncompressed) but '{tmp_path}' has 10 KB free" in err
    assert listing(tmp_path) == before


@pytest.mark.parametrize(
    "config, fragment",
    [
        (COMPASS_2D.replace("[analysis]", "[params]\nm_h = 10.0\n[analysis]"),
         "parameter 'm_h' is both fixed in [params] and swept in [grid]"),
        (COMPASS_2D.replace("m_h =", "mh ="), "[grid]: unknown parameter 'mh' for model 'compass' (did you mean 'm_h'?)"),
        (COMPASS_2D.replace("start = 0.01", "start = -0.6"), "[grid] axis 'gamma': start"),
        (COMPASS_2D.replace("num = 7", "num = 4000").replace("num = 5", "num = 4000"),
         "has 16,000,000 points (4000 x 4000), more than the limit of 10,000,000; its results alone would take about"),
    ],
    ids=["fixed-and-swept", "unknown-parameter", "nonphysical", "too-large-for-memory"],
)
def test_bad_configs_through_the_cli(tmp_path, monkeypatch, capsys, config, fragment):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "sweep.toml").write_text(config)
    before = listing(tmp_path)
    assert cli.main(["sweep", "sweep.toml", "--out", "res"]) == 2
    captured = capsys.readouterr()
    assert captured.out == "" and captured.err.count("\n") == 1 and fragment in captured.err
    assert listing(tmp_path) == before


def test_grid_larger_than_any_disk_subprocess(run_cli, tmp_path):
    """The real free space of the real disk: 10^15 points cannot fit."""
    axes = "\n".join(f"{p} = {{ start = {a}, stop = {b}, num = 100000 }}"
                     for p, a, b in [("m_h", 5.0, 20.0), ("m", 2.0, 8.0), ("gamma", 0.01, 0.05)])
    (tmp_path / "sweep.toml").write_text(f'name = "huge"\nmodel = "compass"\n[grid]\n{axes}\n[analysis]\ncontinuation = false\n')
    before = listing(tmp_path)
    proc = run_cli("sweep", "sweep.toml", "--out", "res", "--max-points", str(10**16))
    assert proc.returncode == 2, proc.stderr
    lines = proc.stderr.splitlines()
    assert len(lines) == 1 and lines[0].startswith("jaxwalk: error: the dataset needs up to "), proc.stderr
    assert "TB on disk" in lines[0] and "free" in lines[0]
    assert listing(tmp_path) == before


def test_local_workers_get_one_device_each(monkeypatch):
    from jaxwalk.sweep.chunks import local_worker_env

    monkeypatch.setenv("XLA_FLAGS", "--xla_cpu_foo=1 --xla_force_host_platform_device_count=8")
    assert local_worker_env() == {"XLA_FLAGS": "--xla_cpu_foo=1 --xla_force_host_platform_device_count=1"}


def test_unreachable_scheduler_is_one_line(tmp_path, monkeypatch, capsys):
    pytest.importorskip("distributed")
    monkeypatch.chdir(tmp_path)
    (tmp_path / "sweep.toml").write_text(COMPASS_2D)
    monkeypatch.setattr("jaxwalk.sweep.chunks.CONNECT_TIMEOUT", "1s")
    assert cli.main(["sweep", "sweep.toml", "--out", "res", "--no-plot", "--dask", "tcp://127.0.0.1:9"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--dask tcp://127.0.0.1:9: cannot reach the scheduler" in err
    assert listing(tmp_path) == ["sweep.toml"]


# ---------------------------------------------------------------- the real analysis: kill -9, Dask

SMALL = """
name = "small"
model = "simplest"
[grid]
gamma = { start = 0.004, stop = 0.016, num = 24 }
[analysis]
continuation = false
"""
#: One point per chunk: 24 chunks, so a kill lands well before the end.
ARGS = ["--chunk-size", "1", "--no-plot", "--no-progress"]


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    """An uninterrupted run, in this process (it also fills the persistent
    compilation cache that the subprocesses and Dask workers then read)."""
    d = tmp_path_factory.mktemp("reference")
    (d / "sweep.toml").write_text(SMALL)
    assert cli.main(["sweep", str(d / "sweep.toml"), "--out", str(d / "res"), *ARGS]) == 0
    return opened(d / "res" / "small.zarr")


def _env():
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(ROOT), env.get("PYTHONPATH")]))
    return env


@pytest.mark.slow
def test_killed_run_continues_to_the_same_dataset(reference, tmp_path):
    (tmp_path / "sweep.toml").write_text(SMALL)
    target = tmp_path / "res" / "small.zarr"
    done = partial_path(target) / "done"
    argv = ["sweep", str(tmp_path / "sweep.toml"), "--out", str(tmp_path / "res"), *ARGS]
    proc = subprocess.Popen([sys.executable, "-m", "jaxwalk", *argv], env=_env(), stdout=subprocess.DEVNULL,
                            stderr=subprocess.PIPE)
    deadline = time.monotonic() + 300
    while not (done.is_dir() and os.listdir(done)):  # at least one chunk on disk
        assert proc.poll() is None, proc.stderr.read().decode()
        assert time.monotonic() < deadline
        time.sleep(0.005)
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    n_done = len(os.listdir(done))
    assert 1 <= n_done < 24 and not target.exists()

    assert cli.main(argv) == 0  # the same command: continues
    ds = opened(target)
    assert_same_dataset(ds, reference)  # two runs of one config, one of them killed: the same numbers
    assert (ds["status"] == 0).sum() > 20
    assert "continued" in ds.attrs["history"] and not partial_path(target).exists()


@pytest.mark.slow
def test_dask_local_cluster_equals_local_run(reference, tmp_path):
    distributed = pytest.importorskip("distributed")

    (tmp_path / "sweep.toml").write_text(SMALL)
    # Workers with this process's environment (``--dask local`` gives each one
    # device instead): the persistent compilation cache's key includes the device
    # count, so they load the program the reference run compiled.
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
        argv = ["sweep", str(tmp_path / "sweep.toml"), "--out", str(tmp_path / "res"), *ARGS, "--dask", cluster.scheduler_address]
        assert cli.main(argv) == 0
    assert_same_dataset(opened(tmp_path / "res" / "small.zarr"), reference)
