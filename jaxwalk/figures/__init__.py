"""Figures of a recorded walk (``jaxwalk simulate``): PNGs and an animated GIF.

Every function takes the trajectory dataset (:func:`jaxwalk.simulate.build_trajectory_dataset`,
or the zarr store read back with xarray) and its model, and draws in world
coordinates: the slope frame turned by ``gamma``, x forward (downhill),
y up. Drawing needs the model's drawing capability, :meth:`Walker.skeleton
<jaxwalk.walker.Walker.skeleton>` and :meth:`Walker.foot_points
<jaxwalk.walker.Walker.foot_points>` (``docs/simulate.md``); a model without
it raises :class:`jaxwalk.ConfigError` with a one-line message. Legs are
coloured by *physical* leg (the stance/swing labels swap every step; leg A is
the stance leg of step 0).
"""

from jaxwalk.figures.animation import save_animation as save_animation
from jaxwalk.figures.gait_figures import (
    WalkGeometry as WalkGeometry,
    save_stick_diagram as save_stick_diagram,
    save_time_series as save_time_series,
    stick_diagram as stick_diagram,
    time_series as time_series,
    walk_geometry as walk_geometry,
)
