"""When the controller block ticks: its clock in the ROS graph, chosen once when its node starts.

- :class:`TimerTicks`, the wall clock: a timer ticks it (``trigger: timer``), or each accepted reading does
  (``trigger: measurement``) with the timer covering their absence;
- :class:`PairedTicks`, where the world waits for each command (sim time, the paced world): each reading is a tick at
  the world's clock (port ``clock``) it pairs with, stepped once the reference sample due by then is in.

A clock holds the block and a ``tick(t_s)`` that steps it and publishes what it wrote; it uses the node for ROS alone
(timers, its clock)."""

from __future__ import annotations

import json
import time
from collections.abc import Callable
from typing import Any

import numpy as np
from rclpy.clock import Clock, ClockType
from rclpy.node import Node
from rosgraph_msgs.msg import Clock as ClockMsg

from robot_controller.blocks import spec
from robot_controller.blocks.controller import Controller
from robot_controller.blocks.values import JointSample
from robot_controller.core import metrics
from robot_controller.core.controller import Status
from robot_controller.ros.loop_processes import LoopProcesses, Sample, host_kept_waiting
from robot_controller.ros.messages import clock_s, stamp_to_s
from robot_controller.ros.process import HOST_MISSED_FILE
from robot_controller.ros.publishing import leave, run_folder
from robot_controller.ros.qos import LATCHED_QOS

Tick = Callable[[float], dict[str, Any]]

# The parameters the timer's period follows.
TIMING_KEYS = ("control_rate_hz", "trigger", "watchdog_periods")
#: s; on the wall clock the loop's usage (``loop_processes``, about 0.1 ms to read) is read at a tick at most this
#: often, and at every tick that ends a long period or a silence: at 1 kHz, each tick's read was a tenth of the loop.
USAGE_EVERY_S = 0.005
# How long (wall s) a paired tick waits for its reference sample before using the latest.
REFERENCE_WAIT_S = 0.3
# How long (wall) a tick waits for a reading before going on with the latest, until the sensor's period is known: long
# enough that a loaded host's late reading is waited for (a full-rate sensor's period is then known from its second).
READING_WAIT_S = 1.0


def timer_period_s(params: dict[str, Any]) -> float:
    """The timer ticks the loop (``trigger: timer``), or, readings driving it, watches twice per watchdog window for
    their absence."""
    period_s = 1.0 / params["control_rate_hz"]
    if params["trigger"] == "measurement":
        return period_s * max(1.0, params["watchdog_periods"] / 2)
    return period_s


class HostMisses:
    """On the wall clock, which missed cycles and watchdog ticks the host caused (``loop_processes``): left for
    ``metrics.json``, which counts those within the ticks it scores."""

    def __init__(self, control_period_s: Callable[[], float], watchdog_periods: Callable[[], int]) -> None:
        self.control_period_s, self.watchdog_periods = control_period_s, watchdog_periods
        self.loop = LoopProcesses(run_folder())
        self.last_tick_s: float | None = None
        self.sampled: Sample | None = None  #: the loop's usage when last read (at a tick, at most USAGE_EVERY_S ago)
        self.sampled_s = -np.inf  #: when (tick s) it was read
        self.missed_for_host: list[float] = []  #: when (tick s) each missed period the host made ended
        # The watchdog's silence, timed from the latest accepted reading's arrival (s) and the loop's usage at the
        # first tick since (the same instant when readings drive the loop).
        self.reading_s: float | None = None
        self.usage_at_reading: Sample | None = None
        self.reading_unsampled = False
        self.watchdog_for_host: list[float] = []  #: when (tick s) each watchdog tick the host made fell

    def note_reading(self, now_s: float) -> None:
        self.reading_s, self.reading_unsampled = now_s, True

    def note_tick(self, now_s: float, watchdog: bool = False) -> None:
        """Count the period that ends at ``now_s`` as the host's miss if the host took from the loop all it ran over
        (``loop_processes.host_kept_waiting``); a watchdog tick on the same terms, over the readings' silence past
        the watchdog's window."""
        period_s = self.control_period_s()
        late_s = -1.0 if self.last_tick_s is None else now_s - self.last_tick_s - metrics.MISSED_PERIODS * period_s
        silent_s = -1.0
        if watchdog and self.reading_s is not None:
            silent_s = now_s - self.reading_s - self.watchdog_periods() * period_s
        # The usage before the period judged is the one read last: up to USAGE_EVERY_S older, its window is wider.
        before = self.sampled
        if late_s > 0 or silent_s > 0 or now_s - self.sampled_s >= USAGE_EVERY_S:
            self.sampled, self.sampled_s = self.loop.usage(), now_s
        usage = self.sampled
        if self.reading_unsampled:
            self.usage_at_reading, self.reading_unsampled = usage, False
        silent_judged = silent_s > 0 and usage is not None and self.usage_at_reading is not None
        if silent_judged and host_kept_waiting(usage - self.usage_at_reading, round(silent_s * 1e9)):
            self.watchdog_for_host.append(now_s)
        late_judged = late_s > 0 and usage is not None and before is not None
        if late_judged and host_kept_waiting(usage - before, round(late_s * 1e9)):
            self.missed_for_host.append(now_s)
        self.last_tick_s = now_s

    def leave(self) -> None:
        host_made = {"ends_s": self.missed_for_host, "watchdog_s": self.watchdog_for_host}
        leave(HOST_MISSED_FILE, json.dumps(host_made))


