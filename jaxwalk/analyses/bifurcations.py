"""``[analysis] bifurcations``: the bifurcation table of a sweep's continuation lines.

After every block is written, the period-1 gaits of each continuation line
are read back from the store and :func:`jaxwalk.bifurcation.locate` finds
the folds, flips, Neimark-Sacker points and lost-gait edges between their
points, to 1e-6 in the continuation parameter. They are written as a table
along a ``bifurcation`` dimension (one row per point):

* ``bifurcation_kind`` int8 (CF flags: ``fold flip neimark_sacker grazing lost
  branch_point border_collision jump switch``; a border collision is located where the
  gaits' ``event_sequence`` changes, for models that log their events; a jump
  where a fold, flip or Neimark-Sacker test changes sign with nothing near the
  unit circle at one end of its closed bracket, one gait on both; a switch
  where the bracket's two ends are two coexisting gaits);
* ``bifurcation_parameter``: the continuation parameter's value;
* ``bifurcation_<axis>`` for every other grid axis: the line's value of it;
* ``bifurcation_line`` int32: the line's index in C order of the other axes;
* ``bifurcation_status`` int8: 0, or why the location did not reach 1e-6;
* ``bifurcation_beyond`` int8: the status beyond a lost-gait edge (0 for sign changes);
* ``bifurcation_point`` ``(bifurcation, section)`` and
  ``bifurcation_multipliers_real`` / ``_imag`` ``(bifurcation, eigen)`` there;
* ``bifurcation_sequence`` int64: the gait's event sequence code there; for a
  border collision (and a switch at a sequence change), ``bifurcation_sequence_beyond``; for a border collision,
  a jump or a switch, ``bifurcation_multipliers_beyond_real`` / ``_imag`` on its
  higher parameter's side and ``bifurcation_jumps`` (which test functions
  change sign by the jump).

The table is computed again, the same, when a finished-but-not-renamed run is resumed.
"""

from __future__ import annotations

from pathlib import Path
from typing import ClassVar

import numpy as np

from jaxwalk.analyses.base import Analysis
from jaxwalk.configs import Table, field
from jaxwalk.status import flag_attributes


class Settings(Table):
    """Its ``[analysis]`` key."""

    where: ClassVar[str] = "[analysis]"

    bifurcations: bool = field(False, "true or false")  # locate the bifurcations of every continuation line


def table(config, model, store: Path, options, params, progress=None):
    """The bifurcation table of the grid written in ``store`` (a zarr group);
    ``params``: every parameter over the grid (:func:`jaxwalk.grid.parameter_grid`);
    ``progress``: a tqdm bar (or ``None``), see :func:`jaxwalk.bifurcation.locate`."""
    import xarray as xr

    from jaxwalk.bifurcation import locate

    ds = xr.open_zarr(store, consolidated=False)
    axis = config.continuation
    k = config.dims.index(axis)
    move = lambda x: np.moveaxis(np.asarray(x), k, len(config.dims) - 1)
    n = config.shape[k]
    others = [d for d in config.dims if d != axis]
    status = move(ds["status"].values).reshape(-1, n)
    v = move(ds["fixed_point"].values).reshape(-1, n, len(model.section_names))
    eig = move(ds["eigenvalues_real"].values + 1j * ds["eigenvalues_imag"].values).reshape(v.shape)
    lines = {name: move(values).reshape(-1, n) for name, values in params.items()}
    # Written by [analysis] event_sequence (on by default where the model logs its events).
    sequences = move(ds["event_sequence"].values).reshape(-1, n) if "event_sequence" in ds else None
    found = locate(model, lines, axis, status, np.nan_to_num(v), np.nan_to_num(eig), solver=options.solver, newton=options.newton,
                   progress=progress, sequences=sequences)
    return table_dataset(found, ds, axis, others, tuple(config.shape[config.dims.index(d)] for d in others))


