"""Shared fixtures: config files, the command line in a subprocess, a fake analysis.

The fake analysis stands in for :func:`jaxwalk.grid.analyse_grid` so that the
sweep front end (config, runner, dataset, CLI) is tested without compiling
anything.
"""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

from jaxwalk.analyses import failure as failure_analysis, gait as gait_analysis, step_down as step_down_analysis
from jaxwalk.status import Status

ROOT = Path(__file__).resolve().parents[1]


def pytest_configure(config):
    config.addinivalue_line(
        "markers", "slow: compiles and runs the real analysis (seconds to minutes on CPU); deselect with -m 'not slow'"
    )


#: A small two-axis compass sweep (7 x 5, continuation along gamma) that the
#: store, runner and API tests run with the fake analysis.
COMPASS_2D = """
name = "grid2d"
model = "compass"
[grid]
m_h = { start = 5.0, stop = 20.0, num = 7 }
gamma = { start = 0.01, stop = 0.05, num = 5 }
[analysis]
continuation = "gamma"
"""
#: Attributes that say when and how a dataset was made, not what it holds.
RUN_ATTRS = ("created", "command", "history", "config_source")


@pytest.fixture
def write_toml(tmp_path):
    """``write_toml(text, name="sweep.toml") -> Path`` in a fresh directory."""

    def write(text: str, name: str = "sweep.toml") -> Path:
        path = tmp_path / name
        path.write_text(textwrap.dedent(text))
        return path

    return write


@pytest.fixture
def run_cli(tmp_path):
    """``run_cli(*args, cwd=tmp_path) -> CompletedProcess`` of ``python -m jaxwalk``."""

    def run(*args: str, cwd: Path = tmp_path) -> subprocess.CompletedProcess:
        env = dict(os.environ)
        env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(ROOT), env.get("PYTHONPATH")]))
        return subprocess.run(
            [sys.executable, "-m", "jaxwalk", *args], cwd=cwd, env=env, capture_output=True, text=True, timeout=120
        )

    return run


class FakeAnalysis:
    """A stand-in for ``jaxwalk.grid.analyse_grid`` with the same signature and outputs.

    Its keys, dtypes and trailing shapes are the declared ones: every output of
    :mod:`jaxwalk.analyses.gait` and, with ``options.step_down``, of
    :mod:`jaxwalk.analyses.step_down`. Numbers are smooth functions of ``s``, the
    sum of the grid values at a point: ``lambda_max = 0.3 + 50 s`` (so it crosses
    1 at ``s = 0.014``), period ``1 + s``, step length ``0.5 + s`` (the rest in
    :meth:`gait_values`); a declared output without a formula there is ``s`` (a
    float), 0 (a count) or the gait's status (a status). Where the first axis
    exceeds ``fail_above`` the status is ``NO_CONVERGENCE`` and every float that
    is not kept ``always`` is NaN, as a real analysis reports a failure; with
    ``nan_with_ok`` one OK point gets a NaN period (a contract violation the
    runner must catch). Every call is recorded in ``calls``.

    With ``options.step_down`` (``[analysis] h_max``), at the grid point of flat
    index ``i`` the first ``k = i mod (count + 1)`` drops survive, so ``h_max = k * dh``;
    for ``k < count`` the next drop falls (``step_down_status`` ``FELL``,
    ``h_failed = (k + 1) * dh``), for ``k = count`` none failed (``OK``,
    ``h_failed`` NaN). Where the gait failed: ``h_max`` NaN, ``step_down_status``
    the gait's status.
    """

    def __init__(self, fail_above: float = np.inf, nan_with_ok: bool = False, error: Exception | None = None):
        self.fail_above = fail_above
        self.nan_with_ok = nan_with_ok
        self.error = error
        self.calls: list[dict] = []

    @staticmethod
    def gait_values(s: np.ndarray, n_v: int) -> dict[str, np.ndarray]:
        """The gait's numbers the tests rely on, by output name (``s``: ``S``; trailing axes last)."""
        lam = 0.3 + 50.0 * s
        return {
            "lambda_max": lam,
            "eigenvalues": lam[..., None] * np.exp(1j * np.linspace(0.0, 1.0, n_v)),
            "fixed_point": s[..., None] + np.arange(n_v),
            "period": 1.0 + s,
            "step_length": 0.5 + s,
            "speed": (0.5 + s) / (1.0 + s),
            "work": 0.1 * s,
            "cost_of_transport": 0.1 * s / (0.5 + s),
            "newton_iterations": np.full(s.shape, 4),
        }

    @staticmethod
    def step_down_values(status: np.ndarray, step_down) -> dict[str, np.ndarray]:
        failed = status != Status.OK
        k = np.arange(status.size).reshape(status.shape) % (step_down.count + 1)
        fell = k < step_down.count
        return {
            "h_max": np.where(failed, np.nan, k * step_down.dh),
            "step_down_status": np.where(failed, status, np.where(fell, Status.FELL, Status.OK)),
            "h_failed": np.where(failed | ~fell, np.nan, (k + 1) * step_down.dh),
        }

    def __call__(self, model, fixed, grid, continuation_axis, options, progress=None):
        self.calls.append(
            {"model": model, "fixed": dict(fixed), "grid": {k: np.array(v) for k, v in grid.items()},
             "continuation_axis": continuation_axis, "options": options}
        )
        if self.error is not None:
            raise self.error
        n_v = len(model.section_names)
        mesh = np.meshgrid(*grid.values(), indexing="ij")
        s = np.sum(mesh, axis=0)
        status = np.where(mesh[0] > self.fail_above, Status.NO_CONVERGENCE, Status.OK).astype(np.int8)
        values = self.gait_values(s, n_v)
        outputs = list(gait_analysis.OUTPUTS)
        step_down = getattr(options, "step_down", None)
        if step_down is not None:
            values.update(self.step_down_values(status, step_down))
            outputs += step_down_analysis.OUTPUTS
        if dict(getattr(options, "more", ())).get("failure_cause"):
            outputs += failure_analysis.OUTPUTS  # 0 everywhere: no step failed (NO_CONVERGENCE is not a step's)
        out = _as_declared(outputs, values, s, status, gait_analysis.ANALYSIS.sizes(True, n_v))
        if self.nan_with_ok:
            out["period"].flat[0] = np.nan
        if progress is not None:
            progress(status.size)
        return out


def _as_declared(outputs, values, s, status, sizes) -> dict[str, np.ndarray]:
    """Each output of ``outputs`` from ``values`` (or its default: ``s``, 0, ``status``)
    with its declared shape and dtype, floats not kept ``always`` NaN where ``status`` failed."""
    failed = status != Status.OK
    out = {}
    for o in outputs:
        shape = o.shape(status.shape, sizes)
        default = status if o.flags else s if o.is_float else np.zeros(status.shape)
        value = np.asarray(values.get(o.name, default))
        value = np.broadcast_to(value.reshape(value.shape + (1,) * (len(shape) - value.ndim)), shape)
        if o.is_float and not o.always:
            value = np.where(failed.reshape(failed.shape + (1,) * (len(shape) - failed.ndim)), np.nan, value)
        out[o.name] = np.array(value, dtype=o.dtype)
    return out


@pytest.fixture
def fake_analysis():
    """The :class:`FakeAnalysis` class (construct with the failures a test needs)."""
    return FakeAnalysis
