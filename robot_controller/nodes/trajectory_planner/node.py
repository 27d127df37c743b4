"""The planner node: the planner block (``blocks.planner``) stepped on the node's clock, its reference published
through a gate (its time starts when the first consumer is matched), the joint trajectory topics handed to it, and
the FollowJointTrajectory action served beside it (``follow_joint_trajectory``), and what the arm does handed to it
(the brakes and the e-stop always, the readings and the controller's state while a goal is in force).

When it is stepped: on the wall clock, by a timer at ``publish_rate_hz``; in sim time, at the sim's ticks
(port ``clock``) on the grid of its period from its start, each grid point's sample one tick early: the controller holds
it until its time, and its tick never waits for this process (the sim's step is the tick)."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
from rclpy.clock import Clock, ClockType
from rosgraph_msgs.msg import Clock as ClockMsg
from std_msgs.msg import Float64MultiArray, MultiArrayDimension

from robot_controller.blocks import registry, spec
from robot_controller.blocks.planner import Planner
from robot_controller.nodes.trajectory_planner.follow_joint_trajectory import FollowJointTrajectoryServer
from robot_controller.ros.adapter import NodeLog
from robot_controller.ros.messages import clock_s, decode, message_class, stamp_to_s
from robot_controller.ros.process import run
from robot_controller.ros.qos import CONTROL_QOS, ESTOP_QOS, LATEST_QOS
from robot_controller.ros.stack_node import StackNode

_GRID_EPS_S = 1e-6
START_POLL_S = 0.05  #: sim time: how often it looks (on the wall clock) whether it may start, before the sim's clock


class TrajectoryPlanner(StackNode):
    serves_actions = True  #: spun by an executor that serves action servers (ros.process.make_executor)

    def __init__(self) -> None:
        super().__init__("trajectory_planner")
        p = self.params
        self.block.start()
        self.pub = self.gated_publisher(Float64MultiArray, spec.REFERENCE.topic)
        self.msg = Float64MultiArray()
        n = p["joint_count"]
        self.msg.layout.dim = [
            MultiArrayDimension(label=name, size=n, stride=n) for name in ("position", "velocity", "acceleration")
        ]
        self.msg.layout.dim.append(MultiArrayDimension(label="time_s", size=1, stride=1))
        self.clock_s = 0.0  # sim time: the sim's latest clock (0 until the first)
        self.next_sample_s = 0.0  # sim time: the next point of the block's grid
        self.timer = None
        self.arm_subscriptions: list = []
        if self.sim_time:
            self.create_subscription(ClockMsg, spec.CLOCK.topic, self.clock_callback, CONTROL_QOS)
            # Before the sim's first clock the time is 0: poll (on the wall clock) for the controller.
            self.start_poll = self.create_timer(
                START_POLL_S, lambda: self.on_grid(self.clock_s), clock=Clock(clock_type=ClockType.STEADY_TIME)
            )
        else:
            self.timer = self.create_timer(1.0 / p["publish_rate_hz"], self.wall_tick)
        self.hear(spec.WAYPOINTS, LATEST_QOS)
        self.hear(spec.CONTROLLER_WAYPOINTS, LATEST_QOS)
        self.hear(spec.ESTOP, ESTOP_QOS)
        self.hear(spec.BRAKES, CONTROL_QOS)  # every change kept: an engagement released before a goal looks counts
        self.action = FollowJointTrajectoryServer(self, self.block)
        self.block.replaced.append(self.action.replaced)
        self.get_logger().info(self.block.summary(", sim time" if self.sim_time else ""))

    def setup(self, params: dict[str, Any]) -> None:
        # On the sim's clock (its ``lockstep`` parameter, the paced world's too) the world waits for each effort.
        self.sim_time = bool(params["lockstep"])
        self.block: Planner = registry.make(self.get_name(), params, NodeLog(self), self.sim_time)

    def check_params(self, params: dict[str, Any]) -> None:
        self.block.check_params(params)

    def apply_params(self, params: dict[str, Any], changed: set[str]) -> None:
        self.block.set_params(params, changed, self.now_s())
        if "publish_rate_hz" in changed and self.timer is not None:
            self.destroy_timer(self.timer)
            self.timer = self.create_timer(1.0 / params["publish_rate_hz"], self.wall_tick)

    def now_s(self) -> float:
        """The planner's time: the sim's latest clock in sim time, else the node's clock, s."""
        return self.clock_s if self.sim_time else clock_s(self)

    def hear(self, port: spec.Port, qos: Any) -> Any:
        """A subscription handing ``port``'s messages to the block (:meth:`take`)."""
        topic = port.topic_for(self.params["controller_name"])
        return self.create_subscription(
            message_class(port.msg_type), topic, lambda msg, name=port.name: self.take(name, msg), qos
        )

    def take(self, port: str, msg: Any) -> None:
        """A message on ``port``, handed to the block as its value at the node's time."""
        self.block.step(self.now_s(), {port: decode(msg)})

    def listen_to_arm(self, on: bool) -> None:
        """Hear the arm only while a goal is in force. Two 100 Hz subscriptions cost the planner's executor (rclpy's
        single-threaded one, which rebuilds its wait set at every wake-up) a third of a CPU, taken from the loop on a
        busy host. Off, what was heard is forgotten: a next goal is never judged on an earlier one's estimate."""
        if on and not self.arm_subscriptions:
            self.block.arm.forget(self.now_s())
            self.arm_subscriptions = [self.hear(spec.READING, LATEST_QOS), self.hear(spec.STATE, LATEST_QOS)]
        elif not on and self.arm_subscriptions:
            for subscription in self.arm_subscriptions:
                self.destroy_subscription(subscription)
            self.arm_subscriptions = []
            self.block.arm.forget(self.now_s())

    def wall_tick(self) -> None:
        now_s = clock_s(self)
        if self.block.start_s is None and not self.pub.open:
            return  # t = 0 is when the controller (and the recorder) can hear it
        self.publish(self.block.step(now_s, {}))
        self.action.monitor(now_s)

    def clock_callback(self, msg: ClockMsg) -> None:
        previous_s, self.clock_s = self.clock_s, stamp_to_s(msg.clock)
        if self.block.start_s is None:
            return
        self.on_grid(self.clock_s)
        # The sample due at the next tick goes out now, a tick early.
        step_s = self.clock_s - previous_s
        if step_s > 0:
            self.on_grid(self.clock_s + step_s)
        self.action.monitor(self.clock_s)

    def on_grid(self, now_s: float) -> None:
        """Sim time: step the block if ``now_s`` is at (or past) the next point of its period's grid."""
        start_s = self.block.start_s
        if start_s is None:
            if not self.pub.open:
                return  # t = 0 is when the controller (and the recorder) can hear it
            start_s = self.next_sample_s = now_s
            self.destroy_timer(self.start_poll)
        if now_s < self.next_sample_s - _GRID_EPS_S:
            return
        period = 1.0 / self.params["publish_rate_hz"]
        self.next_sample_s = start_s + (np.floor((now_s - start_s + _GRID_EPS_S) / period) + 1) * period
        self.publish(self.block.step(now_s, {}))

    def publish(self, outputs: Mapping[str, Any]) -> None:
        reference = outputs.get("reference")
        if reference is not None:
            self.msg.data = reference.data.tolist()
            self.pub.publish(self.msg)

    def finish(self) -> None:
        self.action.shutdown()
        super().finish()


def main(args: list[str] | None = None) -> int:
    return run(TrajectoryPlanner, args)


if __name__ == "__main__":
    raise SystemExit(main())
