"""The planner's reference as the controller receives it: the latest sample due and its time
base (one stamped ahead of the receiver's clock waits for its time), whether the samples due by
a tick are in (lockstep), the trajectory at a tick (held, or extrapolated on its velocity and
acceleration) and whether it is fresh, and the trajectory over the period the command is held
for, which the feedforward is for. Positions rad, velocities rad/s, accelerations rad/s², s."""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass

import numpy as np

from robot_controller.core.controller.supervision import ReferenceSource
from robot_controller.core.controller.tick_state import MAX_EXTRAPOLATION_S, TIME_EPS_S, clipped_age_s

# The planner counts as silent after this many of its periods without a sample.
REFERENCE_TIMEOUT_PERIODS = 5
# A sample stamped up to this far ahead of the receiver's clock (s) waits for its time; one stamped
# further ahead is taken at once, as if stamped now: a clock that far off is wrong, not early.
MAX_AHEAD_S = 1.0
# Samples waiting for their time, at most (one planner period ahead is the normal case).
MAX_UPCOMING = 100


def _minmod(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Per element, the smaller in magnitude of ``a`` and ``b`` where they agree
    in sign, else 0 (the slope limiter of numerical schemes)."""
    sign = np.sign(a)
    limited = sign * np.minimum(np.abs(a), np.abs(b))
    limited[sign != np.sign(b)] = 0.0
    return limited


@dataclass(frozen=True)
class TrajectoryPoint:
    """The planner's trajectory at one tick."""

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
        self._acceleration_slope: np.ndarray | None = None  #: rad/s³, between the last two samples
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
        """A new sample. Its time base is ``sample_time_s`` when the planner sent
        one, otherwise the time it arrived; one stamped ahead of ``received_s``
        (by at most MAX_AHEAD_S) waits for :meth:`advance_to` its time."""
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
            self.period_s = time_s - self.time_s
            # The jerk, from the planner's own samples only (not a hold written in before it spoke).
            previous = self.sample[2]
            slope = (np.asarray(acceleration, dtype=float) - previous) / self.period_s if self.spoke else None
            self.jerk = (
                None if slope is None or self._acceleration_slope is None else _minmod(slope, self._acceleration_slope)
            )
            self._acceleration_slope = slope
        self.spoke = True
        self.sample = (position, velocity, acceleration)
        self.time_s = time_s

    def hold_here(self, position: np.ndarray, now_s: float) -> None:
        """Before the planner has spoken, stand in a sample at rest at ``position``
        dated ``now_s`` (what a controlled stop starts from then). It counts for
        :meth:`ready`, and as the previous sample when the first real one comes."""
        zeros = np.zeros(np.shape(position))
        self.sample = (position.copy(), zeros.copy(), zeros.copy())
        self.time_s = now_s

    def ready(self, tick_s: float) -> bool:
        """Whether every sample due by ``tick_s`` is in (lockstep): the latest is
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
        """Age (s) past which the latest sample is stale: REFERENCE_TIMEOUT_PERIODS
        of the planner's period (the control period until it is learned), at
        least MAX_EXTRAPOLATION_S."""
        period = self.period_s if self.period_s is not None else control_period_s
        return max(REFERENCE_TIMEOUT_PERIODS * period, MAX_EXTRAPOLATION_S)

    def at(self, now_s: float, extrapolate: bool, control_period_s: float) -> TrajectoryPoint:
        """The trajectory at ``now_s``: the latest sample held or, with
        ``extrapolate``, advanced to ``now_s`` on its velocity and acceleration
        (by at most MAX_EXTRAPOLATION_S). Needs a sample."""
        position, velocity, acceleration = self.sample
        fresh = now_s - self.time_s <= self.timeout_s(control_period_s)
        source = ReferenceSource.TRAJECTORY
        if extrapolate:
            age_s = clipped_age_s(now_s, self.time_s)
            if age_s > 0:  # (a sample of the tick's own instant is the trajectory there)
                position = position + velocity * age_s + 0.5 * acceleration * age_s * age_s
                velocity = velocity + acceleration * age_s
                source = ReferenceSource.EXTRAPOLATED
        return TrajectoryPoint(position, velocity, acceleration, fresh, source)

    def over_period(
        self, now_s: float, period_s: float, extrapolate: bool
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The trajectory ``(position, velocity, acceleration)`` a torque held over
        the control period ``[now_s, now_s + period_s]`` is to be computed for:
        at the middle of the period, where the model's torque equals its average
        over the period to second order (the torque at ``now_s`` lags the motion
        by half a period). With ``extrapolate``, the latest sample advanced
        there on its velocity, acceleration and :attr:`jerk`; without, the
        sample as held, as :meth:`at` holds it. Needs a sample."""
        position, velocity, acceleration = self.sample
        if not extrapolate:
            return position, velocity, acceleration
        s = min(max(float(now_s + 0.5 * period_s - self.time_s), 0.0), MAX_EXTRAPOLATION_S)
        jerk = np.zeros(np.shape(acceleration)) if self.jerk is None else self.jerk
        return (
            position + velocity * s + acceleration * (s * s / 2) + jerk * (s**3 / 6),
            velocity + acceleration * s + jerk * (s * s / 2),
            acceleration + jerk * s,
        )
