"""Static figures of a recorded walk: a stick diagram of one step and time series.

* :func:`stick_diagram`: the walker drawn at ~10 instants across one step, each
  at its place along the slope, legs coloured by physical leg and shaded from
  light (early) to dark (late).
* :func:`time_series`: thigh (or leg) angles and shank angles from the vertical,
  the hip's path, each foot's clearance and the mechanical energy, against
  time; dashed lines at heel-strikes (ends of steps), dotted at other impacts.

Both read the trajectory dataset (:mod:`jaxwalk.simulate`) and draw in world
coordinates (x forward, y up: the slope frame turned by ``gamma``).
"""

from __future__ import annotations

import dataclasses
import functools
import json

import numpy as np

from jaxwalk import compiling
from jaxwalk.simulate.output import check_drawable
from jaxwalk.simulate.recorder import AFTER_EVENT, BEFORE_EVENT
from jaxwalk.walker import Walker, as_params

#: Colours of physical legs A and B, and the colour maps used for shading.
LEG_COLOURS = ("tab:blue", "tab:orange")
LEG_CMAPS = ("Blues", "Oranges")
LEG_NAMES = ("leg A", "leg B")
GROUND_COLOUR = "0.35"


@dataclasses.dataclass
class WalkGeometry:
    """A walk in world coordinates (x forward, y up), per sample ``n``.

    Attributes:
        time, step, kind: from the dataset.
        gamma: slope angle.
        skeleton: ``(n, 2, P, 2)`` polylines of physical legs A and B.
        points: ``(n, n_masses, 2)`` the point masses; ``masses`` ``(n_masses,)``.
        hip: ``(n, 2)``.
        clearance: ``(n, 2)`` height of each physical foot's lowest point above the
            ground level the current stance foot stands on (vertical).
        angles: ``(n, 2, P - 1)`` angle of each skeleton segment from the vertical,
            positive with its distal end ahead (rad).
        has_knee: the skeleton has a knee (an odd number of points: hip, knee, foot
            [, heel, toe]).
        step_ends: times of the events that ended a step (heel-strikes).
        impacts: times of other events at which the velocities jumped.
        origin: ``(n, 2)`` the current step frame's origin (slope frame of step 0).
        ground: ``(m, 2)`` polyline of the ground, covering the walk.
        leg_length: the longest hip-to-foot distance of the skeleton (a length scale).
        length_unit, time_unit: the model's output units.
    """

    time: np.ndarray
    step: np.ndarray
    kind: np.ndarray
    gamma: float
    skeleton: np.ndarray
    points: np.ndarray
    masses: np.ndarray
    hip: np.ndarray
    clearance: np.ndarray
    angles: np.ndarray
    has_knee: bool
    step_ends: np.ndarray
    impacts: np.ndarray
    origin: np.ndarray
    ground: np.ndarray
    leg_length: float
    length_unit: str
    time_unit: str

    def to_world(self, p: np.ndarray) -> np.ndarray:
        return to_world(p, self.gamma)


def to_world(p: np.ndarray, gamma: float) -> np.ndarray:
    """Slope-frame points ``(..., 2)`` in world coordinates: x forward, y up."""
    c, s = np.cos(gamma), np.sin(gamma)
    x, y = p[..., 0], p[..., 1]
    return np.stack([c * x + s * y, -s * x + c * y], axis=-1)


@functools.lru_cache(maxsize=None)
def _drawing_fn(model: Walker):
    import jax

    def one(params, q, ctx):
        return model.skeleton(q, params, ctx), model.foot_points(q, params, ctx), model.points(q, params)

    return compiling.jit(jax.vmap(one, in_axes=(None, 0, 0)), model)


def _by_physical_leg(a: np.ndarray, step: np.ndarray) -> np.ndarray:
    """Reorder axis 1 (leg 1 = stance, leg 2 = swing) into physical legs A, B.

    Leg A is the stance leg of step 0; labels swap every step."""
    idx = np.arange(len(step))
    return np.stack([a[idx, (j + step) % 2] for j in range(2)], axis=1)


