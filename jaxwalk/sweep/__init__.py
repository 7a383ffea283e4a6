"""Config-driven parameter sweeps: TOML in, an xarray/zarr dataset out.

``config`` checks and resolves a sweep, ``runner`` runs the analysis over its
grid, ``dataset`` lays out and writes the results; :mod:`jaxwalk.plot` draws
them; ``optimum`` finds each line's best point (``jaxwalk optimum``). See
``docs/sweeps.md``.
"""

from jaxwalk.sweep.config import (
    DEFAULT_MAX_POINTS as DEFAULT_MAX_POINTS,
    ConfigError as ConfigError,
    GridAxis as GridAxis,
    SweepConfig as SweepConfig,
    load_config as load_config,
    loads_config as loads_config,
    parse_config as parse_config,
)
from jaxwalk.sweep.optimum import line_optima as line_optima
from jaxwalk.sweep.runner import check_results as check_results, run_sweep as run_sweep

# jaxwalk.sweep(config, out=None, ...) runs it from a notebook (jaxwalk.api.sweep).
from jaxwalk._callable import make_callable as _make_callable  # noqa: E402

_make_callable(__name__, "sweep")
