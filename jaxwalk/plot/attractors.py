"""Figures of the attractor variables (``[analysis] attractors``, :mod:`jaxwalk.analyses.attractors`).

``attractor_period`` (period-k regions) and ``attractor_rate`` (per-step
contraction) are drawn like any variable, but on a view of the dataset whose
``status`` and ``lambda_max`` are the attractor's: its failures (``fell``,
``no_periodic_attractor``, ...) are the regions named, and the period-1
gait's instability is not hatched where the walker settles on a stable
cycle. ``--vars lambda_max`` (or any period-1 variable) is the period-1 view.
The failure variables (``failure_event``, ...) describe the gait search and
are left out of the attractor's view, so its legend names no cause.
"""

from __future__ import annotations

import xarray as xr

from jaxwalk.plot.statuses import FAILURE_VARIABLES


def view_for(ds: xr.Dataset, name: str) -> xr.Dataset:
    """The dataset ``name`` is drawn from: ``ds`` itself for period-1 variables."""
    if not name.startswith("attractor_") or "attractor_status" not in ds:
        return ds
    # The failure variables say where the gait search's step failed, not the attractor walk's:
    # without them the legend names no cause it did not check.
    gait_search = [v for v in FAILURE_VARIABLES if v in ds]
    return ds.drop_vars(gait_search).assign(status=ds["attractor_status"], lambda_max=ds["attractor_lambda_max"])
