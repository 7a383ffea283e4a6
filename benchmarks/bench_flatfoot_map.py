"""Benchmark: the flat-foot walker's 64 x 64 (l_f, r) lambda_max map, as users run it.

Issue 4's measure: the whole map (fixed point + Jacobian + eigenvalues at each of
4096 configs, continuation along r, seed line along l_f), run by the real
command ``jaxwalk sweep sweeps/flatfoot_lf_r_map.toml`` in a subprocess:

1. **cold**: an empty persistent compilation cache, two CPU devices: wall time
   (compile + run) and peak resident memory (``wait4``'s ``ru_maxrss``);
2. **warm**: the same command again with the cache that run filled: what a
   rerun, or any later run of a same-shaped grid, costs (tracing, loading the
   compiled programs, the run). ``compile = cold - warm``; configs per second
   = 4096 / warm. The two datasets must be equal bit for bit.
3. **second core**: a sub-map (every 4th l_f line: 16 lines x 64 r) in one
   process per device count (2, then 1), each running the sweep twice
   (``jaxwalk.sweep.run_sweep``): the first call traces, compiles (or loads)
   and runs, the second only runs. Speed-up = the one-device run over the
   two-device run, second calls; the first calls' excess is the fixed cost
   of tracing and loading a run pays before computing anything.

    PYTHONPATH=. python benchmarks/bench_flatfoot_map.py [--chunk-size 1024] [--out DIR] [--part map|second-core]

Writes ``benchmarks/results/flatfoot_map.json``; the map itself is left in
``DIR/flatfoot_lf_r_map.zarr`` (default a temporary directory).
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import tempfile
import time
import tomllib
from pathlib import Path

import numpy as np
import xarray as xr

ROOT = Path(__file__).resolve().parents[1]
CONFIG = ROOT / "sweeps" / "flatfoot_lf_r_map.toml"


def _toml(value) -> str:
    """The TOML text of the values a sweep config holds (str, bool, numbers, lists, tables)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return json.dumps(value)
    if isinstance(value, (int, float)):
        return repr(value)
    if isinstance(value, list):
        return "[" + ", ".join(_toml(v) for v in value) + "]"
    if isinstance(value, dict):
        return "{ " + ", ".join(f"{k} = {_toml(v)}" for k, v in value.items()) + " }"
    raise TypeError(f"no TOML form for {value!r}")


def write_sub_map(config: dict, path: Path, every: int = 4) -> int:
    """The map's config with every ``every``-th l_f line; returns the point count."""
    lf = config["grid"]["l_f"]
    values = np.linspace(lf["start"], lf["stop"], lf["num"])[::every]
    grid = dict(config["grid"], l_f={"values": [float(v) for v in values]})
    lines = [f'name = "{config["name"]}_sub"', f'model = "{config["model"]}"', "", "[grid]"]
    lines += [f"{k} = {_toml(v)}" for k, v in grid.items()]
    lines += ["", "[analysis]"] + [f"{k} = {_toml(v)}" for k, v in config["analysis"].items()]
    path.write_text("\n".join(lines) + "\n")
    return len(values) * grid["r"]["num"]


def cache_entries(cache: Path) -> int:
    return sum(1 for _ in cache.rglob("*")) if cache.exists() else 0


def _environment(cache: Path, devices: int) -> dict:
    """A child's environment: this package, the compile cache, ``devices`` CPU devices."""
    env = dict(os.environ)
    env.update(
        PYTHONPATH=os.pathsep.join(filter(None, [str(ROOT), env.get("PYTHONPATH")])),
        JAX_COMPILATION_CACHE_DIR=str(cache),
        EQX_ON_ERROR="nan",
        XLA_FLAGS=f"--xla_force_host_platform_device_count={devices}",
    )
    return env