def take(ticks: TimerTicks | PairedTicks, port: str, value: Any) -> None:
    """A reading or a reference sample as the clock takes them; a receipt timed on arrival (the command path's delay,
    for the latency guard on the wall clock); the e-stop and the brakes at once (time unused)."""
    if port == "reading":
        ticks.take_reading(value)
    elif port == "reference":
        ticks.take_reference(value)
    elif port == "command_receipts":
        ticks.block.take(clock_s(ticks.node), {port: value})
    elif port == "camera_reading":  # aged on arrival: where the world waits, at its latest clock
        if isinstance(ticks, PairedTicks):
            ticks.take_second_reading(value)
        else:
            ticks.block.take(clock_s(ticks.node), {port: value})
    else:
        ticks.block.take(0.0, {port: value})


class TimerTicks:
    """The wall clock: a timer's ticks, or the readings' with the timer covering their absence."""

    def __init__(self, node: Node, block: Controller, tick: Tick) -> None:
        self.node, self.block, self._tick = node, block, tick
        config = lambda: block.controller.config  # noqa: E731 (the config in force at each tick)
        self.misses = HostMisses(lambda: config().control_period_s, lambda: config().watchdog_periods)
        self.timer: Any = None
        self.timer_period = 0.0
        self.params = block.params

    def start(self) -> None:
        self.set_timer_period(timer_period_s(self.params))

    def take(self, port: str, value: Any) -> None:
        take(self, port, value)

    def set_timer_period(self, period_s: float) -> None:
        if period_s == self.timer_period:
            return
        if self.timer is not None:
            self.node.destroy_timer(self.timer)
        self.timer = self.node.create_timer(period_s, self.timer_callback)
        self.timer_period = period_s

    def tick(self, now_s: float) -> None:
        self._tick(now_s)
        status = self.block.status
        if status is not Status.NO_MEASUREMENT:
            self.misses.note_tick(now_s, watchdog=status is Status.WATCHDOG)
        if self.block.params is not self.params:  # a change taken at this tick: the rate or trigger may be new
            before, self.params = self.params, self.block.params
            if any(before[key] != self.params[key] for key in TIMING_KEYS):
                self.set_timer_period(timer_period_s(self.params))

    def take_reading(self, sample: JointSample) -> None:
        now_s = clock_s(self.node)
        if not self.block.take(now_s, {"reading": sample}):
            self.block.check_names(list(sample.names), time.monotonic())
            return
        self.misses.note_reading(now_s)
        if self.block.params["trigger"] == "measurement":
            self.set_timer_period(timer_period_s(self.block.params))  # readings drive the loop again
            self.tick(now_s)

    def take_reference(self, value: Any) -> None:
        self.block.take(clock_s(self.node), {"reference": value})

    def timer_callback(self) -> None:
        now_s = clock_s(self.node)
        period_s = self.block.controller.config.control_period_s
        if self.block.params["trigger"] == "measurement":
            covering = self.timer_period == period_s  # readings are missing: this timer ticks the loop
            if now_s - self.block.last_tick_s < (0.5 if covering else 1.5) * period_s:
                return  # readings are driving the loop; this timer only covers for their absence
            self.set_timer_period(period_s)
        self.tick(now_s)

    def finish(self) -> None:
        self.misses.leave()


