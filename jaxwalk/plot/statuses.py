"""Failure statuses in figures: their names, one colour and one marker each, legend entries.

Names come from the dataset's CF ``flag_values`` / ``flag_meanings`` (the file
is the record of what its codes meant), falling back to :mod:`jaxwalk.status`;
underscores become spaces for the reader ("no convergence"). Colours and
markers are fixed per code so that "fell" looks the same in every figure, and
the colours keep clear of viridis (the values' colour map): greys, reds,
oranges, pinks, browns.
"""

from __future__ import annotations

import numpy as np
import xarray as xr

from jaxwalk.status import Status, describe

#: Fill colour of each failure code in heatmaps (and of its markers in line plots).
STATUS_COLORS: dict[int, str] = {
    Status.FELL: "#a9a9a9",  # grey: the common "no gait here"
    Status.STALLED: "#8c564b",
    Status.TIMEOUT: "#c49c94",
    Status.NONFINITE: "#202020",
    Status.RUNNING: "#ff7f0e",
    Status.SHANK_RELEASING: "#e377c2",
    Status.SCUFFING: "#d62728",
    Status.TOO_MANY_EVENTS: "#f7b6d2",
    Status.NO_CONVERGENCE: "#e8e8e8",  # near white: nothing was found
    Status.SOLVER_FAILED: "#7f7f7f",
    Status.KNEE_BUCKLED: "#ff9896",
    Status.NOT_DIFFERENTIABLE: "#dbb98c",
    Status.NOT_COMPUTED: "#ffffff",  # blank: nothing there yet
    Status.SLIPPING: "#17becf",
    Status.NOT_RETURNED: "#bcbd22",  # olive: walking, but not back on the gait
    Status.UNSTABLE_GAIT: "#9e7b5a",
    Status.FOOT_ROLLING: "#b5651d",
    Status.NOT_A_STATE: "#f5f5dc",  # beige: outside the walker's states, nothing to measure
    Status.NO_PERIODIC_ATTRACTOR: "#c5b0d5",  # lavender: walking on, repeating at no tested period
    Status.CYCLE_NOT_FOUND: "#843c39",
    Status.NOT_LOCATED: "#cedb9c",
}
#: Fallback for a code this version does not know.
UNKNOWN_COLOR = "#5c3c00"

#: Marker of each failure code in line plots.
STATUS_MARKERS: dict[int, str] = {
    Status.FELL: "v",
    Status.STALLED: "s",
    Status.TIMEOUT: "D",
    Status.NONFINITE: "*",
    Status.RUNNING: "^",
    Status.SHANK_RELEASING: "<",
    Status.SCUFFING: "x",
    Status.TOO_MANY_EVENTS: ">",
    Status.NO_CONVERGENCE: "o",
    Status.SOLVER_FAILED: "P",
    Status.KNEE_BUCKLED: "h",
    Status.NOT_DIFFERENTIABLE: "p",
    Status.NOT_COMPUTED: "_",
    Status.SLIPPING: "d",
    Status.NOT_RETURNED: "1",
    Status.UNSTABLE_GAIT: "2",
    Status.FOOT_ROLLING: "X",
    Status.NOT_A_STATE: "3",
    Status.NO_PERIODIC_ATTRACTOR: "4",
    Status.CYCLE_NOT_FOUND: "+",
    Status.NOT_LOCATED: "|",
}


def status_names(status: xr.DataArray) -> dict[int, str]:
    """``{code: readable name}`` from the CF flag attributes of ``status`` (then :mod:`jaxwalk.status`)."""
    names: dict[int, str] = {}
    values, meanings = status.attrs.get("flag_values"), status.attrs.get("flag_meanings")
    if values is not None and isinstance(meanings, str):
        words = meanings.split()
        values = np.atleast_1d(np.asarray(values)).tolist()
        if len(words) == len(values):
            names = {int(v): w for v, w in zip(values, words)}

    def name(code: int) -> str:
        return names.get(code, describe(code)).replace("_", " ")

    return {int(c): name(int(c)) for c in np.unique(status.values)}


def failure_codes(status: np.ndarray) -> list[int]:
    """The failure codes (``!= 0``) present in ``status``, ascending."""
    return [int(c) for c in np.unique(status) if c != Status.OK]


def status_color(code: int) -> str:
    return STATUS_COLORS.get(int(code), UNKNOWN_COLOR)


def status_marker(code: int) -> str:
    return STATUS_MARKERS.get(int(code), "d")


def legend_label(name: str, count: int, shown: bool = False, cause: str | None = None) -> str:
    """``"fell (12 points)"``: the count says how much of the grid a status covers
    (``"fell (12 points shown)"`` when the figure shows only part of the grid);
    ``cause`` (:func:`failure_causes`) follows after a colon."""
    label = f"{name} ({count} point{'s' if count != 1 else ''}{' shown' if shown else ''})"
    return f"{label}: {cause}" if cause else label


#: The dataset variables that say where a failed gait search's step failed (:mod:`jaxwalk.analyses.failure`).
FAILURE_VARIABLES = ("failure_phase", "failure_event", "failure_limit")


def failure_causes(ds: xr.Dataset) -> dict[int, str]:
    """``{status code: "slip in push off, stance friction"}``: for each failure status of
    ``ds``, where its steps failed most often (event, phase, contact limit), ``"mostly "``
    in front unless every point of that status failed there. Empty without the
    :data:`FAILURE_VARIABLES`; a status whose steps name no event (``no convergence``) gets none."""
    if not all(v in ds for v in FAILURE_VARIABLES):
        return {}
    status = ds["status"].values.ravel()
    where = np.stack([ds[v].values.ravel() for v in FAILURE_VARIABLES], -1)
    words = [ds[v].attrs.get("flag_meanings", "").split() for v in FAILURE_VARIABLES]
    name = lambda k, i: (words[k][i] if 0 <= i < len(words[k]) else str(i)).replace("_", " ")  # noqa: E731
    out = {}
    for code in failure_codes(status):
        found, counts = np.unique(where[status == code], axis=0, return_counts=True)
        phase, event, limit = (int(i) for i in found[np.argmax(counts)])
        if event == 0:
            continue
        text = f"{name(1, event)} in {name(0, phase)}" + (f", {name(2, limit)}" if limit else "")
        out[code] = text if counts.max() == counts.sum() else f"mostly {text}"
    return out
