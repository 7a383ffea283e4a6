"""Where a benchmark's figures go: ``benchmarks/results/<name>.json``, with the
machine and versions that produced them (shared by the benchmark scripts)."""

from __future__ import annotations

import json
import os
import platform
import time

import numpy as np


def machine() -> dict:
    """Cores, platform and Python of this machine."""
    return {"cpus": os.cpu_count(), "platform": platform.platform(), "python": platform.python_version()}


def write_result(name: str, result: dict) -> str:
    """Write ``result`` as indented JSON to ``benchmarks/results/<name>.json``; return the path."""
    path = os.path.join(os.path.dirname(os.path.abspath(__file__)), "results", f"{name}.json")
    with open(path, "w") as fh:
        json.dump(result, fh, indent=2)
        fh.write("\n")
    return path


def write_stamped(name: str, result: dict) -> str:
    """:func:`write_result` with the machine, its load, the versions and the date added; prints the path."""
    import jax

    import jaxwalk

    result.update(machine=machine(), load_average=os.getloadavg(),
                  versions={"jaxwalk": jaxwalk.__version__, "jax": jax.__version__},
                  date=time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()))
    path = write_result(name, result)
    print("wrote", path)
    return path


def time_compiled(program, args, repeat: int):
    """``(compile_s, best_run_s, out)``: ``program`` (jitted) compiled for ``args``
    by ``lower().compile()``, then run ``repeat`` times (best time kept; compile apart)."""
    import jax

    t0 = time.perf_counter()
    compiled = program.lower(args).compile()
    compile_s = time.perf_counter() - t0
    best, out = np.inf, None
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = jax.block_until_ready(compiled(args))
        best = min(best, time.perf_counter() - t0)
    return compile_s, best, out