#: wall s a tick waits for a camera's reading due beside the encoder's before it goes on without


class SecondReadings:
    """When a second sensor's reading (a camera's, beside the encoder's) is due at the world's clock: its frames
    come every ``period_s`` and are published ``latency_s`` after their exposure (its first at once)."""

    def __init__(self, wait_s: float, period_s: float, latency_s: float) -> None:
        self.wait_s = wait_s  #: wall s a due reading is waited for (0: never)
        self.period_s, self.lateness_s = period_s, latency_s
        self.last_stamp_s: float | None = None
        self.given_up = False  # said once: a camera that stopped is not waited for again until it comes back

    def arrived(self, stamp_s: float) -> None:
        if self.last_stamp_s is None or stamp_s > self.last_stamp_s:
            self.last_stamp_s = stamp_s
            self.given_up = False

    def due(self, tick_s: float) -> bool:
        """Whether a reading is due by ``tick_s`` (its first, published at once, at the first tick)."""
        if self.given_up or self.wait_s <= 0:
            return False
        if self.last_stamp_s is None:
            return True
        return tick_s >= self.last_stamp_s + self.period_s + self.lateness_s - 1e-9

    def waited_out(self, waiting_since: float, log: Any) -> bool:
        if time.monotonic() - waiting_since <= self.wait_s:
            return False
        self.given_up = True
        log.warning(
            f"sim time: the camera's {spec.CAMERA_READING.topic} due by now did not come within {self.wait_s:g} s: "
            "going on on the encoder alone until it comes"
        )
        return True


