"""The reference the law tracks at a tick, and every way it departs from the planner's
trajectory: a hold (before the first sample, or after a fault until a fresh one comes), a
controlled stop (IEC 60204-1 category 2) when the planner goes quiet, the readings go missing,
the loop is late or a plugin law fails, and a blend from where the arm is back onto the
trajectory. Each reference is named with its :attr:`ReferenceAtTick.status` and
:attr:`ReferenceAtTick.source`: a held or rewritten reference is never passed off as the planner's."""

from __future__ import annotations

import numpy as np

from robot_controller.core.controller.config import ControllerConfig
from robot_controller.core.controller.safe_motion import Blend, ControlledStop
from robot_controller.core.controller.setpoint import PlannerReference, TrajectoryPoint
from robot_controller.core.controller.supervision import ReferenceSource, Status
from robot_controller.core.controller.tick_state import MAX_EXTRAPOLATION_S
from robot_controller.core.laws import Reference


class ReferenceAtTick:
    """The planner's samples and the hold, stops and blend around faults."""

    def __init__(self, joint_count: int) -> None:
        self.joint_count = joint_count
        self.planner = PlannerReference()
        # Start as after a fault: lead the arm from where it is onto the trajectory.
        self._needs_reacquire = True
        self._hold_position: np.ndarray | None = None
        # The reference last used (position, velocity, acceleration) and when: a stop starts from it.
        self._last: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None
        self._last_s = 0.0
        self._stops: dict[ReferenceSource, ControlledStop] = {}  #: the controlled stops under way, by source
        self._blend: Blend | None = None
        self.status = Status.HOLDING  #: the latest reference's: OK, HOLDING, REACQUIRING, a stop's
        self.source = ReferenceSource.HOLD_POSITION  #: where the latest reference came from

    # --- re-acquisition -------------------------------------------------------------

    def request_reacquire(self) -> None:
        """The arm moved (or may have) without this controller: once it is
        tracking again, lead it from where it is then, not where it was."""
        self._needs_reacquire = True

    @property
    def reacquire_pending(self) -> bool:
        return self._needs_reacquire

    def try_reacquire(
        self, now_s: float, arm_position: np.ndarray, arm_velocity: np.ndarray, config: ControllerConfig
    ) -> bool:
        """Leave the sensor-loss stop and, if the planner's trajectory is fresh,
        start a blend from the arm's ``(position, velocity)`` onto it (within
        ``reacquire_acceleration``). False while there is no fresh trajectory to
        lead the arm onto: :meth:`at_tick` holds it meanwhile."""
        self._stops.pop(ReferenceSource.SENSOR_STOP, None)
        self._stops.pop(ReferenceSource.LATE_STOP, None)
        planner = self.planner
        if (
            planner.sample is None
            or not planner.spoke
            or not planner.at(now_s, config.reference_extrapolation, config.control_period_s).fresh
        ):
            return False
        self._needs_reacquire = False
        self._hold_position = None
        point = planner.at(now_s, config.reference_extrapolation, config.control_period_s)
        self._stops.pop(ReferenceSource.REFERENCE_STOP, None)
        self._blend = Blend.starting(
            now_s, arm_position - point.position, arm_velocity - point.velocity, config.reacquire_acceleration
        )
        return True

    # --- the reference at the tick ------------------------------------------------------

    def at_tick(self, now_s: float, arm_position: np.ndarray, config: ControllerConfig) -> Reference:
        """The reference while the readings are healthy: a hold while a
        re-acquisition waits for a fresh trajectory, otherwise
        :meth:`from_trajectory`."""
        if self._needs_reacquire:
            return self._hold(arm_position)
        self._hold_position = None  # a later hold starts where the arm is then
        return self.from_trajectory(now_s, arm_position, config)

    def _hold(self, arm_position: np.ndarray) -> Reference:
        """Hold the arm where it was when the hold began, at rest. HOLDING before
        the planner's first sample, REACQUIRING (waiting for a fresh one) after."""
        if self._hold_position is None:
            self._hold_position = arm_position
        zeros = np.zeros(self.joint_count)
        status = Status.HOLDING if not self.planner.spoke else Status.REACQUIRING
        return self._named(Reference(self._hold_position, zeros, zeros), status, ReferenceSource.HOLD_POSITION)

    def from_trajectory(self, now_s: float, arm_position: np.ndarray, config: ControllerConfig) -> Reference:
        """The trajectory at ``now_s`` (held or extrapolated); while re-acquiring,
        plus the blend's fading offset; a controlled stop of the last reference
        used if the planner went quiet, and a blend from that stop when it
        returns. Before the planner's first sample: a hold at ``arm_position``."""
        planner = self.planner
        if planner.sample is None:
            planner.hold_here(arm_position, now_s)
        if not planner.spoke:
            return self._named(Reference(*planner.sample), Status.HOLDING, ReferenceSource.HOLD_POSITION)
        point = planner.at(now_s, config.reference_extrapolation, config.control_period_s)
        if not point.fresh:
            return self._planner_lost(now_s, point, config)
        planner_stop = self._stops.pop(ReferenceSource.REFERENCE_STOP, None)
        if planner_stop is not None:  # the planner is back: lead from the stop onto its trajectory
            held = planner_stop.at(now_s)
            self._blend = Blend.starting(
                now_s, held[0] - point.position, held[1] - point.velocity, config.reacquire_acceleration
            )
        # The command is held over the period: its feedforward is for the reference over it.
        mid_s = now_s + 0.5 * config.control_period_s
        ahead = planner.over_period(now_s, config.control_period_s, config.reference_extrapolation)
        reference = Reference(point.position, point.velocity, point.acceleration, ahead)
        status, source = Status.OK, point.source
        if self._blend is not None:
            if self._blend.done(now_s):
                self._blend = None
            else:
                offset, offset_ahead = self._blend.offset_at(now_s), self._blend.offset_at(mid_s)
                reference = Reference(
                    point.position + offset[0],
                    point.velocity + offset[1],
                    point.acceleration + offset[2],
                    tuple(x + dx for x, dx in zip(ahead, offset_ahead, strict=True)),
                )
                status, source = Status.REACQUIRING, ReferenceSource.REACQUIRE_BLEND
        return self._used(now_s, reference, status, source)

    def _planner_lost(self, now_s: float, point: TrajectoryPoint, config: ControllerConfig) -> Reference:
        """The planner went quiet: bring the reference to rest at ``stop_deceleration`` from the last
        one used, carried on to now at its velocity (no jump), and hold there."""
        source = ReferenceSource.REFERENCE_STOP
        if source not in self._stops:
            last = self._last or (point.position, point.velocity, point.acceleration)
            carried = np.clip(now_s - self._last_s, 0.0, MAX_EXTRAPOLATION_S)
            self._stops[source] = ControlledStop(now_s, last[0] + last[1] * carried, last[1], config.stop_deceleration)
            self._blend = None
        return self._used(now_s, Reference(*self._stops[source].at(now_s)), Status.REFERENCE_LOST, source)

    def stop(
        self,
        now_s: float,
        source: ReferenceSource,
        arm_position: np.ndarray,
        config: ControllerConfig,
        start: Reference | None = None,
    ) -> Reference:
        """A controlled stop (category 2): from ``start`` or, at the first tick of the stop, from where
        the reference is then (no jump in it), decelerate to rest at ``stop_deceleration`` and hold
        there. ``source``: SENSOR_STOP (readings missing, until re-acquisition), LATE_STOP (the loop's
        delay past its margin, likewise) or LAW_STOP (the plugin law failed: for good; it starts from
        the reference of the tick it failed on, or the last one used)."""
        if source not in self._stops:
            if start is None and source is ReferenceSource.LAW_STOP:
                start = Reference(*(self._last or (np.zeros(self.joint_count),) * 3))
            elif start is None:
                start = self.from_trajectory(now_s, arm_position, config)
            self._stops[source] = ControlledStop(now_s, start.position, start.velocity, config.stop_deceleration)
        return self._used(now_s, Reference(*self._stops[source].at(now_s)), _STOP_STATUS[source], source)

    def stop_at_rest(self, source: ReferenceSource, now_s: float) -> bool:
        """Whether the stop from ``source`` is under way and has come to rest."""
        stop = self._stops.get(source)
        return stop is not None and stop.at_rest(now_s)

    def _used(self, now_s: float, reference: Reference, status: Status, source: ReferenceSource) -> Reference:
        """Remember ``reference`` as the last one used (a later stop starts from it), named."""
        self._last, self._last_s = (reference.position, reference.velocity, reference.acceleration), now_s
        return self._named(reference, status, source)

    def _named(self, reference: Reference, status: Status, source: ReferenceSource) -> Reference:
        self.status, self.source = status, source
        return reference


_STOP_STATUS = {
    ReferenceSource.SENSOR_STOP: Status.WATCHDOG,
    ReferenceSource.LATE_STOP: Status.LATE,
    ReferenceSource.LAW_STOP: Status.LAW_FAULT,
}
