"""SciPy baselines of the gait-and-stability computation: the simplest and the flat-foot walker.

What a classical code does, one configuration at a time: the step map by
``scipy.integrate.solve_ivp(method="DOP853")`` with terminal events
(heel-strike, falls, stalls) at ``rtol=1e-10``, the period-one fixed point by
Newton-Raphson with a central-difference Jacobian of the step map (the method
of Garcia et al. 1998), and the largest Floquet multiplier from the
eigenvalues of that Jacobian.  The physics lives in
``tests/reference/scipy_walkers.py`` (hand-derived, no jaxwalk import).

The flat-foot walker (``--model flatfoot``) the same way: its step map from
``tests/reference/flatfoot/`` (written from docs/model.md, no jaxwalk or JAX:
DOP853 at ``rtol = atol = 1e-10``, the engine's tolerances, with a terminal
event per guard), Newton from the model's stored nominal guess, the Jacobian
at the fixed point Richardson-extrapolated from central differences at h = 1e-5
and 2e-5, at the defaults with ``r`` spread over [0.38, 0.42] (as
``benchmarks/bench_engines.py`` spreads them), one configuration at a time.

Use from a benchmark script::

    from benchmarks.scipy_baseline import scipy_stability
    results = scipy_stability(np.linspace(0.002, 0.015, 16))

or time it directly::

    PYTHONPATH=. python benchmarks/scipy_baseline.py --n 32
    PYTHONPATH=. python benchmarks/scipy_baseline.py --model flatfoot --n 4
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time
from typing import Iterable

import numpy as np

try:
    from tests.reference import scipy_walkers as ref
except ImportError:  # run as a script without the repo root on sys.path
    sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    from tests.reference import scipy_walkers as ref
from tests.reference import flatfoot as ff  # noqa: E402
from tests.reference.flatfoot.step import RTOL as FLATFOOT_RTOL  # noqa: E402

#: Integrator tolerances of the baseline.
RTOL = 1e-10
ATOL = 1e-12
#: Central-difference step (best accuracy for rtol=1e-10: lambda_max to ~1e-8).
FD_STEP = 1e-6


def _scaling_guess(gamma: float) -> np.ndarray:
    """Garcia's leading-order scaling ``theta* = 0.943 gamma^(1/3)``, ``theta_dot* = -theta*``."""
    th = 0.943 * float(gamma) ** (1.0 / 3.0)
    return ref.garcia_to_v((th, -th))


def scipy_stability(gammas: Iterable[float], guess: str = "fit", rtol: float = RTOL, atol: float = ATOL,
                    fd_step: float = FD_STEP, tol: float = 1e-10,
                    max_iter: int = 30) -> list[tuple[str, np.ndarray, float]]:
    """Stable period-one gait and its stability for each slope, one at a time.

    Args:
        gammas: slopes [rad].
        guess: Newton's starting point: ``"fit"`` (the reference's fitted
            gamma^(1/3) law, ~1e-5 from the gait: 2 Newton iterations) or
            ``"scaling"`` (Garcia's leading-order law ``theta = 0.943 gamma^(1/3)``,
            ``theta_dot = -theta``: a few more iterations).
        rtol, atol: DOP853 tolerances.
        fd_step: central-difference step of the Jacobian.
        tol: Newton stops when ``max|P(v) - v| < tol``.
        max_iter: Newton iterations.

    Returns:
        One ``(status, v_star, lambda_max)`` per slope: ``status`` a string
        (``"ok"`` or a failure name, see ``jaxwalk.status.Status``), ``v_star``
        ``(alpha_1, alpha_1_dot, alpha_2_dot)`` just after heel-strike (shape (3,),
        NaN on failure), ``lambda_max`` the largest multiplier modulus.
    """
    guesses = {"fit": ref.simplest_guess, "scaling": _scaling_guess}
    if guess not in guesses:
        raise ValueError(f"guess must be one of {sorted(guesses)}, got {guess!r}")
    out = []
    for gamma in gammas:
        gamma = float(gamma)

        def step(v, gamma=gamma):
            return ref.simplest_step(v, gamma, rtol=rtol, atol=atol)

        fp = ref.fixed_point(step, guesses[guess](gamma), tol=tol, max_iter=max_iter, fd_step=fd_step,
                             richardson=False)
        out.append((fp.status, fp.v, fp.lambda_max))
    return out