def walk_geometry(ds, model: Walker) -> WalkGeometry:
    """World coordinates of everything the figures draw (see :class:`WalkGeometry`)."""
    check_drawable(model)
    params = as_params(json.loads(ds.attrs["params"]))
    gamma = float(model.slope(params))
    q = np.asarray(ds["q"].values)
    ctx = np.asarray(ds["ctx"].values)
    origin = np.asarray(ds["frame_origin"].values)
    step = np.asarray(ds["step"].values).astype(int)
    time = np.asarray(ds["time"].values)
    kind = np.asarray(ds["sample_kind"].values)
    skel, feet, points = (np.asarray(a) for a in _drawing_fn(model)(params, q, ctx))
    if skel.ndim != 4 or skel.shape[1:2] != (2,) or skel.shape[-1] != 2:
        raise ValueError(f"model '{model.name}': skeleton() must return (2, n_points, 2), got {skel.shape[1:]}")
    world = lambda p, o: to_world(p + o, gamma)
    o = origin[:, None, None, :]
    skeleton = _by_physical_leg(world(skel, o), step)
    foot_height = (feet[..., 1].min(axis=-1)) / np.cos(gamma)  # above the stance ground, vertical
    clearance = _by_physical_leg(foot_height, step)
    seg = np.diff(skeleton, axis=2)
    angles = np.unwrap(np.arctan2(seg[..., 0], -seg[..., 1]), axis=0)  # continuous through a fall's full turns
    hip = world(q[:, :2], origin)
    masses = np.asarray(model.masses(params))

    # Events: the sample just after an event follows the one just before it.
    after = np.nonzero(kind == AFTER_EVENT)[0]
    before = after - 1
    assert np.all(kind[before] == BEFORE_EVENT)
    step_done = step[after] != step[before]
    qd = np.asarray(ds["qd"].values)
    jump = np.max(np.abs(qd[after] - qd[before]), axis=1) > 1e-9
    step_ends = time[after][step_done]
    impacts = time[after][~step_done & jump]
    leg_length = float(np.max(np.linalg.norm(skel[:, :, -1] - skel[:, :, 0], axis=-1)))
    units = json.loads(ds.attrs["units"])
    return WalkGeometry(
        time=time,
        step=step,
        kind=kind,
        gamma=gamma,
        skeleton=skeleton,
        points=world(points, origin[:, None, :]),
        masses=masses,
        hip=hip,
        clearance=clearance,
        angles=angles,
        has_knee=skel.shape[2] % 2 == 1,
        step_ends=step_ends,
        impacts=impacts,
        origin=origin,
        ground=_ground(origin, step, skel, gamma),
        leg_length=leg_length,
        length_unit=units["length"],
        time_unit=units["time"],
    )


def _ground(origin, step, skel, gamma) -> np.ndarray:
    """World polyline of the ground: each step's stance level (its frame's y = 0),
    with a vertical edge halfway between two stance feet where the level changes
    (a step-down)."""
    first = np.unique(step, return_index=True)[1]
    o = origin[first]  # frame origin (stance foot) of each step, slope frame
    xs = (skel[..., 0] + origin[:, None, None, 0]).ravel()
    margin = 0.3 * (np.nanmax(xs) - np.nanmin(xs)) + 0.2
    left, right = np.nanmin(xs) - margin, np.nanmax(xs) + margin
    pts = [to_world(np.array([left, o[0, 1]]), gamma)]
    for k in range(1, len(o)):
        drop = o[k - 1, 1] - o[k, 1]
        if abs(drop) > 1e-12:
            edge = to_world(np.array([0.5 * (o[k - 1, 0] + o[k, 0]), o[k - 1, 1]]), gamma)
            pts += [edge, edge - np.array([0.0, drop / np.cos(gamma)])]
    pts.append(to_world(np.array([right, o[-1, 1]]), gamma))
    return np.array(pts)


def _snapshot_indices(geo: WalkGeometry, step: int, n: int) -> np.ndarray:
    """About ``n`` samples evenly spread in time over step ``step``, its first and last included."""
    rows = np.nonzero(geo.step == step)[0]
    if len(rows) == 0:
        raise ValueError(f"the walk has no step {step}")
    t = geo.time[rows]
    targets = np.linspace(t[0], t[-1], n)
    picks = rows[np.clip(np.searchsorted(t, targets), 0, len(rows) - 1)]
    picks[-1] = rows[-1]
    return np.unique(picks)


