"""Benchmark: one ``jaxwalk sweep`` command on two revisions of the code, in one sitting.

A change to what a sweep runs (not a knob of it) has no "before" form left in
the code to time against; its baseline is the revision before it. This
script clones that revision (``--base``, a git revision of this repository)
into a temporary directory and runs the same command, as a user does (the
package's defaults: its own device count, its caches in ``--cache-dir``,
progress bars and plots off), alternately on the base and on this working
tree, the order turned each repeat (B H H B B H ...) so that neither always
runs first in the sitting:

* **cold**: an empty cache directory (tracing, compiling, exporting, running);
* **warm**: the same command again on the cache that run filled (loading
  the traced and compiled programs, running).

Wall time and peak resident memory of each command (``wait4``), then every
variable of the two revisions' warm datasets compared: bit for bit, or the
largest difference; where the statuses differ the benchmark says so and
fails (a speed-up that changes what the map says is not one).

    PYTHONPATH=. python benchmarks/bench_revisions.py --base aec59ee [--config sweeps/flatfoot_human_lf_r_map.toml] [--repeat 1]

Writes ``benchmarks/results/revisions_<config name>.json``. Run it with
nothing else on the machine: the two revisions' figures are compared only
with each other.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
import tomllib
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
sys.path.insert(0, str(HERE))

from _record import write_stamped  # noqa: E402


def checkout(revision: str, where: Path) -> Path:
    """A clone of this repository at ``revision`` in ``where``; returns its root."""
    subprocess.run(["git", "clone", "-q", str(ROOT), str(where)], check=True)
    subprocess.run(["git", "-C", str(where), "checkout", "-q", revision], check=True)
    return where


def run(tree: Path, config: Path, cache: Path, out: Path) -> dict:
    """``jaxwalk sweep`` of ``tree``'s package in a subprocess: wall time and peak RSS."""
    env = dict(os.environ, PYTHONPATH=str(tree))
    for name in ("JAXWALK_CACHE_DIR", "JAX_COMPILATION_CACHE_DIR", "EQX_ON_ERROR"):
        env.pop(name, None)  # the package's own settings, as a user gets them
    cmd = [sys.executable, "-m", "jaxwalk", "--cache-dir", str(cache), "sweep", str(config), "--out", str(out),
           "--overwrite", "--no-plot", "--no-progress"]
    t0 = time.perf_counter()
    proc = subprocess.Popen(cmd, cwd=tree, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    output = proc.stdout.read()
    _, status, usage = os.wait4(proc.pid, 0)
    wall = time.perf_counter() - t0
    if os.waitstatus_to_exitcode(status) != 0:
        raise SystemExit(f"sweep failed in {tree}:\n{output[-3000:]}")
    return {"wall_s": round(wall, 2), "peak_rss_gb": round(usage.ru_maxrss / 2**20, 3)}


def compare(base: Path, head: Path) -> dict:
    """Per variable of two datasets: ``"identical"`` or the largest difference."""
    import xarray as xr

    out = {}
    with xr.open_zarr(base) as a, xr.open_zarr(head) as b:
        for name in sorted(set(a.data_vars) | set(b.data_vars)):
            if name not in a or name not in b:
                out[name] = "only in " + ("base" if name in a else "head")
                continue
            x, y = a[name].values, b[name].values
            if np.array_equal(x, y, equal_nan=x.dtype.kind in "fc"):
                out[name] = "identical"
            elif x.dtype.kind in "fc" and np.array_equal(np.isnan(x), np.isnan(y)):
                out[name] = float(np.nanmax(np.abs(x - y)))
            else:
                same = (x == y) | (np.isnan(x) & np.isnan(y)) if x.dtype.kind in "fc" else x == y
                out[name] = f"differs at {int(np.sum(~same))} points"
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--base", required=True, help="the baseline's git revision")
    parser.add_argument("--config", type=Path, default=ROOT / "sweeps" / "flatfoot_human_lf_r_map.toml")
    parser.add_argument("--repeat", type=int, default=1)
    args = parser.parse_args()
    config = args.config.resolve()
    name = tomllib.loads(config.read_text())["name"]
    runs: dict[str, list] = {"base": [], "head": []}
    with tempfile.TemporaryDirectory(prefix="jaxwalk-revisions-") as tmp:
        tmp = Path(tmp)
        trees = {"base": checkout(args.base, tmp / "base"), "head": ROOT}
        for i in range(args.repeat):
            for label in ("base", "head") if i % 2 == 0 else ("head", "base"):
                tree = trees[label]
                cache, out = tmp / f"cache-{label}-{i}", tmp / f"out-{label}"
                cold, warm = run(tree, config, cache, out), run(tree, config, cache, out)
                runs[label].append({"cold": cold, "warm": warm})
                print(f"{label} ({i + 1}/{args.repeat}): cold {cold['wall_s']:.1f} s, warm {warm['wall_s']:.1f} s",
                      flush=True)
        variables = compare(tmp / "out-base" / f"{name}.zarr", tmp / "out-head" / f"{name}.zarr")
    best = {label: {kind: min(r[kind]["wall_s"] for r in rs) for kind in ("cold", "warm")} for label, rs in runs.items()}
    ratios = {kind: round(best["base"][kind] / best["head"][kind], 3) for kind in ("cold", "warm")}
    print(f"best of {args.repeat}: cold {best['base']['cold']:.1f} -> {best['head']['cold']:.1f} s ({ratios['cold']}x), "
          f"warm {best['base']['warm']:.1f} -> {best['head']['warm']:.1f} s ({ratios['warm']}x)")
    for var, what in variables.items():
        print(f"  {var}: {what}")
    head = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "--short", "HEAD"], capture_output=True, text=True)
    write_stamped(f"revisions_{name}", {
        "config": str(config.relative_to(ROOT)) if config.is_relative_to(ROOT) else str(config),
        "base": args.base, "head": head.stdout.strip() + " (and the working tree)", "runs": runs, "best": best,
        "base_over_head": ratios, "warm_datasets": variables,
    })
    if variables.get("status") != "identical":
        raise SystemExit(f"the statuses differ between the revisions: {variables.get('status')}")


if __name__ == "__main__":
    main()