#: The flat-foot spread: foot ratio r over this range, every other parameter at its default.
FLATFOOT_R = (0.38, 0.42)


def flatfoot_stability(rs: Iterable[float], richardson: bool = True) -> list[tuple[str, np.ndarray, float, float, float]]:
    """The flat-foot gait search at each foot ratio ``r`` (defaults otherwise), one at a time.

    Returns:
        One ``(status, v_star, lambda_max, period, seconds)`` per ``r``: ``v_star``
        is ``(psi, psi_dot)`` just after toe-strike (NaN on failure), ``period`` the
        step time at ``v_star`` (model time units), ``seconds`` the search's wall time.
    """
    out = []
    for r in rs:
        t0 = time.perf_counter()
        fp = ff.gait(ff.params(r=float(r)), richardson=richardson)
        period = fp.step_info["time"] if fp.status == "ok" else math.nan
        out.append((fp.status, fp.v, fp.lambda_max, period, time.perf_counter() - t0))
    return out


def _time_flatfoot(args) -> int:
    lo, hi = args.r_min, args.r_max
    rs = np.linspace(lo, hi, args.n) if args.n > 1 else np.array([0.5 * (lo + hi)])
    best, results = math.inf, []
    for _ in range(max(1, args.repeat)):
        t0 = time.perf_counter()
        results = flatfoot_stability(rs, richardson=not args.plain)
        best = min(best, time.perf_counter() - t0)
    print(f"scipy baseline (flat-foot walker, DOP853 rtol=atol={FLATFOOT_RTOL:g}, Newton + central differences"
          f"{'' if args.plain else ', Richardson at the fixed point'}, guess = the stored nominal gait)")
    for r, (status, v, lam, period, seconds) in zip(rs, results):
        print(f"  r = {r:.6f}: {status:8s} v* = ({v[0]:.12f}, {v[1]:.12f})  lambda_max = {lam:.9f}  "
              f"period = {period:.9f}  {seconds:.3f} s")
    n_ok = sum(status == "ok" for status, *_ in results)
    print(f"configs: {len(rs)}  ok: {n_ok}  r: [{rs[0]:g}, {rs[-1]:g}]")
    print(f"total: {best:.3f} s  per config: {best / len(rs):.4f} s")
    return 0 if n_ok == len(rs) else 1


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--model", choices=("simplest", "flatfoot"), default="simplest")
    parser.add_argument("--plain", action="store_true",
                        help="flat-foot: plain central differences at the fixed point (no Richardson)")
    parser.add_argument("--n", type=int, default=32, help="number of configurations (slopes or foot ratios)")
    parser.add_argument("--r-min", type=float, default=FLATFOOT_R[0], help="flat-foot: smallest foot ratio")
    parser.add_argument("--r-max", type=float, default=FLATFOOT_R[1], help="flat-foot: largest foot ratio")
    parser.add_argument("--gamma-min", type=float, default=0.002)
    parser.add_argument("--gamma-max", type=float, default=0.015)
    parser.add_argument("--guess", choices=("fit", "scaling"), default="fit")
    parser.add_argument("--repeat", type=int, default=1, help="timed repetitions (best is reported)")
    args = parser.parse_args(argv)
    if args.model == "flatfoot":
        return _time_flatfoot(args)

    gammas = np.linspace(args.gamma_min, args.gamma_max, args.n)
    scipy_stability(gammas[:1], guess=args.guess)  # warm-up (imports, caches)
    best = math.inf
    for _ in range(max(1, args.repeat)):
        t0 = time.perf_counter()
        results = scipy_stability(gammas, guess=args.guess)
        best = min(best, time.perf_counter() - t0)
    n_ok = sum(status == "ok" for status, _, _ in results)
    lam = [lm for status, _, lm in results if status == "ok"]
    print(f"scipy baseline (simplest walker, DOP853 rtol={RTOL:g}, Newton + central differences, "
          f"guess={args.guess})")
    print(f"configs: {args.n}  ok: {n_ok}  gamma: [{args.gamma_min:g}, {args.gamma_max:g}]"
          + (f"  lambda_max: [{min(lam):.6f}, {max(lam):.6f}]" if lam else ""))
    print(f"total: {best:.3f} s  per config: {best / args.n:.4f} s")
    return 0 if n_ok == args.n else 1


if __name__ == "__main__":
    raise SystemExit(main())
