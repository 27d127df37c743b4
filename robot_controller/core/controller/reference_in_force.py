"""The reference in force at a tick: the planner's samples as they arrive (:class:`PlannerReference`: held or
extrapolated to the tick, and over the period the command is held for), and every way the reference departs from
them (:class:`ReferenceAtTick`): a hold (before the first sample, or after a fault until a fresh one comes), a
controlled stop (category 2) when the planner goes quiet, the readings go missing, the loop is late or a plugin law
fails, and a blend from where the arm is back onto the trajectory, each named with its status and source."""

from __future__ import annotations

from collections import deque
from typing import NamedTuple

import numpy as np

from robot_controller.core.controller.config import ControllerConfig
from robot_controller.core.controller.safe_motion import Blend, ControlledStop
from robot_controller.core.controller.supervision import ReferenceSource, Status
from robot_controller.core.controller.tick_state import MAX_EXTRAPOLATION_S, TIME_EPS_S, clipped_age_s
from robot_controller.core.laws import Reference

# The planner counts as silent after this many of its periods without a sample.
REFERENCE_TIMEOUT_PERIODS = 5
# A sample stamped up to this far ahead of the receiver's clock (s) waits for its time; one stamped
# further ahead is taken at once, as if stamped now: a clock that far off is wrong, not early.
MAX_AHEAD_S = 1.0
# Samples waiting for their time, at most (one planner period ahead is the normal case).
MAX_UPCOMING = 100


def _minmod(a: list[float], b: list[float]) -> np.ndarray:
    """Per element, the smaller in magnitude of ``a`` and ``b`` where they agree in sign, else 0 (a slope limiter).
    On Python's floats: a few joints, where each NumPy call costs more than its arithmetic."""
    return np.array(
        [
            min(x, y) if x > 0.0 and y > 0.0 else max(x, y) if x < 0.0 and y < 0.0 else 0.0
            for x, y in zip(a, b, strict=True)
        ]
    )


class TrajectoryPoint(NamedTuple):
    """The planner's trajectory at one tick (a named tuple: one is made every tick, and a tuple is made fastest)."""

    position: np.ndarray  #: rad
    velocity: np.ndarray  #: rad/s
    acceleration: np.ndarray  #: rad/s²
    fresh: bool  #: the latest sample is younger than :meth:`PlannerReference.timeout_s`
    source: ReferenceSource  #: TRAJECTORY (the sample as it is) or EXTRAPOLATED


