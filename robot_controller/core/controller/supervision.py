"""Supervision of the controller's inputs, once per tick: the sensor readings (a stale one
refused, the sensor's silence), the tick clock (the period the law integrates over, pauses of
the controller itself) and the verdict, :func:`check_health`: track, stop on the model, or
command nothing. Times in seconds on the controller's clock."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from robot_controller.core.controller.config import ControllerConfig
from robot_controller.core.controller.output import Status

# A gap this many periods long between this controller's own ticks means it
# was not running (frozen, starved): the arm was stopped without it meanwhile.
REACQUIRE_GAP_PERIODS = 5


class Readings:
    """The latest accepted sensor reading: position (rad) and velocity
    (rad/s), the time it was taken (``stamp_s``) and the time it arrived
    (``received_s``, what the watchdog counts silence from)."""

    def __init__(self) -> None:
        self.latest: tuple[np.ndarray, np.ndarray] | None = None  #: (position rad, velocity rad/s)
        self.stamp_s = 0.0
        self.received_s = -np.inf

    def accept(
        self, stamp_s: float, received_s: float, position: np.ndarray, velocity: np.ndarray, max_age_s: float
    ) -> str | None:
        """Keep the reading unless it is more than ``max_age_s`` old when it
        arrives (or stamped that far ahead): after a pause, a sensor's first
        sample can be from before it, and acting on it swings the arm. Returns
        why it was refused (it is then no sign of life either), or None."""
        age_s = received_s - stamp_s
        if abs(age_s) > max_age_s:
            when = "old" if age_s > 0 else "in the future"
            return f"reading stamped {abs(age_s):.3f} s {when} (max_reading_age_s {max_age_s:g})"
        self.latest = (position, velocity)
        self.stamp_s = stamp_s
        self.received_s = received_s
        return None

    def silent_s(self, now_s: float) -> float:
        """Seconds since the latest accepted reading arrived (inf before any)."""
        return now_s - self.received_s

    def excuse_pause(self, gap_s: float, period_s: float, max_age_s: float) -> None:
        """This process was paused for ``gap_s`` seconds (the whole machine
        stalls at times). If the pause is shorter than a reading may be old,
        the readings it held back are on their way: that time is not the
        sensor's silence, so move the last arrival on by the pause."""
        if gap_s <= max_age_s:
            self.received_s += gap_s - period_s


@dataclass(frozen=True)
class Tick:
    """When this tick falls relative to the previous one."""

    dt_s: float  #: s, the period the law integrates over (the gap, at most REACQUIRE_GAP_PERIODS periods)
    gap_s: float  #: s since the previous tick (0 for the first, or a tick not later than it)
    paused: bool  #: the gap is long enough that this controller was not running: the world moved on


class TickClock:
    """The times of this controller's own ticks."""

    def __init__(self) -> None:
        self.last_s: float | None = None

    def advance(self, now_s: float, period_s: float) -> Tick:
        """Move on to the tick at ``now_s`` (s) with nominal period ``period_s`` (s)."""
        dt_s, gap_s = period_s, 0.0
        if self.last_s is not None and now_s > self.last_s:
            gap_s = now_s - self.last_s
            dt_s = min(gap_s, REACQUIRE_GAP_PERIODS * period_s)
        self.last_s = now_s
        return Tick(dt_s, gap_s, gap_s > REACQUIRE_GAP_PERIODS * period_s)


@dataclass(frozen=True)
class Health:
    """The verdict on the inputs for one tick."""

    #: OK (track), WATCHDOG (controlled stop on the model), or no command:
    #: NO_MEASUREMENT, STOPPED (e-stop), SENSOR_LOST (the brake holds)
    status: Status
    #: the arm may move (or have moved) without this controller's command: once the
    #: fault clears, start again from the measurement and lead it back onto the trajectory
    restart: bool


def check_health(readings: Readings, now_s: float, halted: bool, braked: bool, config: ControllerConfig) -> Health:
    """Judge the inputs at ``now_s`` (s), most severe first: no reading ever,
    the e-stop, readings missing past ``sensor_timeout_s`` (category 1: torque
    off, the brake holds), missing past ``watchdog_periods`` (category 2: a
    controlled stop on the arm model). The drive's brakes do not stop the
    tick, but whatever is commanded while they hold does not move the arm,
    so the reference starts again from the measurement (``restart``)."""
    if readings.latest is None:
        return _NO_MEASUREMENT
    if halted:
        return _STOPPED
    silent_s = readings.silent_s(now_s)
    if silent_s > config.sensor_timeout_s:
        return _SENSOR_LOST
    if silent_s > config.watchdog_s:
        return _WATCHDOG
    return _BRAKED if braked else _OK


# Every verdict there is, made once (they are frozen): one is asked for every tick.
_NO_MEASUREMENT = Health(Status.NO_MEASUREMENT, restart=False)
_STOPPED = Health(Status.STOPPED, restart=False)
_SENSOR_LOST = Health(Status.SENSOR_LOST, restart=True)
_WATCHDOG = Health(Status.WATCHDOG, restart=True)
_BRAKED = Health(Status.OK, restart=True)
_OK = Health(Status.OK, restart=False)
