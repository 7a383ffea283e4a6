"""Words on a figure: axis labels, variable labels with units, titles.

Grid axes are labelled ``name: long name [units]`` from their coordinate's
attributes (the parameter's spec); variables by the short symbol their
declaration gives (:attr:`jaxwalk.outputs.Output.label`) and units.
"""

from __future__ import annotations

import re
import textwrap

import xarray as xr

from jaxwalk import analyses

#: Short symbols (matplotlib mathtext) of the variables that declare one (:mod:`jaxwalk.analyses`).
SYMBOLS = {o.name: o.label for o in analyses.declared() if o.label}
#: What each shows, for titles (those that declare it; others: their ``long_name``).
MEANINGS = {o.name: o.meaning for o in analyses.declared() if o.meaning}
#: The legend text of the stability boundary.
STABILITY_LIMIT = r"$\lambda_{\max} = 1$ (stability limit)"
#: The legend text of gaits found but unstable.
UNSTABLE = r"unstable gait ($\lambda_{\max} \geq 1$)"
#: Characters per line of a long axis label: about what a 12-inch figure holds
#: at the axes' font size; a longer parameter description goes on two lines.
AXIS_LABEL_WIDTH = 90
#: Characters per line of a figure's title (its first line: name, quantity, meaning).
TITLE_CHARS = 100


def _units(da: xr.DataArray) -> str:
    units = da.attrs.get("units")
    return f" [{units}]" if units and units != "1" else ""


def axis_label(ds: xr.Dataset, axis: str, long: bool = True) -> str:
    """``"gamma: slope angle (downhill positive) [rad]"``, or ``"gamma [rad]"`` without ``long``
    (small multiples: the long form does not fit under a small panel)."""
    coord = ds[axis]
    long_name = coord.attrs.get("long_name") if long else None
    # Short parentheses (units such as "(M g L)") are not broken across lines.
    text = re.sub(r"\([^()]{1,12}\)", lambda m: m.group(0).replace(" ", "\u00a0"), f"{axis}: {long_name}" if long_name else axis)
    return textwrap.fill(text + _units(coord), AXIS_LABEL_WIDTH)


def variable_label(ds: xr.Dataset, name: str) -> str:
    """``"$h_{\\max}$ [m]"``: symbol and units, for a colour bar or a y axis."""
    return SYMBOLS.get(name, name) + _units(ds[name])


def variable_meaning(ds: xr.Dataset, name: str) -> str:
    """One phrase on what ``name`` measures (its ``long_name`` when it is not a known one)."""
    if name in MEANINGS:
        return MEANINGS[name]
    long = ds[name].attrs.get("long_name", name)
    return long if len(long) <= 60 else long[:57] + "..."


def value_text(ds: xr.Dataset, axis: str, index: int) -> str:
    """``"a = 0.4 m"``: one value of a grid axis."""
    units = ds[axis].attrs.get("units")
    unit = f" {units}" if units and units != "1" else ""
    return f"{axis} = {float(ds[axis].values[index]):.4g}{unit}"


def figure_title(ds: xr.Dataset, name: str, fixed: dict[str, int]) -> str:
    """``"simplest_slope (simplest): lambda_max, local stability ... \\n at a = 0.4 m"``."""
    head = f"{ds.attrs.get('name', '?')} ({ds.attrs.get('model', '?')}): {SYMBOLS.get(name, name)}, {variable_meaning(ds, name)}"
    # A long meaning (the gait sensitivity norm's) ran off both sides of the figure.
    head = textwrap.fill(head, TITLE_CHARS, break_on_hyphens=False)
    if fixed:
        head += "\nat " + ", ".join(value_text(ds, a, i) for a, i in fixed.items())
    held = fixed_parameters_text(ds)
    if held:
        head += f"\n{held}"
    if ds.attrs.get("partial"):  # an unfinished store drawn on request: said in every title
        head += f"\n{ds.attrs['partial'].upper()}"
    return head


def fixed_parameters_text(ds: xr.Dataset, max_chars: int = 110) -> str:
    """``"fixed: m = 5 kg, a = 0.6 m; others at the model's defaults"``: the parameters
    held fixed (the dataset's ``fixed_parameters``) that differ from the model's defaults."""
    import json

    from jaxwalk.models import get_model

    try:
        fixed = json.loads(ds.attrs.get("fixed_parameters", "{}"))
        units = json.loads(ds.attrs.get("parameter_units", "{}"))
        specs = get_model(ds.attrs.get("model", "")).param_specs
    except Exception:  # a dataset of another version or model registry: no caption, not an error
        return ""
    swept = set(str(ds.attrs.get("swept_parameters", "")).split())
    if not set(fixed) - swept:  # every parameter is swept (the simplest walker's gamma): nothing to say
        return ""
    changed = {k: v for k, v in fixed.items() if k not in swept and (k not in specs or float(v) != float(specs[k].default))}
    parts = [f"{k} = {float(v):.4g}{'' if units.get(k) in (None, '', '1') else ' ' + units[k]}" for k, v in changed.items()]
    rest = "others at the model's defaults" if len(changed) < len(set(fixed) - swept) else ""
    text = "; ".join(filter(None, ["fixed: " + ", ".join(parts) if parts else "", rest]))
    if not parts:
        text = "all other parameters at the model's defaults"
    return text if len(text) <= max_chars else text[: max_chars - 3] + "..."


#: Characters of legend text a row of a figure's bottom legend holds (an 8-inch
#: figure at the legend's small font, with the markers).
LEGEND_ROW_CHARS = 110


def legend_columns(handles, most: int = 3) -> int:
    """Columns of a bottom legend: as many as its longest label leaves room for, at most ``most``."""
    longest = max((len(h.get_label()) for h in handles), default=1)
    return max(1, min(most, len(handles), LEGEND_ROW_CHARS // max(longest, 1)))
