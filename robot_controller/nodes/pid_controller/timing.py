"""pid_controller's loop timing: the command path's delay (the drive's receipts), the line while the loop
is later than its gains survive, and jitter, missed cycles and latency on its diagnostics (port ``diagnostics``)."""

from __future__ import annotations

import json
import os
import time
from collections import deque
from pathlib import Path

import numpy as np
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from std_msgs.msg import Float64MultiArray

from robot_controller.blocks import spec
from robot_controller.core import metrics
from robot_controller.ros.loop_processes import LoopProcesses, Sample, host_kept_waiting
from robot_controller.ros.messages import clock_s
from robot_controller.ros.process import HOST_MISSED_FILE
from robot_controller.ros.publishing import COUNTS_DIR_ENV
from robot_controller.ros.stack_node import StackNode

# While the loop is late, its one line comes at most this often (s).
LATE_LINE_PERIOD_S = 2.0
# Commands remembered with their tick time, to pair with the drive's receipts (a second's worth and more).
ISSUED_KEPT = 400
# The receipts come once a second, each message a second's rows: keep a few, never a backlog.
COMMAND_RECEIPTS_QOS = 5


class LoopTiming:
    """How late and how regular the controller's loop is."""

    def __init__(self, node: StackNode) -> None:
        self.node = node
        self.controller = node.controller
        self.issued: deque[tuple[float, tuple[float, ...]]] = deque(maxlen=ISSUED_KEPT)  # (tick s, command)
        self.window_ticks: list[float] = []
        self.window_latency: list[float] = []
        self.next_late_line = -np.inf  # monotonic s
        # Wall clock: which missed cycles the host caused (the loop kept from a CPU by other programs, or stolen).
        self.loop = None if node.lockstep else LoopProcesses(os.environ.get(COUNTS_DIR_ENV, ""))
        self.last_tick: tuple[float, Sample | None] | None = None  #: (time s, the loop's usage) at the last tick
        self.missed_for_host: list[float] = []  #: when (tick s) each missed period the host made ended
        # The watchdog's silence, timed from the latest accepted reading's arrival (s) and the loop's usage at the
        # first tick since (the same instant when readings drive the loop).
        self.reading_s: float | None = None
        self.usage_at_reading: Sample | None = None
        self.reading_unsampled = False
        self.watchdog_for_host: list[float] = []  #: when (tick s) each watchdog tick the host made fell
        self.pub = node.gated_publisher(DiagnosticArray, spec.DIAGNOSTICS.topic, consumer=False)
        if not node.lockstep:
            # When each command reached the drive: the command path's delay, for the latency guard.
            node.create_subscription(
                Float64MultiArray, spec.COMMAND_RECEIPTS.topic, self.receipts_callback, COMMAND_RECEIPTS_QOS
            )
        node.create_timer(node.params["diagnostics_period_s"], self.publish_diagnostics)

    def note_reading(self, now_s: float) -> None:
        """A reading was accepted at ``now_s`` (s): the watchdog's silence starts again."""
        self.reading_s, self.reading_unsampled = now_s, True

    def note_tick(self, now_s: float, command: tuple[float, ...] | None, watchdog: bool = False) -> None:
        """A tick at ``now_s`` that published ``command`` (None: it commanded nothing); ``watchdog``: its verdict
        was the watchdog's (no reading for longer than its window)."""
        lockstep = self.node.lockstep
        if command is not None and not lockstep:
            self.issued.append((now_s, command))
        self.window_ticks.append(now_s)
        if not lockstep:  # in lockstep a tick takes no sim time
            self.window_latency.append(clock_s(self.node) - self.controller.measurement_stamp_s)
            self.note_host_wait(now_s, watchdog)

    def note_host_wait(self, now_s: float, watchdog: bool = False) -> None:
        """Count the period that ends at ``now_s`` as the host's miss if the host took from the loop's processes
        all it ran over (they waited that long for a CPU other programs used, or the CPUs were stolen: processes of
        the loop keeping each other waiting are its own fault, ``loop_processes.host_kept_waiting``). A
        watchdog tick is the host's on the same terms, over the reading's silence past the watchdog's window."""
        assert self.loop is not None
        usage = self.loop.usage()
        if self.reading_unsampled:
            self.usage_at_reading, self.reading_unsampled = usage, False
        if watchdog and self.reading_s is not None and usage is not None and self.usage_at_reading is not None:
            config = self.controller.config
            over_s = now_s - self.reading_s - config.watchdog_periods * config.control_period_s
            if over_s > 0 and host_kept_waiting(usage - self.usage_at_reading, round(over_s * 1e9)):
                self.watchdog_for_host.append(now_s)
        if self.last_tick is not None:
            last_s, last_usage = self.last_tick
            over_s = now_s - last_s - metrics.MISSED_PERIODS * self.controller.config.control_period_s
            measured = over_s > 0 and usage is not None and last_usage is not None
            if measured and host_kept_waiting(usage - last_usage, round(over_s * 1e9)):
                self.missed_for_host.append(now_s)
        self.last_tick = (now_s, usage)

    def leave_host_misses(self) -> None:
        """At the end: when each missed cycle the host made ended, and when each watchdog tick it made fell, for
        metrics.json, which counts those within the ticks it scores (the run's scratch folder, if any)."""
        counts_dir = os.environ.get(COUNTS_DIR_ENV, "")
        if counts_dir and self.loop is not None:
            host_made = {"ends_s": self.missed_for_host, "watchdog_s": self.watchdog_for_host}
            (Path(counts_dir) / HOST_MISSED_FILE).write_text(json.dumps(host_made))

    def receipts_callback(self, msg: Float64MultiArray) -> None:
        """The drive's receipts, rows ``[receipt_time_s, command…]``: each paired with the latest
        tick that issued the same command before it, their difference is the command path's delay."""
        row = 1 + self.node.joint_count
        data = list(msg.data)
        if not data or len(data) % row:
            return
        ticks: dict[tuple[float, ...], list[float]] = {}
        for tick_s, command in self.issued:
            ticks.setdefault(command, []).append(tick_s)
        for start in range(0, len(data), row):
            receipt_s, command = data[start], tuple(data[start + 1 : start + row])
            earlier = [t for t in ticks.get(command, ()) if t <= receipt_s]
            if earlier:
                self.controller.command_delay(receipt_s, receipt_s - earlier[-1])

    def report_late(self) -> None:
        """One line (at most every LATE_LINE_PERIOD_S) while the loop is later than its gains survive."""
        now = time.monotonic()
        if now < self.next_late_line:
            return
        self.next_late_line = now + LATE_LINE_PERIOD_S
        late = self.controller.latency
        margin = self.controller.delay_margin_periods()
        self.node.get_logger().warning(
            f"readings/commands {late.delay_s * 1e3:.0f} ms late beyond what the stamps account for; the gains "
            f"survive {late.tolerated_s * 1e3:.0f} ms (delay margin {margin} periods): controlled stop, holding "
            f"until it is back within {late.tolerated_s * 0.5e3:.0f} ms for 1 s (category 2)"
        )

    def publish_diagnostics(self) -> None:
        ticks, latency = self.window_ticks, self.window_latency
        self.window_ticks, self.window_latency = ticks[-1:], []
        status = DiagnosticStatus(name="pid_controller: control loop", hardware_id="robot_controller")
        values: dict[str, float] = {"ticks": float(max(len(ticks) - 1, 0))}
        if len(ticks) >= 2:
            values.update(metrics.rate_metrics(np.asarray(ticks), self.controller.config.control_period_s))
        values.update(metrics.latency_metrics(np.asarray(latency)))
        if len(ticks) < 2:
            status.level, status.message = DiagnosticStatus.WARN, "not commanding"
        elif values.get("missed_cycles", 0) > 0:
            status.level, status.message = DiagnosticStatus.WARN, f"{int(values['missed_cycles'])} missed cycle(s)"
        else:
            status.level, status.message = DiagnosticStatus.OK, "running"
        status.values = [KeyValue(key=k, value=f"{v:.6g}") for k, v in values.items()]
        report = DiagnosticArray(status=[status])
        report.header.stamp = self.node.get_clock().now().to_msg()
        self.pub.publish(report)