def draw_ground(ax, geo: WalkGeometry, lw: float = 1.5) -> None:
    """The ground line, hatched below every tenth of a leg length (so that a
    camera following the walker shows it moving)."""
    from matplotlib.collections import LineCollection

    g = geo.ground
    ax.plot(g[:, 0], g[:, 1], color=GROUND_COLOUR, lw=lw, zorder=0)
    tick = 0.05 * geo.leg_length
    ticks = []
    for a, b in zip(g[:-1], g[1:]):
        length = float(np.linalg.norm(b - a))
        if abs(b[0] - a[0]) < 1e-12 or length == 0:
            continue  # a step-down's vertical edge
        for s in np.arange(0.0, length, 0.1 * geo.leg_length):
            p = a + (b - a) * s / length
            ticks.append([p, p + np.array([-tick, -tick])])
    if ticks:
        ax.add_collection(LineCollection(ticks, colors=GROUND_COLOUR, linewidths=0.6, zorder=0))


def stick_diagram(
    ds,
    model: Walker,
    *,
    step: int = 0,
    instants: int = 10,
    spread: float = 0.25,
    ax=None,
    geometry: WalkGeometry | None = None,
):
    """Draw the walker at ~``instants`` instants across step ``step`` (the seed
    paper's Fig. 3), legs coloured by physical leg and shaded light (early) to
    dark (late).

    Each snapshot is drawn at its place along the slope, moved on by a further
    ``spread`` leg lengths per snapshot (along the slope, so the feet stay on the
    ground line) so that successive snapshots do not hide each other; with
    ``spread = 0`` they overlap at their true places and the hip's path is drawn.

    Returns the matplotlib figure.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.lines import Line2D

    geo = geometry or walk_geometry(ds, model)
    picks = _snapshot_indices(geo, step, instants)
    along = np.array([np.cos(geo.gamma), -np.sin(geo.gamma)]) * spread * geo.leg_length
    shifts = np.arange(len(picks))[:, None] * along
    skeleton = geo.skeleton[picks] + shifts[:, None, None, :]
    points = geo.points[picks] + shifts[:, None, :]
    lo, hi = skeleton.reshape(-1, 2).min(axis=0), skeleton.reshape(-1, 2).max(axis=0)
    pad = 0.12 * geo.leg_length
    if ax is None:
        aspect = (hi[0] - lo[0] + 2 * pad) / (hi[1] - lo[1] + 3 * pad)
        fig, ax = plt.subplots(figsize=(min(max(3.2 * aspect, 5.0), 12.0), 3.8), dpi=150)
    else:
        fig = ax.figure
    _draw_snapshots(ax, geo, skeleton, points)
    handles = []
    if spread == 0:
        rows = geo.step == step
        ax.plot(geo.hip[rows, 0], geo.hip[rows, 1], ":", color="0.4", lw=1.0, zorder=1)
        handles.append(Line2D([], [], color="0.4", ls=":", label="hip path"))
    handles += _draw_step_ground(ax, geo, step, (lo[0] - geo.leg_length, hi[0] + geo.leg_length))
    ax.set_xlim(lo[0] - pad, hi[0] + pad)
    ax.set_ylim(lo[1] - 2 * pad, hi[1] + pad)
    ax.set_aspect("equal")
    unit = _unit_label(geo.length_unit)
    ax.set_xlabel(f"x (forward){unit}" + (f"; snapshots moved on by {spread:g} leg length each" if spread else ""))
    ax.set_ylabel(f"y (up){unit}")
    stance = step % 2  # the physical leg in stance
    rows = geo.step == step
    t0, t1 = geo.time[rows][0], geo.time[rows][-1]
    ax.set_title(
        f"{model.name} walker, step {step}: {len(picks)} instants over {t1 - t0:.3g}{_unit_label(geo.time_unit, bare=True)}"
        f" (slope {np.degrees(geo.gamma):.2f} deg), light to dark",
        fontsize=10,
    )
    handles = [
        Line2D([], [], color=LEG_COLOURS[stance], lw=2.5, label=f"{LEG_NAMES[stance]} (stance)"),
        Line2D([], [], color=LEG_COLOURS[1 - stance], lw=2.5, label=f"{LEG_NAMES[1 - stance]} (swing)"),
        *handles,
    ]
    ax.legend(handles=handles, loc="lower left", fontsize=8, frameon=False, ncol=len(handles))
    fig.tight_layout()
    return fig


def _draw_snapshots(ax, geo: WalkGeometry, skeleton: np.ndarray, points: np.ndarray) -> None:
    """Each snapshot's legs, shaded light (early) to dark (late), and its point masses."""
    import matplotlib

    cmaps = [matplotlib.colormaps[c] for c in LEG_CMAPS]
    sizes = 8.0 + 40.0 * geo.masses / geo.masses.max()
    n = len(skeleton)
    for j in range(n):
        shade = 0.35 + 0.6 * j / max(n - 1, 1)
        for leg in range(2):
            line = skeleton[j, leg]
            ax.plot(line[:, 0], line[:, 1], color=cmaps[leg](shade), lw=2.0, solid_capstyle="round", zorder=2)
        ax.scatter(points[j, :, 0], points[j, :, 1], s=sizes, color="k", zorder=3, lw=0)


