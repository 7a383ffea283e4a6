"""Benchmark: the cost of each global-stability measure per configuration, as a
ratio to the period-1 stability analysis on the same grid (issue 15).

Every timing is wall-clock seconds of one :func:`jaxwalk.grid.analyse_grid`
call over the whole grid (continuation along gamma), the best of ``--repeat``
warm runs; the first call of each setting (compiling or loading its programs,
plus one run) is timed and reported apart; a setting whose warm calls are
short is timed more often (until 10 s of calls). Settings, each timed in turn:

* ``period1``: gaits and multipliers only (``AnalysisOptions()``);
* ``gait_sensitivity``: ``[analysis] gait_sensitivity = true`` (defaults);
* ``mfpt``: ``[analysis] mfpt = { sigma = .. }`` at the walker's sigma from
  ``tests/test_mfpt.py`` (MFPT 20-500 steps at the default parameters);
* ``basin``: ``[analysis] basin = true`` (defaults);
* ``h_max``: ``[analysis] h_max = { step = 0.0005, count = 40, steps = 10 }``
  (``sweeps/simplest_hmax.toml``).

A measure's time includes its period-1 sweep (what a sweep with it costs);
``ratio`` is that time over ``period1_s``, ``extra_per_config_ms`` the measure's
own milliseconds per configuration ((time - period1_s) / configurations).
``work`` counts what each measure computes (step maps, walks), so the ratios
can be read. Walkers: the simplest walker on its slope line and the compass
gait on a small slope x hip-mass grid (the flat-foot walker is left out: its
programs compile for many minutes; benchmarks/README.md).

One CPU device (``--xla_force_host_platform_device_count=1``): run it pinned
to one core (``taskset -c 1``) on a shared machine; ratios in one process are
the figure, absolute seconds depend on the load recorded at start and end.

    PYTHONPATH=. nice -n 10 taskset -c 1 python benchmarks/bench_global_stability.py [--model simplest] [--repeat 2]

Writes ``benchmarks/results/global_stability_<model>.json``.
"""

from __future__ import annotations

import argparse
import os
import sys
import time

os.environ.setdefault("XLA_FLAGS", "--xla_force_host_platform_device_count=1")
sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

import numpy as np  # noqa: E402

import jaxwalk  # noqa: E402,F401
from benchmarks._record import machine, write_result  # noqa: E402
from jaxwalk.analyses.basin import DEFAULTS as BASIN_DEFAULTS  # noqa: E402
from jaxwalk.grid import AnalysisOptions, analyse_grid  # noqa: E402
from jaxwalk.models import get_model  # noqa: E402
from jaxwalk.parameters import parameter_grid  # noqa: E402
from jaxwalk.sweep import loads_config  # noqa: E402
from jaxwalk.sweep.runner import analysis_options  # noqa: E402

H_MAX = {"step": 0.0005, "count": 40, "steps": 10}  # sweeps/simplest_hmax.toml

#: Per walker: fixed parameters, grid, and the MFPT table (sigma from tests/test_mfpt.py;
#: the compass chain on a coarser mesh than the default 15 x 64: 3-D, 15^3 x 64 steps per gait).
WALKERS = {
    "simplest": {
        "fixed": {},
        "grid": lambda n: {"gamma": np.linspace(0.004, 0.015, n)},
        "mfpt": {"sigma": 1.5e-4},
    },
    "compass": {
        "fixed": {"m": 5.0, "a": 0.5, "b": 0.5},
        "grid": lambda n: {"gamma": np.linspace(0.02, 0.075, n), "m_h": np.array([5.0, 20.0])},
        "mfpt": {"sigma": 3e-3, "mesh": 11, "samples": 32},
    },
}


