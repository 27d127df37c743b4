"""Whether and how a tick may command, and what it reports: the readings (a stale one refused, the
sensor's silence), the tick clock (pauses of the controller itself), the verdict on both
(:func:`check_health`), the latency guard (:class:`LatencyGuard`), the tick's :class:`Status` and
:class:`ReferenceSource` (a reference the controller made up is always named, never passed off as the
planner's), and :class:`ControlOutput`. Times in s on the controller's clock (a command receipt on the
drive's: across hosts the clocks agree).
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass
from enum import StrEnum
from statistics import median
from typing import TYPE_CHECKING, NamedTuple

import numpy as np

from robot_controller.core.controller.config import ControllerConfig, law_config
from robot_controller.core.errors import ConfigError
from robot_controller.core.estimation import steady_state_gain
from robot_controller.core.laws import PidTerms, lqr, robustness
from robot_controller.core.laws.pid import PidConfig

if TYPE_CHECKING:
    from collections.abc import Sequence

    from robot_controller.core.model import ArmDynamics


class Status(StrEnum):
    """A tick's status; its code on the state topic is its place here (``state_layout.STATUS_CODES``)."""

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
    #: a plugin law's extra terms for the controller's state (its ``state_terms``), N·m per joint
    law_terms: dict[str, np.ndarray] | None = None

    @property
    def command(self) -> np.ndarray:
        return self.terms.command

    @property
    def error(self) -> np.ndarray:
        return self.reference - self.measured


# A gap this many periods long between this controller's own ticks means it
# was not running (frozen, starved): the arm was stopped without it meanwhile.
REACQUIRE_GAP_PERIODS = 5


class PositionNoise(NamedTuple):
    """What a reading says of its positions' errors (a camera's): each joint's σ (rad; ``inf``: it says nothing
    of that joint) and how they go together (None: independent)."""

    std: np.ndarray
    correlation: np.ndarray | None = None


def age_refusal(stamp_s: float, received_s: float, max_age_s: float) -> str | None:
    """Why a reading stamped ``stamp_s`` that arrived at ``received_s`` is refused (older than ``max_age_s``, or
    stamped that far ahead), or None."""
    age_s = received_s - stamp_s
    if abs(age_s) <= max_age_s:
        return None
    when = "old" if age_s > 0 else "in the future"
    return f"reading stamped {abs(age_s):.3f} s {when} (max_reading_age_s {max_age_s:g})"


class Readings:
    """The latest accepted reading, when it was taken (``stamp_s``) and when it arrived (``received_s``, what
    the watchdog counts silence from)."""

    def __init__(self) -> None:
        self.latest: tuple[np.ndarray, np.ndarray] | None = None  #: (position rad, velocity rad/s)
        self.noise: PositionNoise | None = None  #: what the latest reading said of its own errors, if anything
        self.stamp_s = 0.0
        self.received_s = -np.inf

    def accept(
        self,
        stamp_s: float,
        received_s: float,
        position: np.ndarray,
        velocity: np.ndarray,
        max_age_s: float,
        noise: PositionNoise | None = None,
    ) -> str | None:
        """Keep the reading unless it is more than ``max_age_s`` old when it arrives (or stamped that far ahead):
        after a pause, a sensor's first sample can be from before it, and acting on it swings the arm. Returns
        why it was refused (it is then no sign of life either), or None."""
        if refused := age_refusal(stamp_s, received_s, max_age_s):
            return refused
        self.latest = (position, velocity)
        self.noise = noise
        self.stamp_s = stamp_s
        self.received_s = received_s
        return None

    def silent_s(self, now_s: float) -> float:
        """Seconds since the latest accepted reading arrived (inf before any)."""
        return now_s - self.received_s

    def excuse_pause(self, gap_s: float, period_s: float, max_age_s: float) -> None:
        """This process was paused for ``gap_s`` s. If that is shorter than a reading may be old, the readings
        it held back are on their way: that time is not the sensor's silence."""
        if gap_s <= max_age_s:
            self.received_s += gap_s - period_s