def _draw_step_ground(ax, geo: WalkGeometry, step: int, world_x) -> list:
    """The ground under step ``step``: the level of its stance foot, and where the
    next touchdown's level differs (a step-down), that level dashed. Returns the
    legend handles it adds."""
    from matplotlib.lines import Line2D

    rows = np.nonzero(geo.step == step)[0]
    levels = [geo.origin[rows[0], 1]]
    after = np.nonzero(geo.step == step + 1)[0]
    if len(after) and abs(geo.origin[after[0], 1] - levels[0]) > 1e-12:
        levels.append(geo.origin[after[0], 1])
    world_x = np.array(world_x)
    for k, level in enumerate(levels):
        x = (world_x - level * np.sin(geo.gamma)) / np.cos(geo.gamma)  # slope x of those world x on this level
        line = to_world(np.stack([x, np.full(2, level)], axis=-1), geo.gamma)
        ax.plot(line[:, 0], line[:, 1], color=GROUND_COLOUR, lw=1.5 if k == 0 else 1.0, ls="-" if k == 0 else "--", zorder=0)
    if len(levels) == 1:
        return []
    drop = (levels[0] - levels[1]) / np.cos(geo.gamma)
    return [Line2D([], [], color=GROUND_COLOUR, ls="--", lw=1.0, label=f"ground after the step-down ({drop:.3g})")]


