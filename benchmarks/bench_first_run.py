"""What a new user waits for: cold, rerun and new-size wall times of a sweep
through the command line, with nothing set (issue 11).

Each run is ``python -m jaxwalk sweep CONFIG --out DIR --no-plot --no-progress``
in a fresh process, with no jaxwalk, JAX or equinox variable in its environment
and ``XDG_CACHE_HOME`` pointed at a new directory (a user whose cache is empty):

* cold: the first run (traces, compiles, keeps the programs);
* rerun: the same command again (loads them);
* new size: the same config with another number of points on its first axis;
* no cache: ``--no-cache``, what every run cost before the caches were on by default.

Wall time of the whole process (import included), as a user sees it, and the
programs it compiled (JAX's compile requests less its persistent cache's hits)
and traced (jaxwalk.program_cache), counted as tests/test_cache.py counts them.
The process is ``python -c`` running ``jaxwalk.cli.main`` behind the counters:
what ``python -m jaxwalk`` runs.

    PYTHONPATH=. python benchmarks/bench_first_run.py sweeps/simplest_slope.toml sweeps/compass_slope.toml
    PYTHONPATH=. python benchmarks/bench_first_run.py --skip-no-cache sweeps/flatfoot_lf_r_map.toml
"""

from __future__ import annotations

import argparse
import json
import os
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
UNSET = ("JAXWALK_CACHE_DIR", "JAX_COMPILATION_CACHE_DIR", "EQX_ON_ERROR", "XLA_FLAGS")


# ``jaxwalk ARGS`` as ``python -m jaxwalk`` runs it, also reporting what it compiled
# (JAX's compile requests less the persistent cache's hits) and traced.
PROBE = """
import json, sys
import jax.monitoring
n = {"requests": 0, "hits": 0}
jax.monitoring.register_event_duration_secs_listener(
    lambda e, s, **k: n.__setitem__("requests", n["requests"] + (e == "/jax/core/compile/backend_compile_duration")))
jax.monitoring.register_event_listener(
    lambda e, **k: n.__setitem__("hits", n["hits"] + (e == "/jax/compilation_cache/cache_hits")))
from jaxwalk import cli, program_cache
status = cli.main(sys.argv[1:])
print(json.dumps({"compiled": n["requests"] - n["hits"], "traced": program_cache.counts["traced"]}))
sys.exit(status)
"""


def run(config: Path, out: Path, xdg: Path, *extra: str) -> dict:
    env = {k: v for k, v in os.environ.items() if k not in UNSET}
    env.update(XDG_CACHE_HOME=str(xdg), PYTHONPATH=str(ROOT))
    start = time.perf_counter()
    proc = subprocess.run(
        [sys.executable, "-c", PROBE, *extra, "sweep", str(config), "--out", str(out), "--no-plot", "--no-progress",
         "--overwrite"], env=env, capture_output=True, text=True,
    )
    wall = time.perf_counter() - start
    if proc.returncode:
        raise SystemExit(proc.stderr)
    return {"wall_s": round(wall, 1), **json.loads(proc.stdout.strip().splitlines()[-1])}


def resized(config: Path, tmp: Path) -> Path:
    """The config with its first grid axis at about 1.5x the points."""
    text = config.read_text()
    match = re.search(r"num = (\d+)", text)
    n = int(match.group(1))
    path = tmp / config.name
    path.write_text(text[: match.start()] + f"num = {n + n // 2}" + text[match.end() :])
    return path


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("configs", nargs="+", type=Path)
    parser.add_argument("--skip-no-cache", action="store_true", help="leave out the --no-cache run (a cold run again)")
    args = parser.parse_args()
    results = []
    for config in args.configs:
        with tempfile.TemporaryDirectory() as tmp:
            tmp = Path(tmp)
            xdg = tmp / "cache"
            row = {"config": str(config), "load_before": os.getloadavg()[0]}
            row["cold"] = run(config, tmp / "out", xdg)
            row["rerun"] = run(config, tmp / "out", xdg)
            row["new_size"] = run(resized(config, tmp), tmp / "out2", xdg)
            if not args.skip_no_cache:
                row["no_cache"] = run(config, tmp / "out3", tmp / "other", "--no-cache")
            row["load_after"] = os.getloadavg()[0]
            results.append(row)
            print(json.dumps(row), flush=True)
    print(json.dumps({"date": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()), "results": results}))


if __name__ == "__main__":
    main()
