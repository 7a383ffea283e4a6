"""The basin of attraction drawn on a 2-D slice of the section (``jaxwalk basin``).

``config`` checks the command's TOML config, ``run`` finds the gait, walks a grid
of starts about it and writes the dataset, ``figure`` draws the image. The
measure itself (a start's fate, the norm) is :mod:`jaxwalk.global_stability.basin`.
See ``docs/global_stability.md``.
"""

from jaxwalk.basin.config import (
    BASIN_KEYS as BASIN_KEYS,
    TOP_LEVEL_KEYS as TOP_LEVEL_KEYS,
    BasinConfig as BasinConfig,
    load_basin_config as load_basin_config,
    parse_basin_config as parse_basin_config,
)