def run_sweep(config: Path, out: Path, cache: Path, devices: int, chunk: int) -> dict:
    """``jaxwalk sweep`` in a subprocess: wall time, peak RSS, cache entries added."""
    env = _environment(cache, devices)
    cmd = [sys.executable, "-m", "jaxwalk", "sweep", str(config), "--out", str(out), "--overwrite"]
    cmd += ["--no-plot", "--no-progress", "--chunk-size", str(chunk)]
    before = cache_entries(cache)
    t0 = time.perf_counter()
    proc = subprocess.Popen(cmd, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    output = proc.stdout.read()
    _, status, usage = os.wait4(proc.pid, 0)
    wall = time.perf_counter() - t0
    if os.waitstatus_to_exitcode(status) != 0:
        raise SystemExit(f"sweep failed ({config.name}, {devices} device(s)):\n{output}")
    return {"wall_s": wall, "peak_rss_gb": usage.ru_maxrss / 2**20, "compiled": cache_entries(cache) > before}


def inner_run(config: Path, out: Path, chunk: int) -> None:
    """In this process: the sweep twice, timed; prints one JSON line."""
    import jax

    from jaxwalk.sweep.runner import run_sweep

    times = []
    for _ in range(2):
        t0 = time.perf_counter()
        run_sweep(config, out, progress=False, plot=False, overwrite=True, chunk_size=chunk, command="bench")
        times.append(time.perf_counter() - t0)
    print(json.dumps({"devices": jax.device_count(), "first_s": times[0], "run_s": times[1]}))


def second_core(config: Path, tmp: Path, cache: Path, chunk: int) -> dict:
    """The sub-map's run time on two devices and on one (:func:`inner_run` in a subprocess each)."""
    out = {}
    for devices in (2, 1):
        env = _environment(cache, devices)
        cmd = [sys.executable, __file__, "--inner", str(config), "--out", str(tmp / f"sub{devices}"), "--chunk-size", str(chunk)]
        proc = subprocess.run(cmd, env=env, capture_output=True, text=True)
        if proc.returncode:
            raise SystemExit(f"sub-map run on {devices} device(s) failed:\n{proc.stderr[-2000:]}")
        out[devices] = json.loads(proc.stdout.strip().splitlines()[-1])
        print(f"sub-map on {devices} device(s): first call {out[devices]['first_s']:.1f} s, run {out[devices]['run_s']:.1f} s", flush=True)
    return {"two_devices": out[2], "one_device": out[1], "speedup": out[1]["run_s"] / out[2]["run_s"]}


def statuses(path: Path) -> dict:
    with xr.open_zarr(path) as ds:
        status = ds["status"].values
        return {
            "status": status,
            "lambda_max": ds["lambda_max"].values,
            "counts": {str(s): int(n) for s, n in zip(*np.unique(status, return_counts=True))},
        }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--chunk-size", type=int, default=1024, help="grid points per block (default 1024: 16 lines)")
    parser.add_argument("--out", type=Path, default=None, help="where the map is written (default: a temporary directory)")
    parser.add_argument("--part", choices=("all", "map", "second-core"), default="all", help="what to measure (default all)")
    parser.add_argument("--inner", type=Path, default=None, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.inner is not None:
        return inner_run(args.inner, args.out, args.chunk_size)
    config = tomllib.loads(CONFIG.read_text())
    n_points = config["grid"]["l_f"]["num"] * config["grid"]["r"]["num"]
    path = ROOT / "benchmarks" / "results" / "flatfoot_map.json"
    result = json.loads(path.read_text()) if path.exists() and args.part != "all" else {}
    result.update(
        date=time.strftime("%Y-%m-%d"),
        machine={"cpus": os.cpu_count(), "platform": platform.platform(), "python": platform.python_version()},
        config=str(CONFIG.relative_to(ROOT)),
        points=n_points,
        chunk_size=args.chunk_size,
    )

    with tempfile.TemporaryDirectory(prefix="jaxwalk-bench-") as tmp:
        tmp = Path(tmp)
        cache, out = tmp / "cache", args.out or tmp / "map"
        if args.part in ("all", "map"):
            cold = run_sweep(CONFIG, tmp / "cold", cache, 2, args.chunk_size)
            print(f"cold map: {cold['wall_s']:.1f} s, peak RSS {cold['peak_rss_gb']:.2f} GB", flush=True)
            warm = run_sweep(CONFIG, out, cache, 2, args.chunk_size)
            print(f"warm map: {warm['wall_s']:.1f} s, peak RSS {warm['peak_rss_gb']:.2f} GB", flush=True)
            name = config["name"] + ".zarr"
            a, b = statuses(tmp / "cold" / name), statuses(out / name)
            identical = bool(
                np.array_equal(a["status"], b["status"]) and np.array_equal(a["lambda_max"], b["lambda_max"], equal_nan=True)
            )
            result.update(
                cold=cold,
                warm=warm,
                compile_s=cold["wall_s"] - warm["wall_s"],
                configs_per_s=n_points / warm["wall_s"],
                cold_equals_warm=identical,
                statuses=b["counts"],
            )
        if args.part in ("all", "second-core"):
            sub = tmp / "sub_map.toml"
            n_sub = write_sub_map(config, sub)
            result["sub_map"] = {"points": n_sub, **second_core(sub, tmp, cache, args.chunk_size)}

    path.write_text(json.dumps(result, indent=2) + "\n")
    if "warm" in result:
        print(
            f"map {n_points} points: cold {result['cold']['wall_s']:.1f} s, warm {result['warm']['wall_s']:.1f} s "
            f"({result['configs_per_s']:.2f} configs/s), peak RSS cold {result['cold']['peak_rss_gb']:.2f} / "
            f"warm {result['warm']['peak_rss_gb']:.2f} GB, identical {result['cold_equals_warm']}"
        )
    if "sub_map" in result:
        print(f"second core: {result['sub_map']['speedup']:.2f}x (sub-map run, {result['sub_map']['points']} points)")


if __name__ == "__main__":
    main()
