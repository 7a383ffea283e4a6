"""The trajectory dataset of a recorded walk: an xarray Dataset, CF-style
attributes, provenance (layout: ``docs/simulate.md``)."""

from __future__ import annotations

import datetime as _dt
import json
from typing import Any

import numpy as np

from jaxwalk.simulate.config import SimulateConfig
from jaxwalk.simulate.recorder import SAMPLE_KINDS, Trajectory
from jaxwalk.status import flag_attributes
from jaxwalk.walker import Walker


def coordinate_units(model: Walker) -> tuple[list[str], list[str]]:
    """Units of ``q`` and ``qd``: the hip position is a length, the rest are angles
    (the engine's convention, :mod:`jaxwalk.walker`)."""
    from jaxwalk.sweep.dataset import output_units

    u = output_units(model)
    length, time = u["length"], u["time"]
    q_units = [length if i < 2 else "rad" for i in range(model.n_q)]
    if time == "1":  # dimensionless time: rates carry the units of their coordinates
        qd_units = list(q_units)
    else:
        rate = lambda unit: f"{time}-1" if unit == "1" else f"{unit} {time}-1"
        qd_units = [rate(unit) for unit in q_units]
    return q_units, qd_units


def _flags(names) -> dict[str, Any]:
    return {"flag_values": list(range(len(names))), "flag_meanings": " ".join(names)}


def build_trajectory_dataset(
    config: SimulateConfig,
    model: Walker,
    traj: Trajectory,
    *,
    gait=None,
    command: str | None = None,
    created: _dt.datetime | None = None,
    solver=None,
):
    """The trajectory dataset (layout: ``docs/simulate.md``).

    Args:
        config: the resolved config; ``model`` its model; ``traj`` the recorded walk.
        gait: the :class:`jaxwalk.gait.Gait` the walk started from (``None`` with ``v0``).
        command: the command line that made it; ``created`` the time (default now, UTC).
        solver: the :class:`jaxwalk.step.SolverOptions` used (recorded as JSON).
    """
    import xarray as xr

    from jaxwalk.sweep.dataset import output_units

    units = output_units(model)
    created = created or _dt.datetime.now(_dt.timezone.utc)
    return xr.Dataset(
        _variables(model, traj, units["length"], units["time"]),
        coords=_coordinates(model, traj, units["time"]),
        attrs=_attributes(config, model, units, gait=gait, command=command, created=created, solver=solver),
    )


def _coordinates(model: Walker, traj: Trajectory, time_u: str) -> dict[str, tuple]:
    """The dataset's coordinates: time, the model's names, step numbers."""
    q_units, qd_units = coordinate_units(model)
    return {
        "time": ("time", traj.time, {
            "long_name": "time since the start of the walk (repeated at each event: the states just before and just after it)",
            "units": time_u,
        }),
        "coordinate": ("coordinate", np.array(model.coordinates, dtype=object), {
            "long_name": "generalized coordinates q: hip position in the slope frame, then absolute segment angles from the slope normal",
        }),
        "q_units": ("coordinate", np.array(q_units, dtype=object), {"long_name": "units of q"}),
        "qd_units": ("coordinate", np.array(qd_units, dtype=object), {"long_name": "units of qd"}),
        "constraint": ("constraint", np.arange(model.n_constraints), {"long_name": "constraint row of the model (model.constraints)"}),
        "limit": ("limit", np.array(model.limits, dtype=object), {"long_name": "contact limits the model checks (model.limits; none for most models)"}),
        "context": ("context", np.array(model.context, dtype=object), {"long_name": "entries of the discrete state ctx"}),
        "xy": ("xy", np.array(["x", "y"], dtype=object), {"long_name": "slope frame axes: x along the slope (downhill), y normal to it"}),
        "step_number": ("step_number", np.arange(len(traj.step_status)), {"long_name": "step index, from 0"}),
        "section": ("section", np.array(model.section_names, dtype=object), {"long_name": "section coordinates at the start of a step"}),
    }


