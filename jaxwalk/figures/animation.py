"""An animated GIF of a recorded walk (matplotlib's ``PillowWriter``).

Frames are taken at ``1/fps`` of real time: a model in seconds plays at real
speed; a dimensionless model (time unit ``sqrt(L/g)``) plays as if its leg were
1 m long (one time unit = ``sqrt(1 m / 9.81 m s-2)`` = 0.319 s). Each frame
shows the recorded sample at or just before its time (after an event, the state
just after it). The view holds the whole walk when it is at most
:data:`FOLLOW_ABOVE` leg lengths wide, and otherwise follows the hip. At most
``max_frames`` frames (the start of a long walk): with the defaults a GIF
stays well below 3 MB.
"""

from __future__ import annotations

import numpy as np

from jaxwalk.figures.gait_figures import (
    LEG_COLOURS,
    LEG_NAMES,
    WalkGeometry,
    _unit_label,
    draw_ground,
    walk_geometry,
)
from jaxwalk.walker import Walker

#: Seconds per time unit of a dimensionless model: sqrt(1 m / 9.81 m s-2).
DIMENSIONLESS_SECONDS = float(np.sqrt(1.0 / 9.81))
#: A walk wider than this many leg lengths is shown by a camera following the hip.
FOLLOW_ABOVE = 4.5


def frame_indices(geo: WalkGeometry, fps: float, max_frames: int) -> np.ndarray:
    """Sample index shown in each frame (the last sample at or before its time);
    a walk that fits in ``max_frames`` ends on its final state, held for half a second."""
    seconds = 1.0 if geo.time_unit == "s" else DIMENSIONLESS_SECONDS
    step = 1.0 / (fps * seconds)  # model time per frame
    end = geo.time[-1]
    times = np.arange(0.0, end + 0.5 * step, step)[:max_frames]
    idx = np.searchsorted(geo.time, times, side="right") - 1
    idx = np.clip(idx, 0, len(geo.time) - 1)
    if len(times) < max_frames:  # the final state, held for half a second
        idx = np.append(idx, np.full(max(1, int(round(0.5 * fps))), len(geo.time) - 1))
    return idx


def save_animation(
    ds,
    model: Walker,
    path,
    *,
    fps: float = 20.0,
    max_frames: int = 300,
    dpi: int = 100,
    height: float = 2.8,
    geometry: WalkGeometry | None = None,
) -> int:
    """Write an animated GIF of the walk to ``path``; return the number of frames."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.animation import FuncAnimation, PillowWriter

    geo = geometry or walk_geometry(ds, model)
    frames = frame_indices(geo, fps, max_frames)
    L = geo.leg_length
    shown = geo.skeleton[frames].reshape(-1, 2)
    lo, hi = shown.min(axis=0), shown.max(axis=0)
    pad = 0.15 * L
    follow = (hi[0] - lo[0]) > FOLLOW_ABOVE * L
    if follow:  # a window of 3 leg lengths around the hip
        width_world = 3.0 * L
        y_lo, y_hi = -1.2 * L - 2 * pad - 1.5 * L * abs(np.tan(geo.gamma)), 2 * pad
    else:
        width_world = (hi[0] - lo[0]) + 2 * pad
        y_lo, y_hi = lo[1] - 2 * pad, hi[1] + 2 * pad  # room for the caption
    aspect = width_world / (y_hi - y_lo)
    fig, ax = plt.subplots(figsize=(min(height * aspect, 9.0), height), dpi=dpi)
    ax.set_aspect("equal")
    ax.set_axis_off()
    fig.subplots_adjust(0, 0, 1, 1)
    draw_ground(ax, geo)
    legs = [ax.plot([], [], color=LEG_COLOURS[k], lw=3.0, solid_capstyle="round", zorder=2, label=LEG_NAMES[k])[0] for k in range(2)]
    sizes = 15.0 + 70.0 * geo.masses / geo.masses.max()
    dots = ax.scatter(geo.points[0, :, 0], geo.points[0, :, 1], s=sizes, color="k", zorder=3, lw=0)
    (trail,) = ax.plot([], [], ":", color="0.5", lw=1.0, zorder=1)
    text = ax.text(0.01, 0.97, "", transform=ax.transAxes, va="top", fontsize=8, family="monospace")
    tu = _unit_label(geo.time_unit, bare=True)

    def window(i):
        if follow:
            x_c, y_c = geo.hip[i]
            ax.set_xlim(x_c - 0.5 * width_world, x_c + 0.5 * width_world)
            ax.set_ylim(y_c + y_lo, y_c + y_hi)
        else:
            ax.set_xlim(lo[0] - pad, hi[0] + pad)
            ax.set_ylim(y_lo, y_hi)

    def update(n):
        i = frames[n]
        for k in range(2):
            legs[k].set_data(geo.skeleton[i, k, :, 0], geo.skeleton[i, k, :, 1])
        dots.set_offsets(geo.points[i])
        trail.set_data(geo.hip[: i + 1, 0], geo.hip[: i + 1, 1])
        text.set_text(f"{model.name}  t = {geo.time[i]:5.2f}{tu}  step {geo.step[i]}")
        window(i)
        return [*legs, dots, trail, text]

    window(frames[0])
    anim = FuncAnimation(fig, update, frames=len(frames), blit=False)
    try:
        anim.save(str(path), writer=PillowWriter(fps=fps))
    finally:
        plt.close(fig)
    return len(frames)