def time_series(ds, model: Walker, *, geometry: WalkGeometry | None = None):
    """Thigh (or leg) and shank angles from the vertical, the hip's path, foot
    clearance and mechanical energy (the seed paper's Fig. 4 a-d, plus energy).

    Returns the matplotlib figure.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from jaxwalk.status import describe

    geo = geometry or walk_geometry(ds, model)
    panels = ["thigh", "shank", "hip", "clearance", "energy"] if geo.has_knee else ["thigh", "hip", "clearance", "energy"]
    ncols = 2
    nrows = (len(panels) + 1) // 2
    fig, axes = plt.subplots(nrows, ncols, figsize=(10.0, 3.0 * nrows), dpi=130)
    axes = axes.ravel()
    for k, ax in enumerate(axes[len(panels):]):
        if k == 0:
            _summary(ax, ds)
        else:
            ax.remove()
    for ax, name in zip(axes, panels):
        _PANELS[name](ax, geo, ds, name)
        if name != "hip":
            ax.set_xlabel(f"time{_unit_label(geo.time_unit)}")
    status = int(ds["status"].values)
    lu = _unit_label(geo.length_unit)
    fig.suptitle(
        f"{model.name} walker: {int(ds['steps_completed'].values)} steps"
        + (f", then {describe(status)}" if status != 0 else "")
        + (f"; step-down {ds.attrs['drop']:g}{lu} at the first touchdown" if float(ds.attrs["drop"]) > 0 else ""),
        fontsize=11,
    )
    fig.tight_layout()
    return fig


def _mark_events(ax, geo: WalkGeometry) -> None:
    """Dashed lines at heel-strikes (ends of steps), dotted at other impacts."""
    for te in geo.step_ends:
        ax.axvline(te, color="0.6", ls="--", lw=0.7, zorder=0)
    for te in geo.impacts:
        ax.axvline(te, color="0.75", ls=":", lw=0.7, zorder=0)


def _angle_panel(ax, geo: WalkGeometry, ds, name: str) -> None:
    seg = 0 if name == "thigh" else 1
    what = "thigh" if (name == "thigh" and geo.has_knee) else ("shank" if name == "shank" else "leg")
    for leg in range(2):
        ax.plot(geo.time, geo.angles[:, leg, seg], color=LEG_COLOURS[leg], label=LEG_NAMES[leg])
    _mark_events(ax, geo)
    ax.axhline(0.0, color="0.8", lw=0.6, zorder=0)
    ax.set_ylabel(f"{what} angle (rad)")
    ax.set_title(f"{what} angles from the vertical (+: distal end forward)", fontsize=9)
    ax.legend(fontsize=8, frameon=False)


def _hip_panel(ax, geo: WalkGeometry, ds, name: str) -> None:
    lu = _unit_label(geo.length_unit)
    ax.plot(geo.hip[:, 0], geo.hip[:, 1], color="k", lw=1.2)
    ends = np.isin(geo.time, geo.step_ends) & (geo.kind == AFTER_EVENT)
    ax.plot(geo.hip[ends, 0], geo.hip[ends, 1], "o", color="0.4", ms=3, label="heel-strikes")
    ax.set_xlabel(f"x_h (forward){lu}")
    ax.set_ylabel(f"y_h (up){lu}")
    ax.set_title("hip path (world frame)", fontsize=9)
    ax.legend(fontsize=8, frameon=False)


def _clearance_panel(ax, geo: WalkGeometry, ds, name: str) -> None:
    for leg in range(2):
        ax.plot(geo.time, geo.clearance[:, leg], color=LEG_COLOURS[leg], label=LEG_NAMES[leg])
    _mark_events(ax, geo)
    ax.axhline(0.0, color="0.6", lw=0.6, zorder=0)
    swing = np.max(geo.clearance, axis=1)
    ax.set_ylim(min(-0.02 * geo.leg_length, float(np.nanmin(geo.clearance)) * 1.1), float(np.nanmax(swing)) * 1.15 + 1e-3 * geo.leg_length)
    ax.set_ylabel(f"height{_unit_label(geo.length_unit)}")
    ax.set_title("foot clearance: lowest foot point above the stance ground (vertical)", fontsize=9)
    ax.legend(fontsize=8, frameon=False)


def _energy_panel(ax, geo: WalkGeometry, ds, name: str) -> None:
    energy = np.asarray(ds["energy"].values)
    work = np.asarray(ds["work"].values)
    eu = _unit_label(ds["energy"].attrs.get("units", "1"))
    ax.plot(geo.time, energy - energy[0], color="k", label="mechanical energy E - E(0)")
    if np.any(work != 0):
        ax.plot(geo.time, work, color="tab:green", label="actuator work")
    _mark_events(ax, geo)
    ax.set_ylabel(f"energy{eu}")
    ax.set_title("energy (drops at impacts)", fontsize=9)
    ax.legend(fontsize=8, frameon=False)


#: The panels of :func:`time_series`: ``draw(ax, geometry, dataset, name)``.
_PANELS = {
    "thigh": _angle_panel,
    "shank": _angle_panel,
    "hip": _hip_panel,
    "clearance": _clearance_panel,
    "energy": _energy_panel,
}


def _summary(ax, ds) -> None:
    """A text panel: how the walk started and how each step ended."""
    from jaxwalk.status import describe

    ax.set_axis_off()
    a = ds.attrs
    section = [str(x) for x in ds["section"].values]
    start = json.loads(a["start_section"])
    lines = [f"start: {a['start'].split(' (')[0]}"]
    lines += [f"  {n} = {v:.6g}" for n, v in zip(section, start)]
    if "gait_lambda_max" in a:
        lines.append(f"  lambda_max = {a['gait_lambda_max']:.4g}, period = {a['gait_period']:.4g}")
    if float(a["drop"]) > 0:
        lines.append(f"step-down at the first touchdown: {float(a['drop']):g}")
    lines.append("steps: duration, length, outcome")
    n = len(ds["step_number"])
    for k in range(min(n, 8)):
        lines.append(
            f"  {k}: {float(ds['step_duration'][k]):.4f}, {float(ds['step_length'][k]):.4f}, "
            f"{describe(int(ds['step_status'][k]))}"
        )
    if n > 8:
        lines.append(f"  ... ({n} steps)")
    ax.text(0.02, 0.98, "\n".join(lines), va="top", ha="left", family="monospace", fontsize=8, transform=ax.transAxes)


def save_stick_diagram(ds, model: Walker, path, **kwargs) -> None:
    """:func:`stick_diagram` saved as a PNG at ``path``."""
    import matplotlib.pyplot as plt

    fig = stick_diagram(ds, model, **kwargs)
    try:
        fig.savefig(path, format="png")
    finally:
        plt.close(fig)


def save_time_series(ds, model: Walker, path, **kwargs) -> None:
    """:func:`time_series` saved as a PNG at ``path``."""
    import matplotlib.pyplot as plt

    fig = time_series(ds, model, **kwargs)
    try:
        fig.savefig(path, format="png")
    finally:
        plt.close(fig)


def _unit_label(unit: str, bare: bool = False) -> str:
    if unit == "1":
        return "" if bare else " (model units)"
    return f" {unit}" if bare else f" ({unit})"
