"""Simulate a walker for N steps and record its trajectory (``jaxwalk simulate``).

``config`` checks and resolves the command's TOML config, ``start`` finds where
the walk starts (the periodic gait, or given section coordinates, with an
optional step-down at the first touchdown), ``recorder`` walks and samples the
trajectory (run_step's state machine, one phase at a time), ``dataset`` lays it
out as an xarray dataset, ``output`` checks and writes the files, and ``run``
ties them together. See ``docs/simulate.md``.
"""

from jaxwalk.simulate.config import (
    DEFAULT_DT_SCALES as DEFAULT_DT_SCALES,
    DT_RANGE as DT_RANGE,
    MAX_STEPS as MAX_STEPS,
    SIMULATE_KEYS as SIMULATE_KEYS,
    TOP_LEVEL_KEYS as TOP_LEVEL_KEYS,
    SimulateConfig as SimulateConfig,
    load_simulate_config as load_simulate_config,
    loads_simulate_config as loads_simulate_config,
    parse_simulate_config as parse_simulate_config,
)
from jaxwalk.simulate.dataset import (
    build_trajectory_dataset as build_trajectory_dataset,
    coordinate_units as coordinate_units,
)
from jaxwalk.simulate.output import (
    check_drawable as check_drawable,
    check_outputs as check_outputs,
    output_paths as output_paths,
)
from jaxwalk.simulate.recorder import (
    AFTER_EVENT as AFTER_EVENT,
    BEFORE_EVENT as BEFORE_EVENT,
    REGULAR as REGULAR,
    SAMPLE_KINDS as SAMPLE_KINDS,
    Trajectory as Trajectory,
    record_walk as record_walk,
)
from jaxwalk.simulate.run import run_simulation as run_simulation
from jaxwalk.simulate.start import (
    GaitNotFound as GaitNotFound,
    check_start as check_start,
    find_start_gait as find_start_gait,
    initial_state as initial_state,
)
from jaxwalk.walker import as_params as as_params

# jaxwalk.simulate(config, out=None, ...) runs it from a notebook (jaxwalk.api.simulate).
from jaxwalk._callable import make_callable as _make_callable  # noqa: E402

_make_callable(__name__, "simulate")