class PairedTicks:
    """Where the world waits for each command, each reading is a tick at the world's clock it pairs with, computed
    once the reference sample due by then has arrived (or, from a planner slower than the control rate, after
    ``REFERENCE_WAIT_S`` with the latest). A sensor slower than the loop (one that reports every other tick) leaves
    ticks with no reading due: once the readings' period is known from two of their stamps, such a tick goes on at once
    with the latest reading; before, after ``READING_WAIT_S``. A reading due and missing is waited for (a sensor that
    stopped is the world's drive timeout's to brake, as ever)."""

    def __init__(self, node: Node, block: Controller, tick: Tick) -> None:
        self.node, self.block, self._tick = node, block, tick
        self.clock_s = -np.inf  # the world's latest clock
        self.reading: JointSample | None = None  # waiting for its clock
        self.tick_s: float | None = None  # a measured tick waiting for its reference
        self.waiting_since = 0.0  # monotonic s the tick began waiting
        self.reference_waits = 0  # ticks that went on without a due reference sample
        self.paired_s: float | None = None  # the world's clock the latest reading paired with
        self.paired_stamp_s: float | None = None  # and that reading's stamp
        self.clock_seen = time.monotonic()  # when the world's clock last moved on
        self.reading_period_s: float | None = None  # s between the last two readings' stamps
        params = block.params  # a camera's readings beside the encoder's: when they are due
        self.second = SecondReadings(params["camera_wait_s"], params["camera_period_s"], params["camera_latency_s"])

    def start(self) -> None:
        self.node.create_timer(0.1, self.reference_wait_check, clock=Clock(clock_type=ClockType.STEADY_TIME))
        self.node.create_subscription(ClockMsg, spec.CLOCK.topic, self.clock_callback, LATCHED_QOS)

    def take(self, port: str, value: Any) -> None:
        take(self, port, value)

    def clock_callback(self, msg: ClockMsg) -> None:
        clock_s = max(self.clock_s, stamp_to_s(msg.clock))
        if clock_s > self.clock_s:
            self.clock_seen = time.monotonic()
        self.clock_s = clock_s
        self.pair()

    def take_reading(self, sample: JointSample) -> None:
        """One reading per world tick; the tick's time is the clock it pairs with (a delayed sensor's stamp is older
        than the tick)."""
        checked = self.block.checked_reading(sample)
        if checked is None:
            self.block.check_names(list(sample.names), time.monotonic())
            return
        self.reading = checked
        self.pair()

    def take_second_reading(self, sample: JointSample) -> None:
        """A camera's reading beside the encoder's: taken at the world's latest clock; a tick it is due for waits
        for it (so the same run fuses it at the same tick), at most ``camera_wait_s``."""
        clock_s = max(self.clock_s, 0.0)
        self.block.take(clock_s, {"camera_reading": sample})
        self.second.arrived(sample.stamp_s)
        self.try_tick()

    def take_reference(self, value: Any) -> None:
        # Received at the tick in force (the world's latest clock, so a sample sent a tick early waits for it).
        self.block.take(max(self.clock_s, 0.0), {"reference": value})
        self.try_tick()

    def pair(self) -> None:
        """A tick is due once the world's clock for it and its reading are both in, whichever came first (the world
        publishes the next clock only after this tick's command: one to one), or its clock alone if no reading is
        due then."""
        if self.tick_s is not None or self.clock_s <= self.block.last_tick_s:
            return
        if self.reading is None:
            if self.reading_due():
                return
            self.tick_without_reading()
            return
        if self.reading.stamp_s > self.clock_s + 1e-9:
            return  # the reading is for a tick whose clock has not arrived yet
        reading, self.reading = self.reading, None
        if self.paired_stamp_s is not None and self.clock_s > self.paired_s:
            # The sensor's period in the world's ticks it answers (its lateness is the same every time): a camera's
            # reading repeated between its frames (the same stamp) answers every tick.
            self.reading_period_s = self.clock_s - self.paired_s
        self.paired_s, self.paired_stamp_s = self.clock_s, reading.stamp_s
        self.block.take(self.clock_s, {"reading": reading})  # a refused one is said; the tick goes on
        self.tick_s = self.clock_s
        self.waiting_since = time.monotonic()
        self.try_tick()

    def reading_due(self) -> bool:
        """Whether a reading is due at the world's clock: always, until the readings' period is known."""
        if self.reading_period_s is None or self.paired_s is None:
            return True
        return self.clock_s - self.paired_s >= self.reading_period_s - 1e-9

    def tick_without_reading(self) -> None:
        self.tick_s = self.clock_s
        self.waiting_since = time.monotonic()
        self.try_tick()

    def try_tick(self) -> None:
        """Tick if the measured tick's reference sample is in."""
        tick_s = self.tick_s
        if tick_s is None or not self.block.controller.reference_ready(tick_s):
            return
        if self.second.due(tick_s) and not self.second.waited_out(self.waiting_since, self.block.log):
            return
        self.tick_s = None
        self._tick(tick_s)
        self.pair()

    def reference_wait_check(self) -> None:
        """A planner slower than the control rate leaves ticks with no sample due, a sensor slower than it ticks with no
        reading due; until their periods are learned from two samples, do not wait forever."""
        if self.tick_s is not None and self.second.due(self.tick_s):
            if self.second.waited_out(self.waiting_since, self.block.log):
                self.try_tick()
            return
        if self.tick_s is None:
            waited = self.clock_s > self.block.last_tick_s and time.monotonic() - self.clock_seen > READING_WAIT_S
            if waited and self.reading_period_s is None and self.paired_s is not None and self.reading is None:
                self.block.log.info(
                    f"sim time: no reading for t={self.clock_s:.3f} s after {READING_WAIT_S:g} s; ticking on "
                    "the latest until the sensor's rate is known from its second reading"
                )
                self.tick_without_reading()
            return
        block = self.block
        if not block.controller.has_reference():
            # Nothing to fall back on before the first sample: wait (the launcher ends a stalled run).
            block.waits.waiting(
                "reference",
                f"sim time: the first {spec.REFERENCE.topic} sample (trajectory_planner's)",
                time.monotonic(),
            )
            return
        if time.monotonic() - self.waiting_since > REFERENCE_WAIT_S:
            said = (
                f"sim time: no reference sample for t={self.tick_s:.3f} s "
                f"after {REFERENCE_WAIT_S:g} s; using the latest"
            )
            if block.reference_samples < 2:
                # The planner's period is learned from its first two samples; until then a planner slower than the
                # control rate leaves ticks without a sample due: said once.
                if self.reference_waits == 0:
                    block.log.info(said + " until the planner's rate is known from its second sample")
            else:
                block.log.warn("reference_wait", said)
            self.reference_waits += 1
            tick_s, self.tick_s = self.tick_s, None
            self._tick(tick_s)

    def finish(self) -> None:
        pass
