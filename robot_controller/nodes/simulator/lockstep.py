"""The simulator's lockstep ticks (``lockstep: true``): it publishes the true state and the clock for tick k,
then waits; the effort for tick k advances exactly one control period. It holds the next tick while
the recorder (its ``recorder_clock``) is ``RECORDER_LAG_MAX_S`` behind, so no queue overflows."""

from __future__ import annotations

import numpy as np
from rclpy.clock import Clock, ClockType
from rosgraph_msgs.msg import Clock as ClockMsg

from robot_controller.blocks import spec
from robot_controller.core.model import steps_per_period
from robot_controller.ros.publishing import recorded
from robot_controller.ros.qos import CLOCK_QOS
from robot_controller.ros.stack_node import StackNode

#: Sim seconds the recorder may be behind: under a third of what the queues hold, and over what
#: the loop runs between its reports (0.1 s wall, 1-2 sim s) so a recorder keeping up never holds it.
RECORDER_LAG_MAX_S = 3.0


class LockstepTicks:
    """The simulator's ticks in lockstep: one control period of physics per effort."""

    def __init__(self, node: StackNode) -> None:
        self.node = node
        self.efforts_applied = 0
        self.published = 0
        self.recorder_clock_ns: int | None = None  #: the tick the recorder has taken; None: no recorder
        self.held_for_recorder = False
        self.holds_for_recorder = 0
        self.resume_for_recorder = True  #: the recorder's report publishes a held tick (a paced world's thread does)
        end_s = node.params["lockstep_end_s"]
        self.end_ns = round(end_s * 1e9) if end_s > 0 else None  #: no tick after this (the run's end)
        self.ended = False
        self.steps_per_tick = steps_per_period(node.plant.physics_dt, 1.0 / node.params["control_rate_hz"])
        self.clock_pub = node.gated_publisher(ClockMsg, spec.CLOCK.topic, consumer=False, qos=CLOCK_QOS)
        self.clock_msg = ClockMsg()
        self.waiting_for_effort = False
        if recorded():
            self.recorder_clock_ns = 0
            node.create_subscription(ClockMsg, spec.RECORDER_CLOCK.topic, self.recorder_clock, CLOCK_QOS)
        self.start_poll = node.create_timer(0.05, self.start, clock=Clock(clock_type=ClockType.STEADY_TIME))

    def start(self) -> None:
        """Publish tick 0 once the sensor (and recorder) listen and the motor talks (nothing is ever re-sent)."""
        node = self.node
        # The motor matched (not only named in the graph: a motor of an earlier run can linger there).
        if not (node.state_pub.open and self.clock_pub.open and node.effort_sub.get_publisher_count()):
            return
        node.destroy_timer(self.start_poll)
        node.get_logger().info("lockstep: sensor and motor matched, starting at t = 0")
        with node.lock:  # a paced world's thread (``paced``) ticks too
            self.publish()

    def take_effort(self, effort: np.ndarray) -> None:
        if not self.waiting_for_effort:
            self.node.warn_throttled("extra_effort", "lockstep: effort with no tick waiting for it, ignored")
            return
        self.accept(effort)
        self.advance()

    def accept(self, effort: np.ndarray) -> None:
        """The effort in force from now (none while a brake holds): it releases the start and drive-timeout brakes."""
        node = self.node
        self.waiting_for_effort = False
        node.brakes.set("start", False)
        node.brakes.set("drive_timeout", False)
        node.effort = np.zeros(node.joint_count) if node.brakes.reasons else effort
        self.efforts_applied += 1

    def advance(self) -> None:
        """One control period of physics on the effort in force, then the next tick (unless the run's end or
        the recorder holds it)."""
        node = self.node
        node.step(self.steps_per_tick)
        if self.end_ns is not None and node.steps_done * node.physics_dt_ns > self.end_ns:
            # The run's end: no more ticks, so the graph falls quiet and the recorder catches up.
            if not self.ended:
                self.ended = True
                node.get_logger().info(f"lockstep: the run's end, t = {self.end_ns * 1e-9:g} s: no more ticks")
            return
        if self.recorder_behind():
            self.held_for_recorder = True
            self.holds_for_recorder += 1
            return
        self.publish()

    def recorder_behind(self) -> bool:
        next_tick_ns = self.node.steps_done * self.node.physics_dt_ns
        return self.recorder_clock_ns is not None and next_tick_ns - self.recorder_clock_ns > RECORDER_LAG_MAX_S * 1e9

    def recorder_clock(self, msg: ClockMsg) -> None:
        self.recorder_clock_ns = max(self.recorder_clock_ns, msg.clock.sec * 1_000_000_000 + msg.clock.nanosec)
        if self.resume_for_recorder and self.held_for_recorder and not self.recorder_behind():
            self.held_for_recorder = False
            self.publish()

    def publish(self) -> None:
        """The true state first: the tick's longest path (sensor → controller → motor → here) starts there."""
        stamp_ns = self.node.steps_done * self.node.physics_dt_ns
        self.waiting_for_effort = True
        self.published += 1
        self.node.publish_state(stamp_ns)
        self.clock_msg.clock.sec, self.clock_msg.clock.nanosec = divmod(stamp_ns, 1_000_000_000)
        self.clock_pub.publish(self.clock_msg)

    def report(self) -> None:
        self.node.get_logger().info(
            f"lockstep: {self.published} ticks published, {self.efforts_applied} "
            f"efforts applied, t = {self.node.steps_done * self.node.plant.physics_dt:.3f} s"
            + (f"; held {self.holds_for_recorder} times for the recorder" if self.holds_for_recorder else "")
        )