class PlannerReference:
    """The latest reference sample due from the planner, and those not due yet."""

    def __init__(self) -> None:
        self.sample: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None  #: (position, velocity, acceleration)
        self.spoke = False  #: a sample has arrived from the planner (not just a hold written in)
        self.time_s = 0.0  #: s, the latest sample's time base
        self.period_s: float | None = None  #: s, learned from consecutive sample times
        #: rad/s³, the trajectory's jerk as the last three samples' accelerations agree on it (0 where
        #: they do not: an acceleration that jumps, as a shaped step's does on a sample, has none)
        self.jerk: np.ndarray | None = None
        self._acceleration_slope: list[float] | None = None  #: rad/s³, between the last two samples
        #: samples stamped ahead of their receipt, oldest first: (time_s, position, velocity, acceleration)
        self._upcoming: deque[tuple[float, np.ndarray, np.ndarray, np.ndarray]] = deque(maxlen=MAX_UPCOMING)

    def receive(
        self,
        received_s: float,
        position: np.ndarray,
        velocity: np.ndarray,
        acceleration: np.ndarray,
        sample_time_s: float | None = None,
    ) -> None:
        """A new sample, timed ``sample_time_s`` (None: its arrival); one stamped ahead of ``received_s`` (by at
        most MAX_AHEAD_S) waits for :meth:`advance_to` its time."""
        time_s = received_s if sample_time_s is None else sample_time_s
        if TIME_EPS_S < time_s - received_s <= MAX_AHEAD_S:
            self._upcoming.append((time_s, position, velocity, acceleration))
            return
        self._take(time_s, position, velocity, acceleration)

    def advance_to(self, now_s: float) -> None:
        """Take every waiting sample due by ``now_s``, in order."""
        upcoming = self._upcoming
        while upcoming and upcoming[0][0] <= now_s + TIME_EPS_S:
            self._take(*upcoming.popleft())

    def _take(self, time_s: float, position: np.ndarray, velocity: np.ndarray, acceleration: np.ndarray) -> None:
        if self.sample is not None and time_s > self.time_s:
            self.period_s = period_s = time_s - self.time_s
            # The jerk, from the planner's own samples only (not a hold written in before it spoke).
            slope = None
            if self.spoke:
                now, before = np.asarray(acceleration, dtype=float).tolist(), self.sample[2].tolist()
                slope = [(a - b) / period_s for a, b in zip(now, before, strict=True)]
            self.jerk = (
                None if slope is None or self._acceleration_slope is None else _minmod(slope, self._acceleration_slope)
            )
            self._acceleration_slope = slope
        self.spoke = True
        self.sample = (position, velocity, acceleration)
        self.time_s = time_s

    def hold_here(self, position: np.ndarray, now_s: float) -> None:
        """Before the planner has spoken, a sample at rest at ``position`` dated ``now_s`` (what a stop starts from
        then); it counts for :meth:`ready`, and as the previous sample when the first real one comes."""
        zeros = np.zeros(np.shape(position))
        self.sample = (position.copy(), zeros.copy(), zeros.copy())
        self.time_s = now_s

    def ready(self, tick_s: float) -> bool:
        """Whether every sample due by ``tick_s`` is in (where the world waits): the latest is
        at least as new as the tick, a later one is waiting, or the next is not due yet."""
        self.advance_to(tick_s)
        if self._upcoming:
            return True
        if self.sample is None:
            return False
        if self.time_s >= tick_s - TIME_EPS_S:
            return True
        return self.period_s is not None and self.time_s + self.period_s > tick_s + TIME_EPS_S

    def timeout_s(self, control_period_s: float) -> float:
        """Age (s) past which the latest sample is stale: REFERENCE_TIMEOUT_PERIODS planner periods (control
        periods until it is learned), at least MAX_EXTRAPOLATION_S."""
        period = self.period_s if self.period_s is not None else control_period_s
        return max(REFERENCE_TIMEOUT_PERIODS * period, MAX_EXTRAPOLATION_S)

    def at(self, now_s: float, extrapolate: bool, control_period_s: float) -> TrajectoryPoint:
        """The latest sample held or, with ``extrapolate``, advanced to ``now_s`` on its velocity and acceleration
        (by at most MAX_EXTRAPOLATION_S)."""
        position, velocity, acceleration = self.sample
        fresh = now_s - self.time_s <= self.timeout_s(control_period_s)
        source = ReferenceSource.TRAJECTORY
        if extrapolate:
            age_s = clipped_age_s(now_s, self.time_s)
            if age_s > 0:  # (a sample of the tick's own instant is the trajectory there)
                q, v, a = position.tolist(), velocity.tolist(), acceleration.tolist()  # (as in over_period)
                position = np.array(
                    [qj + vj * age_s + 0.5 * aj * age_s * age_s for qj, vj, aj in zip(q, v, a, strict=True)]
                )
                velocity = np.array([vj + aj * age_s for vj, aj in zip(v, a, strict=True)])
                source = ReferenceSource.EXTRAPOLATED
        return TrajectoryPoint(position, velocity, acceleration, fresh, source)

    def over_period(
        self, now_s: float, period_s: float, extrapolate: bool
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The trajectory a torque held over ``[now_s, now_s + period_s]`` is computed for: at the middle of the
        period, where the model's torque equals its average over the period to second order (the torque at
        ``now_s`` lags the motion by half a period); with ``extrapolate``, advanced there on the sample's velocity,
        acceleration and :attr:`jerk`, else the sample as held."""
        position, velocity, acceleration = self.sample
        if not extrapolate:
            return position, velocity, acceleration
        s = min(max(float(now_s + 0.5 * period_s - self.time_s), 0.0), MAX_EXTRAPOLATION_S)
        half_s2, sixth_s3 = s * s / 2, s**3 / 6
        # On Python's floats, joint by joint (a NumPy call costs more than its arithmetic on a few joints).
        q, v, a = position.tolist(), velocity.tolist(), acceleration.tolist()
        jerk = [0.0] * len(a) if self.jerk is None else self.jerk.tolist()
        return (
            np.array(
                [qj + vj * s + aj * half_s2 + jj * sixth_s3 for qj, vj, aj, jj in zip(q, v, a, jerk, strict=True)]
            ),
            np.array([vj + aj * s + jj * half_s2 for vj, aj, jj in zip(v, a, jerk, strict=True)]),
            np.array([aj + jj * s for aj, jj in zip(a, jerk, strict=True)]),
        )


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
        """The arm moved (or may have) without this controller: lead it from where it is once tracking again."""
        self._needs_reacquire = True

    @property
    def reacquire_pending(self) -> bool:
        return self._needs_reacquire

    def try_reacquire(
        self, now_s: float, arm_position: np.ndarray, arm_velocity: np.ndarray, config: ControllerConfig
    ) -> bool:
        """Leave the sensor-loss stop and, if the planner's trajectory is fresh, start a blend from the arm onto it
        (within ``reacquire_acceleration``). False while there is none: :meth:`at_tick` holds the arm meanwhile."""
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
        """A hold while a re-acquisition waits for a fresh trajectory, otherwise :meth:`from_trajectory`."""
        if self._needs_reacquire:
            return self._hold(arm_position)
        self._hold_position = None  # a later hold starts where the arm is then
        return self.from_trajectory(now_s, arm_position, config)

    def _hold(self, arm_position: np.ndarray) -> Reference:
        """Hold the arm where it was when the hold began: HOLDING before the planner's first sample, REACQUIRING
        after."""
        if self._hold_position is None:
            self._hold_position = arm_position
        zeros = np.zeros(self.joint_count)
        status = Status.HOLDING if not self.planner.spoke else Status.REACQUIRING
        return self._named(Reference(self._hold_position, zeros, zeros), status, ReferenceSource.HOLD_POSITION)

    def from_trajectory(self, now_s: float, arm_position: np.ndarray, config: ControllerConfig) -> Reference:
        """The trajectory at ``now_s``, plus the blend's fading offset while re-acquiring; a controlled stop if
        the planner went quiet, and a blend from it when it returns. Before its first sample: a hold."""
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
        """A controlled stop (category 2) from ``start`` or from where the reference is at its first tick, to rest at
        ``stop_deceleration``, held. ``source``: SENSOR_STOP or LATE_STOP (until re-acquisition), LAW_STOP (for
        good; from the reference of the tick the law failed on, or the last one used)."""
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
