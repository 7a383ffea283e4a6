"""Words on a figure: axis labels, variable labels with units, titles.

Grid axes are labelled ``name: long name [units]`` from their coordinate's
attributes (the parameter's spec); variables by a short symbol and units,
since their ``long_name`` attributes are sentences.
"""

from __future__ import annotations

import xarray as xr

#: Short symbols (matplotlib mathtext) for the variables figures usually show.
SYMBOLS = {
    "lambda_max": r"$\lambda_{\max}$",
    "h_max": r"$h_{\max}$",
    "speed": "speed",
    "cost_of_transport": "cost of transport",
    "step_length": "step length",
    "period": "step period",
    "attractor_period": "attractor period k [steps]",
    "attractor_rate": r"attractor rate $\lambda_{\max,k}^{1/k}$",
    "gait_sensitivity_norm": "gait sensitivity norm",
    "mfpt": "MFPT",
}
#: What each shows, for titles.
MEANINGS = {
    "lambda_max": "local stability: largest eigenvalue modulus (stable below 1)",
    "h_max": "global stability: largest survived step-down",
    "speed": "mean walking speed",
    "cost_of_transport": "actuator work per weight and distance",
    "step_length": "distance the stance foot advances per step",
    "period": "duration of one step",
    "attractor_period": "steps per cycle of the gait the walker settles on",
    "attractor_rate": "per-step contraction of the gait the walker settles on",
    "gait_sensitivity_norm": "response of step time and length to floor height (H2 norm)",
    "mfpt": "mean steps before a fall on random terrain",
}
#: The legend text of the stability boundary.
STABILITY_LIMIT = r"$\lambda_{\max} = 1$ (stability limit)"
#: The legend text of gaits found but unstable.
UNSTABLE = r"unstable gait ($\lambda_{\max} \geq 1$)"


def _units(da: xr.DataArray) -> str:
    units = da.attrs.get("units")
    return f" [{units}]" if units and units != "1" else ""


def axis_label(ds: xr.Dataset, axis: str, long: bool = True) -> str:
    """``"gamma: slope angle (downhill positive) [rad]"``, or ``"gamma [rad]"`` without ``long``
    (small multiples: the long form does not fit under a small panel)."""
    coord = ds[axis]
    long_name = coord.attrs.get("long_name") if long else None
    return (f"{axis}: {long_name}" if long_name else axis) + _units(coord)


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
