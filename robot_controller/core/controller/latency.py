"""Whether the loop's signals come later than its feedback survives (the controller's latency
stop, docs/design.md §4), and that survival: the delay margin of the gains in force.

Two delays add up to the loop's unaccounted delay, each as the median of its last
:data:`WINDOW` (at least :data:`MIN_SAMPLES`; jitter and one-off stalls move a median by one
place at most): a reading's **age** on arrival beyond what latency compensation accounts for
(``compensated_s``), and a command's **delay** to the drive (from ``/motor/command_receipts``,
for :data:`COMMAND_MEMORY_S`). Above the margin the loop is **late**; it is on time again once
the delay has stayed within half the margin for :data:`CLEAR_AFTER_S` (hysteresis). Times in
seconds on the controller's clock (a receipt on the drive's: across hosts the clocks agree).
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass
from statistics import median
from typing import TYPE_CHECKING

from robot_controller.core.controller.tick_state import MAX_EXTRAPOLATION_S
from robot_controller.core.estimation import steady_state_gain
from robot_controller.core.laws import lqr, robustness
from robot_controller.core.laws.pid import PidConfig

if TYPE_CHECKING:
    from robot_controller.core.controller.config import ControllerConfig
    from robot_controller.core.model import ArmDynamics

#: How many recent readings (and command receipts) the medians cover.
WINDOW = 10
#: A median of fewer is no evidence (the first reading alone, one stray receipt).
MIN_SAMPLES = WINDOW // 2
#: A command delay older than this (s) is forgotten: receipts come once a second.
COMMAND_MEMORY_S = 2.5
#: The delay must stay within half the margin this long (s) before the loop is on time again.
CLEAR_AFTER_S = 1.0


@dataclass(frozen=True)
class LatencyState:
    late: bool
    delay_s: float  #: the loop's unaccounted delay now (s): readings' part + commands' part
    tolerated_s: float  #: what the gains survive (s)
    cleared: bool = False  #: on time again at this verdict, after being late


class LatencyGuard:
    """``tolerated_s``: the delay margin in seconds (margin periods × control period);
    ``compensated_s``: how much of a reading's age the controller accounts for (0 without
    latency compensation)."""

    def __init__(self, tolerated_s: float, compensated_s: float) -> None:
        self.tolerated_s = tolerated_s
        self.compensated_s = compensated_s
        self._readings: deque[float] = deque(maxlen=WINDOW)
        self._commands: deque[tuple[float, float]] = deque(maxlen=WINDOW)  # (receipt s, delay s)
        self._late = False
        self._within_since: float | None = None  # when the delay last came within half the margin

    @classmethod
    def for_margin(cls, margin_periods: int | None, config: ControllerConfig) -> LatencyGuard | None:
        """The guard for a delay margin of ``margin_periods`` (None when it is not known: no guard)."""
        if margin_periods is None:
            return None
        compensated_s = MAX_EXTRAPOLATION_S if config.latency_compensation else 0.0
        return cls(margin_periods * config.control_period_s, compensated_s)

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
        """The verdict at ``now_s``: late above the margin, on time again after
        ``CLEAR_AFTER_S`` within half of it."""
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
    gains: PidConfig, dynamics: ArmDynamics | None, joint_count: int, config: ControllerConfig
) -> int | None:
    """Whole control periods of delay nobody accounts for (a late command, a reading stamped on
    arrival) the feedback with ``gains`` survives on the worst joint, the arm linearised at rest at
    the design pose (:func:`robustness.delay_margin_periods`). With the disturbance observer, the
    loop through the filter and the observer (:func:`robustness.observer_delay_margin_periods`),
    for the filter as it is while the readings agree with it and as it becomes when they do not
    (``KalmanConfig.at_mismatch``: late readings disagree), the worse. None without the arm model."""
    if dynamics is None:
        return None
    period_s = config.control_period_s
    inertia = lqr.design_inertia(dynamics, joint_count, config.design_position)
    scale = config.observer_torque_scale(dynamics, joint_count)
    margins = []
    for j in range(joint_count):
        ki, kp, kd = float(gains.ki[j]), float(gains.kp[j]), float(gains.kd[j])
        joint_inertia, damping = float(inertia[j]), float(dynamics.damping[j])
        if config.observes_disturbance:
            joint_filter = config.estimator if scale is None else config.estimator.for_inertia(float(scale[j]))
            for filter_ in (joint_filter, joint_filter.at_mismatch()):
                filter_gains = steady_state_gain(filter_, joint_inertia, damping, period_s, estimate_disturbance=True)
                margins.append(robustness.observer_delay_margin_periods((ki, kp, kd), filter_gains, period_s))
        else:
            A, B = lqr.discretise(joint_inertia, damping, period_s)
            margins.append(int(robustness.delay_margin_periods(A, B, robustness.pid_gain_row(kp, ki, kd))[0]))
    return min(margins)