class Tick(NamedTuple):
    """When this tick falls relative to the previous one (a named tuple: one is made every tick)."""

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
    """Judge the inputs at ``now_s``, most severe first: no reading ever, the e-stop, readings missing past
    ``sensor_timeout_s`` (category 1), past ``watchdog_periods`` (category 2, on the model). Under the drive's
    brakes a command does not move the arm, so the reference starts again from the measurement (``restart``)."""
    if readings.latest is None:
        return _NO_MEASUREMENT
    if halted:
        return _STOPPED
    silent_s = readings.silent_s(now_s)
    if silent_s > config.sensor_timeout_s:
        return _SENSOR_LOST
    if silent_s > config.watchdog_periods * config.control_period_s:  # the watchdog's window
        return _WATCHDOG
    return _BRAKED if braked else _OK


# Every verdict there is, made once (they are frozen): one is asked for every tick.
_NO_MEASUREMENT = Health(Status.NO_MEASUREMENT, restart=False)
_STOPPED = Health(Status.STOPPED, restart=False)
_SENSOR_LOST = Health(Status.SENSOR_LOST, restart=True)
_WATCHDOG = Health(Status.WATCHDOG, restart=True)
_BRAKED = Health(Status.OK, restart=True)
_OK = Health(Status.OK, restart=False)


# --- the latency guard (docs/design.md §4) -------------------------------------------------
# Two delays add up to the loop's unaccounted delay, each the median of its last WINDOW (at least
# MIN_SAMPLES: jitter and one-off stalls move a median by one place at most): a reading's age on
# arrival beyond what latency compensation accounts for (compensated_s), and a command's delay to
# the drive (from the drive's command receipts, for COMMAND_MEMORY_S). Above the delay margin the loop
# is late; it is on time again once the delay has stayed within half the margin for CLEAR_AFTER_S.

#: How many recent readings (and command receipts) the medians cover.
WINDOW = 10
#: A median of fewer is no evidence (the first reading alone, one stray receipt).
MIN_SAMPLES = WINDOW // 2
#: A command delay older than this (s) is forgotten: receipts come once a second.
COMMAND_MEMORY_S = 2.5
#: The delay must stay within half the margin this long (s) before the loop is on time again.
CLEAR_AFTER_S = 1.0


class LatencyState(NamedTuple):
    """The latency guard's verdict at a tick (a named tuple: one is made every tick on the wall clock)."""

    late: bool
    delay_s: float  #: the loop's unaccounted delay now (s): readings' part + commands' part
    tolerated_s: float  #: what the gains survive (s)
    cleared: bool = False  #: on time again at this verdict, after being late


class LatencyGuard:
    """``tolerated_s``: the delay margin, s; ``compensated_s``: how much of a reading's age the controller
    accounts for (0 without latency compensation)."""

    def __init__(self, tolerated_s: float, compensated_s: float) -> None:
        self.tolerated_s = tolerated_s
        self.compensated_s = compensated_s
        self._readings: deque[float] = deque(maxlen=WINDOW)
        self._commands: deque[tuple[float, float]] = deque(maxlen=WINDOW)  # (receipt s, delay s)
        self._late = False
        self._within_since: float | None = None  # when the delay last came within half the margin

    @classmethod
    def for_margin(cls, margin_periods: int | None, period_s: float, compensated_s: float) -> LatencyGuard | None:
        """The guard for ``margin_periods`` control periods of ``period_s`` (None when unknown: no guard)."""
        if margin_periods is None:
            return None
        return cls(margin_periods * period_s, compensated_s)

    def reading(self, age_s: float) -> None:
        """A reading arrived ``age_s`` seconds after its stamp."""
        self._readings.append(max(0.0, age_s - self.compensated_s))

    def command(self, receipt_s: float, delay_s: float) -> None:
        """A command reached the drive ``delay_s`` seconds after the tick that issued it."""
        self._commands.append((receipt_s, max(0.0, delay_s)))

    def delay_s(self, now_s: float) -> float:
        """The loop's unaccounted delay at ``now_s`` (s)."""
        readings = median(self._readings) if len(self._readings) >= MIN_SAMPLES else 0.0
        recent = [delay for receipt, delay in self._commands if now_s - receipt <= COMMAND_MEMORY_S]
        return readings + (median(recent) if len(recent) >= MIN_SAMPLES else 0.0)

    def update(self, now_s: float) -> LatencyState:
        """Late above the margin, on time again after ``CLEAR_AFTER_S`` within half of it."""
        delay = self.delay_s(now_s)
        was_late = self._late
        if delay > self.tolerated_s:
            self._late, self._within_since = True, None
        elif self._late:
            if delay > 0.5 * self.tolerated_s:
                self._within_since = None
            elif self._within_since is None:
                self._within_since = now_s
            elif now_s - self._within_since >= CLEAR_AFTER_S:
                self._late, self._within_since = False, None
        return LatencyState(self._late, delay, self.tolerated_s, was_late and not self._late)