def table_dataset(found, ds, axis: str, others: list[str], line_shape: tuple[int, ...]):
    """The table as an ``xarray.Dataset`` along ``bifurcation``, from ``found``
    (:class:`jaxwalk.bifurcation.Bifurcations`: one entry per point) and the sweep
    dataset ``ds`` (its axes' values and units); ``others``: the grid axes
    across the lines, of shape ``line_shape`` (C order of ``found.line``)."""
    import xarray as xr

    from jaxwalk.bifurcation import KIND_MEANINGS, Kind

    where = np.unravel_index(found.line, line_shape) if others else ()
    dim = "bifurcation"
    names = {"event_names": ds["event_sequence"].attrs["event_names"]} if "event_sequence" in ds else {}
    kinds = list(Kind)
    data = {
        "bifurcation_kind": (dim, found.kind, {
            "long_name": "kind of bifurcation located on a continuation line",
            "flag_values": [int(c) for c in kinds], "flag_meanings": " ".join(c.name.lower() for c in kinds),
            "flag_descriptions": "; ".join(f"{int(c)} {c.name.lower()}: {KIND_MEANINGS[c]}" for c in kinds),
        }),
        "bifurcation_parameter": (dim, found.parameter, {
            "long_name": f"value of the continuation parameter {axis} at the bifurcation (to 1e-6)",
            "units": ds[axis].attrs.get("units", ""),
        }),
        "bifurcation_line": (dim, found.line, {"long_name": "index of the continuation line (C order of the other grid axes)"}),
        "bifurcation_status": (dim, found.status, {"long_name": "outcome of the location (0: located to 1e-6)", **flag_attributes()}),
        "bifurcation_beyond": (dim, found.beyond, {
            "long_name": "status beyond an edge where the gait is lost (0 for sign changes)", **flag_attributes(),
        }),
        "bifurcation_point": ((dim, "section"), found.v, {
            "long_name": "the gait's fixed point at the bifurcation (a border collision's, a jump's or a switch's: on its lower parameter's side)"}),
        "bifurcation_multipliers_real": ((dim, "eigen"), found.multipliers.real, {"long_name": "real part of the multipliers there"}),
        "bifurcation_multipliers_imag": ((dim, "eigen"), found.multipliers.imag, {"long_name": "imaginary part of the multipliers there"}),
        "bifurcation_sequence": (dim, found.sequence, {
            "long_name": "event sequence code of the gait's step there (jaxwalk.event_log; 0: not logged)", **names}),
        "bifurcation_sequence_beyond": (dim, found.sequence_beyond, {
            "long_name": ("a border collision's event sequence code on its higher parameter's side, and a switch's "
                          "at a sequence change (0 for other kinds)"), **names}),
        "bifurcation_multipliers_beyond_real": ((dim, "eigen"), found.multipliers_beyond.real, {
            "long_name": "real part of a border collision's, a jump's or a switch's multipliers on its higher parameter's side (NaN for other kinds)"}),
        "bifurcation_multipliers_beyond_imag": ((dim, "eigen"), found.multipliers_beyond.imag, {
            "long_name": "imaginary part of a border collision's, a jump's or a switch's multipliers on its higher parameter's side (NaN for other kinds)"}),
        "bifurcation_jumps": (dim, found.jumps, {
            "long_name": "test functions whose sign changes across a border collision, a jump or a switch, by the multipliers' "
                         "jump (bit mask: fold 1, flip 2, neimark_sacker 4; 0 for other kinds)"}),
    }
    for d, index in zip(others, where):
        data[f"bifurcation_{d}"] = (dim, np.asarray(ds[d].values)[index], {"long_name": f"the line's value of {d}"})
    return xr.Dataset(data)


def write_table(config, model, store: Path, options, params, progress: bool = True) -> None:
    """Compute the table and add it to the store (replacing one written before),
    with a progress bar of the location's rounds of solves (stderr) unless ``progress`` is false."""
    import sys

    import zarr
    from tqdm.auto import tqdm

    # delay: the bar is drawn once locate() has set its total (the rounds planned).
    with tqdm(total=0, unit="round", desc="locating bifurcations", disable=not progress, file=sys.stderr, delay=1.0) as bar:
        found = table(config, model, store, options, params, bar)
    # xarray's append sets the group's attributes to the appended dataset's:
    # keep the sweep's global attributes (its config, units, history, ...).
    attrs = dict(zarr.open_group(store, mode="r", zarr_format=3).attrs)
    found.attrs.update(attrs)
    found.to_zarr(store, mode="a", zarr_format=3, consolidated=False)
    zarr.open_group(store, mode="r+", zarr_format=3).attrs.update(attrs)


class Bifurcations(Analysis):
    name = "bifurcations"
    keys = Settings.keys()
    order = 40
    off = False
    whole_grid = True

    def parse(self, table, fail, *, continuation) -> bool:
        """``true`` needs a continuation axis (the lines it searches)."""
        value = Settings.pick(table, fail).bifurcations
        if value and continuation is None:
            raise fail("[analysis]: bifurcations = true needs a continuation axis (continuation is off)")
        return value

    def grid_options(self, resolved):
        return None  # nothing per block: the table is made from the whole lines written

    def finish(self, config, model, store, options, params, progress: bool = True) -> None:
        write_table(config, model, store, options, params, progress)


ANALYSIS = Bifurcations()
