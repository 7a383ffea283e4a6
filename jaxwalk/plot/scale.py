"""The value scale of a figure: linear, or logarithmic where the variable asks for it.

A variable asks with the dataset attribute ``plot_scale = "log"`` (written from
:attr:`jaxwalk.outputs.Output.log_scale`). It gets a log scale only where that
reads better than a linear one: every drawn value positive and the values
spanning more than a decade (the mean first-passage time runs from 8 to 40,000
steps on one line of the shoe walker; linearly, everything below 4,000 is one colour).
"""

from __future__ import annotations

import numpy as np
import xarray as xr

#: The smallest ratio of largest to smallest drawn value that earns a log scale.
MIN_DECADES_RATIO = 10.0


def use_log_scale(ds: xr.Dataset, name: str, values: np.ndarray) -> bool:
    """Whether ``ds[name]``, whose drawn (finite) values are ``values``, is drawn on a log scale."""
    if ds[name].attrs.get("plot_scale") != "log":
        return False
    values = np.asarray(values, np.float64)
    values = values[np.isfinite(values)]
    return bool(values.size and values.min() > 0.0 and values.max() >= MIN_DECADES_RATIO * values.min())