def delay_margin_periods(
    gains: PidConfig,
    dynamics: ArmDynamics | None,
    joint_count: int,
    config: ControllerConfig,
    inertia: np.ndarray | None = None,
) -> int | None:
    """The worst joint's :func:`joint_delay_margins` (None without the arm model)."""
    margins = joint_delay_margins(gains, dynamics, joint_count, config, inertia)
    return None if margins is None else min(margins)


def joint_delay_margins(
    gains: PidConfig,
    dynamics: ArmDynamics | None,
    joint_count: int,
    config: ControllerConfig,
    inertia: np.ndarray | None = None,
    up_to: int = 50,
    joints: Sequence[int] | None = None,
) -> list[int] | None:
    """Per joint, whole control periods of unaccounted delay (a late command, a reading stamped on arrival) the
    feedback with ``gains`` survives, the arm linearised at rest at the design pose. With the disturbance
    observer, through the filter and the observer, the worse of the filter while readings agree and at the
    mismatch (late readings disagree). None without the arm model.

    :param inertia: kg·m² per joint the loop is linearised with (None: the nominal model's at the design pose; the
        inertia adaptation's gains are judged on the inertia it learnt)
    :param up_to: count no further than this many periods
    :param joints: only these joints' margins (None: every joint)
    """
    if dynamics is None:
        return None
    period_s = config.control_period_s
    if inertia is None:
        inertia = lqr.design_inertia(dynamics, joint_count, config.design_position)
    scale = config.observer_torque_scale(dynamics, joint_count)
    margins = []
    for j in range(joint_count) if joints is None else joints:
        ki, kp, kd = float(gains.ki[j]), float(gains.kp[j]), float(gains.kd[j])
        joint_inertia, damping = float(inertia[j]), float(dynamics.damping[j])
        if config.observes_disturbance:
            joint_filter = config.estimator if scale is None else config.estimator.for_inertia(float(scale[j]))
            both = (joint_filter, joint_filter.at_mismatch())
            filters = [steady_state_gain(f, joint_inertia, damping, period_s, estimate_disturbance=True) for f in both]
            margins.append(
                min(robustness.observer_delay_margin_periods((ki, kp, kd), f, period_s, up_to) for f in filters)
            )
        else:
            A, B = lqr.discretise(joint_inertia, damping, period_s)
            row = robustness.pid_gain_row(kp, ki, kd)
            margins.append(int(robustness.delay_margin_periods(A, B, row, up_to)[0]))
    return margins


def check_delay_margin(
    config: ControllerConfig, dynamics: ArmDynamics | None, joint_count: int, gains: PidConfig | None = None
) -> None:
    """Refuse (``ConfigError``, naming the joint) a built-in law whose gains (None: designed here) leave a
    joint fewer than ``min_delay_margin_periods`` control periods of delay margin."""
    needed = config.min_delay_margin_periods
    if needed <= 0:
        return
    gains = law_config(config, dynamics, joint_count) if gains is None else gains
    margins = joint_delay_margins(gains, dynamics, joint_count, config)
    if margins is None or min(margins) >= needed:
        return
    j = int(np.argmin(margins))
    key = "stop_law" if config.plugin_law else "controller_type"
    hint = (
        "raise lqr_r or lower lqr_q"
        if config.builtin_law == "lqr"
        else "lower that joint's gains (one value each is scaled to each joint's inertia)"
    )
    raise ConfigError(
        f"{key} {config.builtin_law}: the gains leave joint {dynamics.joint_names[j]} a delay margin of {margins[j]} "
        f"control periods, below min_delay_margin_periods {needed} (the loop is unstable with "
        f"{margins[j] + 1} period(s) of delay): {hint}"
    )
