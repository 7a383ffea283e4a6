"""Write small reference sweeps, or compare two such runs: the check that a refactor of
the result schema changed no number and no attribute.

    PYTHONPATH=. python benchmarks/schema_identity.py write /tmp/schema_before [NAME ...]
    PYTHONPATH=. python benchmarks/schema_identity.py write /tmp/schema_after
    PYTHONPATH=. python benchmarks/schema_identity.py compare /tmp/schema_before /tmp/schema_after

The sweeps are the bundled compass and simplest configs on small grids, plus one
simplest sweep with every analysis beside the gait (step-down, attractors,
bifurcations, gait sensitivity norm, MFPT). ``compare`` requires every variable,
coordinate and attribute to be identical (xarray ``identical``) save the
provenance attributes (time, command, versions), and the zarr metadata of every
array (dtype, chunks, fill value, codecs) to be equal.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

SWEEPS = {
    "compass_small": """name = "compass_small"\nmodel = "compass"\n[params]\nm = 5.0\na = 0.5\nb = 0.5\n
[grid]\ngamma = { start = 0.02, stop = 0.075, num = 7 }\nm_h = { start = 5.0, stop = 20.0, num = 3 }\n
[analysis]\nstability = true\ncontinuation = "gamma"\n""",
    "simplest_small": """name = "simplest_small"\nmodel = "simplest"\n[grid]\ngamma = { start = 0.002, stop = 0.019, num = 12 }\n
[analysis]\nstability = true\ncontinuation = "gamma"\n""",
    "simplest_independent": """name = "simplest_independent"\nmodel = "simplest"\n[grid]\ngamma = { start = 0.002, stop = 0.019, num = 9 }\n
[analysis]\nstability = false\ncontinuation = false\n""",
    "simplest_hmax_small": """name = "simplest_hmax_small"\nmodel = "simplest"\n[grid]\ngamma = { start = 0.004, stop = 0.014, num = 4 }\n
[analysis]\ncontinuation = "gamma"\nh_max = { step = 0.0005, count = 8, steps = 6 }\n""",
    "simplest_everything": """name = "simplest_everything"\nmodel = "simplest"\n[grid]\ngamma = { start = 0.012, stop = 0.019, num = 8 }\n
[analysis]\ncontinuation = "gamma"\nh_max = { step = 0.001, count = 4, steps = 4 }\nattractors = { max_period = 4, steps = 60 }\n
bifurcations = true\ngait_sensitivity = true\nmfpt = { sigma = 0.0005, mesh = 9, samples = 8, max_axes = 1 }\n""",
}
PROVENANCE = ("created", "history", "command", "config_source")


def write(out: Path, names=None) -> None:
    from jaxwalk.sweep import loads_config, run_sweep

    out.mkdir(parents=True, exist_ok=True)
    for name, text in SWEEPS.items():
        if names and name not in names:
            continue
        run_sweep(loads_config(text, source=name), out, progress=False, plot=False, overwrite=True, command="schema_identity")
        print("wrote", name, flush=True)


def _strip(attrs: dict) -> dict:
    return {k: v for k, v in attrs.items() if k not in PROVENANCE and not k.endswith("_version")}


def _metadata(store: Path) -> dict:
    out = {}
    for f in sorted(store.rglob("zarr.json")):
        meta = json.loads(f.read_text())
        meta.pop("consolidated_metadata", None)
        if "attributes" in meta:
            meta["attributes"] = _strip(meta["attributes"])
        out[str(f.relative_to(store))] = meta
    return out


def compare(before: Path, after: Path) -> int:
    import xarray as xr

    bad = 0
    for name in SWEEPS:
        a = xr.open_zarr(before / f"{name}.zarr").load()
        b = xr.open_zarr(after / f"{name}.zarr").load()
        a.attrs, b.attrs = _strip(a.attrs), _strip(b.attrs)
        same = a.identical(b) and list(a.data_vars) == list(b.data_vars)
        meta = _metadata(before / f"{name}.zarr") == _metadata(after / f"{name}.zarr")
        print(f"{name}: {len(a.data_vars)} variables, identical={same}, zarr metadata equal={meta}")
        if not same:
            for v in sorted(set(a.variables) | set(b.variables)):
                if v not in a or v not in b or not a[v].identical(b[v]):
                    print("   differs:", v)
            for k in sorted(set(a.attrs) | set(b.attrs)):
                if a.attrs.get(k) != b.attrs.get(k):
                    print("   attribute differs:", k)
        bad += not (same and meta)
    return bad


if __name__ == "__main__":
    if sys.argv[1] == "write":
        write(Path(sys.argv[2]), sys.argv[3:])
    else:
        sys.exit(compare(Path(sys.argv[2]), Path(sys.argv[3])))
