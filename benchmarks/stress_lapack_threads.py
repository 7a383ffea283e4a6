"""Stress check: batched linear solves from two threads at once, as a sweep's workers run them.

Two Python threads, each calling its own copy of one program on its own CPU
device (``--devices two``) or both on the first (``one``), ``--calls`` times: a
``fori_loop`` of 20 order-15 solves, ``vmap``-ed over ``--batch`` matrices. With
``--solve jnp`` the solve is ``jnp.linalg.solve`` (jaxlib's batched LAPACK
kernels, which split a large batch over XLA's intra-op pool and wait on the
calling thread): at batch 256 both threads were seen asleep for good. With
``--solve jaxwalk`` it is :func:`jaxwalk.mechanics.solve` (one matrix per LAPACK
call). A thread still running after ``--timeout`` seconds is reported as a hang;
the process then exits without waiting for it.

    PYTHONPATH=. python benchmarks/stress_lapack_threads.py --solve jaxwalk --batch 1 16 64 256 2048
"""

from __future__ import annotations

import argparse
import os
import sys
import threading
import time

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

import jaxwalk  # noqa: E402,F401  (before jax: one CPU device per core)
import jax  # noqa: E402
import jax.numpy as jnp  # noqa: E402

from jaxwalk import mechanics  # noqa: E402


def run(solve, batch: int, calls: int, devices: str, timeout: float) -> str:
    """One stress run; its line of report."""
    key = jax.random.PRNGKey(batch)
    a = jax.random.normal(key, (batch, 15, 15)) + 4 * jnp.eye(15)
    b = jax.random.normal(jax.random.split(key)[0], (batch, 15))

    def loop(a, b):
        return jax.lax.fori_loop(0, 20, lambda i, x: solve(a, b + 1e-3 * x), b)

    program = jax.jit(jax.vmap(loop))
    devs = jax.devices()
    placed = [devs[0], devs[-1]] if devices == "two" else [devs[0], devs[0]]
    args = [(jax.device_put(a, d), jax.device_put(b, d)) for d in placed]
    for arg in args:
        program(*arg).block_until_ready()
    done = [0, 0]

    def work(i):
        for _ in range(calls):
            program(*args[i]).block_until_ready()
            done[i] += 1

    start = time.perf_counter()
    threads = [threading.Thread(target=work, args=(i,), daemon=True) for i in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(timeout=timeout)
    hang = any(t.is_alive() for t in threads)
    return f"batch {batch:5d}: {done} of {calls} calls per thread in {time.perf_counter() - start:.1f} s, {'HANG' if hang else 'ok'}"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--solve", choices=["jaxwalk", "jnp"], default="jaxwalk")
    ap.add_argument("--batch", nargs="+", type=int, default=[1, 16, 64, 256, 2048])
    ap.add_argument("--calls", type=int, default=100)
    ap.add_argument("--devices", choices=["one", "two"], default="two")
    ap.add_argument("--timeout", type=float, default=120.0)
    args = ap.parse_args()
    solve = mechanics.solve if args.solve == "jaxwalk" else jnp.linalg.solve
    for batch in args.batch:
        line = run(solve, batch, args.calls, args.devices, args.timeout)
        print(line, flush=True)
        if "HANG" in line:
            os._exit(1)  # the hung threads cannot be joined


if __name__ == "__main__":
    main()
