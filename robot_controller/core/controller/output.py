"""What one tick of the joint controller reports: its :class:`Status`, where
the reference came from (:class:`ReferenceSource`) and the command with its
terms (:class:`ControlOutput`).

A reference the controller made up or rewrote (a hold, a controlled stop, a
blend back onto the trajectory) is always named in ``reference_source``,
never passed off as the planner's.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import StrEnum

import numpy as np

from robot_controller.core.laws import PidTerms


class Status(StrEnum):
    OK = "ok"
    HOLDING = "holding"  #: no reference yet: holding the first measured position
    NO_MEASUREMENT = "no_measurement"  #: no valid sensor message yet: no command
    WATCHDOG = "watchdog"  #: readings missing: controlled stop on the model's estimate (category 2)
    #: readings missing, the stop on the model over (at rest, held briefly) or past sensor_timeout_s:
    #: no command, the brake holds (category 1)
    SENSOR_LOST = "sensor_lost"
    REACQUIRING = "reacquiring"  #: a fault cleared: led from where the arm is back onto the trajectory
    REFERENCE_LOST = "reference_lost"  #: the planner went quiet: controlled stop of the reference, holding
    STOPPED = "stopped"  #: e-stop or brake: no command until it lifts
    LAW_FAULT = "law_fault"  #: the plugin law failed: controlled stop on the built-in law (category 2)
    LAW_STOPPED = "law_stopped"  #: after LAW_FAULT's stop and hold: no command, the brake holds (category 1)
    LATE = "late"  #: readings or commands later than the delay margin: controlled stop on the model (category 2)
    LATE_STOPPED = "late_stopped"  #: after LATE's stop and hold: no command, the brake holds (category 1)

    @property
    def commanding(self) -> bool:
        """Whether a tick in this state sends a torque to the motor."""
        return self not in _NOT_COMMANDING


# Made once: asked every tick.
_NOT_COMMANDING = frozenset(
    (Status.NO_MEASUREMENT, Status.SENSOR_LOST, Status.STOPPED, Status.LAW_STOPPED, Status.LATE_STOPPED)
)


class ReferenceSource(StrEnum):
    """Where the tick's reference (rad, rad/s, rad/s²) came from."""

    TRAJECTORY = "trajectory"  #: the planner's latest sample as it is (held between samples)
    EXTRAPOLATED = "extrapolated"  #: the planner's latest sample advanced to the tick on its v and a
    HOLD_POSITION = "hold_position"  #: no trajectory to follow (yet, or again): hold where the arm was
    REACQUIRE_BLEND = "reacquire_blend"  #: the trajectory plus a fading offset from where the arm was
    REFERENCE_STOP = "reference_stop"  #: the planner went quiet: its last reference brought to rest
    SENSOR_STOP = "sensor_stop"  #: readings missing: the reference brought to rest, the arm on the model
    LAW_STOP = "law_stop"  #: the plugin law failed: the reference brought to rest for the built-in law
    LATE_STOP = "late_stop"  #: the loop's delay is past its margin: the reference brought to rest, held
    NONE = "none"  #: no command this tick: ``reference`` only repeats the arm's position

    @property
    def from_planner(self) -> bool:
        """Whether the reference is the planner's own (not held or rewritten by the controller)."""
        return self in (ReferenceSource.TRAJECTORY, ReferenceSource.EXTRAPOLATED)


@dataclass
class ControlOutput:
    """One tick: the command and everything that went into it."""

    time_s: float
    status: Status
    reference: np.ndarray  #: rad, the position reference the law tracked
    measured: np.ndarray  #: rad, the arm's position as estimated at the tick
    terms: PidTerms
    reference_source: ReferenceSource = ReferenceSource.TRAJECTORY
    #: N·m per joint, the external torque the disturbance observer estimates (the command
    #: subtracts it, inside ``terms.feedforward``); None without an observer or a command
    disturbance: np.ndarray | None = None
    #: a plugin law's extra terms for ``/controller/state`` (its ``state_terms``), N·m per joint
    law_terms: dict[str, np.ndarray] | None = None

    @property
    def command(self) -> np.ndarray:
        return self.terms.command

    @property
    def error(self) -> np.ndarray:
        return self.reference - self.measured