def _variables(model: Walker, traj: Trajectory, length_u: str, time_u: str) -> dict[str, tuple]:
    """The dataset's variables: per sample, per step, and the walk's outcome."""
    q_units, qd_units = coordinate_units(model)
    n_q = model.n_q
    force_u = "1" if length_u == "1" else "N or N m"
    energy_u = "1" if length_u == "1" else "J"
    power_u = "1" if length_u == "1" else "W"
    guard_flags = {"flag_values": list(range(-1, len(model.guards))), "flag_meanings": " ".join(("none", *model.guards))}
    return {
        "phase": ("time", traj.phase, {"long_name": "phase of the step", **_flags(model.phases)}),
        "step": ("time", traj.step, {
            "long_name": "index of the step the sample belongs to (the state after the last completed step's heel-strike has index steps_completed)",
            "units": "1",
        }),
        "sample_kind": ("time", traj.sample_kind, {"long_name": "regular sample (a multiple of dt) or the state just before/after an event", **_flags(SAMPLE_KINDS)}),
        "event_guard": ("time", traj.event_guard, {"long_name": "guard whose zero crossing caused the event (event samples only)", **guard_flags}),
        "q": (("time", "coordinate"), traj.y[:, :n_q], {
            "long_name": "generalized coordinates in the frame of the current step (slope frame, stance foot at the origin at the step's start; leg 1 = stance leg)",
            "units_per_coordinate": json.dumps(dict(zip(model.coordinates, q_units))),
        }),
        "qd": (("time", "coordinate"), traj.y[:, n_q:], {
            "long_name": "generalized velocities",
            "units_per_coordinate": json.dumps(dict(zip(model.coordinates, qd_units))),
        }),
        "contact_force": (("time", "constraint"), traj.contact_force, {
            "long_name": "constraint forces: the KKT multipliers lambda of model.dynamics (NaN where the constraint is inactive)",
            "units": force_u,
            "comment": "a force for a position constraint (foot x, y; positive y: the ground pushes up), a torque for an angle constraint (a knee lock); impulses at impacts are not included",
        }),
        "limit_use": (("time", "limit"), traj.limit_use, {
            "long_name": "use of each contact limit: 0 unloaded, 1 at its edge (where its failure guard crosses zero), above 1 beyond it (model.limit_use)",
            "units": "1",
            "comment": "NaN where the limit does not apply in the phase; inf where the contact's normal force does not push. The largest value over a walk says which limit a failing or nearly failing walk meets, and when",
        }),
        "ctx": (("time", "context"), traj.ctx, {"long_name": "discrete state (contact anchors, ground level of the next touchdown), in the frame of the current step"}),
        "frame_origin": (("time", "xy"), traj.origin, {
            "long_name": "origin of the current step's frame in the first step's frame (slope frame); world = frame_origin + q[:2] for the hip",
            "units": length_u,
        }),
        "energy": ("time", traj.energy, {
            "long_name": "total mechanical energy (kinetic + gravity + springs), gravity potential measured in the first step's frame",
            "units": energy_u,
        }),
        "actuator_power": ("time", traj.actuator_power, {
            "long_name": "power of the actuators, qd . Q_actuator (model.actuator_power; 0 for a passive model)",
            "units": power_u,
        }),
        "work": ("time", traj.work, {
            "long_name": "cumulative actuator work since the start (Simpson's rule between samples on the dense solution; "
                         "a reset's own work added at its event)",
            "units": energy_u,
        }),
        "step_status": ("step_number", traj.step_status, {"long_name": "outcome of each step (0: completed)", **flag_attributes()}),
        "step_start_time": ("step_number", traj.step_start_time, {"long_name": "time at the start of the step", "units": time_u}),
        "step_duration": ("step_number", traj.step_duration, {"long_name": "duration of the step (to the event that ended it)", "units": time_u}),
        "step_length": ("step_number", traj.step_length, {"long_name": "distance the stance foot advanced in the step, along the slope", "units": length_u}),
        "section_start": (("step_number", "section"), traj.section_start, {"long_name": "section coordinates at the start of the step"}),
        "section_end": (("step_number", "section"), traj.section_end, {"long_name": "section coordinates at the end of the step (NaN if it failed)"}),
        "status": ((), np.int8(traj.status), {"long_name": "outcome of the walk: 0 if every step was completed, else the failed step's status", **flag_attributes()}),
        "steps_completed": ((), np.int32(traj.steps_completed), {"long_name": "steps completed", "units": "1"}),
    }


def _start(config: SimulateConfig, gait) -> dict[str, Any]:
    """Attributes saying where the walk started: given ``v0``, or the periodic gait."""
    if config.v0 is not None:
        return {"start": "v0 (given section coordinates)", "start_section": json.dumps(list(config.v0))}
    return {
        "start": "periodic gait (find_gait from the model's initial guess)",
        "start_section": json.dumps([float(x) for x in np.asarray(gait.v)]),
        "gait_lambda_max": float(gait.lambda_max),
        "gait_period": float(gait.period),
        "gait_step_length": float(gait.step_length),
        "gait_newton_iterations": int(gait.iterations),
    }


def _attributes(config: SimulateConfig, model: Walker, units, *, gait, command, created, solver) -> dict[str, Any]:
    """The dataset's attributes: the model, the config, the start, provenance."""
    from jaxwalk.files import provenance
    from jaxwalk.sweep.dataset import units_note

    return {
        "title": f"jaxwalk simulation '{config.name}' of the {model.name} model",
        "Conventions": "CF-1.10",
        "name": config.name,
        "model": model.name,
        "model_description": model.description,
        "params": json.dumps(config.fixed),
        "parameter_units": json.dumps({p.name: p.units for p in model.parameters}),
        "units": json.dumps(units),
        "units_note": units_note(model),
        "steps_requested": config.steps,
        "drop": config.drop,
        "drop_comment": "vertical step-down of the ground at the first touchdown (model length units); later steps on the new level",
        "dt": config.dt,
        **_start(config, gait),
        "status_meanings": flag_attributes()["flag_descriptions"],
        "solver_options": json.dumps(solver.as_record(model) if solver is not None else {}, default=str),
        "config": config.to_json(),
        "config_toml": config.text if config.text is not None else "",
        "config_source": config.source,
        **provenance(command, "jaxwalk.simulate.run_simulation", created=created),
    }
