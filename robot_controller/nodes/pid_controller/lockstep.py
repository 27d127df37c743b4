"""pid_controller in lockstep (``lockstep: true``, sim time): each reading is a tick at
the sim's ``/clock`` it pairs with, computed once the reference sample due by then has
arrived (or, from a planner slower than the control rate, after ``REFERENCE_WAIT_S``
with the latest).
"""

from __future__ import annotations

import time

import numpy as np
from rclpy.clock import Clock, ClockType
from rosgraph_msgs.msg import Clock as ClockMsg

from robot_controller.ros.qos import LATCHED_QOS
from robot_controller.ros.stack_node import StackNode
from robot_controller.ros.stamps import stamp_to_s

# How long (wall) a tick waits for a reference sample before using the latest.
REFERENCE_WAIT_S = 0.3


class LockstepPairing:
    """Pairs each reading with its tick on the sim's ``/clock`` and ticks the controller node."""

    def __init__(self, node: StackNode) -> None:
        self.node = node
        self.controller = node.controller
        self.clock_s = -np.inf  # the latest /clock
        self.reading: tuple[float, tuple[np.ndarray, np.ndarray]] | None = None  # waiting for its /clock
        self.tick_s: float | None = None  # a measured tick waiting for its reference
        self.waiting_since = 0.0  # monotonic s the tick began waiting
        self.reference_waits = 0  # ticks that went on without a due reference sample
        node.create_timer(0.1, self.reference_wait_check, clock=Clock(clock_type=ClockType.STEADY_TIME))
        node.create_subscription(ClockMsg, "/clock", self.clock_callback, LATCHED_QOS)

    def clock_callback(self, msg: ClockMsg) -> None:
        self.clock_s = max(self.clock_s, stamp_to_s(msg.clock))
        self.pair()

    def take_reading(self, stamp_s: float, position: np.ndarray, velocity: np.ndarray) -> None:
        """One reading per sim tick; the tick's time is the /clock it pairs with (a delayed sensor's
        stamp is older than the tick)."""
        self.reading = (stamp_s, (position, velocity))
        self.pair()

    def pair(self) -> None:
        """A tick is due once the sim's /clock for it and its reading are both in, whichever came
        first (the sim publishes the next /clock only after this tick's command: one to one)."""
        if self.reading is None or self.tick_s is not None or self.clock_s <= self.node.last_tick_s:
            return
        stamp_s, (position, velocity) = self.reading
        if stamp_s > self.clock_s + 1e-9:
            return  # the reading is for a tick whose /clock has not arrived yet
        self.reading = None
        refused = self.controller.set_measurement(stamp_s, self.clock_s, position, velocity)
        if refused:
            self.node.warn_throttled("joint_states_age", f"/joint_states dropped: {refused}")
        self.tick_s = self.clock_s
        self.waiting_since = time.monotonic()
        self.try_tick()

    def try_tick(self) -> None:
        """Tick if the measured tick's reference sample is in."""
        tick_s = self.tick_s
        if tick_s is None or not self.controller.reference_ready(tick_s):
            return
        self.tick_s = None
        self.node.tick(tick_s)
        self.pair()

    def reference_wait_check(self) -> None:
        """A planner slower than the control rate leaves ticks with no sample due;
        until its period is learned from two samples, do not wait forever."""
        if self.tick_s is None:
            return
        node = self.node
        if not self.controller.has_reference():
            # Nothing to fall back on before the first sample: wait (the launcher ends a stalled lockstep).
            node.warn_throttled("first_reference", "lockstep: waiting for the first /trajectory sample")
            return
        if time.monotonic() - self.waiting_since > REFERENCE_WAIT_S:
            said = (
                f"lockstep: no reference sample for t={self.tick_s:.3f} s "
                f"after {REFERENCE_WAIT_S:g} s; using the latest"
            )
            if self.reference_waits == 0:
                # A planner slower than the control rate leaves the first such tick without a sample.
                node.get_logger().info(said + " (a planner slower than the control rate)")
            else:
                node.warn_throttled("reference_wait", said)
            self.reference_waits += 1
            tick_s, self.tick_s = self.tick_s, None
            node.tick(tick_s)