def _toml(value) -> str:
    """A TOML value for the few kinds an ``[analysis]`` table here holds."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, dict):
        return "{ " + ", ".join(f"{k} = {_toml(v)}" for k, v in value.items()) + " }"
    return repr(value)


def options_for(table: dict, name: str, fixed: dict, grid: dict) -> AnalysisOptions:
    """The :class:`AnalysisOptions` a sweep config with this ``[analysis]`` table
    runs with: the config is written as TOML and resolved by the sweep's own
    loader and :func:`jaxwalk.sweep.runner.analysis_options`, so the benchmark
    times exactly what ``jaxwalk sweep`` would run."""
    lines = ['name = "bench"', f'model = "{name}"', "[params]"]
    lines += [f"{k} = {float(v)!r}" for k, v in fixed.items()]
    lines += ["[grid]"] + [f"{k} = {{ values = [{', '.join(repr(float(x)) for x in v)}] }}" for k, v in grid.items()]
    lines += ["[analysis]", 'continuation = "gamma"'] + [f"{k} = {_toml(v)}" for k, v in table.items()]
    return analysis_options(loads_config("\n".join(lines)))


#: Warm calls of a setting go on until they add up to this many seconds (at most
#: MAX_CALLS): a one-second sweep timed once moves with the load by more than the
#: ratios it is compared by.
MIN_WARM_SECONDS = 10.0
MAX_CALLS = 10


def timed(run, repeat: int) -> tuple[float, float, dict]:
    """``(first_s, best_s, result)``: seconds of the first call (compile or load,
    plus one run) and the best of at least ``repeat`` further calls (more, up to
    :data:`MAX_CALLS`, until they add up to :data:`MIN_WARM_SECONDS`)."""
    t0 = time.perf_counter()
    out = run()
    first = time.perf_counter() - t0
    best, spent, calls = np.inf, 0.0, 0
    while calls < repeat or (spent < MIN_WARM_SECONDS and calls < MAX_CALLS):
        t0 = time.perf_counter()
        out = run()
        took = time.perf_counter() - t0
        best, spent, calls = min(best, took), spent + took, calls + 1
    return first, best, out


def mfpt_steps_per_gait(model, res: dict, mfpt_table: dict) -> dict:
    """Step maps one gait's chain takes (fine mesh plus the coarse one of the
    error estimate): ``mesh^d x samples + ((mesh+1)//2)^d x samples/2``, ``d``
    the meshed axes at the first found gait."""
    import jax.numpy as jnp

    from jaxwalk.global_stability.mfpt import MFPTOptions, _linearise_program, principal_mesh
    from jaxwalk.step import SolverOptions

    opts = MFPTOptions(**mfpt_table)
    i = int(np.flatnonzero(res["status"].reshape(-1) == 0)[0])
    v = res["fixed_point"].reshape(-1, res["fixed_point"].shape[-1])[i]
    p = {k: jnp.asarray(np.broadcast_to(x, res["status"].shape).reshape(-1)[i]) for k, x in res["__params__"].items()}
    lin = _linearise_program(model, SolverOptions())(p, jnp.asarray(v))
    d = principal_mesh(np.asarray(lin.J), np.asarray(lin.B), v, opts, opts.mesh).axes.shape[1]
    coarse = (opts.mesh + 1) // 2
    steps = opts.mesh**d * opts.samples + coarse**d * max(2, opts.samples // 2)
    return {"meshed_axes": d, "mesh": opts.mesh, "samples": opts.samples, "span": opts.span, "step_maps_per_gait": steps}


def _range(x) -> list[float] | None:
    x = np.asarray(x, float)
    x = x[np.isfinite(x)]
    return None if x.size == 0 else [float(x.min()), float(x.max())]


def work_of(name: str, model, res: dict, tables: dict) -> dict:
    """What the measure ``name`` computed on the grid (counts from its outputs)."""
    ok = res["status"] == 0
    if name == "period1":
        return {"gaits_found": int(ok.sum()), "stable": int((ok & (res["lambda_max"] < 1)).sum()),
                "newton_iterations": int(res["newton_iterations"].sum())}
    if name == "gait_sensitivity":
        n_v = res["fixed_point"].shape[-1]
        gsn = res["gait_sensitivity_norm"]
        return {"gaits": int(ok.sum()), "finite": int(np.isfinite(gsn).sum()), "range": _range(gsn),
                "per_gait": f"one forward-mode step with {n_v + 1} tangents, 48 Smith doublings ({n_v}x{n_v})"}
    if name == "mfpt":
        per = mfpt_steps_per_gait(model, res, tables["mfpt"])
        return {**per, "gaits": int(ok.sum()), "step_maps": per["step_maps_per_gait"] * int(ok.sum()),
                "mfpt_range": _range(res["mfpt"]), "error_range": _range(res["mfpt_error"]),
                "per_gait": "host loop: linearise, two chains (one batched step program each), sparse solve, eigs"}
    if name == "basin":
        walks = BASIN_DEFAULTS["samples"] + BASIN_DEFAULTS["directions"] * (BASIN_DEFAULTS["scan"] + BASIN_DEFAULTS["bisections"])
        measured = int((res["basin_status"] == 0).sum())
        return {"gaits_measured": measured, "walks_per_gait": walks, "max_steps_per_walk": BASIN_DEFAULTS["steps"],
                "step_maps_at_most": measured * walks * BASIN_DEFAULTS["steps"], "fraction_range": _range(res["basin_fraction"])}
    if name == "h_max":
        h, failed = res["h_max"], np.isfinite(res["h_failed"])
        drops = np.where(ok, np.rint(np.nan_to_num(h) / H_MAX["step"]) + failed, 0)
        return {"drops_tried": int(drops.sum()), "step_maps_at_most": int(drops.sum()) * (1 + H_MAX["steps"]),
                "h_max_range": _range(h)}
    raise KeyError(name)


def bench(name: str, n: int, repeat: int) -> dict:
    """Time the period-1 sweep and each measure on one walker's grid; the result record."""
    spec = WALKERS[name]
    model = get_model(name)
    grid = spec["grid"](n)
    configs = int(np.prod([len(v) for v in grid.values()]))
    tables = {"period1": {}, "gait_sensitivity": {"gait_sensitivity": True}, "mfpt": {"mfpt": spec["mfpt"]},
              "basin": {"basin": True}, "h_max": {"h_max": H_MAX}}
    load_start = os.getloadavg()
    t_start = time.perf_counter()
    rows = {}
    for measure, table in tables.items():
        options = options_for(table, name, spec["fixed"], grid)
        first, best, res = timed(lambda: analyse_grid(model, spec["fixed"], grid, "gamma", options), repeat)
        res["__params__"] = parameter_grid(model, spec["fixed"], grid)
        rows[measure] = {"first_call_s": first, "best_s": best, "per_config_ms": 1e3 * best / configs,
                         "work": work_of(measure, model, res, {"mfpt": spec["mfpt"]})}
        print(f"{name} {measure}: first {first:.2f} s, best {best:.3f} s", flush=True)
    p1 = rows["period1"]["best_s"]
    for row in rows.values():
        row["ratio"] = row["best_s"] / p1
        row["extra_per_config_ms"] = 1e3 * (row["best_s"] - p1) / configs
    return {
        "date": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()),
        "machine": machine(),
        "load_average_start": [round(x, 2) for x in load_start],
        "load_average_end": [round(x, 2) for x in os.getloadavg()],
        "xla_flags": os.environ.get("XLA_FLAGS", ""),
        "grid": {k: [float(v[0]), float(v[-1]), len(v)] for k, v in grid.items()},
        "fixed": spec["fixed"],
        "continuation": "gamma",
        "configurations": configs,
        "repeat": repeat,
        "settings": {k: v for k, v in tables.items() if v},
        "total_s": time.perf_counter() - t_start,
        "measures": rows,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--model", choices=list(WALKERS), action="append", help="walker(s) to time (default: both)")
    parser.add_argument("--n", type=int, default=None, help="gamma points (default: 64 simplest, 6 compass)")
    parser.add_argument("--repeat", type=int, default=2)
    args = parser.parse_args()
    for name in args.model or list(WALKERS):
        n = args.n or {"simplest": 64, "compass": 6}[name]
        result = bench(name, n, args.repeat)
        print(write_result(f"global_stability_{name}", result), flush=True)


if __name__ == "__main__":
    main()
