"""Where the shoe walker's 64 x 64 map spends its warm time: per point, by region of the
(l_f, r) plane (4 lines of 64 ratios each: all gaits; all ``running``; the failures
beside them; gaits mixed with failures), each sweep run twice in one process and the
second timed (programs loaded, nothing compiled).

    PYTHONPATH=. python benchmarks/profile_map_regions.py
"""
import time, tomllib, copy
import jaxwalk
base = tomllib.load(open("sweeps/flatfoot_human_lf_r_map.toml", "rb"))
regions = {"ok (l_f 0.271-0.300)": (0.271, 0.300), "running (l_f 0.100-0.119)": (0.100, 0.119),
           "foot_rolling/slipping/running (l_f 0.138-0.167)": (0.138, 0.167), "mixed with gaits (l_f 0.186-0.214)": (0.186, 0.214)}
for name, (a, b) in regions.items():
    cfg = copy.deepcopy(base); cfg["name"] = "cls"
    cfg["grid"]["l_f"] = {"start": a, "stop": b, "num": 4}
    jaxwalk.sweep(cfg, progress=False)  # compile / load
    t = time.perf_counter(); ds = jaxwalk.sweep(cfg, progress=False); dt = time.perf_counter() - t
    st = ds.status.values; it = ds.newton_iterations.values
    import numpy as np
    counts = {int(s): int((st == s).sum()) for s in np.unique(st)}
    print(f"{name:48s} {dt:6.2f} s  {1e3*dt/st.size:6.1f} ms/point  statuses {counts}  newton iters {it.sum()}", flush=True)
