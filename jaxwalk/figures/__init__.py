"""Figures of a recorded walk (``jaxwalk simulate``): PNGs and an animated GIF.

Every function takes the trajectory dataset (:func:`jaxwalk.simulate.build_trajectory_dataset`,
or the zarr store read back with xarray) and its model, and draws in world
coordinates: the slope frame turned by ``gamma``, x forward (downhill),
y up. Drawing needs two model methods (``docs/simulate.md``):

* ``skeleton(q, params, ctx) -> (2, n_points, 2)``: a polyline per leg (leg 1
  the stance leg) from the hip to the foot, ``hip, [knee], ankle/foot, [heel,
  toe]``, in the slope frame;
* ``foot_points(q, params, ctx) -> (2, n_foot, 2)``: the points of each foot
  that can touch the ground, in the slope frame.

A model without them raises :class:`jaxwalk.sweep.config.ConfigError` with a
one-line message. Legs are coloured by *physical* leg (the stance/swing labels
swap every step; leg A is the stance leg of step 0).
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
