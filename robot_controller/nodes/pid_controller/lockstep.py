"""pid_controller in lockstep (``lockstep: true``, sim time): each reading is a
tick at the sim's ``/clock`` it pairs with, computed once the reference sample
due by then has arrived (or, from a planner slower than the control rate, after
``REFERENCE_WAIT_S`` with the latest).
"""

from __future__ import annotations

import time

import numpy as np
from rclpy.clock import Clock, ClockType
from rosgraph_msgs.msg import Clock as ClockMsg

from robot_controller.ros.qos import LATCHED_QOS
from robot_controller.ros.stamps import stamp_to_s

# Lockstep: how long (wall) a tick waits for a reference sample before using the latest.
REFERENCE_WAIT_S = 0.3


class LockstepPairing:
    """The pairing of readings with ticks of the :class:`~robot_controller.nodes.pid_controller.node.PidControllerNode`
    in lockstep."""

    def init_lockstep(self) -> None:
        self.pending_tick_s: float | None = None  # lockstep: measurement waiting for its reference
        self.pending_since = 0.0  # wall time (monotonic) the pending tick began waiting
        self.reference_waits = 0  # ticks that went on without a due reference sample
        self.pending_reading: tuple[float, tuple[np.ndarray, np.ndarray]] | None = None  # lockstep
        self.sim_clock_s = -np.inf  # lockstep: the latest /clock
        if self.lockstep:
            self.create_timer(0.1, self.reference_wait_check, clock=Clock(clock_type=ClockType.STEADY_TIME))
            self.create_subscription(ClockMsg, "/clock", self.clock_callback, LATCHED_QOS)

    def clock_callback(self, msg: ClockMsg) -> None:
        self.sim_clock_s = max(self.sim_clock_s, stamp_to_s(msg.clock))
        self.pair_lockstep_reading()

    def pair_lockstep_reading(self) -> None:
        """Lockstep: a tick is due once the sim's /clock for it and its reading are
        both in, whichever came first (the sim publishes the next /clock only
        after this tick's command, so they pair one to one)."""
        if self.pending_reading is None or self.pending_tick_s is not None or self.sim_clock_s <= self.last_tick_s:
            return
        stamp_s, (position, velocity) = self.pending_reading
        if stamp_s > self.sim_clock_s + 1e-9:
            return  # the reading is for a tick whose /clock has not arrived yet
        self.pending_reading = None
        refused = self.controller.set_measurement(stamp_s, self.sim_clock_s, position, velocity)
        if refused:
            self.warn_throttled("joint_states_age", f"/joint_states dropped: {refused}")
        self.pending_tick_s = self.sim_clock_s
        self.pending_since = time.monotonic()
        self.try_lockstep_tick()

    def try_lockstep_tick(self) -> None:
        tick_s = self.pending_tick_s
        if tick_s is None or not self.controller.reference_ready(tick_s):
            return
        self.pending_tick_s = None
        self.tick(tick_s)
        self.pair_lockstep_reading()

    def reference_wait_check(self) -> None:
        """A planner slower than the control rate leaves ticks with no sample due;
        until its period is learned from two samples, do not wait forever."""
        if self.pending_tick_s is None:
            return
        if not self.controller.has_reference():
            # Before the planner's first sample, nothing to fall back on: wait (the
            # launcher ends a run whose lockstep stalls).
            self.warn_throttled("first_reference", "lockstep: waiting for the first /trajectory sample")
            return
        if time.monotonic() - self.pending_since > REFERENCE_WAIT_S:
            said = (
                f"lockstep: no reference sample for t={self.pending_tick_s:.3f} s "
                f"after {REFERENCE_WAIT_S:g} s; using the latest"
            )
            if self.reference_waits == 0:
                # Once at the start, a planner slower than the control rate (the tutorial's, 20 Hz)
                # is expected to leave this tick without a sample: its period is learned from here on.
                self.get_logger().info(said + " (a planner slower than the control rate)")
            else:
                self.warn_throttled("reference_wait", said)
            self.reference_waits += 1
            tick_s, self.pending_tick_s = self.pending_tick_s, None
            self.tick(tick_s)
