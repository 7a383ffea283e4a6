"""Named outcomes of a step, a gait search or a step-down trial.

Every batched computation in jaxwalk carries an ``int8`` status next to its
numbers, from the innermost phase loop up to the dataset and the plots: a
walker that falls, stalls or never finishes its step is data, not a NaN.

The integer values are part of the file format (they are written to datasets
with CF ``flag_values`` / ``flag_meanings``): append new codes, never renumber.
"""

from __future__ import annotations

import enum


class Status(enum.IntEnum):
    """Outcome codes. ``OK`` (0) is the only success."""

    OK = 0
    FELL = 1
    STALLED = 2
    TIMEOUT = 3
    NONFINITE = 4
    RUNNING = 5
    SHANK_RELEASING = 6
    SCUFFING = 7
    TOO_MANY_EVENTS = 8
    NO_CONVERGENCE = 9
    SOLVER_FAILED = 10
    KNEE_BUCKLED = 11
    NOT_DIFFERENTIABLE = 12
    NOT_COMPUTED = 13  # a store's fill value: the point's chunk was never written
    SLIPPING = 14
    NO_PERIODIC_ATTRACTOR = 15
    CYCLE_NOT_FOUND = 16
    NOT_RETURNED = 17
    UNSTABLE_GAIT = 18
    FOOT_ROLLING = 19
    NOT_A_STATE = 20
    NOT_LOCATED = 21
    IN_PROGRESS = 127  # internal: a step still running; never written to a dataset


#: One sentence per status, used in dataset attributes, docs and plot legends.
STATUS_MEANINGS: dict[Status, str] = {
    Status.OK: "periodic gait found (or step completed)",
    Status.FELL: ("fell: a leg angle left its range or the hip dropped too low (the compass walker: also a step "
                  "that starts with the new stance foot behind the hip)"),
    Status.STALLED: "stalled: the walker stopped or moved backwards",
    Status.TIMEOUT: "no event ended a phase before its time limit (the kneed walker: no knee-strike in time)",
    Status.NONFINITE: "the state, or a number reported at a gait found, came out non-finite (NaN; inf where no infinity is a value)",
    Status.RUNNING: "running: a stance ground contact's force or impact impulse would have to pull (it lifts off: flight)",
    Status.SHANK_RELEASING: "shank releasing: heel-strike with the swing knee unlocked",
    Status.SCUFFING: ("scuffing: a foot below the ground beyond tolerance, or a landing into it (a heel-strike not "
                      "ahead of the stance foot or with the heel rising, a trailing heel that would sink; the "
                      "compass walker: a swing leg still behind the stance leg at mid-stance, its foot must cross the ground)"),
    Status.TOO_MANY_EVENTS: "the step never ended: too many events in one step",
    Status.NO_CONVERGENCE: "Newton's method did not converge to a fixed point",
    Status.SOLVER_FAILED: "the ODE solver failed (its step budget, or an event time it could not locate)",
    Status.KNEE_BUCKLED: ("a locked knee on its extension stop alone (no latch) would have to pull to stay straight "
                          "(a force, or an impact's impulse)"),
    Status.NOT_DIFFERENTIABLE: ("gait found, but no derivative: a fold (I - J singular), a defective dominant "
                                "eigenvalue, or a derivative (or a value an optimisation steps on) came out non-finite"),
    Status.NOT_COMPUTED: "not computed: this point's chunk was not written (an unfinished or damaged store)",
    Status.SLIPPING: "slipping: a ground contact force or impulse left its friction cone",
    Status.NO_PERIODIC_ATTRACTOR: (
        "no periodic attractor: walked from the unstable gait's neighbourhood, the walker kept walking "
        "without repeating at any tested period (quasi-periodic, chaotic, longer period, or too slow to settle)"
    ),
    Status.CYCLE_NOT_FOUND: ("no genuine period-k cycle: Newton on the k-step map found none where the walk repeated "
                             "(attractors), or converged onto a shorter cycle (a re-solve along a line)"),
    Status.NOT_RETURNED: (
        "not returned: walked every allowed step from the perturbed start without a failure, "
        "but never came within tol of the gait's cycle (a slower return, another attractor, or none)"
    ),
    Status.UNSTABLE_GAIT: "the period-1 gait is unstable and no attractor of it is known: no basin to measure",
    Status.FOOT_ROLLING: (
        "foot rolling: the flat stance foot's centre of pressure left the foot (it would tip onto its heel or toe)"
    ),
    Status.NOT_A_STATE: (
        "not a state: a perturbed start outside the walker's states (the model's into_section moves it, e.g. a "
        "flat foot below the ground); its walk is not read, and it is left out of the basin's counts"
    ),
    Status.NOT_LOCATED: ("not located: a bracket (a bifurcation, a border collision) was not narrowed to its "
                         "tolerance, out of iterations or with a trial gait on a third event sequence, a "
                         "continuation step was refused for a tangent that turned too far, or beyond an edge "
                         "Newton started from the line's gait converged to another gait; Newton was not the limit"),
    Status.IN_PROGRESS: "internal: step in progress",
}

#: Codes that may appear in a dataset, in order.
DATASET_STATUSES: tuple[Status, ...] = tuple(s for s in Status if s != Status.IN_PROGRESS)
#: Codes an analysis may return (``NOT_COMPUTED`` is the store's, not a result).
RESULT_STATUSES: tuple[Status, ...] = tuple(s for s in DATASET_STATUSES if s != Status.NOT_COMPUTED)


def flag_attributes() -> dict[str, object]:
    """CF-convention attributes for a ``status`` variable.

    Returns ``flag_values`` (list of int) and ``flag_meanings`` (space-separated
    snake_case names, as CF requires) plus a ``flag_descriptions`` string with
    the sentences of :data:`STATUS_MEANINGS`.
    """
    return {
        "flag_values": [int(s) for s in DATASET_STATUSES],
        "flag_meanings": " ".join(s.name.lower() for s in DATASET_STATUSES),
        "flag_descriptions": "; ".join(
            f"{int(s)} {s.name.lower()}: {STATUS_MEANINGS[s]}" for s in DATASET_STATUSES
        ),
    }


def describe(code: int) -> str:
    """Human-readable name of a status code (``'fell'``, ``'ok'``, ...)."""
    try:
        return Status(int(code)).name.lower()
    except ValueError:
        return f"unknown({int(code)})"
